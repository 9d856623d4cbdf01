//! Hostile texture images in scene bundles (issue 37): headers that claim huge
//! images, decompression bombs that stay within the pixel cap but not within the
//! server's texture budget, truncated files and lies about the format. Each gets a 422
//! that names the material's field, before anything large is decoded.

use super::inputs::{file, tar};
use super::{case, upload, Case};
use serde_json::{json, Value};

/// `scene` with its material's reflectance read from `texture`.
fn textured(mut scene: Value, texture: &str) -> String {
    scene["materials"]["m"]["reflectance"] = json!({"type": "bitmap", "filename": texture});
    scene.to_string()
}

fn encoded(format: image::ImageFormat, w: u32, h: u32, color: image::ColorType) -> Vec<u8> {
    let data = vec![90u8; (w * h) as usize * usize::from(color.bytes_per_pixel())];
    let mut out = std::io::Cursor::new(Vec::new());
    image::write_buffer_with_format(&mut out, &data, w, h, color, format).unwrap();
    out.into_inner()
}

/// A PNG whose header claims `w` x `h` pixels (checksum corrected), data unchanged.
fn png_claiming(color: image::ColorType, w: u32, h: u32) -> Vec<u8> {
    let mut png = encoded(image::ImageFormat::Png, 2, 2, color);
    png[16..20].copy_from_slice(&w.to_be_bytes());
    png[20..24].copy_from_slice(&h.to_be_bytes());
    let mut crc = flate2::Crc::new();
    crc.update(&png[12..29]);
    png[29..33].copy_from_slice(&crc.sum().to_be_bytes());
    png
}

/// A JPEG whose start-of-frame claims `w` x `h` pixels.
fn jpeg_claiming(w: u16, h: u16) -> Vec<u8> {
    let mut jpg = encoded(image::ImageFormat::Jpeg, 8, 8, image::ColorType::Rgb8);
    let sof = jpg
        .windows(2)
        .position(|m| m == [0xFF, 0xC0])
        .expect("a baseline JPEG has a SOF0 marker");
    jpg[sof + 5..sof + 7].copy_from_slice(&h.to_be_bytes());
    jpg[sof + 7..sof + 9].copy_from_slice(&w.to_be_bytes());
    jpg
}

pub fn image_cases(scene: &Value) -> Vec<Case> {
    let png_scene = textured(scene.clone(), "t.png");
    let jpg_scene = textured(scene.clone(), "t.jpg");
    let bundle = |scene: &str, name: &str, data: &[u8]| {
        upload(tar(&[
            file("scene.json", scene.as_bytes()),
            file(name, data),
        ]))
    };
    let png = encoded(image::ImageFormat::Png, 16, 16, image::ColorType::Rgb8);
    let jpg = encoded(image::ImageFormat::Jpeg, 16, 16, image::ColorType::Rgb8);
    let field = "materials.m.reflectance";
    vec![
        case(
            "texture: PNG header claiming 100000 x 100000 pixels",
            bundle(
                &png_scene,
                "t.png",
                &png_claiming(image::ColorType::Rgb8, 100_000, 100_000),
            ),
            &[422],
        )
        .mentions(field),
        case(
            "texture: PNG bomb, 8192 x 8192 16-bit RGB (768 MiB of texels) from 70 bytes",
            bundle(
                &png_scene,
                "t.png",
                &png_claiming(image::ColorType::Rgb16, 8192, 8192),
            ),
            &[422],
        )
        .mentions(field),
        case(
            "texture: PNG truncated to half",
            bundle(&png_scene, "t.png", &png[..png.len() / 2]),
            &[422],
        )
        .mentions(field),
        case(
            "texture: JPEG header claiming 65000 x 65000 pixels",
            bundle(&jpg_scene, "t.jpg", &jpeg_claiming(65_000, 65_000)),
            &[422],
        )
        .mentions(field),
        case(
            "texture: JPEG truncated to half",
            bundle(&jpg_scene, "t.jpg", &jpg[..jpg.len() / 2]),
            &[422],
        )
        .mentions(field),
        case(
            "texture: a GIF named .png",
            bundle(&png_scene, "t.png", b"GIF89a\x01\x00\x01\x00\x00\x00\x00;"),
            &[422],
        )
        .mentions(field),
        case(
            "texture: the named image is missing from the bundle",
            upload(tar(&[file("scene.json", png_scene.as_bytes())])),
            &[422],
        )
        .mentions(field),
    ]
}
