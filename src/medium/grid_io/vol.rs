//! Mitsuba `.vol` volumes, version 3 (the format is described in the module above).

use super::{
    check_grid, check_shape, io_error, open_with_len, read_floats, value_count, write_floats,
    DenseGrid, GridError, Result, MEMORY,
};
use std::fs::File;
use std::io::{self, BufReader, Read, Write};
use std::path::Path;

/// Bytes before the data in a Mitsuba .vol file.
pub(super) const VOL_HEADER_BYTES: u64 = 48;

struct VolHeader {
    dims: [i64; 3],
    bounds: ([f32; 3], [f32; 3]),
}

fn le_i32(b: &[u8], at: usize) -> i32 {
    i32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn le_f32(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// Byte offsets: magic 0..3, version 3, encoding 4, dims 8/12/16, channels 20,
/// bounds min 24/28/32 and max 36/40/44.
fn parse_vol_header(path: &Path, h: &[u8; VOL_HEADER_BYTES as usize]) -> Result<VolHeader> {
    let path = path.to_path_buf();
    let (version, encoding, channels) = (h[3], le_i32(h, 4), le_i32(h, 20));
    if &h[0..3] != b"VOL" {
        Err(GridError::VolMagic { path })
    } else if version != 3 {
        Err(GridError::VolVersion {
            path,
            found: version,
        })
    } else if encoding != 1 {
        Err(GridError::VolEncoding {
            path,
            found: encoding,
        })
    } else if channels != 1 {
        Err(GridError::VolChannels {
            path,
            found: channels,
        })
    } else {
        Ok(VolHeader {
            dims: [8, 12, 16].map(|at| i64::from(le_i32(h, at))),
            bounds: (
                [24, 28, 32].map(|at| le_f32(h, at)),
                [36, 40, 44].map(|at| le_f32(h, at)),
            ),
        })
    }
}

pub(super) fn read_vol(path: &Path) -> Result<DenseGrid> {
    let (file, len) = open_with_len(path)?;
    read_vol_from(path, BufReader::new(file), len)
}

/// Reads a volume of `len` bytes; `path` names it in errors.
fn read_vol_from(path: &Path, mut reader: impl Read, len: u64) -> Result<DenseGrid> {
    if len < VOL_HEADER_BYTES {
        return Err(GridError::VolHeaderTruncated {
            path: path.to_path_buf(),
            found: len,
        });
    }
    let mut header = [0u8; VOL_HEADER_BYTES as usize];
    reader.read_exact(&mut header).map_err(io_error(path))?;
    let header = parse_vol_header(path, &header)?;
    let count = value_count(path, header.dims)?;
    let data = read_floats(path, &mut reader, count, len - VOL_HEADER_BYTES)?;
    Ok(DenseGrid {
        dims: header.dims.map(|d| d as usize),
        data,
        bounds: Some(header.bounds),
    })
}

/// Writes a Mitsuba volume (version 3, float32, one channel). A grid without bounds
/// is written with the unit cube, the box Mitsuba assumes by default.
pub fn write_vol(path: &Path, grid: &DenseGrid) -> io::Result<()> {
    let bytes = encode_vol(grid)?;
    let mut f = File::create(path)?;
    f.write_all(&bytes)?;
    f.sync_all()
}

/// [`write_vol`] to a writer (`dims` checked to fit an i32).
fn write_vol_to(w: &mut impl Write, grid: &DenseGrid, dims: &[i32]) -> io::Result<()> {
    let (min, max) = grid.bounds.unwrap_or(([0.0; 3], [1.0; 3]));
    w.write_all(b"VOL\x03")?;
    for v in [1, dims[0], dims[1], dims[2], 1] {
        w.write_all(&v.to_le_bytes())?;
    }
    write_floats(w, &min)?;
    write_floats(w, &max)?;
    write_floats(w, &grid.data)
}

/// The bytes [`write_vol`] writes.
pub fn encode_vol(grid: &DenseGrid) -> io::Result<Vec<u8>> {
    check_shape(grid)?;
    let dims: Vec<i32> = grid
        .dims
        .iter()
        .map(|&d| i32::try_from(d).map_err(|_| io::Error::other("dimension exceeds i32")))
        .collect::<io::Result<_>>()?;
    let mut out = Vec::with_capacity(VOL_HEADER_BYTES as usize + 4 * grid.data.len());
    write_vol_to(&mut out, grid, &dims)?;
    Ok(out)
}

/// A Mitsuba `.vol` file in memory (for fuzzing and tests), checked as [`load_grid`]
/// checks a file; errors name `<memory>`.
pub fn decode_vol(bytes: &[u8]) -> Result<DenseGrid> {
    let path = Path::new(MEMORY);
    let grid = read_vol_from(path, bytes, bytes.len() as u64)?;
    check_grid(path, grid)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::grid_io::tests::{load, sample, vol_with};
    use tempfile::TempDir;

    fn patched_vol(patch: impl FnOnce(&mut Vec<u8>)) -> Result<DenseGrid> {
        let dir = TempDir::new().unwrap();
        load(&vol_with(&dir, &sample(), patch))
    }

    #[test]
    fn vol_round_trip() {
        let dir = TempDir::new().unwrap();
        let path = vol_with(&dir, &sample(), |_| {});
        assert_eq!(load(&path).unwrap(), sample());
    }

    #[test]
    fn vol_without_bounds_is_written_as_unit_cube() {
        let dir = TempDir::new().unwrap();
        let grid = DenseGrid {
            bounds: None,
            ..sample()
        };
        let loaded = load(&vol_with(&dir, &grid, |_| {})).unwrap();
        assert_eq!(loaded.bounds, Some(([0.0; 3], [1.0; 3])));
    }

    #[test]
    fn vol_layout_matches_mitsuba() {
        let dir = TempDir::new().unwrap();
        let bytes = std::fs::read(vol_with(&dir, &sample(), |_| {})).unwrap();
        assert_eq!(&bytes[..4], b"VOL\x03");
        assert_eq!(le_i32(&bytes, 4), 1);
        assert_eq!([8, 12, 16, 20].map(|at| le_i32(&bytes, at)), [3, 4, 5, 1]);
        assert_eq!(le_f32(&bytes, 24), -1.0);
        assert_eq!(le_f32(&bytes, 44), 3.5);
        assert_eq!(bytes.len(), 48 + 60 * 4);
        // x fastest: the second value in the file is voxel (1, 0, 0).
        assert_eq!(le_f32(&bytes, 52), 0.25);
    }

    #[test]
    fn vol_truncated_or_padded_data_is_refused() {
        let short = patched_vol(|b| b.truncate(b.len() - 8));
        assert!(
            matches!(
                short,
                Err(GridError::DataLength {
                    expected: 60,
                    found_bytes: 232,
                    ..
                })
            ),
            "{short:?}"
        );
        let message = short.unwrap_err().to_string();
        assert!(
            message.contains("expected 60 floats (240 bytes)"),
            "{message}"
        );
        assert!(message.contains("file holds 58"), "{message}");
        let long = patched_vol(|b| b.push(0));
        assert!(
            matches!(
                long,
                Err(GridError::DataLength {
                    found_bytes: 241,
                    ..
                })
            ),
            "{long:?}"
        );
    }

    #[test]
    fn vol_truncated_header_is_refused() {
        let r = patched_vol(|b| b.truncate(20));
        assert!(
            matches!(r, Err(GridError::VolHeaderTruncated { found: 20, .. })),
            "{r:?}"
        );
    }

    #[test]
    fn vol_wrong_magic_is_refused() {
        let r = patched_vol(|b| b[0] = b'X');
        assert!(matches!(r, Err(GridError::VolMagic { .. })), "{r:?}");
    }

    #[test]
    fn vol_other_version_encoding_or_channels_are_refused() {
        let r = patched_vol(|b| b[3] = 2);
        assert!(
            matches!(r, Err(GridError::VolVersion { found: 2, .. })),
            "{r:?}"
        );
        // Mitsuba 0.6 used encoding 3 for uint8 data.
        let r = patched_vol(|b| b[4] = 3);
        assert!(
            matches!(r, Err(GridError::VolEncoding { found: 3, .. })),
            "{r:?}"
        );
        let r = patched_vol(|b| b[20] = 3);
        assert!(
            matches!(r, Err(GridError::VolChannels { found: 3, .. })),
            "{r:?}"
        );
    }

    #[test]
    fn vol_bad_dims_are_refused_before_allocating() {
        let r = patched_vol(|b| b[12..16].copy_from_slice(&0i32.to_le_bytes()));
        assert!(
            matches!(
                r,
                Err(GridError::BadDims {
                    dims: [3, 0, 5],
                    ..
                })
            ),
            "{r:?}"
        );
        let r = patched_vol(|b| b[8..12].copy_from_slice(&(-4i32).to_le_bytes()));
        assert!(matches!(r, Err(GridError::BadDims { .. })), "{r:?}");
        // 2^26 * 4 * 5 values: over the cap, though the file is tiny.
        let r = patched_vol(|b| b[8..12].copy_from_slice(&(1i32 << 26).to_le_bytes()));
        assert!(matches!(r, Err(GridError::TooLarge { .. })), "{r:?}");
    }

    #[test]
    fn vol_bounds_that_are_not_a_box_are_refused() {
        // min x = 5 > max x = 1
        let r = patched_vol(|b| b[24..28].copy_from_slice(&5f32.to_le_bytes()));
        assert!(matches!(r, Err(GridError::BadBounds { .. })), "{r:?}");
    }
}
