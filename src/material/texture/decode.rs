//! Reading bitmap textures: PNG and JPEG through the `image` crate, OpenEXR and
//! Radiance HDR through the film's readers.
//!
//! A texture file is hostile input like every upload: the header's size is checked
//! before anything is allocated for it (at most [`MAX_PIXELS`]), the decoder's own
//! allocations are capped, and a panic inside a third-party decoder becomes an error
//! rather than a dead worker. PNG and JPEG are sRGB-encoded unless `raw` (Mitsuba's
//! rule, for opacity and weight maps too); EXR and HDR are linear. Alpha is dropped:
//! cut-outs take their opacity from a texture of their own, as in Mitsuba.

use super::texels::Texels;
use crate::film::{decode_exr, decode_hdr, is_exr, Image, MAX_PIXELS};
use image::{DynamicImage, ImageDecoder};
use std::io::Cursor;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Why a texture file could not be read; the message starts with the file's name.
#[derive(Debug, thiserror::Error)]
#[error("{name}: {message}")]
pub struct TextureError {
    pub name: String,
    pub message: String,
}

/// Decodes a texture file's bytes; `name` is how the scene names it.
pub fn decode(bytes: &[u8], name: &str, raw: bool) -> Result<Texels, TextureError> {
    decode_within(bytes, name, raw, usize::MAX)
}

/// [`decode`], refusing a PNG or JPEG whose header promises more than `max_bytes` of
/// texels before anything is decoded: a few KiB of compressed zeros can claim
/// hundreds of MiB (a decompression bomb), and only the header says so in time.
pub fn decode_within(
    bytes: &[u8],
    name: &str,
    raw: bool,
    max_bytes: usize,
) -> Result<Texels, TextureError> {
    let err = |message: String| TextureError {
        name: name.to_string(),
        message,
    };
    let decoded = catch_unwind(AssertUnwindSafe(|| {
        if is_exr(bytes) {
            decode_exr(bytes).map(from_image).map_err(|e| e.to_string())
        } else if is_radiance(bytes) {
            decode_hdr(bytes).map(from_image).map_err(|e| e.to_string())
        } else {
            decode_with_image_crate(bytes, raw, max_bytes)
        }
    }));
    decoded
        .unwrap_or_else(|_| Err("the image decoder failed on this file".into()))
        .map_err(err)
}

fn is_radiance(bytes: &[u8]) -> bool {
    bytes.starts_with(b"#?RADIANCE") || bytes.starts_with(b"#?RGBE")
}

fn from_image(image: Image) -> Texels {
    let data = image.pixels().iter().flat_map(|p| p.to_array()).collect();
    Texels::from_floats(image.width(), image.height(), 3, data)
}

fn decode_with_image_crate(bytes: &[u8], raw: bool, max_bytes: usize) -> Result<Texels, String> {
    let reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    if !matches!(
        reader.format(),
        Some(image::ImageFormat::Png | image::ImageFormat::Jpeg)
    ) {
        return Err("not a PNG, JPEG, OpenEXR or Radiance HDR image".into());
    }
    let mut decoder = reader.into_decoder().map_err(|e| e.to_string())?;
    let (width, height) = decoder.dimensions();
    check_size(width, height)?;
    check_bytes(width, height, decoder.color_type(), max_bytes)?;
    let mut limits = image::Limits::default();
    // Four f32 channels per pixel at most, plus the decoder's own working room.
    limits.max_alloc = Some(MAX_PIXELS * 16 + (64 << 20));
    decoder.set_limits(limits).map_err(|e| e.to_string())?;
    let image = DynamicImage::from_decoder(decoder).map_err(|e| e.to_string())?;
    Ok(texels(image, !raw))
}

fn check_size(width: u32, height: u32) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err(format!("an empty image ({width} x {height})"));
    }
    if u64::from(width) * u64::from(height) > MAX_PIXELS {
        return Err(format!(
            "{width} x {height} pixels, more than the {MAX_PIXELS} caustic reads"
        ));
    }
    Ok(())
}

/// Refuses an image whose texels (as [`texels`] keeps them) would exceed `max_bytes`.
fn check_bytes(
    width: u32,
    height: u32,
    color: image::ColorType,
    max_bytes: usize,
) -> Result<(), String> {
    let channels: u64 = if color.has_color() { 3 } else { 1 };
    let per_channel: u64 = if color.bytes_per_pixel() / color.channel_count() == 1 {
        1
    } else {
        4
    };
    let need = u64::from(width) * u64::from(height) * channels * per_channel;
    if need <= max_bytes as u64 {
        return Ok(());
    }
    Err(format!(
        "{width} x {height} pixels decode to {} MiB, above the {} MiB left for this \
         scene's textures",
        need.div_ceil(1 << 20),
        max_bytes >> 20
    ))
}

/// 8-bit images keep their bytes; deeper ones become linear floats.
fn texels(image: DynamicImage, srgb: bool) -> Texels {
    let (w, h) = (image.width(), image.height());
    let grey = !image.color().has_color();
    match image {
        DynamicImage::ImageLuma8(_) | DynamicImage::ImageLumaA8(_) => {
            Texels::from_bytes(w, h, 1, image.into_luma8().into_raw(), srgb)
        }
        DynamicImage::ImageRgb8(_) | DynamicImage::ImageRgba8(_) => {
            Texels::from_bytes(w, h, 3, image.into_rgb8().into_raw(), srgb)
        }
        DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_) => {
            Texels::from_floats(w, h, 3, image.into_rgb32f().into_raw())
        }
        _ if grey => {
            let data = image.into_luma16().into_raw();
            Texels::from_floats(w, h, 1, unit_floats(&data, srgb))
        }
        _ => {
            let data = image.into_rgb16().into_raw();
            Texels::from_floats(w, h, 3, unit_floats(&data, srgb))
        }
    }
}

fn unit_floats(data: &[u16], srgb: bool) -> Vec<f32> {
    data.iter()
        .map(|&v| {
            let x = f32::from(v) / 65535.0;
            if srgb {
                crate::film::srgb_eotf(x)
            } else {
                x
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rgb;

    fn png(width: u32, height: u32, color: image::ColorType, data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        image::ImageEncoder::write_image(
            image::codecs::png::PngEncoder::new(&mut out),
            data,
            width,
            height,
            color.into(),
        )
        .unwrap();
        out
    }

    #[test]
    fn png_rows_come_top_first_and_decode_as_srgb_unless_raw() {
        let bytes = png(1, 2, image::ColorType::Rgb8, &[255, 0, 0, 0, 188, 0]);
        let t = decode(&bytes, "t.png", false).unwrap();
        assert_eq!((t.width(), t.height()), (1, 2));
        assert_eq!(t.get(0, 0), Rgb::new(1.0, 0.0, 0.0));
        assert!((t.get(0, 1).y - 0.5029).abs() < 1e-3);
        let raw = decode(&bytes, "t.png", true).unwrap();
        assert_eq!(raw.get(0, 1).y, 188.0 / 255.0);
    }

    #[test]
    fn grey_and_alpha_images_keep_one_or_three_channels() {
        let grey = decode(
            &png(2, 1, image::ColorType::La8, &[10, 0, 20, 255]),
            "g",
            true,
        );
        let grey = grey.unwrap();
        assert!(grey.is_grey());
        assert_eq!(grey.get(1, 0), Rgb::splat(20.0 / 255.0));
        let rgba = png(1, 1, image::ColorType::Rgba8, &[1, 2, 3, 0]);
        let t = decode(&rgba, "a", true).unwrap();
        assert_eq!(t.get(0, 0), Rgb::new(1.0, 2.0, 3.0) / 255.0);
        let deep = png(1, 1, image::ColorType::Rgb16, &[255, 255, 0, 0, 128, 0]);
        let t = decode(&deep, "d", true).unwrap();
        assert_eq!(t.get(0, 0).x, 1.0);
    }

    #[test]
    fn huge_headers_truncated_files_and_garbage_are_errors() {
        // A PNG header claiming 100000 x 100000 pixels: refused before decoding.
        let big = with_header_size(
            png(1, 1, image::ColorType::Rgb8, &[0, 0, 0]),
            100_000,
            100_000,
        );
        let e = decode(&big, "big.png", false).unwrap_err().to_string();
        assert!(
            e.starts_with("big.png: 100000 x 100000 pixels, more than"),
            "{e}"
        );
        let ok = png(4, 4, image::ColorType::Rgb8, &[7; 48]);
        let e = decode(&ok[..ok.len() / 2], "cut.png", false).unwrap_err();
        assert_eq!(e.name, "cut.png");
        let e = decode(b"GIF89a not supported", "x.gif", false).unwrap_err();
        assert!(e.message.contains("not a PNG"), "{e}");
    }

    /// `png`'s image with its header's size changed (and its checksum made right).
    fn with_header_size(mut png: Vec<u8>, width: u32, height: u32) -> Vec<u8> {
        png[16..20].copy_from_slice(&width.to_be_bytes());
        png[20..24].copy_from_slice(&height.to_be_bytes());
        let mut crc = flate2::Crc::new();
        crc.update(&png[12..29]);
        png[29..33].copy_from_slice(&crc.sum().to_be_bytes());
        png
    }

    #[test]
    fn bombs_are_refused_by_their_header_within_the_budget() {
        // 8192 x 8192 16-bit RGB claims 768 MiB of f32 texels from a few bytes.
        let bomb = with_header_size(png(1, 1, image::ColorType::Rgb16, &[0; 6]), 8192, 8192);
        let e = decode_within(&bomb, "bomb.png", false, 512 << 20).unwrap_err();
        assert!(
            e.message
                .contains("decode to 768 MiB, above the 512 MiB left"),
            "{e}"
        );
        // The budget counts what is kept: 8-bit grey is a byte a pixel, deep RGB 12.
        let grey = png(4, 4, image::ColorType::L8, &[9; 16]);
        assert!(decode_within(&grey, "g", true, 16).is_ok());
        assert!(decode_within(&grey, "g", true, 15).is_err());
        let deep = png(2, 2, image::ColorType::Rgb16, &[1; 24]);
        assert!(decode_within(&deep, "d", true, 48).is_ok());
        assert!(decode_within(&deep, "d", true, 47).is_err());
    }
}
