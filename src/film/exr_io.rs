//! OpenEXR input and output: linear float32 R, G, B.
//!
//! Extra layers (albedo, normal, variance, ...) go into the same single-part file
//! as prefixed channels (`albedo.R`, `albedo.G`, `albedo.B`), which is the
//! OpenEXR layer naming convention and what denoisers and viewers (tev, Blender,
//! oiiotool) read; multi-part files are less widely supported.

use std::fs::File;
use std::io::{BufRead, BufWriter, Cursor, Read, Seek};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use exr::meta::header::Header;
use exr::meta::MetaData;
use exr::prelude::{
    self as x, AnyChannel, AnyChannels, FlatSamples, Layer, LayerAttributes, ReadChannels,
    ReadLayers, SmallVec, Text, WritableImage,
};
use glam::Vec3 as Rgb;

use super::atomic::write_atomic;
use super::error::check_pixels;
use super::sniff::not_exr;
use super::{FilmError, Image, MAX_PIXELS};

/// Lossless, scan lines, widely readable; ZIP keeps noisy float snapshots smaller
/// than RLE does.
const ENCODING: x::Encoding = x::Encoding {
    compression: x::Compression::ZIP16,
    blocks: x::Blocks::ScanLines,
    line_order: x::LineOrder::Increasing,
};

const MEMORY: &str = "<memory>";

/// Writes `image` as linear float32 R, G, B, atomically (temporary file + rename).
pub fn write_exr(path: impl AsRef<Path>, image: &Image) -> Result<(), FilmError> {
    write_exr_layers(path, image, &[])
}

/// Writes `base` as R, G, B plus each `(name, image)` as `name.R`, `name.G`,
/// `name.B`, atomically. All images must have the base's size; names must be
/// non-empty, distinct, Latin-1, and not begin or end with a dot.
pub fn write_exr_layers(
    path: impl AsRef<Path>,
    base: &Image,
    layers: &[(&str, &Image)],
) -> Result<(), FilmError> {
    let path = path.as_ref();
    let exr = build(base, layers, &path.display().to_string())?;
    write_atomic(path, |out| write_to(&exr, out, path))
}

/// The EXR file for `image` as bytes (e.g. for an HTTP response).
pub fn encode_exr(image: &Image) -> Result<Vec<u8>, FilmError> {
    encode_exr_layers(image, &[])
}

/// The layered EXR file of [`write_exr_layers`] as bytes.
pub fn encode_exr_layers(base: &Image, layers: &[(&str, &Image)]) -> Result<Vec<u8>, FilmError> {
    let exr = build(base, layers, MEMORY)?;
    let mut out = Cursor::new(Vec::new());
    write_to(&exr, &mut out, Path::new(MEMORY))?;
    Ok(out.into_inner())
}

/// Reads the R, G, B channels (alpha and other layers are ignored) of the first
/// part that has them, converting f16/u32 samples to f32. The image is the data
/// window; its offset is ignored.
pub fn read_exr(path: impl AsRef<Path>) -> Result<Image, FilmError> {
    read_exr_layer(path, "")
}

/// Reads layer `name` (channels `name.R`, `name.G`, `name.B`); `""` is the base.
pub fn read_exr_layer(path: impl AsRef<Path>, name: &str) -> Result<Image, FilmError> {
    let path = path.as_ref();
    read_file(path, path, name)
}

/// [`read_exr`] of a file that errors call `shown` (e.g. the name a scene gives it,
/// rather than the server's path to it).
pub fn read_exr_named(path: impl AsRef<Path>, shown: &str) -> Result<Image, FilmError> {
    read_file(path.as_ref(), Path::new(shown), "")
}

fn read_file(path: &Path, shown: &Path, layer: &str) -> Result<Image, FilmError> {
    let io = |source| FilmError::Io {
        path: shown.to_path_buf(),
        source,
    };
    let file = File::open(path).map_err(io)?;
    let len = file.metadata().map_err(io)?.len();
    decode(std::io::BufReader::new(file), len, shown, layer)
}

/// [`read_exr`] from bytes in memory (e.g. an uploaded reference image).
pub fn decode_exr(bytes: &[u8]) -> Result<Image, FilmError> {
    decode_exr_layer(bytes, "")
}

/// [`read_exr_layer`] from bytes in memory.
pub fn decode_exr_layer(bytes: &[u8], name: &str) -> Result<Image, FilmError> {
    decode(
        Cursor::new(bytes),
        bytes.len() as u64,
        Path::new(MEMORY),
        name,
    )
}

type FlatImage = x::Image<Layer<AnyChannels<FlatSamples>>>;

fn build(base: &Image, layers: &[(&str, &Image)], what: &str) -> Result<FlatImage, FilmError> {
    let mut channels = rgb_channels("", base, what)?;
    for (i, (name, image)) in layers.iter().enumerate() {
        check_layer_name(name, &layers[..i], what)?;
        if image.size() != base.size() {
            return Err(FilmError::SizeMismatch {
                a: base.size(),
                b: image.size(),
            });
        }
        channels.extend(rgb_channels(&format!("{name}."), image, what)?);
    }
    let size = (base.width() as usize, base.height() as usize);
    let channels = AnyChannels::sort(SmallVec::from_vec(channels));
    let layer = Layer::new(size, LayerAttributes::default(), ENCODING, channels);
    Ok(x::Image::from_layer(layer))
}

fn check_layer_name(name: &str, earlier: &[(&str, &Image)], what: &str) -> Result<(), FilmError> {
    let bad = if name.is_empty() || name.starts_with('.') || name.ends_with('.') {
        Some("empty or dot at an end")
    } else if earlier.iter().any(|(n, _)| *n == name) {
        Some("duplicate")
    } else {
        None
    };
    match bad {
        Some(why) => Err(FilmError::Exr(format!(
            "{what}: bad layer name {name:?} ({why})"
        ))),
        None => Ok(()),
    }
}

fn rgb_channels(
    prefix: &str,
    image: &Image,
    what: &str,
) -> Result<Vec<AnyChannel<FlatSamples>>, FilmError> {
    let px = image.pixels();
    let plane = |f: fn(&Rgb) -> f32| FlatSamples::F32(px.iter().map(f).collect());
    let name = |c: &str| {
        Text::new_or_none(format!("{prefix}{c}")).ok_or_else(|| {
            FilmError::Exr(format!(
                "{what}: channel name \"{prefix}{c}\" is not Latin-1"
            ))
        })
    };
    Ok(vec![
        AnyChannel::new(name("R")?, plane(|p| p.x)),
        AnyChannel::new(name("G")?, plane(|p| p.y)),
        AnyChannel::new(name("B")?, plane(|p| p.z)),
    ])
}

fn write_to(
    exr: &FlatImage,
    out: &mut (impl std::io::Write + Seek),
    path: &Path,
) -> Result<(), FilmError> {
    // exr expects a buffered writer; BufWriter over &mut keeps the caller's handle.
    let mut buffered = BufWriter::new(out);
    exr.write()
        .to_buffered(&mut buffered)
        .map_err(|e| exr_error(e, path))?;
    buffered.into_inner().map_err(|e| FilmError::Io {
        path: path.to_path_buf(),
        source: e.into_error(),
    })?;
    Ok(())
}

/// Most bytes of samples a file may claim, all parts and channels together: RGBA
/// float32 at [`MAX_PIXELS`] (1 GiB). Every channel of every part is decoded before
/// the R, G, B are picked, so the pixel cap alone would let a header with many
/// channels ask for many times that.
const MAX_SAMPLE_BYTES: u64 = 16 * MAX_PIXELS;

/// Headroom on the compression bound for chunk tables and tiny files.
const CLAIM_SLACK_BYTES: u64 = 1 << 16;

/// Most bytes of samples one byte of compressed data can stand for, rounded up. The
/// header sizes all buffers before any data is read, so a small file claiming more
/// than its bytes could hold is refused without decoding it:
/// - none: 1; RLE: 64 (a two-byte run yields at most 128 bytes);
/// - ZIP1, ZIP16: 1032, deflate's limit (a 258-byte match in two bits);
/// - PXR24: 1376, deflate's limit times 4/3 (float32 is stored as 24 bits);
/// - PIZ: 1032 covers its Huffman runs (at most 255 repeats of a 16-bit value after
///   a code of 9 bits or more, about 450);
/// - B44, B44A: 11 (a flat 4x4 block of 32 bytes packs into 3);
/// - DWAA, DWAB (and HTJ2K, which the crate does not decode): 2^18, since a flat
///   DCT block keeps only its DC value, 2 bytes per 8x8 pixels, deflated; for those
///   only [`MAX_SAMPLE_BYTES`] really bounds a small file's claim.
fn max_ratio(c: x::Compression) -> u64 {
    use x::Compression::*;
    match c {
        Uncompressed => 1,
        RLE => 64,
        ZIP1 | ZIP16 | PIZ => 1032,
        PXR24 => 1376,
        B44 | B44A => 11,
        DWAA(_) | DWAB(_) | HTJ2K32 | HTJ2K256 => 1 << 18,
    }
}

/// Bytes the crate allocates for a part: every channel at full resolution (it sizes
/// blocks that way, subsampled or not), or one block if that is more. A block's
/// size comes from the tile size or from the width times the lines per block, so a
/// tile or a DWA block (256 lines) far larger than the image is a way to claim
/// more: the crate reserves that much for a chunk whose size field says so.
fn claimed_bytes(h: &Header) -> u64 {
    let bytes: u64 = (h.channels.list.iter())
        .map(|c| c.sample_type.bytes_per_sample() as u64)
        .sum();
    let block_pixels = match h.blocks {
        exr::meta::BlockDescription::Tiles(t) => {
            (t.tile_size.0 as u64).saturating_mul(t.tile_size.1 as u64)
        }
        exr::meta::BlockDescription::ScanLines => {
            (h.compression.scan_lines_per_block() as u64).saturating_mul(h.layer_size.0 as u64)
        }
    };
    let pixels = h.layer_size.0 as u64 * h.layer_size.1 as u64;
    pixels.max(block_pixels).saturating_mul(bytes)
}

/// Checks every part's data window and the parts' claims together against the
/// caps and against what `len` bytes of file could hold, before any decoding.
fn check_claims(headers: &[Header], len: u64, what: &str) -> Result<(), FilmError> {
    let mut total = 0u64;
    let mut compressed_floor = 0u64;
    for h in headers {
        check_pixels(what, h.layer_size.0 as u64, h.layer_size.1 as u64)?;
        let claimed = claimed_bytes(h);
        total = total.saturating_add(claimed);
        compressed_floor = compressed_floor.saturating_add(claimed / max_ratio(h.compression));
    }
    let too_large = |detail: String| FilmError::TooLarge {
        what: what.to_string(),
        detail,
    };
    if total > MAX_SAMPLE_BYTES {
        return Err(too_large(format!(
            "the parts claim {total} bytes of samples, more than the {MAX_SAMPLE_BYTES} caustic reads"
        )));
    }
    if compressed_floor > len + CLAIM_SLACK_BYTES {
        return Err(too_large(format!(
            "the parts claim {total} bytes of samples, more than a {len}-byte file can hold"
        )));
    }
    Ok(())
}

type FlatLayers = x::Image<x::Layers<AnyChannels<FlatSamples>>>;

fn read_flat(reader: impl Read + Seek, path: &Path) -> Result<FlatLayers, FilmError> {
    x::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .non_parallel()
        .from_buffered(reader)
        .map_err(|e| exr_error(e, path))
}

/// Hostile files make the crate panic: arithmetic that overflows where overflow is
/// checked (B44 blocks), assertions on chunk indices. On its decompression threads a
/// panic aborts the process, hence `non_parallel` above; on this thread it is caught
/// here and becomes an error naming the file.
fn catching<T>(path: &Path, read: impl FnOnce() -> Result<T, FilmError>) -> Result<T, FilmError> {
    catch_unwind(AssertUnwindSafe(read)).unwrap_or_else(|panic| {
        let text = (panic.downcast_ref::<&str>().map(|s| s.to_string()))
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown error".into());
        Err(FilmError::Exr(format!(
            "{}: the EXR reader failed: {text}",
            path.display()
        )))
    })
}

fn decode(
    mut reader: impl BufRead + Seek,
    len: u64,
    path: &Path,
    prefix: &str,
) -> Result<Image, FilmError> {
    let head = reader.fill_buf().map_err(|source| FilmError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    if let Some(why) = not_exr(head) {
        return Err(FilmError::Exr(format!("{}: {why}", path.display())));
    }
    let exr = catching(path, || {
        let meta =
            MetaData::read_from_buffered(&mut reader, false).map_err(|e| exr_error(e, path))?;
        check_claims(&meta.headers, len, &path.display().to_string())?;
        reader.rewind().map_err(|source| FilmError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        read_flat(reader, path)
    })?;
    let prefix = if prefix.is_empty() {
        String::new()
    } else {
        format!("{prefix}.")
    };
    exr.layer_data
        .iter()
        .find_map(|layer| rgb_of_layer(layer, &prefix))
        .ok_or_else(|| FilmError::NoRgb(no_rgb_path(path, &prefix)))
}

/// `None` if the part lacks any of the channels or one is subsampled.
fn rgb_of_layer(layer: &Layer<AnyChannels<FlatSamples>>, prefix: &str) -> Option<Image> {
    let (w, h) = (layer.size.width(), layer.size.height());
    let channel = |c: &str| {
        let name = format!("{prefix}{c}");
        let ch = layer
            .channel_data
            .list
            .iter()
            .find(|ch| ch.name.eq(&name))?;
        (ch.sample_data.len() == w * h).then_some(&ch.sample_data)
    };
    let (r, g, b) = (channel("R")?, channel("G")?, channel("B")?);
    let pixels = r
        .values_as_f32()
        .zip(g.values_as_f32())
        .zip(b.values_as_f32())
        .map(|((r, g), b)| Rgb::new(r, g, b))
        .collect();
    Some(Image::from_pixels(
        u32::try_from(w).ok()?,
        u32::try_from(h).ok()?,
        pixels,
    ))
}

// NoRgb carries a path; for a named layer say which layer was missing.
fn no_rgb_path(path: &Path, prefix: &str) -> PathBuf {
    if prefix.is_empty() {
        path.to_path_buf()
    } else {
        PathBuf::from(format!(
            "{} (layer {})",
            path.display(),
            prefix.trim_end_matches('.')
        ))
    }
}

fn exr_error(e: x::Error, path: &Path) -> FilmError {
    match e {
        x::Error::Io(source) => FilmError::Io {
            path: path.to_path_buf(),
            source,
        },
        other => FilmError::Exr(format!("{}: {other}", path.display())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: u32, h: u32, k: f32) -> Image {
        let pixels = (0..w * h)
            .map(|i| {
                Rgb::new(
                    i as f32 * k,
                    1.0 / (i as f32 + 3.0),
                    -(i as f32) * 1e-7 + 1e20 * k,
                )
            })
            .collect();
        Image::from_pixels(w, h, pixels)
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let img = ramp(7, 5, 0.37);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rt.exr");
        write_exr(&path, &img).unwrap();
        let back = read_exr(&path).unwrap();
        assert_eq!(back.size(), (7, 5));
        assert_eq!(back, img);
        assert_eq!(back.get(6, 0), img.get(6, 0), "row 0 stays at the top");
    }

    #[test]
    fn encode_decode_in_memory() {
        let img = ramp(3, 4, 2.5);
        let bytes = encode_exr(&img).unwrap();
        assert_eq!(&bytes[..4], &[0x76, 0x2f, 0x31, 0x01], "EXR magic number");
        assert_eq!(decode_exr(&bytes).unwrap(), img);
    }

    #[test]
    fn layered_file_round_trip() {
        let base = ramp(4, 3, 1.0);
        let albedo = ramp(4, 3, 0.5);
        let normal = ramp(4, 3, -0.25);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("layers.exr");
        write_exr_layers(&path, &base, &[("albedo", &albedo), ("normal", &normal)]).unwrap();
        assert_eq!(read_exr(&path).unwrap(), base);
        assert_eq!(read_exr_layer(&path, "albedo").unwrap(), albedo);
        assert_eq!(read_exr_layer(&path, "normal").unwrap(), normal);
        let err = read_exr_layer(&path, "variance").unwrap_err();
        assert!(matches!(err, FilmError::NoRgb(_)));
        assert!(err.to_string().contains("layers.exr (layer variance)"));
    }

    #[test]
    fn layer_names_are_prefixed_channels() {
        let base = Image::new(2, 2);
        let bytes = encode_exr_layers(&base, &[("albedo", &base)]).unwrap();
        let exr = read_flat(Cursor::new(bytes), Path::new(MEMORY)).unwrap();
        let names: Vec<String> = exr.layer_data[0]
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        assert_eq!(names, ["B", "G", "R", "albedo.B", "albedo.G", "albedo.R"]);
    }

    #[test]
    fn bad_layers_are_errors() {
        let base = Image::new(2, 2);
        let small = Image::new(1, 2);
        let mismatch = encode_exr_layers(&base, &[("albedo", &small)]).unwrap_err();
        assert!(matches!(
            mismatch,
            FilmError::SizeMismatch {
                a: (2, 2),
                b: (1, 2)
            }
        ));
        let dup = encode_exr_layers(&base, &[("a", &base), ("a", &base)]).unwrap_err();
        assert!(dup.to_string().contains("duplicate"));
        assert!(encode_exr_layers(&base, &[("", &base)]).is_err());
        assert!(encode_exr_layers(&base, &[("albédo✓", &base)]).is_err());
    }

    #[test]
    fn reads_f16_rgba_and_rejects_missing_rgb() {
        use x::f16;
        let size = (2usize, 1usize);
        let rgba = |n: &str, v: [f32; 2]| {
            AnyChannel::new(
                n,
                FlatSamples::F16(v.iter().map(|&v| f16::from_f32(v)).collect()),
            )
        };
        let chans = vec![
            rgba("A", [1.0, 1.0]),
            rgba("B", [0.25, 4.0]),
            rgba("G", [0.5, 2.0]),
            rgba("R", [1.5, 0.125]),
        ];
        let layer = Layer::new(
            size,
            LayerAttributes::default(),
            ENCODING,
            AnyChannels::sort(SmallVec::from_vec(chans)),
        );
        let mut bytes = Cursor::new(Vec::new());
        x::Image::from_layer(layer)
            .write()
            .to_buffered(&mut bytes)
            .unwrap();
        let img = decode_exr(bytes.get_ref()).unwrap();
        assert_eq!(
            img.pixels(),
            &[Rgb::new(1.5, 0.5, 0.25), Rgb::new(0.125, 2.0, 4.0)]
        );

        let only_y = vec![AnyChannel::new("Y", FlatSamples::F32(vec![1.0, 2.0]))];
        let layer = Layer::new(
            size,
            LayerAttributes::default(),
            ENCODING,
            AnyChannels::sort(SmallVec::from_vec(only_y)),
        );
        let mut bytes = Cursor::new(Vec::new());
        x::Image::from_layer(layer)
            .write()
            .to_buffered(&mut bytes)
            .unwrap();
        assert!(matches!(
            decode_exr(bytes.get_ref()),
            Err(FilmError::NoRgb(_))
        ));
    }

    #[test]
    fn read_errors_name_the_file() {
        let missing = read_exr("/no/such/dir/missing.exr").unwrap_err();
        assert!(matches!(missing, FilmError::Io { .. }));
        assert!(missing.to_string().contains("/no/such/dir/missing.exr"));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("garbage.exr");
        std::fs::write(&path, b"not an exr file at all").unwrap();
        let garbage = read_exr(&path).unwrap_err();
        assert!(garbage.to_string().contains("garbage.exr"), "{garbage}");
        // A PNG where an EXR is expected says that it is a PNG.
        let png = dir.path().join("image.exr");
        crate::film::write_png(&png, &Image::new(2, 2), 0.0).unwrap();
        let e = read_exr(&png).unwrap_err().to_string();
        assert!(
            e.contains("image.exr: a PNG image, not an OpenEXR file"),
            "{e}"
        );
        let bytes = std::fs::read(&png).unwrap();
        let e = decode_exr(&bytes).unwrap_err().to_string();
        assert!(e.contains("a PNG image, not an OpenEXR file"), "{e}");
    }
}
