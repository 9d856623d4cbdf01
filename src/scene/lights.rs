//! Compiling the lights that are not shapes (points, spots, directional, constant and
//! environment lights), and the medium each light of a compiled scene emits into.
//! Imports `format`, `files`, `load`, `materials` and `shapes`.

use super::error::{Result, SceneError};
use super::files::resolve;
use super::format::*;
use super::load::transform_matrix;
use super::materials::rgb;
use super::shapes::similarity_scale;
use super::Scene;
use crate::light::{DirectionalLight, EnvMap, Light, PointLight, SpotLight};
use crate::math::{Mat3, Rgb, Vec3};
use std::path::Path;

pub(super) fn light(path: &str, l: &LightDesc, base: Option<&Path>) -> Result<Light> {
    Ok(match l {
        LightDesc::Point {
            position,
            intensity,
        } => Light::Point(PointLight {
            position: (*position).into(),
            intensity: rgb(*intensity),
        }),
        LightDesc::Spot {
            position,
            target,
            intensity,
            cutoff_angle,
            beam_width,
        } => {
            let p = Vec3::from(*position);
            Light::Spot(SpotLight::new(
                p,
                Vec3::from(*target) - p,
                rgb(*intensity),
                cutoff_angle.to_radians(),
                beam_width.unwrap_or(cutoff_angle * 0.75).to_radians(),
            ))
        }
        LightDesc::Directional {
            direction,
            irradiance,
        } => Light::Directional(DirectionalLight {
            direction: Vec3::from(*direction).normalize(),
            irradiance: rgb(*irradiance),
        }),
        LightDesc::Constant { radiance } => Light::Constant {
            radiance: rgb(*radiance),
        },
        LightDesc::Envmap {
            filename,
            scale,
            transform,
        } => {
            let field = format!("{path}.filename");
            let base =
                base.ok_or_else(|| SceneError::new(&field, "file references need a scene folder"))?;
            let full = resolve(base, &field, filename)?;
            // Named as the scene names it: the server shows the message to clients.
            let img = crate::film::read_exr_named(&full, filename)
                .map_err(|e| SceneError::new(&field, e.to_string()))?;
            let texels: Vec<Rgb> = img.pixels().iter().map(|p| *p * *scale).collect();
            if texels.iter().any(|t| !crate::math::is_valid_radiance(*t)) {
                return Err(SceneError::new(
                    &field,
                    "the map holds NaN, infinite or negative values",
                ));
            }
            let rot = Mat3::from_mat4(transform_matrix(transform.as_ref()));
            if similarity_scale(rot).is_none_or(|s| (s - 1.0).abs() > 1e-3) {
                return Err(SceneError::new(
                    format!("{path}.transform"),
                    "an environment map may only be rotated",
                ));
            }
            Light::EnvMap(EnvMap::new(
                img.width() as usize,
                img.height() as usize,
                texels,
                rot,
            ))
        }
    })
}

/// The medium a light emits into: an area light on a medium boundary emits into the
/// medium on its normal side; other lights sit in whatever medium surrounds them.
pub(super) fn light_medium(scene: &Scene, i: usize) -> Option<u32> {
    if !scene.has_media {
        return None;
    }
    match &scene.lights[i] {
        Light::Area(a) => {
            let shape = &scene.shapes[a.shape as usize];
            if shape.is_medium_boundary() {
                return shape.exterior;
            }
            let (p, n) = a.sample_area(0.5, crate::math::Vec2::splat(0.5));
            scene.medium_at(p + n * 1e-4 * (1.0 + p.abs().max_element()))
        }
        Light::Point(l) => scene.medium_at(l.position),
        Light::Spot(l) => scene.medium_at(l.position),
        // Light from infinity arrives through whatever surrounds the scene.
        _ => scene.medium_at(scene.sphere.center + Vec3::Y * 2.0 * scene.sphere.radius),
    }
}
