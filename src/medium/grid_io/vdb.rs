//! OpenVDB files, read with the `vdb-rs` crate (what it reads is listed in the module
//! above).

use super::{io_error, value_count, DenseGrid, GridError, Result};
use std::fs::File;
use std::io::{self, BufReader, Read};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

/// `OPENVDB_MAGIC` (0x56444220) as the int64 every .vdb file starts with.
const VDB_MAGIC: [u8; 8] = [0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0];
pub(super) const VDB_FLOAT_TREE: &str = "Tree_float_5_4_3";
/// OpenVDB appends this to the type name of grids saved as half floats.
const VDB_HALF_SUFFIX: &str = "_HalfFloat";
pub(super) const DEFAULT_VDB_GRID: &str = "density";

pub(super) fn read_vdb(path: &Path, name: &str) -> Result<DenseGrid> {
    check_vdb_magic(path)?;
    // vdb-rs answers some malformed input with a panic (todo!, assert!, unwrap);
    // an uploaded file must not take down the worker, so those become errors.
    let loaded = catch_unwind(AssertUnwindSafe(|| read_float_grid(path, name)));
    let grid = loaded.map_err(|panic| GridError::Vdb {
        path: path.to_path_buf(),
        message: panic_text(panic.as_ref()),
    })??;
    densify(path, name, &grid)
}

/// vdb-rs 0.6 compares the magic number the wrong way round and so accepts any
/// file; checking it here turns "not a VDB file" into a clear error.
fn check_vdb_magic(path: &Path) -> Result<()> {
    let mut magic = [0u8; 8];
    let read = File::open(path).and_then(|mut f| f.read_exact(&mut magic));
    match read {
        Ok(()) if magic == VDB_MAGIC => Ok(()),
        Err(e) if e.kind() != io::ErrorKind::UnexpectedEof => Err(io_error(path)(e)),
        _ => Err(GridError::VdbMagic {
            path: path.to_path_buf(),
        }),
    }
}

fn panic_text(panic: &(dyn std::any::Any + Send)) -> String {
    let text = panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned());
    format!(
        "the VDB reader failed: {}",
        text.unwrap_or_else(|| "unknown error".into())
    )
}

fn read_float_grid(path: &Path, name: &str) -> Result<vdb_rs::Grid<f32>> {
    let vdb_error = |e: vdb_rs::ParseError| GridError::Vdb {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let file = File::open(path).map_err(io_error(path))?;
    let mut reader = vdb_rs::VdbReader::new(BufReader::new(file)).map_err(vdb_error)?;
    let Some(descriptor) = reader.grid_descriptors.get(name) else {
        let mut available = reader.available_grids();
        available.sort();
        return Err(GridError::VdbNoGrid {
            path: path.to_path_buf(),
            name: name.to_string(),
            available,
        });
    };
    check_grid_kind(path, descriptor)?;
    reader.read_grid::<f32>(name).map_err(vdb_error)
}

/// Refuses what vdb-rs would misread (other value types, instances, compressed half
/// floats) and what is not a density (level sets).
fn check_grid_kind(path: &Path, d: &vdb_rs::GridDescriptor) -> Result<()> {
    let path = path.to_path_buf();
    let name = d.name.clone();
    let value_type = d.grid_type.strip_suffix(VDB_HALF_SUFFIX);
    if value_type.unwrap_or(&d.grid_type) != VDB_FLOAT_TREE {
        let grid_type = d.grid_type.clone();
        return Err(GridError::VdbGridType {
            path,
            name,
            grid_type,
        });
    }
    if !d.instance_parent.is_empty() {
        let parent = d.instance_parent.clone();
        return Err(GridError::VdbInstanced { path, name, parent });
    }
    let packed = vdb_rs::Compression::ZIP | vdb_rs::Compression::BLOSC;
    if d.meta_data.is_half_float() && d.compression.intersects(packed) {
        return Err(GridError::VdbHalfCompressed { path, name });
    }
    let level_set = vdb_rs::MetadataValue::String("level set".into());
    if d.meta_data.0.get("class") == Some(&level_set) {
        return Err(GridError::VdbLevelSet { path, name });
    }
    Ok(())
}

/// One active value of a VDB tree: a voxel (`size` 1) or a tile of `size`^3 voxels
/// whose lowest corner is `origin`.
struct ActiveBlock {
    origin: [i64; 3],
    size: i64,
    value: f32,
}

/// Walked twice (box, then fill) rather than collected: a large grid's list of
/// blocks would outweigh the dense grid itself.
fn active_blocks(grid: &vdb_rs::Grid<f32>) -> impl Iterator<Item = ActiveBlock> + '_ {
    // The crate hands out integer index coordinates as f32, exact below 2^24.
    grid.iter().map(|(c, value, level)| ActiveBlock {
        origin: [c.x, c.y, c.z].map(|v| v.round() as i64),
        size: level.scale() as i64,
        value,
    })
}

/// Inclusive index-space box around all active blocks.
fn active_box(mut blocks: impl Iterator<Item = ActiveBlock>) -> Option<([i64; 3], [i64; 3])> {
    let first = blocks.next()?;
    let mut lo = first.origin;
    let mut hi = first.origin.map(|o| o + first.size - 1);
    for b in blocks {
        for a in 0..3 {
            lo[a] = lo[a].min(b.origin[a]);
            hi[a] = hi[a].max(b.origin[a] + b.size - 1);
        }
    }
    Some((lo, hi))
}

fn densify(path: &Path, name: &str, grid: &vdb_rs::Grid<f32>) -> Result<DenseGrid> {
    let Some((lo, hi)) = active_box(active_blocks(grid)) else {
        return Err(GridError::VdbEmpty {
            path: path.to_path_buf(),
            name: name.to_string(),
        });
    };
    let dims = [0, 1, 2].map(|a| hi[a] - lo[a] + 1);
    let mut data = vec![0.0f32; value_count(path, dims)?];
    let dims = dims.map(|d| d as usize);
    for b in active_blocks(grid) {
        fill_block(&mut data, dims, lo, &b);
    }
    let bounds = Some(world_box(&grid.transform, lo, hi));
    Ok(DenseGrid { dims, data, bounds })
}

fn fill_block(data: &mut [f32], dims: [usize; 3], lo: [i64; 3], b: &ActiveBlock) {
    let start = [0, 1, 2].map(|a| (b.origin[a] - lo[a]) as usize);
    let n = b.size as usize;
    for z in start[2]..start[2] + n {
        for y in start[1]..start[1] + n {
            let row = dims[0] * (y + dims[1] * z);
            data[row + start[0]..row + start[0] + n].fill(b.value);
        }
    }
}

/// World-space box of the voxels `lo..=hi`: each voxel reaches half a voxel past its
/// index, and a negative scale swaps the ends, hence the min/max.
fn world_box(map: &vdb_rs::Map, lo: [i64; 3], hi: [i64; 3]) -> ([f32; 3], [f32; 3]) {
    let (scale, offset) = match map {
        vdb_rs::Map::UniformScaleMap { scale_values, .. } => (scale_values, None),
        vdb_rs::Map::ScaleTranslateMap {
            scale_values,
            translation,
            ..
        } => (scale_values, Some(translation)),
    };
    let scale = [scale.x, scale.y, scale.z];
    let offset = offset.map_or([0.0; 3], |t| [t.x, t.y, t.z]);
    let world = |a: usize, i: f64| (i * scale[a] + offset[a]) as f32;
    let ends = [0, 1, 2].map(|a| {
        let (p, q) = (world(a, lo[a] as f64 - 0.5), world(a, hi[a] as f64 + 0.5));
        (p.min(q), p.max(q))
    });
    (ends.map(|e| e.0), ends.map(|e| e.1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::grid_io::load_grid;
    use crate::medium::grid_io::tests::load;
    use std::path::PathBuf;
    use tempfile::TempDir;

    // Files from deploy/scripts/make_vdb_fixture.py (see tests/data/README.md).

    fn fixture(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data")
            .join(name)
    }

    /// The fixture script's value for the sparse voxels.
    fn voxel_value(i: i64, j: i64, k: i64) -> f32 {
        0.125 * (7 * i + 3 * j + 5 * k).rem_euclid(8) as f32 + 0.0625
    }

    /// What "density" must densify to: index box [-3, 0, 5] ..= [15, 15, 15].
    fn expected_density() -> DenseGrid {
        let dims = [19, 16, 11];
        let mut data = vec![0.0; 19 * 16 * 11];
        let at = |i: i64, j: i64, k: i64| (i + 3 + 19 * (j + 16 * (k - 5))) as usize;
        for (i, j, k) in index_box([8, 8, 8], [16, 16, 16]) {
            data[at(i, j, k)] = 0.5;
        }
        for (i, j, k) in index_box([-3, 0, 5], [3, 4, 7]) {
            data[at(i, j, k)] = voxel_value(i, j, k);
        }
        // Index -3.5 .. 15.5 through scale 0.25 and translation (1, 2, 3).
        let bounds = Some(([0.125, 1.875, 4.125], [4.875, 5.875, 6.875]));
        DenseGrid { dims, data, bounds }
    }

    /// All (i, j, k) with lo <= (i, j, k) < hi.
    fn index_box(lo: [i64; 3], hi: [i64; 3]) -> Vec<(i64, i64, i64)> {
        let mut out = Vec::new();
        for k in lo[2]..hi[2] {
            for j in lo[1]..hi[1] {
                for i in lo[0]..hi[0] {
                    out.push((i, j, k));
                }
            }
        }
        out
    }

    #[test]
    fn vdb_blosc_density_with_tile_and_negative_indices() {
        let grid = load(&fixture("grids.vdb")).unwrap();
        assert_eq!(grid, expected_density());
        let named = load_grid(&fixture("grids.vdb"), Some("density")).unwrap();
        assert_eq!(named, grid);
    }

    #[test]
    fn vdb_zlib_density_matches_blosc() {
        assert_eq!(
            load(&fixture("density_zip.vdb")).unwrap(),
            expected_density()
        );
    }

    #[test]
    fn vdb_half_float_grid_by_name() {
        let grid = load_grid(&fixture("temperature_active.vdb"), Some("temperature")).unwrap();
        assert_eq!(grid.dims, [2, 3, 4]);
        let expected: Vec<f32> = index_box([0; 3], [2, 3, 4])
            .into_iter()
            .map(|(i, j, k)| 1.0 + voxel_value(i, j, k))
            .collect();
        assert_eq!(grid.data, expected);
        assert_eq!(grid.bounds, Some(([-0.25; 3], [0.75, 1.25, 1.75])));
    }

    #[test]
    fn vdb_compressed_half_float_grid_is_refused_with_a_hint() {
        let err = load_grid(&fixture("grids.vdb"), Some("temperature")).unwrap_err();
        assert!(
            matches!(err, GridError::VdbHalfCompressed { .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("codec=active"), "{err}");
    }

    #[test]
    fn vdb_missing_grid_lists_the_available_ones() {
        let r = load_grid(&fixture("grids.vdb"), Some("smoke"));
        let err = r.unwrap_err();
        assert!(matches!(err, GridError::VdbNoGrid { .. }), "{err:?}");
        let message = err.to_string();
        assert!(
            message.contains("holds: density, sdf, temperature, velocity"),
            "{message}"
        );
    }

    #[test]
    fn vdb_vector_and_level_set_grids_are_refused() {
        let r = load_grid(&fixture("grids.vdb"), Some("velocity"));
        assert!(
            matches!(&r, Err(GridError::VdbGridType { grid_type, .. }) if grid_type == "Tree_vec3s_5_4_3"),
            "{r:?}"
        );
        let r = load_grid(&fixture("grids.vdb"), Some("sdf"));
        assert!(matches!(r, Err(GridError::VdbLevelSet { .. })), "{r:?}");
    }

    #[test]
    fn vdb_broken_files_are_errors_not_panics() {
        let dir = TempDir::new().unwrap();
        let bytes = std::fs::read(fixture("density_zip.vdb")).unwrap();
        let not_vdb = dir.path().join("not.vdb");
        std::fs::write(&not_vdb, b"VOL\x03 and then some bytes").unwrap();
        let r = load(&not_vdb);
        assert!(matches!(r, Err(GridError::VdbMagic { .. })), "{r:?}");
        // Cut at several depths: in the header, the descriptors and the tree data.
        for len in [6, 40, 300, 2_000, bytes.len() / 2, bytes.len() - 10] {
            let path = dir.path().join(format!("cut{len}.vdb"));
            std::fs::write(&path, &bytes[..len]).unwrap();
            let r = load(&path).map(|g| g.dims);
            assert!(r.is_err(), "cut at {len}: {r:?}");
        }
    }

    #[test]
    fn vdb_reader_panics_become_errors() {
        // vdb-rs panics on a transform type it does not know; renaming the map in
        // place (same length, so every offset stays valid) provokes that.
        let mut bytes = std::fs::read(fixture("density_zip.vdb")).unwrap();
        let name = b"UniformScaleTranslateMap";
        let at = bytes.windows(name.len()).position(|w| w == name).unwrap();
        bytes[at..at + name.len()].copy_from_slice(b"UniformScaleTranslateMaq");
        let dir = TempDir::new().unwrap();
        let path = dir.path().join("odd_map.vdb");
        std::fs::write(&path, bytes).unwrap();
        let err = load(&path).unwrap_err();
        assert!(matches!(err, GridError::Vdb { .. }), "{err:?}");
        assert!(err.to_string().contains("Maq"), "{err}");
    }
}
