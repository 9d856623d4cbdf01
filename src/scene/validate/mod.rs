//! Value checks that serde cannot express: finiteness, ranges, references by name.
//! Every error names the JSON path of the offending field.

mod checks;
mod light;
mod material;
mod medium;
mod shape;

use super::error::{Result, SceneError};
use super::format::*;
use crate::film::MAX_RADIUS;
use checks::{finite3, in_range, medium_ref, nonzero3, positive};
use light::validate_light;
use material::validate_material;
use medium::validate_medium;
use shape::validate_shape;
pub use shape::validate_transform;

pub fn validate(scene: &SceneFile) -> Result<()> {
    if scene.format != 1 {
        return Err(SceneError::new(
            "format",
            format!(
                "unsupported format version {} (this build reads 1)",
                scene.format
            ),
        ));
    }
    validate_camera(scene)?;
    validate_film(&scene.film)?;
    for (name, m) in &scene.materials {
        validate_material(&format!("materials.{name}"), m)?;
    }
    for (name, m) in &scene.media {
        validate_medium(&format!("media.{name}"), m)?;
    }
    for (i, s) in scene.shapes.iter().enumerate() {
        validate_shape(scene, &format!("shapes[{i}]"), s)?;
    }
    for (i, l) in scene.lights.iter().enumerate() {
        validate_light(&format!("lights[{i}]"), l)?;
    }
    if let Some(v) = &scene.integrator {
        if v.get("algorithm").and_then(|a| a.as_str()).is_none() {
            return Err(SceneError::new(
                "integrator",
                "must be an object naming its \"algorithm\"",
            ));
        }
    }
    Ok(())
}

/// Largest image side a scene may ask for; servers may cap further.
pub const MAX_RESOLUTION: u32 = 16384;

fn validate_film(f: &FilmDesc) -> Result<()> {
    for (field, v) in [("film.width", f.width), ("film.height", f.height)] {
        if v == 0 || v > MAX_RESOLUTION {
            return Err(SceneError::new(
                field,
                format!("{v} is out of range: 1..={MAX_RESOLUTION}"),
            ));
        }
    }
    filter(&f.filter.0).map_err(|e| SceneError::new("film.filter", e))
}

/// Checks a pixel filter's parameters, saying which one is out of range and why: the
/// radius bounds what one sample costs ([`MAX_RADIUS`] pixels), Mitchell's B and C
/// stay in the square Mitchell and Netravali studied.
pub fn filter(f: &Filter) -> std::result::Result<(), String> {
    let max = MAX_RADIUS;
    let (name, v, range) = match *f {
        Filter::Box { radius } | Filter::Tent { radius } => ("radius", radius as f64, (0.0, max)),
        Filter::Gaussian { stddev } => ("stddev", stddev as f64, (0.0, max / 4.0)),
        Filter::Lanczos { lobes } => ("lobes", lobes as f64, (0.0, max)),
        Filter::Mitchell { b, c } => {
            return match [("B", b), ("C", c)]
                .iter()
                .find(|(_, v)| !(0.0..=1.0).contains(v))
            {
                Some((name, v)) => Err(format!("{name} {v} is out of range: [0, 1]")),
                None => Ok(()),
            };
        }
    };
    if v > range.0 && v <= range.1 {
        Ok(())
    } else {
        Err(format!(
            "{name} {v} is out of range: greater than {} and at most {} (a radius of at most {max} pixels)",
            range.0, range.1
        ))
    }
}

fn validate_camera(scene: &SceneFile) -> Result<()> {
    let c = &scene.camera;
    if c.kind != "pinhole" && c.kind != "thinlens" {
        return Err(SceneError::new(
            "camera.type",
            format!("unknown camera \"{}\" (pinhole or thinlens)", c.kind),
        ));
    }
    finite3("camera.look_at.origin", c.look_at.origin)?;
    finite3("camera.look_at.target", c.look_at.target)?;
    nonzero3("camera.look_at.up", c.look_at.up)?;
    let o = glam::Vec3::from(c.look_at.origin);
    let f = glam::Vec3::from(c.look_at.target) - o;
    if f.length_squared() == 0.0 {
        return Err(SceneError::new(
            "camera.look_at.target",
            "equals the origin: no viewing direction",
        ));
    }
    let up = glam::Vec3::from(c.look_at.up);
    if f.normalize().cross(up.normalize()).length() < 1e-6 {
        return Err(SceneError::new(
            "camera.look_at.up",
            "is parallel to the viewing direction",
        ));
    }
    in_range("camera.fov", c.fov, 1e-3, 179.0, "degrees in (0, 179]")?;
    in_range(
        "camera.aperture_radius",
        c.aperture_radius,
        0.0,
        f32::MAX,
        "non-negative",
    )?;
    match (c.kind.as_str(), c.aperture_radius > 0.0) {
        ("pinhole", true) => {
            return Err(SceneError::new(
                "camera.aperture_radius",
                "a pinhole camera has no aperture (use \"type\": \"thinlens\")",
            ))
        }
        ("thinlens", false) => {
            return Err(SceneError::new(
                "camera.aperture_radius",
                "a thin lens needs a positive aperture radius",
            ))
        }
        _ => {}
    }
    if let Some(d) = c.focus_distance {
        positive("camera.focus_distance", d)?;
    }
    if let Some(m) = &c.medium {
        medium_ref(scene, "camera.medium", m)?;
    }
    Ok(())
}
