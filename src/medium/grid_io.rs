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
//! request memory the machine cannot give, which aborts the process.

use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Write};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Component, Path, PathBuf};

/// A grid of this many values (1 GiB of float32, e.g. 1024 x 512 x 512) or more is
/// refused before anything is allocated for it. `.vol` and raw grids are also held to
/// their file's real length before allocating, so only a VDB file's active box (local
/// scenes only) can reach this cap from a few bytes.
const MAX_VALUES: u64 = 1 << 28;
/// Bytes before the data in a Mitsuba .vol file.
const VOL_HEADER_BYTES: u64 = 48;
/// Reading in chunks keeps peak memory at the grid plus this, not twice the grid.
const READ_CHUNK_BYTES: usize = 1 << 20;
/// `OPENVDB_MAGIC` (0x56444220) as the int64 every .vdb file starts with.
const VDB_MAGIC: [u8; 8] = [0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0];
const VDB_FLOAT_TREE: &str = "Tree_float_5_4_3";
/// OpenVDB appends this to the type name of grids saved as half floats.
const VDB_HALF_SUFFIX: &str = "_HalfFloat";
const DEFAULT_VDB_GRID: &str = "density";
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
        Format::Vol => read_vol(path)?,
        Format::Raw => read_raw(path)?,
        Format::Vdb => read_vdb(path, grid.unwrap_or(DEFAULT_VDB_GRID))?,
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

/// A Mitsuba `.vol` file in memory (for fuzzing and tests), checked as [`load_grid`]
/// checks a file; errors name `<memory>`.
pub fn decode_vol(bytes: &[u8]) -> Result<DenseGrid> {
    let path = Path::new(MEMORY);
    let grid = read_vol_from(path, bytes, bytes.len() as u64)?;
    check_grid(path, grid)
}

/// A raw grid in memory: its JSON `header` and the bytes of the `data` file it names
/// (whose name is checked, not opened), checked as [`load_grid`] checks files.
pub fn decode_raw(header: &[u8], data: &[u8]) -> Result<DenseGrid> {
    let path = Path::new(MEMORY);
    let header = parse_raw_header(path, header)?;
    if !is_plain_relative(&header.data) {
        return Err(GridError::DataOutsideFolder {
            path: path.to_path_buf(),
            data: header.data,
        });
    }
    let count = value_count(path, header.dims)?;
    let values = read_floats(path, &mut &data[..], count, data.len() as u64)?;
    check_grid(path, raw_grid(header, values))
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

// ---------------------------------------------------------------- Mitsuba .vol

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

fn read_vol(path: &Path) -> Result<DenseGrid> {
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
    check_shape(grid)?;
    let too_big = |_| io::Error::new(io::ErrorKind::InvalidInput, "dimension exceeds i32");
    let dims: Vec<i32> = grid
        .dims
        .iter()
        .map(|&d| i32::try_from(d).map_err(too_big))
        .collect::<io::Result<_>>()?;
    let (min, max) = grid.bounds.unwrap_or(([0.0; 3], [1.0; 3]));
    let mut w = BufWriter::new(File::create(path)?);
    w.write_all(b"VOL\x03")?;
    for v in [1, dims[0], dims[1], dims[2], 1] {
        w.write_all(&v.to_le_bytes())?;
    }
    write_floats(&mut w, &min)?;
    write_floats(&mut w, &max)?;
    write_floats(&mut w, &grid.data)?;
    w.into_inner().map_err(|e| e.into_error())?.sync_all()
}

// ------------------------------------------------------------ raw + JSON header

#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHeader {
    dims: [i64; 3],
    data: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    bounds: Option<RawBounds>,
}

#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBounds {
    min: [f32; 3],
    max: [f32; 3],
}

fn read_raw(path: &Path) -> Result<DenseGrid> {
    let text = std::fs::read(path).map_err(io_error(path))?;
    let header = parse_raw_header(path, &text)?;
    let count = value_count(path, header.dims)?;
    let data_path = resolve_data(path, &header.data)?;
    let (file, len) = open_with_len(&data_path)?;
    let data = read_floats(&data_path, &mut BufReader::new(file), count, len)?;
    Ok(raw_grid(header, data))
}

fn parse_raw_header(path: &Path, text: &[u8]) -> Result<RawHeader> {
    serde_json::from_slice(text).map_err(|source| GridError::Header {
        path: path.to_path_buf(),
        source,
    })
}

fn raw_grid(header: RawHeader, data: Vec<f32>) -> DenseGrid {
    DenseGrid {
        dims: header.dims.map(|d| d as usize),
        data,
        bounds: header.bounds.map(|b| (b.min, b.max)),
    }
}

/// No absolute path, no `..`: the name alone stays inside the folder.
fn is_plain_relative(name: &str) -> bool {
    let plain = |c: Component| matches!(c, Component::Normal(_) | Component::CurDir);
    !name.is_empty() && Path::new(name).components().all(plain)
}

/// The header's data file, which must stay inside the header's folder: checked on
/// the name (no absolute path, no `..`) and again after resolving links.
fn resolve_data(header: &Path, name: &str) -> Result<PathBuf> {
    let outside = || GridError::DataOutsideFolder {
        path: header.to_path_buf(),
        data: name.to_string(),
    };
    if !is_plain_relative(name) {
        return Err(outside());
    }
    let folder = match header.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let full = folder
        .join(name)
        .canonicalize()
        .map_err(|e| match e.kind() {
            io::ErrorKind::NotFound => GridError::MissingData {
                path: header.to_path_buf(),
                data: name.to_string(),
            },
            _ => io_error(header)(e),
        })?;
    let folder = folder.canonicalize().map_err(io_error(header))?;
    if full.starts_with(&folder) {
        Ok(full)
    } else {
        Err(outside())
    }
}

/// Writes `json_path` (the header) and the data next to it, named after the header
/// with the extension `.raw`.
pub fn write_raw(json_path: &Path, grid: &DenseGrid) -> io::Result<()> {
    check_shape(grid)?;
    let data_name = json_path
        .file_stem()
        .map(|s| Path::new(s).with_extension("raw"))
        .and_then(|p| p.to_str().map(str::to_string))
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "header path has no name"))?;
    let header = RawHeader {
        dims: grid.dims.map(|d| d as i64),
        data: data_name.clone(),
        bounds: grid.bounds.map(|(min, max)| RawBounds { min, max }),
    };
    let mut w = BufWriter::new(File::create(json_path.with_file_name(&data_name))?);
    write_floats(&mut w, &grid.data)?;
    w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
    std::fs::write(json_path, serde_json::to_vec_pretty(&header)?)
}

// --------------------------------------------------------------------- OpenVDB

fn read_vdb(path: &Path, name: &str) -> Result<DenseGrid> {
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
    use tempfile::TempDir;

    /// A small grid whose every value differs, with bounds that are not the unit cube.
    fn sample() -> DenseGrid {
        let dims = [3, 4, 5];
        DenseGrid {
            dims,
            data: (0..60).map(|i| i as f32 * 0.25).collect(),
            bounds: Some(([-1.0, 0.0, 2.0], [1.0, 2.0, 3.5])),
        }
    }

    fn load(path: &Path) -> Result<DenseGrid> {
        load_grid(path, None)
    }

    /// A .vol file of `grid` in `dir`, with `patch` applied to its bytes.
    fn vol_with(dir: &TempDir, grid: &DenseGrid, patch: impl FnOnce(&mut Vec<u8>)) -> PathBuf {
        let path = dir.path().join("g.vol");
        write_vol(&path, grid).unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        patch(&mut bytes);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    fn patched_vol(patch: impl FnOnce(&mut Vec<u8>)) -> Result<DenseGrid> {
        let dir = TempDir::new().unwrap();
        load(&vol_with(&dir, &sample(), patch))
    }

    /// A raw header with the given text in `dir`, next to a valid data file `g.raw`.
    fn raw_header(dir: &TempDir, text: &str) -> PathBuf {
        write_raw(&dir.path().join("g.json"), &sample()).unwrap();
        let path = dir.path().join("h.json");
        std::fs::write(&path, text).unwrap();
        path
    }

    fn raw_with_header(text: &str) -> Result<DenseGrid> {
        let dir = TempDir::new().unwrap();
        load(&raw_header(&dir, text))
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
    fn raw_round_trip_with_and_without_bounds() {
        let dir = TempDir::new().unwrap();
        let path = dir.path().join("smoke.json");
        write_raw(&path, &sample()).unwrap();
        assert!(dir.path().join("smoke.raw").is_file());
        assert_eq!(load(&path).unwrap(), sample());
        let unbounded = DenseGrid {
            bounds: None,
            ..sample()
        };
        write_raw(&path, &unbounded).unwrap();
        assert_eq!(load(&path).unwrap(), unbounded);
    }

    #[test]
    fn raw_header_may_name_a_file_in_a_subfolder() {
        let dir = TempDir::new().unwrap();
        std::fs::create_dir(dir.path().join("data")).unwrap();
        write_raw(&dir.path().join("data/g.json"), &sample()).unwrap();
        let path = dir.path().join("h.json");
        std::fs::write(&path, r#"{"dims": [3, 4, 5], "data": "./data/g.raw"}"#).unwrap();
        assert_eq!(load(&path).unwrap().data, sample().data);
    }

    #[test]
    fn raw_header_escaping_its_folder_is_refused() {
        let dir = TempDir::new().unwrap();
        std::fs::create_dir(dir.path().join("bundle")).unwrap();
        write_raw(&dir.path().join("outside.json"), &sample()).unwrap();
        for data in ["../outside.raw", "/etc/passwd", "sub/../../outside.raw", ""] {
            let path = dir.path().join("bundle/h.json");
            let text = format!(r#"{{"dims": [3, 4, 5], "data": "{data}"}}"#);
            std::fs::write(&path, text).unwrap();
            let r = load(&path);
            assert!(
                matches!(&r, Err(GridError::DataOutsideFolder { data: d, .. }) if d == data),
                "{data}: {r:?}"
            );
        }
    }

    #[cfg(unix)]
    #[test]
    fn raw_data_linked_outside_its_folder_is_refused() {
        let dir = TempDir::new().unwrap();
        std::fs::create_dir(dir.path().join("bundle")).unwrap();
        write_raw(&dir.path().join("outside.json"), &sample()).unwrap();
        let link = dir.path().join("bundle/g.raw");
        std::os::unix::fs::symlink(dir.path().join("outside.raw"), link).unwrap();
        let path = dir.path().join("bundle/h.json");
        std::fs::write(&path, r#"{"dims": [3, 4, 5], "data": "g.raw"}"#).unwrap();
        let r = load(&path);
        assert!(
            matches!(r, Err(GridError::DataOutsideFolder { .. })),
            "{r:?}"
        );
    }

    #[test]
    fn raw_missing_data_file_is_refused() {
        let r = raw_with_header(r#"{"dims": [3, 4, 5], "data": "nowhere.raw"}"#);
        assert!(
            matches!(&r, Err(GridError::MissingData { data, .. }) if data == "nowhere.raw"),
            "{r:?}"
        );
    }

    #[test]
    fn raw_data_of_the_wrong_length_is_refused() {
        let r = raw_with_header(r#"{"dims": [3, 4, 6], "data": "g.raw"}"#);
        assert!(
            matches!(
                r,
                Err(GridError::DataLength {
                    expected: 72,
                    found_bytes: 240,
                    ..
                })
            ),
            "{r:?}"
        );
    }

    #[test]
    fn raw_header_errors_are_refused() {
        for text in [
            r#"{"dims": [3, 4], "data": "g.raw"}"#,
            r#"{"dims": [3, 4, 5], "data": "g.raw", "bound": {"min": [0,0,0], "max": [1,1,1]}}"#,
            r#"{"dims": [3, 4, 5]}"#,
            "not json",
        ] {
            let r = raw_with_header(text);
            assert!(matches!(r, Err(GridError::Header { .. })), "{text}: {r:?}");
        }
        let r = raw_with_header(r#"{"dims": [3, 0, 5], "data": "g.raw"}"#);
        assert!(matches!(r, Err(GridError::BadDims { .. })), "{r:?}");
        let r = raw_with_header(r#"{"dims": [4096, 4096, 4096], "data": "g.raw"}"#);
        assert!(matches!(r, Err(GridError::TooLarge { .. })), "{r:?}");
        let bounds = r#""bounds": {"min": [0, 0, 0], "max": [1, 0, 1]}"#;
        let r = raw_with_header(&format!(
            r#"{{"dims": [3, 4, 5], "data": "g.raw", {bounds}}}"#
        ));
        assert!(matches!(r, Err(GridError::BadBounds { .. })), "{r:?}");
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

    // ---- OpenVDB: files from deploy/scripts/make_vdb_fixture.py (see tests/data/README.md)

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
