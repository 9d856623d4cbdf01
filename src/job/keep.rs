//! What an upload keeps: `scene.json` and the files it names, nothing else. A bundle
//! may carry anything beside them (180 MB of padding, the Mitsuba files its scene
//! was imported from); none of it is stored, counted in the scene's size, or sent
//! to workers that fetch the scene.

use std::collections::HashSet;
use std::io;
use std::path::{Path, PathBuf};

/// A file removed from the bundle: its name in the bundle and its size.
pub struct Dropped {
    pub name: PathBuf,
    pub bytes: u64,
}

/// Removes every file below `root` (canonical) that is not in `keep` (canonical
/// paths), and the folders that leaves empty.
pub fn drop_all_but(root: &Path, keep: &HashSet<PathBuf>) -> io::Result<Vec<Dropped>> {
    let mut dropped = Vec::new();
    sweep(root, root, keep, &mut dropped)?;
    dropped.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(dropped)
}

/// Bundles are at most 32 folders deep (`MAX_ENTRY_DEPTH`), which bounds the recursion.
fn sweep(
    root: &Path,
    dir: &Path,
    keep: &HashSet<PathBuf>,
    out: &mut Vec<Dropped>,
) -> io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let path = entry.path();
        if entry.file_type()?.is_dir() {
            sweep(root, &path, keep, out)?;
            if std::fs::read_dir(&path)?.next().is_none() {
                std::fs::remove_dir(&path)?;
            }
        } else if !keep.contains(&path) {
            let bytes = entry.metadata()?.len();
            std::fs::remove_file(&path)?;
            let name = path.strip_prefix(root).unwrap_or(&path).to_path_buf();
            out.push(Dropped { name, bytes });
        }
    }
    Ok(())
}

/// Names shown in a warning at most.
const SHOWN: usize = 5;

/// The warning for what was dropped, leaving out `expected` (names in the bundle:
/// what an import read and has no more use for); `None` if nothing else went.
pub fn warning(dropped: &[Dropped], expected: &HashSet<PathBuf>) -> Option<String> {
    let unnamed: Vec<&Dropped> = dropped
        .iter()
        .filter(|d| !expected.contains(&d.name))
        .collect();
    if unnamed.is_empty() {
        return None;
    }
    let total: u64 = unnamed.iter().map(|d| d.bytes).sum();
    let mut list: Vec<String> = unnamed
        .iter()
        .take(SHOWN)
        .map(|d| format!("{} ({})", d.name.display(), size(d.bytes)))
        .collect();
    if unnamed.len() > SHOWN {
        list.push(format!("and {} more", unnamed.len() - SHOWN));
    }
    Some(format!(
        "not stored: {} file{} of the bundle that the scene does not name, {} in all: {}",
        unnamed.len(),
        if unnamed.len() == 1 { "" } else { "s" },
        size(total),
        list.join(", ")
    ))
}

fn size(bytes: u64) -> String {
    match bytes {
        b if b < 1 << 10 => format!("{b} B"),
        b if b < 1 << 20 => format!("{:.1} KiB", b as f64 / 1024.0),
        b => format!("{:.1} MiB", b as f64 / (1 << 20) as f64),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_what_is_kept_stays_and_empty_folders_go() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().canonicalize().unwrap();
        for (name, text) in [
            ("scene.json", "{}"),
            ("m/a.obj", "v"),
            ("m/pad.bin", "xxxx"),
            ("deep/er/junk", "xx"),
        ] {
            let p = root.join(name);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
        let keep: HashSet<PathBuf> = ["scene.json", "m/a.obj"]
            .iter()
            .map(|n| root.join(n))
            .collect();
        let dropped = drop_all_but(&root, &keep).unwrap();
        let names: Vec<_> = dropped.iter().map(|d| d.name.to_str().unwrap()).collect();
        assert_eq!(names, ["deep/er/junk", "m/pad.bin"]);
        assert!(root.join("m/a.obj").is_file() && root.join("scene.json").is_file());
        assert!(!root.join("deep").exists());
        let expected: HashSet<PathBuf> = [PathBuf::from("deep/er/junk")].into();
        assert_eq!(
            warning(&dropped, &expected).as_deref(),
            Some("not stored: 1 file of the bundle that the scene does not name, 4 B in all: m/pad.bin (4 B)")
        );
        assert_eq!(warning(&dropped[..1], &expected), None);
    }
}
