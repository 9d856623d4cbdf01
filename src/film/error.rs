use std::path::PathBuf;

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
    #[error("image sizes differ: {}x{} vs {}x{}", a.0, a.1, b.0, b.1)]
    SizeMismatch { a: (u32, u32), b: (u32, u32) },
    #[error("{}: no R, G, B channels found", .0.display())]
    NoRgb(PathBuf),
}
