//! Compiles the scene's `media` into [`Medium`] values: coefficients, phase functions,
//! grid files and their placement, procedural noise.

use super::error::{Result, SceneError};
use super::files::resolve;
use super::format::{BoundsDesc, MediumDesc, PhaseDesc, TransformDesc, V3};
use super::load::transform_matrix;
use crate::math::{Rgb, Vec3};
use crate::medium::grid_io::{load_grid_named, DenseGrid};
use crate::medium::noise::{Fbm, FbmParams};
use crate::medium::voxels::{DensityField, VoxelGrid};
use crate::medium::{Heterogeneous, Homogeneous, Medium, Phase};
use glam::{Affine3A, Mat4};
use std::path::Path;

pub fn phase(p: &PhaseDesc) -> Phase {
    match *p {
        PhaseDesc::Isotropic => Phase::Isotropic,
        PhaseDesc::HenyeyGreenstein { g } => Phase::HenyeyGreenstein { g },
        PhaseDesc::Schlick { k } => Phase::Schlick { k },
        PhaseDesc::Rayleigh => Phase::Rayleigh,
    }
}

fn rgb(v: V3) -> Rgb {
    Rgb::from_array(v)
}

pub fn medium(path: &str, m: &MediumDesc, base: Option<&Path>) -> Result<Medium> {
    match m {
        MediumDesc::Homogeneous {
            sigma_a,
            sigma_s,
            sigma_t,
            albedo,
            scale,
            phase: p,
        } => {
            let (a, s) = match (sigma_a, sigma_s, sigma_t, albedo) {
                (Some(a), Some(s), _, _) => (rgb(*a), rgb(*s)),
                (_, _, Some(t), Some(al)) => {
                    let s = rgb(*t) * rgb(*al);
                    (rgb(*t) - s, s)
                }
                _ => unreachable!("validated: one pair of coefficients"),
            };
            Ok(Medium::Homogeneous(Homogeneous::new(
                a * *scale,
                s * *scale,
                phase(p),
            )))
        }
        MediumDesc::Grid {
            file,
            grid,
            sigma_t,
            albedo,
            albedo_file,
            scale,
            bounds,
            transform,
            phase: p,
        } => {
            let density = read_grid(&format!("{path}.file"), file, grid.as_deref(), base)?;
            let albedo_grid = match albedo_file {
                Some(f) => Some(VoxelGrid::new(&read_grid(
                    &format!("{path}.albedo_file"),
                    f,
                    None,
                    base,
                )?)),
                None => None,
            };
            let to_local = placement(path, bounds.as_ref(), transform.as_ref(), density.bounds)?;
            Ok(Medium::Heterogeneous(Box::new(Heterogeneous::new(
                DensityField::Grid(VoxelGrid::new(&density)),
                rgb(*albedo),
                albedo_grid,
                rgb(*sigma_t) * *scale,
                phase(p),
                to_local,
            ))))
        }
        MediumDesc::Procedural {
            sigma_t,
            albedo,
            scale,
            octaves,
            lacunarity,
            gain,
            frequency,
            seed,
            threshold,
            bounds,
            transform,
            phase: p,
        } => {
            let fbm = Fbm::new(FbmParams {
                octaves: *octaves,
                lacunarity: *lacunarity,
                gain: *gain,
                frequency: *frequency,
                seed: *seed,
                threshold: *threshold,
            });
            let to_local = placement(path, bounds.as_ref(), transform.as_ref(), None)?;
            Ok(Medium::Heterogeneous(Box::new(Heterogeneous::new(
                DensityField::Noise(fbm),
                rgb(*albedo),
                None,
                rgb(*sigma_t) * *scale,
                phase(p),
                to_local,
            ))))
        }
    }
}

fn read_grid(
    field: &str,
    file: &str,
    grid: Option<&str>,
    base: Option<&Path>,
) -> Result<DenseGrid> {
    let base = base.ok_or_else(|| SceneError::new(field, "file references need a scene folder"))?;
    let full = resolve(base, field, file)?;
    // The error names the file as the scene does, not by the server's path.
    load_grid_named(&full, Path::new(file), grid).map_err(|e| SceneError::new(field, e.to_string()))
}

/// World-to-unit-cube map from `bounds`, a `transform` of the unit cube, or the
/// bounds the grid file carries.
fn placement(
    path: &str,
    bounds: Option<&BoundsDesc>,
    transform: Option<&TransformDesc>,
    file_bounds: Option<([f32; 3], [f32; 3])>,
) -> Result<Affine3A> {
    let to_world = if let Some(t) = transform {
        transform_matrix(Some(t))
    } else {
        let (lo, hi) = match (bounds, file_bounds) {
            (Some(b), _) => (b.min, b.max),
            (None, Some(fb)) => fb,
            (None, None) => {
                return Err(SceneError::new(
                    path,
                    "the grid file has no bounds: give `bounds` or `transform`",
                ))
            }
        };
        let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
        if (hi - lo).min_element() <= 0.0 {
            return Err(SceneError::new(path, "the volume's bounds are empty"));
        }
        Mat4::from_translation(lo) * Mat4::from_scale(hi - lo)
    };
    let inv = to_world.inverse();
    if !inv.is_finite() || to_world.determinant().abs() < 1e-30 {
        return Err(SceneError::new(
            format!("{path}.transform"),
            "is singular (the volume has no extent)",
        ));
    }
    Ok(Affine3A::from_mat4(inv))
}
