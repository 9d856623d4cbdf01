//! Medium and phase function checks. Imports `checks` and `shape` (transforms).

use super::super::error::{Result, SceneError};
use super::super::format::*;
use super::checks::*;
use super::shape::validate_transform;

pub(super) fn validate_medium(path: &str, m: &MediumDesc) -> Result<()> {
    match m {
        MediumDesc::Homogeneous {
            sigma_a,
            sigma_s,
            sigma_t,
            albedo,
            scale,
            phase,
        } => {
            match (sigma_a, sigma_s, sigma_t, albedo) {
                (Some(a), Some(s), None, None) => {
                    non_negative3(&format!("{path}.sigma_a"), *a)?;
                    non_negative3(&format!("{path}.sigma_s"), *s)?;
                }
                (None, None, Some(t), Some(al)) => {
                    non_negative3(&format!("{path}.sigma_t"), *t)?;
                    unit3(&format!("{path}.albedo"), *al)?;
                }
                _ => {
                    return Err(SceneError::new(
                        path,
                        "give either sigma_a and sigma_s, or sigma_t and albedo",
                    ))
                }
            }
            positive(&format!("{path}.scale"), *scale)?;
            validate_phase(&format!("{path}.phase"), phase)
        }
        MediumDesc::Grid {
            file,
            albedo_file,
            sigma_t,
            albedo,
            scale,
            bounds,
            transform,
            phase,
            ..
        } => {
            crate::scene::files::check_relative(&format!("{path}.file"), file)?;
            if let Some(f) = albedo_file {
                crate::scene::files::check_relative(&format!("{path}.albedo_file"), f)?;
            }
            non_negative3(&format!("{path}.sigma_t"), *sigma_t)?;
            unit3(&format!("{path}.albedo"), *albedo)?;
            positive(&format!("{path}.scale"), *scale)?;
            validate_placement(path, bounds.as_ref(), transform.as_ref())?;
            validate_phase(&format!("{path}.phase"), phase)
        }
        MediumDesc::Procedural {
            sigma_t,
            albedo,
            scale,
            octaves,
            lacunarity,
            gain,
            frequency,
            threshold,
            bounds,
            transform,
            phase,
            ..
        } => {
            non_negative3(&format!("{path}.sigma_t"), *sigma_t)?;
            unit3(&format!("{path}.albedo"), *albedo)?;
            positive(&format!("{path}.scale"), *scale)?;
            if !(1..=16).contains(octaves) {
                return Err(SceneError::new(
                    format!("{path}.octaves"),
                    format!("{octaves} is out of range: 1..=16"),
                ));
            }
            in_range(
                &format!("{path}.lacunarity"),
                *lacunarity,
                1.0,
                16.0,
                "[1, 16]",
            )?;
            in_range(&format!("{path}.gain"), *gain, 0.0, 1.0, "[0, 1]")?;
            in_range(
                &format!("{path}.frequency"),
                *frequency,
                1e-3,
                1e3,
                "[0.001, 1000]",
            )?;
            in_range(
                &format!("{path}.threshold"),
                *threshold,
                0.0,
                0.99,
                "[0, 0.99]",
            )?;
            if bounds.is_none() && transform.is_none() {
                return Err(SceneError::new(
                    path,
                    "a procedural medium needs `bounds` or `transform`",
                ));
            }
            validate_placement(path, bounds.as_ref(), transform.as_ref())?;
            validate_phase(&format!("{path}.phase"), phase)
        }
    }
}

pub(super) fn validate_placement(
    path: &str,
    bounds: Option<&BoundsDesc>,
    transform: Option<&TransformDesc>,
) -> Result<()> {
    if bounds.is_some() && transform.is_some() {
        return Err(SceneError::new(
            path,
            "give either `bounds` or `transform`, not both",
        ));
    }
    if let Some(b) = bounds {
        finite3(&format!("{path}.bounds.min"), b.min)?;
        finite3(&format!("{path}.bounds.max"), b.max)?;
        if (0..3).any(|a| b.max[a] <= b.min[a]) {
            return Err(SceneError::new(
                format!("{path}.bounds"),
                "max must exceed min on every axis",
            ));
        }
    }
    if let Some(t) = transform {
        validate_transform(&format!("{path}.transform"), t)?;
    }
    Ok(())
}

pub(super) fn validate_phase(path: &str, p: &PhaseDesc) -> Result<()> {
    // |g| = 1 is a delta lobe that the phase-sampling code cannot represent.
    match p {
        PhaseDesc::HenyeyGreenstein { g } => {
            in_range(&format!("{path}.g"), *g, -0.999, 0.999, "[-0.999, 0.999]")
        }
        PhaseDesc::Schlick { k } => {
            in_range(&format!("{path}.k"), *k, -0.999, 0.999, "[-0.999, 0.999]")
        }
        PhaseDesc::Isotropic | PhaseDesc::Rayleigh => Ok(()),
    }
}
