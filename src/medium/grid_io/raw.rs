//! Raw float32 grids described by a JSON header (the format is described in the
//! module above).

use super::{
    check_grid, check_shape, io_error, open_with_len, read_floats, value_count, write_floats,
    DenseGrid, GridError, Result, MEMORY,
};
use std::fs::File;
use std::io::{self, BufReader, BufWriter};
use std::path::{Component, Path, PathBuf};

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

pub(super) fn read_raw(path: &Path) -> Result<DenseGrid> {
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

/// The data file the raw grid header at `path` names, resolved as the reader
/// resolves it; `None` when `path` is not a `.json` header or not a valid one.
pub fn raw_data_file(path: &Path) -> Option<PathBuf> {
    if super::Format::of(path).ok()? != super::Format::Raw {
        return None;
    }
    let text = std::fs::read(path).ok()?;
    resolve_data(path, &parse_raw_header(path, &text).ok()?.data).ok()
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::grid_io::tests::{load, sample};
    use tempfile::TempDir;

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
}
