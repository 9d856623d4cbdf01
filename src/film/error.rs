use std::path::PathBuf;

/// Most pixels an image reader accepts (8192 x 8192, the server's default
/// `--max-resolution` per side, so any image it can render can be read back as a
/// reference). Image headers alone size the decoding buffers: a few bytes claiming
/// 100000 x 100000 pixels must be this error, not an attempt to allocate 40 GB. Every
/// image reader (EXR, Radiance HDR) checks it before decoding.
pub const MAX_PIXELS: u64 = 1 << 26;

/// Errors from reading, writing or comparing images.
///
/// Messages name the file involved so that a log line or an HTTP error body is
/// useful on its own.
#[derive(Debug, thiserror::Error)]
pub enum FilmError {
    #[error("I/O error on {}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// The message starts with the file name (or "<memory>").
    #[error("EXR error: {0}")]
    Exr(String),
    /// The message starts with the file name (or "<memory>").
    #[error("PNG error: {0}")]
    Png(String),
    /// The message starts with the file name (or "<memory>").
    #[error("Radiance HDR error: {0}")]
    Hdr(String),
    /// A header claims more than a reader accepts (see [`MAX_PIXELS`]); refused
    /// before anything is allocated for it.
    #[error("{what}: {detail}")]
    TooLarge { what: String, detail: String },
    #[error("image sizes differ: {}x{} vs {}x{}", a.0, a.1, b.0, b.1)]
    SizeMismatch { a: (u32, u32), b: (u32, u32) },
    #[error("{}: no R, G, B channels found", .0.display())]
    NoRgb(PathBuf),
}

/// Refuses `width` x `height` beyond [`MAX_PIXELS`]; `what` names the file.
pub(super) fn check_pixels(what: &str, width: u64, height: u64) -> Result<(), FilmError> {
    match width.checked_mul(height) {
        Some(n) if n <= MAX_PIXELS => Ok(()),
        _ => Err(FilmError::TooLarge {
            what: what.to_string(),
            detail: format!("{width} x {height} pixels, more than the {MAX_PIXELS} caustic reads"),
        }),
    }
}
