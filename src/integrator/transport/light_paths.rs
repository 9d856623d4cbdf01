//! How many light paths an iteration traces, and the checks of the parameters every
//! light pass takes (`max_depth`, `light_paths`, a memory budget), so that each
//! algorithm refuses a bad value with the same words.

use super::params::{check_max_depth, ParamError};
use serde::{Deserialize, Serialize};

/// Light subpaths per iteration: a multiple of the pixel count (a number, as for every
/// other algorithm) or an absolute count (`{"count": N}`), which suits these methods:
/// their cost per camera sample does not grow with the number of virtual lights.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged, deny_unknown_fields)]
pub enum LightPaths {
    Multiple(f32),
    Count { count: u32 },
}

impl LightPaths {
    /// Paths for an image of `pixels` pixels (at least one).
    pub fn count(self, pixels: usize) -> usize {
        match self {
            LightPaths::Multiple(m) => light_path_count(pixels, m),
            LightPaths::Count { count } => count.max(1) as usize,
        }
    }

    pub(crate) fn check(self) -> Result<(), ParamError> {
        match self {
            LightPaths::Multiple(m) if !(m > 0.0 && m <= 64.0) => Err(ParamError::new(
                "light_paths",
                format!("light_paths as a multiple of the pixel count must be in (0, 64], got {m}"),
            )),
            LightPaths::Count { count } if !(1..=MAX_PATH_COUNT).contains(&count) => {
                Err(ParamError::new(
                    "light_paths.count",
                    format!("light_paths.count must be in 1..={MAX_PATH_COUNT}, got {count}"),
                ))
            }
            _ => Ok(()),
        }
    }
}

/// Most light paths a count may ask for per iteration.
pub const MAX_PATH_COUNT: u32 = 1 << 24;
/// Light paths per iteration: `multiple` x the pixel count, at least one.
pub(crate) fn light_path_count(pixels: usize, multiple: f32) -> usize {
    ((pixels as f64 * multiple as f64).round() as usize).max(1)
}

/// The checks of a light pass that keeps its paths (vertices, segments or beams)
/// within `max_vertex_mib`.
pub(crate) fn check_light_pass(
    max_depth: u32,
    light_paths: LightPaths,
    max_vertex_mib: f32,
) -> Result<(), ParamError> {
    check_max_depth(max_depth)?;
    light_paths.check()?;
    if !(max_vertex_mib.is_finite() && max_vertex_mib > 0.0) {
        return Err(ParamError::new(
            "max_vertex_mib",
            format!("max_vertex_mib must be positive, got {max_vertex_mib}"),
        ));
    }
    Ok(())
}
