//! 8-bit sRGB PNG output of linear images.

use std::io::Write;
use std::path::Path;

use rayon::prelude::*;

use super::atomic::write_atomic;
use super::{FilmError, Image};

/// The exact sRGB encoding function (IEC 61966-2-1), linear -> encoded, for
/// values in [0, 1].
pub fn srgb_oetf(linear: f32) -> f32 {
    oetf(linear as f64) as f32
}

/// The inverse of [`srgb_oetf`], encoded -> linear.
pub fn srgb_eotf(encoded: f32) -> f32 {
    let e = encoded as f64;
    let l = if e <= 0.04045 {
        e / 12.92
    } else {
        ((e + 0.055) / 1.055).powf(2.4)
    };
    l as f32
}

// f64 so that values near a rounding boundary (0.5 linear -> 187.52) round the
// same way on every platform.
fn oetf(l: f64) -> f64 {
    if l <= 0.0031308 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

fn encode_channel(linear: f32, gain: f64) -> u8 {
    let e = oetf(linear as f64 * gain);
    // NaN would otherwise pass through clamp; show it as black.
    let e = if e.is_nan() { 0.0 } else { e.clamp(0.0, 1.0) };
    (e * 255.0).round() as u8
}

/// RGB8 bytes, top row first: pixels scaled by 2^exposure, sRGB-encoded, clamped.
pub fn to_srgb8(image: &Image, exposure: f32) -> Vec<u8> {
    let gain = (exposure as f64).exp2();
    let mut out = vec![0u8; image.pixels().len() * 3];
    out.par_chunks_mut(3)
        .zip(image.pixels().par_iter())
        .for_each(|(o, p)| {
            o[0] = encode_channel(p.x, gain);
            o[1] = encode_channel(p.y, gain);
            o[2] = encode_channel(p.z, gain);
        });
    out
}

/// Writes an sRGB PNG of `image` after `exposure` stops, atomically.
pub fn write_png(path: impl AsRef<Path>, image: &Image, exposure: f32) -> Result<(), FilmError> {
    let path = path.as_ref();
    write_atomic(path, |out| {
        write_png_to(out, image, exposure, &path.display().to_string())
    })
}

/// The PNG file of [`write_png`] as bytes.
pub fn encode_png(image: &Image, exposure: f32) -> Result<Vec<u8>, FilmError> {
    let mut out = Vec::new();
    write_png_to(&mut out, image, exposure, "<memory>")?;
    Ok(out)
}

fn write_png_to(
    out: impl Write,
    image: &Image,
    exposure: f32,
    what: &str,
) -> Result<(), FilmError> {
    let err = |e: png::EncodingError| FilmError::Png(format!("{what}: {e}"));
    let mut enc = png::Encoder::new(out, image.width(), image.height());
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    // Tells viewers the bytes are sRGB, so they are shown without a second guess.
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = enc.write_header().map_err(err)?;
    writer
        .write_image_data(&to_srgb8(image, exposure))
        .map_err(err)?;
    writer.finish().map_err(err)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3 as Rgb;

    fn grey(values: &[f32]) -> Image {
        let px = values.iter().map(|&v| Rgb::splat(v)).collect();
        Image::from_pixels(values.len() as u32, 1, px)
    }

    fn reds(image: &Image, exposure: f32) -> Vec<u8> {
        to_srgb8(image, exposure).chunks(3).map(|c| c[0]).collect()
    }

    #[test]
    fn known_values() {
        let img = grey(&[0.0, 1.0, 0.0031308, 0.5, 2.0, -1.0, f32::NAN, f32::INFINITY]);
        // 0.0031308 * 12.92 * 255 = 10.31; 0.5 -> 0.7354 * 255 = 187.5.
        assert_eq!(reds(&img, 0.0), [0, 255, 10, 188, 255, 0, 0, 255]);
    }

    #[test]
    fn oetf_is_continuous_at_the_boundary() {
        let below = srgb_oetf(0.0031308);
        let above = srgb_oetf(0.003_130_81);
        assert!((below - 0.04045).abs() < 1e-6, "{below}");
        assert!((above - below).abs() < 1e-5);
        for v in [0.0, 0.001, 0.2, 0.5, 1.0] {
            assert!((srgb_eotf(srgb_oetf(v)) - v).abs() < 1e-6);
        }
    }

    #[test]
    fn exposure_plus_one_doubles() {
        let half = grey(&[0.25, 0.001, 0.5]);
        let full = grey(&[0.5, 0.002, 1.0]);
        assert_eq!(to_srgb8(&half, 1.0), to_srgb8(&full, 0.0));
        assert_eq!(to_srgb8(&full, -1.0), to_srgb8(&half, 0.0));
    }

    #[test]
    fn rows_are_top_first_and_channels_in_order() {
        let mut img = Image::new(1, 2);
        img.set(0, 0, Rgb::new(1.0, 0.0, 0.0));
        img.set(0, 1, Rgb::new(0.0, 0.0, 1.0));
        assert_eq!(to_srgb8(&img, 0.0), [255, 0, 0, 0, 0, 255]);
    }

    #[test]
    fn png_decodes_to_the_same_bytes() {
        let img = Image::from_pixels(
            3,
            2,
            (0..6)
                .map(|i| Rgb::new(i as f32 / 5.0, 0.5, 0.01))
                .collect(),
        );
        let bytes = encode_png(&img, 0.0).unwrap();
        let mut reader = png::Decoder::new(std::io::Cursor::new(&bytes))
            .read_info()
            .unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (3, 2));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(&buf[..info.buffer_size()], to_srgb8(&img, 0.0).as_slice());
    }

    #[test]
    fn write_png_to_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        let img = grey(&[0.5, 1.0]);
        write_png(&path, &img, 0.0).unwrap();
        assert_eq!(
            std::fs::read(&path).unwrap(),
            encode_png(&img, 0.0).unwrap()
        );
    }
}
