//! What kind of image a file is, from its first bytes: so that a PNG given where an
//! EXR is expected is called a PNG, not a corrupt EXR.

/// The first four bytes of every OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Magic bytes of the image formats people mistake for each other.
const KNOWN: [(&[u8], &str); 11] = [
    (b"\x89PNG\r\n\x1a\n", "a PNG image"),
    (b"\xff\xd8\xff", "a JPEG image"),
    (b"#?RADIANCE", "a Radiance HDR image"),
    (b"#?RGBE", "a Radiance HDR image"),
    (b"II*\0", "a TIFF image"),
    (b"MM\0*", "a TIFF image"),
    (b"GIF8", "a GIF image"),
    (b"PF\n", "a PFM image"),
    (b"Pf\n", "a PFM image"),
    (b"BM", "a BMP image"),
    (b"qoif", "a QOI image"),
];

/// Whether `head` (a file's first bytes) starts like an OpenEXR file.
pub fn is_exr(head: &[u8]) -> bool {
    head.starts_with(&EXR_MAGIC)
}

/// The kind of image `head` starts like, in words ("a PNG image"), when it is a
/// known format other than OpenEXR.
pub fn other_image_format(head: &[u8]) -> Option<&'static str> {
    if head.len() >= 12 && head.starts_with(b"RIFF") && &head[8..12] == b"WEBP" {
        return Some("a WebP image");
    }
    KNOWN
        .iter()
        .find(|(magic, _)| head.starts_with(magic))
        .map(|(_, what)| *what)
}

/// Why `head` cannot be read as OpenEXR, when its first bytes already tell:
/// "a PNG image, not an OpenEXR file".
pub fn not_exr(head: &[u8]) -> Option<String> {
    if is_exr(head) || head.len() < EXR_MAGIC.len() {
        return None;
    }
    Some(match other_image_format(head) {
        Some(what) => format!("{what}, not an OpenEXR file"),
        None => "not an OpenEXR file (it does not start with the OpenEXR signature)".into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_are_named_by_their_magic_bytes() {
        assert!(not_exr(&[0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0]).is_none());
        let png = not_exr(b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR").unwrap();
        assert_eq!(png, "a PNG image, not an OpenEXR file");
        assert!(not_exr(b"\xff\xd8\xff\xe0\0\x10JFIF")
            .unwrap()
            .starts_with("a JPEG image"));
        assert!(not_exr(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n")
            .unwrap()
            .starts_with("a Radiance HDR image"));
        assert!(not_exr(b"RIFF\x10\0\0\0WEBPVP8 ")
            .unwrap()
            .starts_with("a WebP image"));
        assert!(not_exr(b"hello world")
            .unwrap()
            .contains("does not start with the OpenEXR signature"));
        // Too short to tell: the EXR reader says what is wrong.
        assert!(not_exr(b"ab").is_none());
    }
}
