//! Checks of the lights that are not shapes. Imports `checks` and `shape`
//! (transforms).

use super::super::error::{Result, SceneError};
use super::super::format::*;
use super::checks::*;
use super::shape::validate_transform;

pub(super) fn validate_light(path: &str, l: &LightDesc) -> Result<()> {
    match l {
        LightDesc::Point {
            position,
            intensity,
        } => {
            finite3(&format!("{path}.position"), *position)?;
            non_negative3(&format!("{path}.intensity"), *intensity)
        }
        LightDesc::Spot {
            position,
            target,
            intensity,
            cutoff_angle,
            beam_width,
        } => {
            finite3(&format!("{path}.position"), *position)?;
            finite3(&format!("{path}.target"), *target)?;
            if position == target {
                return Err(SceneError::new(
                    format!("{path}.target"),
                    "equals the position: no axis",
                ));
            }
            non_negative3(&format!("{path}.intensity"), *intensity)?;
            in_range(
                &format!("{path}.cutoff_angle"),
                *cutoff_angle,
                1e-3,
                179.0,
                "degrees in (0, 179]",
            )?;
            if let Some(b) = beam_width {
                in_range(
                    &format!("{path}.beam_width"),
                    *b,
                    0.0,
                    *cutoff_angle,
                    "degrees in [0, cutoff_angle]",
                )?;
            }
            Ok(())
        }
        LightDesc::Directional {
            direction,
            irradiance,
        } => {
            nonzero3(&format!("{path}.direction"), *direction)?;
            non_negative3(&format!("{path}.irradiance"), *irradiance)
        }
        LightDesc::Constant { radiance } => non_negative3(&format!("{path}.radiance"), *radiance),
        LightDesc::Envmap {
            filename,
            scale,
            transform,
        } => {
            crate::scene::files::check_relative(&format!("{path}.filename"), filename)?;
            in_range(
                &format!("{path}.scale"),
                *scale,
                0.0,
                f32::MAX,
                "non-negative",
            )?;
            if let Some(t) = transform {
                validate_transform(&format!("{path}.transform"), t)?;
            }
            Ok(())
        }
    }
}
