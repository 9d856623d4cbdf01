//! `caustic import`: a Mitsuba 3 XML scene converted to caustic's JSON scene format,
//! with every approximation the import made printed as a warning.

use super::args::ImportArgs;
use anyhow::{anyhow, Context, Result};
use caustic::integrator::Settings;
use caustic::scene::files::{self, slashed};
use caustic::scene::mitsuba::{self, Import};
use caustic::scene::SceneFile;
use std::path::Path;

/// Imports an XML scene and prints its warnings (and its sample count) to stderr.
pub fn import_xml(path: &Path) -> Result<Import> {
    // The importer's errors name their file (and line) already.
    let import = mitsuba::import_file(path).map_err(|e| match e.path.is_empty() {
        true => anyhow!("{}: {e}", path.display()),
        false => anyhow!("{e}"),
    })?;
    for w in &import.warnings {
        eprintln!("warning: {w}");
    }
    Ok(import)
}

pub fn import(a: &ImportArgs) -> Result<()> {
    let mut import = import_xml(&a.scene)?;
    let invalid = |e: &dyn std::fmt::Display| {
        anyhow!("{}: the imported scene is invalid: {e}", a.scene.display())
    };
    caustic::scene::validate::validate(&import.scene).map_err(|e| invalid(&e))?;
    Settings::scene_defaults(import.scene.integrator.as_ref()).map_err(|e| invalid(&e))?;
    if let Some(out) = &a.output {
        place_files(&mut import.scene, &a.scene, out)?;
    }
    let mut json = serde_json::to_string_pretty(&import.scene)?;
    json.push('\n');
    match &a.output {
        Some(out) => {
            caustic::film::write_bytes_atomic(out, json.as_bytes())?;
            eprintln!("wrote {}", out.display());
        }
        None => print!("{json}"),
    }
    if let Some(spp) = import.spp {
        eprintln!(
            "note: sample_count {spp} is not part of a caustic scene; render with --spp {spp} \
             (`caustic render` of the XML uses it by default)"
        );
    }
    Ok(())
}

/// The folder a file is in, canonical.
fn folder_of(path: &Path) -> Result<std::path::PathBuf> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
    let dir = dir.unwrap_or(Path::new("."));
    dir.canonicalize()
        .with_context(|| format!("folder {}", dir.display()))
}

/// Makes the scene's file references hold from `out`'s folder, which is created if
/// need be: unchanged when it is the XML's folder; prefixed with the way down when
/// the XML's folder lies inside it; else (a scene may not reach out of its folder
/// with `..`) the files are copied beside `out`, in the same places relative to it.
fn place_files(scene: &mut SceneFile, xml: &Path, out: &Path) -> Result<()> {
    let from = folder_of(xml)?;
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let to = folder_of(out)?;
    if from == to {
        return Ok(());
    }
    if let Ok(down) = from.strip_prefix(&to) {
        for (_, name) in files::references_mut(scene) {
            *name = slashed(&down.join(name.as_str()));
        }
        return Ok(());
    }
    let needed = files::needed(scene, &from);
    for src in &needed {
        let rel = src.strip_prefix(&from).map_err(|_| {
            anyhow!(
                "{} leads outside {}'s folder: cannot copy it beside {}",
                src.display(),
                xml.display(),
                out.display()
            )
        })?;
        copy_to(src, &to.join(rel))?;
    }
    if !needed.is_empty() {
        eprintln!(
            "copied {} file{} the scene names to {}",
            needed.len(),
            if needed.len() == 1 { "" } else { "s" },
            to.display()
        );
    }
    Ok(())
}

/// Copies `src` to `dst`, creating folders; a different file already at `dst` is an
/// error rather than something to overwrite.
fn copy_to(src: &Path, dst: &Path) -> Result<()> {
    if dst.exists() {
        let same = std::fs::read(src)? == std::fs::read(dst)?;
        if same {
            return Ok(());
        }
        return Err(anyhow!(
            "{} already exists and differs from {}: write the scene to another folder, or \
             remove it",
            dst.display(),
            src.display()
        ));
    }
    if let Some(dir) = dst.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::copy(src, dst)
        .with_context(|| format!("copying {} to {}", src.display(), dst.display()))?;
    Ok(())
}
