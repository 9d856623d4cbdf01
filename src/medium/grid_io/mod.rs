//! Loading dense scalar voxel grids (densities of participating media) from files.
//!
//! [`load_grid`] picks the format by extension (case-insensitive) and returns a
//! [`DenseGrid`] whose values are all finite and `>= 0`, or a [`GridError`] that says
//! what is wrong. Grid files arrive in uploaded bundles, so nothing in a file is
//! trusted: sizes are checked against the file's length before anything is allocated.
//!
//! # `.vol`: Mitsuba volume, version 3
//! Little endian: the bytes `V O L`, a version byte (3), then int32 encoding
//! (1 = float32), int32 xres, yres, zres, int32 channel count (1), six float32 bounds
//! (xmin ymin zmin xmax ymax zmax), then `xres*yres*zres` float32 values, x fastest.
//! Other versions, encodings and channel counts are refused. As in Mitsuba 3, the
//! bounds are the box the voxel cells cover, so values sit at cell centres.
//! [`write_vol`] writes this format (the unit cube when a grid has no bounds).
//!
//! # `.json`: raw float32 data with a header
//! ```json
//! {"dims": [nx, ny, nz], "data": "smoke.raw", "bounds": {"min": [0, 0, 0], "max": [1, 1, 1]}}
//! ```
//! `data` names a file of exactly `nx*ny*nz` little-endian float32 values, x fastest
//! (index = x + nx * (y + ny * z)), with no header. Its path is relative to the
//! header's folder and may not leave it: no absolute path, no `..`, and no symbolic
//! link that resolves outside the folder. `bounds` is optional (then `None`). Unknown
//! keys are refused, so a misspelt `bounds` is an error rather than silently absent.
//! [`write_raw`] writes a header and its `.raw` file.
//!
//! # `.vdb`: OpenVDB, read with the `vdb-rs` crate (0.6)
//! The grid is chosen by name (default `"density"`). Its active voxels and active
//! tiles are written into a dense grid spanning their index-space bounding box;
//! inactive voxels inside that box become 0 (the background of a fog volume).
//! `bounds` is that box in the file's world space: index `i` is the centre of a voxel
//! covering `[i - 0.5, i + 0.5]`, mapped through the grid's transform.
//!
//! What vdb-rs 0.6 reads, and so what this loader accepts:
//! - file format versions 222 to 224 (OpenVDB 3 and later; what OpenVDB 10 writes);
//!   it claims 213 to 221 in part, and some of those reach unimplemented paths in the
//!   crate (returned here as errors);
//! - uncompressed, zlib and blosc data, with or without active-mask compression.
//!   The bundled c-blosc is built with its blosclz and lz4 codecs only (OpenVDB
//!   writes lz4); blosc data packed with zlib, zstd or snappy fails to decompress;
//! - float grids (`Tree_float_5_4_3`). Other value types (double, vec3s, int, bool,
//!   points) are refused here by type name, since the crate would misread their bytes
//!   as floats;
//! - float grids saved as half floats only without zlib or blosc: OpenVDB writes no
//!   size field for an empty half-float block, vdb-rs expects one and loses its place.
//!   Such grids are refused with a hint (`vdb_tool -read in.vdb -write codec=active
//!   out.vdb` rewrites a file in a form it reads);
//! - transforms `UniformScaleMap`, `UniformScaleTranslateMap` and
//!   `ScaleTranslateMap` (axis-aligned). Affine, frustum and other maps are not
//!   supported by the crate and come back as an error;
//! - active tiles stored in internal nodes (8^3 and 128^3 voxels). Tiles stored at
//!   the root level (4096^3 voxels each) are skipped by the crate without a word.
//!   Instanced grids (sharing another grid's tree) are refused here.
//!
//! Level-set grids (class `"level set"`) are refused: they hold signed distances, not
//! densities. vdb-rs panics on some malformed input; those panics are caught and
//! returned as errors, but a size field forged to an absurd value can still make it
//! request memory the machine cannot give, which aborts the process. So a server or
//! worker reads `.vdb` files in a child process with a memory limit and a deadline
//! (`vdb_child`); only a local render reads them in process.

mod raw;
mod vdb;
mod vdb_child;
mod vol;

pub use raw::{decode_raw, raw_data_file, write_raw};
pub use vdb_child::{
    child_main as vdb_child_main, isolate_vdb, read_in_child as read_vdb_in_child, Isolation,
};
pub use vol::{decode_vol, encode_vol, write_vol};

use std::fs::File;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use vdb::VDB_FLOAT_TREE;
use vol::VOL_HEADER_BYTES;

/// A grid of this many values (1 GiB of float32, e.g. 1024 x 512 x 512) or more is
/// refused before anything is allocated for it. `.vol` and raw grids are also held to
/// their file's real length before allocating, so only a VDB file's active box (local
/// scenes only) can reach this cap from a few bytes.
const MAX_VALUES: u64 = 1 << 28;
/// Reading in chunks keeps peak memory at the grid plus this, not twice the grid.
const READ_CHUNK_BYTES: usize = 1 << 20;
/// What errors about in-memory input name.
const MEMORY: &str = "<memory>";

/// A dense scalar voxel grid. Values sit at voxel centres; x varies fastest:
/// index = x + dims[0] * (y + dims[1] * z).
#[derive(Clone, Debug, PartialEq)]
pub struct DenseGrid {
    pub dims: [usize; 3],
    pub data: Vec<f32>,
    /// Axis-aligned box the grid covers in the file's own space, if the file says
    /// (Mitsuba .vol and OpenVDB do; raw grids give it in their JSON header, optional).
    pub bounds: Option<([f32; 3], [f32; 3])>,
}

/// Why a grid file could not be loaded. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum GridError {
    #[error("cannot read {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("{}: unknown grid format; expected a .vol, .json or .vdb file", path.display())]
    UnknownFormat { path: PathBuf },
    #[error(
        "{}: this format holds one grid, so the grid name \"{name}\" does not apply \
         (names select grids in .vdb files only)",
        path.display()
    )]
    GridNameNotApplicable { path: PathBuf, name: String },
    #[error(
        "{}: file is {found} bytes, shorter than the {VOL_HEADER_BYTES}-byte Mitsuba volume header",
        path.display()
    )]
    VolHeaderTruncated { path: PathBuf, found: u64 },
    #[error("{}: not a Mitsuba volume: the file does not start with \"VOL\"", path.display())]
    VolMagic { path: PathBuf },
    #[error("{}: Mitsuba volume version {found}; only version 3 is supported", path.display())]
    VolVersion { path: PathBuf, found: u8 },
    #[error(
        "{}: Mitsuba volume encoding {found}; only encoding 1 (float32) is supported",
        path.display()
    )]
    VolEncoding { path: PathBuf, found: i32 },
    #[error(
        "{}: {found} channels per voxel; only 1 (a scalar density) is supported",
        path.display()
    )]
    VolChannels { path: PathBuf, found: i32 },
    #[error("{}: invalid dimensions {dims:?}: each must be at least 1", path.display())]
    BadDims { path: PathBuf, dims: [i64; 3] },
    #[error(
        "{}: dimensions {dims:?} reach the limit of {MAX_VALUES} values",
        path.display()
    )]
    TooLarge { path: PathBuf, dims: [i64; 3] },
    #[error(
        "{}: expected {expected} floats ({} bytes) of voxel data, file holds {}",
        path.display(),
        expected * 4,
        describe_bytes(*found_bytes)
    )]
    DataLength {
        path: PathBuf,
        expected: u64,
        found_bytes: u64,
    },
    #[error(
        "{}: bounds min {min:?} max {max:?} are not a box: they must be finite with min < max on every axis",
        path.display()
    )]
    BadBounds {
        path: PathBuf,
        min: [f32; 3],
        max: [f32; 3],
    },
    #[error(
        "{}: value {value} at index {index} (voxel {voxel:?}) is not finite",
        path.display()
    )]
    NonFiniteValue {
        path: PathBuf,
        index: usize,
        voxel: [usize; 3],
        value: f32,
    },
    #[error(
        "{}: value {value} at index {index} (voxel {voxel:?}) is negative; densities must be >= 0",
        path.display()
    )]
    NegativeValue {
        path: PathBuf,
        index: usize,
        voxel: [usize; 3],
        value: f32,
    },
    #[error("{}: invalid raw grid header: {source}", path.display())]
    Header {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error(
        "{}: data file \"{data}\" must be a relative path inside the header's folder \
         (no absolute path, no \"..\", no link leading outside)",
        path.display()
    )]
    DataOutsideFolder { path: PathBuf, data: String },
    #[error("{}: data file \"{data}\" does not exist", path.display())]
    MissingData { path: PathBuf, data: String },
    #[error("{}: not an OpenVDB file (wrong magic number)", path.display())]
    VdbMagic { path: PathBuf },
    #[error("{}: cannot read OpenVDB data: {message}", path.display())]
    Vdb { path: PathBuf, message: String },
    #[error(
        "{}: no grid named \"{name}\"; the file holds: {}",
        path.display(),
        available.join(", ")
    )]
    VdbNoGrid {
        path: PathBuf,
        name: String,
        available: Vec<String>,
    },
    #[error(
        "{}: grid \"{name}\" is a {grid_type}; only scalar float grids ({VDB_FLOAT_TREE}) are supported",
        path.display()
    )]
    VdbGridType {
        path: PathBuf,
        name: String,
        grid_type: String,
    },
    #[error(
        "{}: grid \"{name}\" is a level set (signed distances), not a density",
        path.display()
    )]
    VdbLevelSet { path: PathBuf, name: String },
    #[error(
        "{}: grid \"{name}\" is an instance of grid \"{parent}\"; instanced grids are not supported",
        path.display()
    )]
    VdbInstanced {
        path: PathBuf,
        name: String,
        parent: String,
    },
    #[error(
        "{}: grid \"{name}\" is saved as half floats with zlib or blosc compression, which \
         the VDB reader cannot read; rewrite it with active-mask compression only, e.g. \
         `vdb_tool -read in.vdb -write codec=active out.vdb`",
        path.display()
    )]
    VdbHalfCompressed { path: PathBuf, name: String },
    #[error("{}: grid \"{name}\" has no active voxels", path.display())]
    VdbEmpty { path: PathBuf, name: String },
}

type Result<T> = std::result::Result<T, GridError>;

impl GridError {
    /// The file the error names.
    fn path_mut(&mut self) -> &mut PathBuf {
        use GridError::*;
        match self {
            Io { path, .. }
            | UnknownFormat { path, .. }
            | GridNameNotApplicable { path, .. }
            | VolHeaderTruncated { path, .. }
            | VolMagic { path, .. }
            | VolVersion { path, .. }
            | VolEncoding { path, .. }
            | VolChannels { path, .. }
            | BadDims { path, .. }
            | TooLarge { path, .. }
            | DataLength { path, .. }
            | BadBounds { path, .. }
            | NonFiniteValue { path, .. }
            | NegativeValue { path, .. }
            | Header { path, .. }
            | DataOutsideFolder { path, .. }
            | MissingData { path, .. }
            | VdbMagic { path, .. }
            | Vdb { path, .. }
            | VdbNoGrid { path, .. }
            | VdbGridType { path, .. }
            | VdbLevelSet { path, .. }
            | VdbInstanced { path, .. }
            | VdbHalfCompressed { path, .. }
            | VdbEmpty { path, .. } => path,
        }
    }
}

fn describe_bytes(bytes: u64) -> String {
    if bytes.is_multiple_of(4) {
        format!("{}", bytes / 4)
    } else {
        format!("{bytes} bytes")
    }
}

fn io_error(path: &Path) -> impl FnOnce(io::Error) -> GridError + '_ {
    move |source| GridError::Io {
        path: path.to_path_buf(),
        source,
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Format {
    Vol,
    Raw,
    Vdb,
}

impl Format {
    fn of(path: &Path) -> Result<Format> {
        let ext = path.extension().and_then(|e| e.to_str());
        match ext.map(str::to_ascii_lowercase).as_deref() {
            Some("vol") => Ok(Format::Vol),
            Some("json") => Ok(Format::Raw),
            Some("vdb") => Ok(Format::Vdb),
            _ => Err(GridError::UnknownFormat {
                path: path.to_path_buf(),
            }),
        }
    }
}

/// Loads a grid, choosing the format by extension: `.vol` (Mitsuba volume, version 3,
/// float32, 1 channel; refuse other versions/types/channel counts with a clear message),
/// `.json` (a header naming a raw little-endian float32 file next to it),
/// `.vdb` (OpenVDB, read with the `vdb-rs` crate; `grid` picks the grid by name,
/// default "density", and active voxels are densified over the active bounding box).
///
/// `grid` must be `None` for `.vol` and `.json`, which hold one grid each: a name
/// there would otherwise be ignored without a word. See the module doc for formats.
pub fn load_grid(path: &Path, grid: Option<&str>) -> Result<DenseGrid> {
    let format = Format::of(path)?;
    if let (Some(name), Format::Vol | Format::Raw) = (grid, format) {
        return Err(GridError::GridNameNotApplicable {
            path: path.to_path_buf(),
            name: name.to_string(),
        });
    }
    let loaded = match format {
        Format::Vol => vol::read_vol(path)?,
        Format::Raw => raw::read_raw(path)?,
        Format::Vdb => vdb_child::read(path, grid.unwrap_or(vdb::DEFAULT_VDB_GRID))?,
    };
    check_grid(path, loaded)
}

/// [`load_grid`] for a file a scene names: errors show `shown` (the name the scene
/// gave) and a raw header's data file relative to it, never the server's own path,
/// since the server shows these messages to clients.
pub fn load_grid_named(path: &Path, shown: &Path, grid: Option<&str>) -> Result<DenseGrid> {
    load_grid(path, grid).map_err(|mut e| {
        let named = e.path_mut();
        let folder = path.parent().unwrap_or(Path::new(""));
        let shown_folder = shown.parent().unwrap_or(Path::new(""));
        *named = match named.strip_prefix(folder) {
            Ok(rel) if named.as_path() != path => shown_folder.join(rel),
            _ => shown.to_path_buf(),
        };
        e
    })
}

fn check_grid(path: &Path, grid: DenseGrid) -> Result<DenseGrid> {
    check_bounds(path, grid.bounds)?;
    check_values(path, &grid)?;
    Ok(grid)
}

/// Number of values for `dims`, refusing empty, overflowing or absurd sizes before
/// anything is allocated for them.
fn value_count(path: &Path, dims: [i64; 3]) -> Result<usize> {
    if dims.iter().any(|&d| d < 1) {
        return Err(GridError::BadDims {
            path: path.to_path_buf(),
            dims,
        });
    }
    let count = dims
        .iter()
        .try_fold(1u64, |acc, &d| acc.checked_mul(d as u64))
        .filter(|&n| n < MAX_VALUES);
    match count {
        Some(n) => Ok(n as usize),
        None => Err(GridError::TooLarge {
            path: path.to_path_buf(),
            dims,
        }),
    }
}

fn check_bounds(path: &Path, bounds: Option<([f32; 3], [f32; 3])>) -> Result<()> {
    let Some((min, max)) = bounds else {
        return Ok(());
    };
    let ok = (0..3).all(|a| min[a].is_finite() && max[a].is_finite() && min[a] < max[a]);
    if ok {
        Ok(())
    } else {
        Err(GridError::BadBounds {
            path: path.to_path_buf(),
            min,
            max,
        })
    }
}

/// Densities feed free-flight sampling and majorants: one NaN or negative value
/// poisons every path through it, so the first one is reported by position.
fn check_values(path: &Path, grid: &DenseGrid) -> Result<()> {
    let Some(index) = grid.data.iter().position(|v| !(v.is_finite() && *v >= 0.0)) else {
        return Ok(());
    };
    let [nx, ny, _] = grid.dims;
    let voxel = [index % nx, (index / nx) % ny, index / (nx * ny)];
    let value = grid.data[index];
    let path = path.to_path_buf();
    Err(if value.is_finite() {
        GridError::NegativeValue {
            path,
            index,
            voxel,
            value,
        }
    } else {
        GridError::NonFiniteValue {
            path,
            index,
            voxel,
            value,
        }
    })
}

/// Reads `count` little-endian float32 values, having checked that the reader holds
/// exactly that many bytes (`available`), so a short or padded file is an error.
fn read_floats(path: &Path, r: &mut impl Read, count: usize, available: u64) -> Result<Vec<f32>> {
    if available != count as u64 * 4 {
        return Err(GridError::DataLength {
            path: path.to_path_buf(),
            expected: count as u64,
            found_bytes: available,
        });
    }
    let mut out = Vec::with_capacity(count);
    let mut buf = vec![0u8; READ_CHUNK_BYTES];
    while out.len() < count {
        let n = ((count - out.len()) * 4).min(READ_CHUNK_BYTES);
        r.read_exact(&mut buf[..n]).map_err(io_error(path))?;
        let values = buf[..n].chunks_exact(4);
        out.extend(values.map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])));
    }
    Ok(out)
}

fn write_floats(w: &mut impl Write, data: &[f32]) -> io::Result<()> {
    for v in data {
        w.write_all(&v.to_le_bytes())?;
    }
    Ok(())
}

/// Writers refuse a grid whose data does not match its dims: the file would be
/// unreadable, and the mistake is the caller's.
fn check_shape(grid: &DenseGrid) -> io::Result<()> {
    let expected = grid.dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
    if expected == Some(grid.data.len()) && grid.dims.iter().all(|&d| d >= 1) {
        return Ok(());
    }
    Err(io::Error::new(
        io::ErrorKind::InvalidInput,
        format!(
            "grid dims {:?} do not match its {} values",
            grid.dims,
            grid.data.len()
        ),
    ))
}

fn open_with_len(path: &Path) -> Result<(File, u64)> {
    let file = File::open(path).map_err(io_error(path))?;
    let len = file.metadata().map_err(io_error(path))?.len();
    Ok((file, len))
}

#[cfg(test)]
mod tests {
    use super::*;
    use tempfile::TempDir;

    /// A small grid whose every value differs, with bounds that are not the unit cube.
    pub(super) fn sample() -> DenseGrid {
        let dims = [3, 4, 5];
        DenseGrid {
            dims,
            data: (0..60).map(|i| i as f32 * 0.25).collect(),
            bounds: Some(([-1.0, 0.0, 2.0], [1.0, 2.0, 3.5])),
        }
    }

    pub(super) fn load(path: &Path) -> Result<DenseGrid> {
        load_grid(path, None)
    }

    /// A .vol file of `grid` in `dir`, with `patch` applied to its bytes.
    pub(super) fn vol_with(
        dir: &TempDir,
        grid: &DenseGrid,
        patch: impl FnOnce(&mut Vec<u8>),
    ) -> PathBuf {
        let path = dir.path().join("g.vol");
        write_vol(&path, grid).unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        patch(&mut bytes);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    #[test]
    fn nan_value_is_named_by_index_and_voxel() {
        let mut grid = sample();
        grid.data[17] = f32::NAN;
        grid.data[30] = f32::NAN;
        let dir = TempDir::new().unwrap();
        let r = load(&vol_with(&dir, &grid, |_| {}));
        // 17 = 2 + 3 * (1 + 4 * 1)
        assert!(
            matches!(
                r,
                Err(GridError::NonFiniteValue {
                    index: 17,
                    voxel: [2, 1, 1],
                    ..
                })
            ),
            "{r:?}"
        );
        grid.data[17] = f32::INFINITY;
        let r = load(&vol_with(&dir, &grid, |_| {}));
        assert!(
            matches!(r, Err(GridError::NonFiniteValue { index: 17, .. })),
            "{r:?}"
        );
    }

    #[test]
    fn negative_value_is_named_by_index_and_voxel() {
        let mut grid = sample();
        grid.data[59] = -0.5;
        let dir = TempDir::new().unwrap();
        let r = load(&vol_with(&dir, &grid, |_| {}));
        let err = r.unwrap_err();
        assert!(
            matches!(
                err,
                GridError::NegativeValue {
                    index: 59,
                    voxel: [2, 3, 4],
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("-0.5 at index 59"), "{err}");
    }

    #[test]
    fn format_and_grid_name_are_checked() {
        let dir = TempDir::new().unwrap();
        let r = load(&dir.path().join("g.nrrd"));
        assert!(matches!(r, Err(GridError::UnknownFormat { .. })), "{r:?}");
        let r = load(&dir.path().join("absent.vol"));
        assert!(matches!(r, Err(GridError::Io { .. })), "{r:?}");
        let path = vol_with(&dir, &sample(), |_| {});
        let upper = dir.path().join("G.VOL");
        std::fs::rename(&path, &upper).unwrap();
        assert_eq!(load(&upper).unwrap(), sample());
        let r = load_grid(&upper, Some("density"));
        assert!(
            matches!(r, Err(GridError::GridNameNotApplicable { .. })),
            "{r:?}"
        );
    }

    #[test]
    fn writers_refuse_data_that_does_not_match_dims() {
        let dir = TempDir::new().unwrap();
        let mut grid = sample();
        grid.data.pop();
        assert!(write_vol(&dir.path().join("g.vol"), &grid).is_err());
        assert!(write_raw(&dir.path().join("g.json"), &grid).is_err());
    }

    #[test]
    fn shipped_smoke_plume_loads() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/media/smoke.vol");
        let grid = load(&path).unwrap();
        assert_eq!(grid.dims, [64, 64, 64]);
        assert_eq!(grid.bounds, Some(([0.0; 3], [1.0; 3])));
        assert!(grid.data.iter().all(|v| (0.0..=1.0).contains(v)));
        let filled = grid.data.iter().filter(|&&v| v > 0.01).count();
        assert!(filled > 10_000, "only {filled} voxels above 0.01");
        let max = grid.data.iter().fold(0.0f32, |a, &v| a.max(v));
        assert!(max > 0.5, "max density {max}");
        let border = |i: usize| i == 0 || i == 63;
        let on_border = (0..grid.data.len()).filter(|i| {
            let v = [i % 64, (i / 64) % 64, i / 4096];
            v.iter().any(|&c| border(c)) && grid.data[*i] != 0.0
        });
        assert_eq!(on_border.count(), 0, "the plume touches the border");
    }
}
