//! `caustic import`: a Mitsuba 3 XML scene converted to caustic's JSON scene format,
//! with every approximation the import made printed as a warning.

use super::args::ImportArgs;
use anyhow::Result;
use caustic::integrator::Settings;
use caustic::scene::mitsuba::{self, Import};
use std::path::Path;

/// Imports an XML scene and prints its warnings (and its sample count) to stderr.
pub fn import_xml(path: &Path) -> Result<Import> {
    let import =
        mitsuba::import_file(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    for w in &import.warnings {
        eprintln!("warning: {w}");
    }
    Ok(import)
}

pub fn import(a: &ImportArgs) -> Result<()> {
    let import = import_xml(&a.scene)?;
    let invalid = |e: &dyn std::fmt::Display| {
        anyhow::anyhow!("{}: the imported scene is invalid: {e}", a.scene.display())
    };
    caustic::scene::validate::validate(&import.scene).map_err(|e| invalid(&e))?;
    Settings::scene_defaults(import.scene.integrator.as_ref()).map_err(|e| invalid(&e))?;
    let mut json = serde_json::to_string_pretty(&import.scene)?;
    json.push('\n');
    match &a.output {
        Some(out) => {
            caustic::film::write_bytes_atomic(out, json.as_bytes())?;
            eprintln!("wrote {}", out.display());
            let folder = |p: &Path| {
                let dir = p.parent().filter(|d| !d.as_os_str().is_empty());
                dir.unwrap_or(Path::new(".")).canonicalize().ok()
            };
            let mut names = Vec::new();
            caustic::client::referenced_files(&serde_json::to_value(&import.scene)?, &mut names);
            if !names.is_empty() && folder(out) != folder(&a.scene) {
                eprintln!(
                    "warning: the scene names files relative to {}'s folder; move {} there",
                    a.scene.display(),
                    out.display()
                );
            }
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
