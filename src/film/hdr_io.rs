//! Radiance RGBE (`.hdr`) input, through the `image` crate's decoder: the format
//! other renderers (SmallVCM, Radiance, many older research codes) write, so that
//! their images can be compared with ours, and [`read_image`], which picks the reader
//! by file extension.
//!
//! RGBE keeps an 8-bit mantissa m per channel under a shared exponent e. Encoders
//! truncate (Radiance's own, SmallVCM's), so the value is decoded as Radiance does,
//! at the middle of its step: (m + 1/2) 2^(e - 136). The `image` crate decodes
//! m 2^(e - 136), half a step low, which biased SmallVCM images by -0.3% on average;
//! the half step is added here. What is left is the rounding, within 1/256 of the
//! brightest channel of a pixel: error figures against such an image have a floor of
//! that order.

use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

use glam::Vec3 as Rgb;
use image::codecs::hdr::HdrDecoder;
use image::ImageDecoder;

use super::error::check_pixels;
use super::{read_exr, FilmError, Image};

/// Reads a Radiance `.hdr` file (run-length encoded or flat scan lines, the usual
/// `-Y height +X width` orientation: row 0 at the top).
pub fn read_hdr(path: impl AsRef<Path>) -> Result<Image, FilmError> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|source| FilmError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    decode(BufReader::new(file), &path.display().to_string())
}

/// [`read_hdr`] from bytes in memory.
pub fn decode_hdr(bytes: &[u8]) -> Result<Image, FilmError> {
    decode(bytes, "<memory>")
}

/// Reads an image for comparison: `.hdr` as Radiance RGBE, anything else as EXR.
pub fn read_image(path: impl AsRef<Path>) -> Result<Image, FilmError> {
    let path = path.as_ref();
    let is_hdr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("hdr"));
    if is_hdr {
        read_hdr(path)
    } else {
        read_exr(path)
    }
}

fn decode(reader: impl BufRead, what: &str) -> Result<Image, FilmError> {
    let err = |e: image::ImageError| FilmError::Hdr(format!("{what}: {e}"));
    let decoder = HdrDecoder::new(reader).map_err(err)?;
    let (width, height) = decoder.dimensions();
    // The header alone sizes the buffer. No bound from the file's length: the old
    // run-length form repeats a pixel 2^(8k) times for k repeat codes in a row.
    check_pixels(what, width.into(), height.into())?;
    let mut bytes = vec![0u8; decoder.total_bytes() as usize];
    decoder.read_image(&mut bytes).map_err(err)?;
    let pixels = bytes
        .chunks_exact(12)
        .map(|p| {
            let c = |i: usize| f32::from_ne_bytes(p[4 * i..4 * i + 4].try_into().unwrap());
            mid_step(Rgb::new(c(0), c(1), c(2)))
        })
        .collect();
    Ok(Image::from_pixels(width, height, pixels))
}

/// `v` = m 2^(e - 136) moved to (m + 1/2) 2^(e - 136). The brightest channel's m is
/// in [128, 256), so its float exponent is e - 129 and half a step is 2^(that - 8).
/// Black stays black (e = 0); values too small for a normal f32 are left alone.
fn mid_step(v: Rgb) -> Rgb {
    let max = v.max_element();
    if !max.is_normal() {
        return v;
    }
    let exponent = (max.to_bits() >> 23) & 0xff;
    if exponent <= 8 {
        return v;
    }
    v + Rgb::splat(f32::from_bits((exponent - 8) << 23))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3 x 2 file in the flat (not run-length encoded) form SmallVCM writes:
    /// mantissa bytes m and exponent byte e stand for (m + 1/2) 2^(e - 136), which
    /// f32 holds exactly for these.
    fn flat_file() -> (Vec<u8>, Vec<Rgb>) {
        let mut bytes = b"#?RADIANCE\n# test\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 3\n".to_vec();
        let pixels: [([u8; 3], u8); 6] = [
            ([128, 64, 0], 129),    // (128.5, 64.5, 0.5) / 128
            ([255, 128, 1], 128),   // (255.5, 128.5, 1.5) / 256
            ([0, 0, 0], 0),         // black
            ([192, 192, 192], 130), // 192.5 / 64
            ([128, 0, 128], 138),   // (128.5, 0.5, 128.5) x 4
            ([200, 2, 4], 100),     // small: 2^-36 x (200.5, 2.5, 4.5)
        ];
        let mut want = Vec::new();
        for (m, e) in pixels {
            bytes.extend_from_slice(&[m[0], m[1], m[2], e]);
            let (scale, half) = if e == 0 {
                (0.0, 0.0)
            } else {
                (2f32.powi(e as i32 - 136), 0.5)
            };
            want.push((Rgb::new(m[0] as f32, m[1] as f32, m[2] as f32) + half) * scale);
        }
        (bytes, want)
    }

    #[test]
    fn flat_rgbe_decodes_exactly_with_row_zero_at_the_top() {
        let (bytes, want) = flat_file();
        let img = decode_hdr(&bytes).unwrap();
        assert_eq!(img.size(), (3, 2));
        assert_eq!(img.pixels(), &want[..]);
        assert_eq!(img.get(0, 0), Rgb::new(128.5, 64.5, 0.5) / 128.0);
        assert_eq!(img.get(2, 0), Rgb::ZERO);
        assert_eq!(img.get(0, 1), Rgb::splat(192.5 / 64.0));
    }

    #[test]
    fn read_image_chooses_by_extension() {
        let dir = tempfile::tempdir().unwrap();
        let (bytes, want) = flat_file();
        let hdr = dir.path().join("a.HDR");
        std::fs::write(&hdr, &bytes).unwrap();
        assert_eq!(read_image(&hdr).unwrap().pixels(), &want[..]);
        let exr = dir.path().join("b.exr");
        let img = Image::from_pixels(3, 2, want.clone());
        super::super::write_exr(&exr, &img).unwrap();
        assert_eq!(read_image(&exr).unwrap(), img);
    }

    #[test]
    fn truncated_or_foreign_files_are_errors_that_name_the_file() {
        let (bytes, _) = flat_file();
        let short = decode_hdr(&bytes[..bytes.len() - 5]).unwrap_err();
        assert!(short.to_string().contains("<memory>"), "{short}");
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("not.hdr");
        std::fs::write(&png, b"\x89PNG\r\n\x1a\nnot radiance").unwrap();
        let err = read_image(&png).unwrap_err().to_string();
        assert!(err.contains("not.hdr"), "{err}");
        let missing = read_image(dir.path().join("missing.hdr")).unwrap_err();
        assert!(matches!(missing, FilmError::Io { .. }), "{missing}");
        // A header that claims more than a file could hold is refused before any
        // buffer is sized by it.
        let huge = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 60000 +X 60000\n";
        let err = decode_hdr(huge).unwrap_err().to_string();
        assert!(err.contains("60000 x 60000"), "{err}");
    }
}
