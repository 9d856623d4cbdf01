//! Value checks that serde cannot express: finiteness, ranges, references by name.
//! Every error names the JSON path of the offending field.

use super::error::{Result, SceneError};
use super::format::*;
use crate::film::MAX_RADIUS;

fn finite3(path: &str, v: V3) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(SceneError::new(path, format!("{v:?} is not finite")))
    }
}

fn non_negative3(path: &str, v: V3) -> Result<()> {
    finite3(path, v)?;
    if v.iter().all(|&x| x >= 0.0) {
        Ok(())
    } else {
        Err(SceneError::new(path, format!("{v:?} has a negative value")))
    }
}

fn unit3(path: &str, v: V3) -> Result<()> {
    non_negative3(path, v)?;
    if v.iter().all(|&x| x <= 1.0) {
        Ok(())
    } else {
        Err(SceneError::new(
            path,
            format!("{v:?} exceeds 1 (albedo above 1 creates energy)"),
        ))
    }
}

/// A reflectance: a constant within [0, 1], or a texture (whose values are used as
/// the images give them, as in Mitsuba).
fn unit_param(path: &str, p: &Param) -> Result<()> {
    match p {
        Param::Value(v) => unit3(path, *v),
        Param::Texture(t) => validate_texture(path, t),
    }
}

/// A non-negative colour, or a texture (an emitter's radiance).
fn non_negative_param(path: &str, p: &Param) -> Result<()> {
    match p {
        Param::Value(v) => non_negative3(path, *v),
        Param::Texture(t) => validate_texture(path, t),
    }
}

fn validate_texture(path: &str, t: &TextureDesc) -> Result<()> {
    let to_uv = |rows: &Option<[[f32; 3]; 2]>| match rows {
        Some(r) if !r.iter().flatten().all(|x| x.is_finite()) => Err(SceneError::new(
            format!("{path}.to_uv"),
            format!("{r:?} is not finite"),
        )),
        _ => Ok(()),
    };
    let inner = |field: &str, p: &Param| non_negative_param(&format!("{path}.{field}"), p);
    match t {
        TextureDesc::Bitmap {
            filename, to_uv: r, ..
        } => {
            super::files::check_relative(&format!("{path}.filename"), filename)?;
            to_uv(r)
        }
        TextureDesc::Checkerboard {
            color0,
            color1,
            to_uv: r,
        } => {
            inner("color0", color0)?;
            inner("color1", color1)?;
            to_uv(r)
        }
        TextureDesc::Scale { texture, scale } => {
            inner("texture", texture)?;
            match scale {
                Param::Value(v) => non_negative3(&format!("{path}.scale"), *v),
                Param::Texture(_) => Err(SceneError::new(
                    format!("{path}.scale"),
                    "must be a number or an [r, g, b] array",
                )),
            }
        }
    }
}

fn in_range(path: &str, x: f32, lo: f32, hi: f32, what: &str) -> Result<()> {
    if x.is_finite() && x >= lo && x <= hi {
        Ok(())
    } else {
        Err(SceneError::new(
            path,
            format!("{x} is out of range: {what}"),
        ))
    }
}

fn positive(path: &str, x: f32) -> Result<()> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(SceneError::new(
            path,
            format!("{x} must be positive and finite"),
        ))
    }
}

fn nonzero3(path: &str, v: V3) -> Result<()> {
    finite3(path, v)?;
    if v.iter().any(|&x| x != 0.0) {
        Ok(())
    } else {
        Err(SceneError::new(path, "must not be the zero vector"))
    }
}

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

fn validate_material(path: &str, m: &MaterialDesc) -> Result<()> {
    match m {
        MaterialDesc::Diffuse { reflectance, .. } => {
            unit_param(&format!("{path}.reflectance"), reflectance)
        }
        MaterialDesc::Phong {
            kd, ks, exponent, ..
        } => {
            unit3(&format!("{path}.kd"), *kd)?;
            unit3(&format!("{path}.ks"), *ks)?;
            let sum = [kd[0] + ks[0], kd[1] + ks[1], kd[2] + ks[2]];
            if sum.iter().any(|&s| s > 1.0 + 1e-6) {
                return Err(SceneError::new(
                    path,
                    format!("kd + ks = {sum:?} exceeds 1 (not energy conserving)"),
                ));
            }
            in_range(&format!("{path}.exponent"), *exponent, 0.0, 1e6, "0..=1e6")
        }
        MaterialDesc::Mirror { reflectance, .. } => {
            unit_param(&format!("{path}.reflectance"), reflectance)
        }
        MaterialDesc::Dielectric {
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        } => {
            positive(&format!("{path}.int_ior"), *int_ior)?;
            positive(&format!("{path}.ext_ior"), *ext_ior)?;
            unit_param(
                &format!("{path}.specular_reflectance"),
                specular_reflectance,
            )?;
            unit_param(
                &format!("{path}.specular_transmittance"),
                specular_transmittance,
            )
        }
        MaterialDesc::ThinDielectric {
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        } => interface(
            path,
            [*int_ior, *ext_ior],
            &Param::Value(*specular_reflectance),
            &Param::Value(*specular_transmittance),
        ),
        MaterialDesc::Conductor {
            eta,
            k,
            roughness,
            specular_reflectance,
            ..
        } => {
            non_negative3(&format!("{path}.eta"), *eta)?;
            if eta.iter().any(|&e| e <= 0.0) {
                return Err(SceneError::new(format!("{path}.eta"), "must be positive"));
            }
            non_negative3(&format!("{path}.k"), *k)?;
            in_range(
                &format!("{path}.roughness"),
                *roughness,
                0.0,
                1.0,
                "GGX alpha in [0, 1]",
            )?;
            unit_param(
                &format!("{path}.specular_reflectance"),
                specular_reflectance,
            )
        }
        MaterialDesc::RoughConductor {
            alpha,
            alpha_u,
            alpha_v,
            eta,
            k,
            specular_reflectance,
            ..
        } => {
            roughness(path, alpha, alpha_u, alpha_v)?;
            non_negative3(&format!("{path}.eta"), *eta)?;
            non_negative3(&format!("{path}.k"), *k)?;
            if (0..3).any(|c| eta[c] == 0.0 && k[c] == 0.0) {
                return Err(SceneError::new(
                    format!("{path}.k"),
                    "eta and k are both zero in a channel (no such conductor)",
                ));
            }
            unit_param(
                &format!("{path}.specular_reflectance"),
                specular_reflectance,
            )
        }
        MaterialDesc::RoughDielectric {
            alpha,
            alpha_u,
            alpha_v,
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
            ..
        } => {
            roughness(path, alpha, alpha_u, alpha_v)?;
            interface(
                path,
                [*int_ior, *ext_ior],
                specular_reflectance,
                specular_transmittance,
            )
        }
        MaterialDesc::Plastic {
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            ..
        } => coating(
            path,
            [*int_ior, *ext_ior],
            diffuse_reflectance,
            *specular_reflectance,
        ),
        MaterialDesc::RoughPlastic {
            alpha,
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            ..
        } => {
            roughness(path, &Some(Scalar::value(*alpha)), &None, &None)?;
            coating(
                path,
                [*int_ior, *ext_ior],
                diffuse_reflectance,
                *specular_reflectance,
            )
        }
        MaterialDesc::Null {} => Ok(()),
        MaterialDesc::Mask { opacity, material } => {
            unit_param(&format!("{path}.opacity"), opacity)?;
            if matches!(
                **material,
                MaterialDesc::Mask { .. } | MaterialDesc::Null {}
            ) {
                return Err(SceneError::new(
                    format!("{path}.material"),
                    "a mask holds a scattering material (not a mask or null)",
                ));
            }
            validate_material(&format!("{path}.material"), material)
        }
        MaterialDesc::NormalMap {
            normalmap: map,
            material,
            ..
        }
        | MaterialDesc::BumpMap {
            texture: map,
            material,
            ..
        } => perturbed(path, m, map, material),

        MaterialDesc::Mixture { weights, materials } => {
            if weights.len() != materials.len() || materials.is_empty() {
                return Err(SceneError::new(
                    format!("{path}.weights"),
                    format!(
                        "{} weights for {} materials: give one weight per material, and at \
                         least one material",
                        weights.len(),
                        materials.len()
                    ),
                ));
            }
            for (k, w) in weights.iter().enumerate() {
                in_range(&format!("{path}.weights[{k}]"), *w, 0.0, f32::MAX, ">= 0")?;
            }
            if weights.iter().sum::<f32>() <= 0.0 {
                return Err(SceneError::new(
                    format!("{path}.weights"),
                    "must sum to more than zero",
                ));
            }
            components(path, materials)
        }
        MaterialDesc::Blend { weight, materials } => {
            unit_param(&format!("{path}.weight"), &weight.0)?;
            if materials.len() != 2 {
                return Err(SceneError::new(
                    format!("{path}.materials"),
                    format!("a blend holds two materials, not {}", materials.len()),
                ));
            }
            components(path, materials)
        }
    }
}

/// A normal or bump map: its texture, a finite scale, and a nested material that
/// scatters (masks go outside normal maps, not inside).
fn perturbed(path: &str, m: &MaterialDesc, map: &Param, material: &MaterialDesc) -> Result<()> {
    match m {
        MaterialDesc::NormalMap { .. } => {
            let p = format!("{path}.normalmap");
            match map {
                Param::Value(v) => finite3(&p, *v)?,
                Param::Texture(t) => validate_texture(&p, t)?,
            }
        }
        MaterialDesc::BumpMap { scale, .. } => {
            let p = format!("{path}.texture");
            match map {
                Param::Value(v) => non_negative3(&p, *v)?,
                Param::Texture(t) => validate_texture(&p, t)?,
            }
            if !scale.is_finite() {
                return Err(SceneError::new(
                    format!("{path}.scale"),
                    format!("{scale} is not finite"),
                ));
            }
        }
        _ => unreachable!("not a normal or bump map"),
    }
    if matches!(
        material,
        MaterialDesc::Mask { .. }
            | MaterialDesc::Null {}
            | MaterialDesc::NormalMap { .. }
            | MaterialDesc::BumpMap { .. }
    ) {
        return Err(SceneError::new(
            format!("{path}.material"),
            "a normal or bump map holds a scattering material (not a mask, null, \
             normal map or bump map); put a mask outside it",
        ));
    }
    validate_material(&format!("{path}.material"), material)
}

/// The materials of a mixture or blend: scattering ones (masks and null boundaries
/// hold no BSDF to weigh).
fn components(path: &str, materials: &[MaterialDesc]) -> Result<()> {
    for (k, m) in materials.iter().enumerate() {
        let path = format!("{path}.materials[{k}]");
        if matches!(
            m,
            MaterialDesc::Mask { .. }
                | MaterialDesc::Null {}
                | MaterialDesc::NormalMap { .. }
                | MaterialDesc::BumpMap { .. }
        ) {
            return Err(SceneError::new(
                path,
                "a mixture holds scattering materials (not a mask, null, normal map or bump \
                 map); put a normal or bump map outside the mixture or blend",
            ));
        }
        validate_material(&path, m)?;
    }
    Ok(())
}

/// A dielectric interface's IORs and the colours of its two lobes.
fn interface(path: &str, [int_ior, ext_ior]: [f32; 2], r: &Param, t: &Param) -> Result<()> {
    positive(&format!("{path}.int_ior"), int_ior)?;
    positive(&format!("{path}.ext_ior"), ext_ior)?;
    unit_param(&format!("{path}.specular_reflectance"), r)?;
    unit_param(&format!("{path}.specular_transmittance"), t)
}

/// A plastic's coating (IORs that differ, as Mitsuba requires) and base.
fn coating(path: &str, [int_ior, ext_ior]: [f32; 2], diffuse: &Param, specular: V3) -> Result<()> {
    positive(&format!("{path}.int_ior"), int_ior)?;
    positive(&format!("{path}.ext_ior"), ext_ior)?;
    if int_ior == ext_ior {
        return Err(SceneError::new(
            format!("{path}.int_ior"),
            "equals ext_ior: a coating needs an interface",
        ));
    }
    unit_param(&format!("{path}.diffuse_reflectance"), diffuse)?;
    unit3(&format!("{path}.specular_reflectance"), specular)
}

/// A rough material's `alpha`, or `alpha_u` with `alpha_v`, each in [0, 10] (or a
/// texture).
fn roughness(path: &str, a: &Option<Scalar>, u: &Option<Scalar>, v: &Option<Scalar>) -> Result<()> {
    let given = [("alpha", a), ("alpha_u", u), ("alpha_v", v)];
    for (key, x) in given {
        let path = format!("{path}.{key}");
        match x.as_ref().map(|x| &x.0) {
            Some(Param::Value(x)) => in_range(&path, x[0], 0.0, 10.0, "alpha in [0, 10]")?,
            Some(Param::Texture(t)) => validate_texture(&path, t)?,
            None => {}
        }
    }
    match (a, u, v) {
        (Some(_), None, None) | (None, Some(_), Some(_)) | (None, None, None) => Ok(()),
        (Some(_), _, _) => Err(SceneError::new(
            format!("{path}.alpha"),
            "give alpha, or alpha_u and alpha_v, not both",
        )),
        (None, Some(_), None) => Err(SceneError::new(
            format!("{path}.alpha_v"),
            "missing: alpha_u needs alpha_v",
        )),
        (None, None, Some(_)) => Err(SceneError::new(
            format!("{path}.alpha_u"),
            "missing: alpha_v needs alpha_u",
        )),
    }
}

fn validate_medium(path: &str, m: &MediumDesc) -> Result<()> {
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
            super::files::check_relative(&format!("{path}.file"), file)?;
            if let Some(f) = albedo_file {
                super::files::check_relative(&format!("{path}.albedo_file"), f)?;
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

fn validate_placement(
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

fn validate_phase(path: &str, p: &PhaseDesc) -> Result<()> {
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

fn medium_ref(scene: &SceneFile, path: &str, name: &str) -> Result<()> {
    if scene.media.contains_key(name) {
        Ok(())
    } else {
        Err(SceneError::new(path, format!("unknown medium \"{name}\"")))
    }
}

fn validate_shape(scene: &SceneFile, path: &str, s: &ShapeDesc) -> Result<()> {
    let c = &s.common;
    if !scene.materials.contains_key(&c.material) {
        return Err(SceneError::new(
            format!("{path}.material"),
            format!("unknown material \"{}\"", c.material),
        ));
    }
    if let Some(e) = &c.emission {
        non_negative_param(&format!("{path}.emission.radiance"), &e.radiance)?;
        if matches!(
            scene.materials.get(&c.material),
            Some(MaterialDesc::Null {})
        ) {
            return Err(SceneError::new(
                format!("{path}.emission"),
                "a `null` (index-matched) boundary cannot emit: rays pass through it unseen",
            ));
        }
    }
    if let Some(m) = &c.interior {
        medium_ref(scene, &format!("{path}.interior"), m)?;
    }
    if let Some(m) = &c.exterior {
        medium_ref(scene, &format!("{path}.exterior"), m)?;
    }
    if let Some(t) = &c.transform {
        validate_transform(&format!("{path}.transform"), t)?;
    }
    validate_geometry(path, &s.geometry)
}

pub fn validate_transform(path: &str, t: &TransformDesc) -> Result<()> {
    if t.matrix.is_some() && (t.translate.is_some() || !t.rotate.is_empty() || t.scale.is_some()) {
        return Err(SceneError::new(
            path,
            "give either `matrix` or translate/rotate/scale, not both",
        ));
    }
    if let Some(m) = &t.matrix {
        if m.iter().any(|x| !x.is_finite()) {
            return Err(SceneError::new(format!("{path}.matrix"), "is not finite"));
        }
    }
    if let Some(v) = t.translate {
        finite3(&format!("{path}.translate"), v)?;
    }
    for (i, r) in t.rotate.iter().enumerate() {
        nonzero3(&format!("{path}.rotate[{i}].axis"), r.axis)?;
        in_range(
            &format!("{path}.rotate[{i}].angle"),
            r.angle,
            -1e6,
            1e6,
            "degrees",
        )?;
    }
    match t.scale {
        Some(Scale::Uniform(s)) if !(s.is_finite() && s != 0.0) => Err(SceneError::new(
            format!("{path}.scale"),
            "must be finite and non-zero",
        )),
        Some(Scale::PerAxis(v)) if !v.iter().all(|x| x.is_finite() && *x != 0.0) => Err(
            SceneError::new(format!("{path}.scale"), "must be finite and non-zero"),
        ),
        _ => Ok(()),
    }
}

fn validate_geometry(path: &str, g: &GeometryDesc) -> Result<()> {
    match g {
        GeometryDesc::Sphere { center, radius } => {
            finite3(&format!("{path}.center"), *center)?;
            positive(&format!("{path}.radius"), *radius)
        }
        GeometryDesc::Rectangle { corners } => {
            for (i, c) in corners.iter().flatten().enumerate() {
                finite3(&format!("{path}.corners[{i}]"), *c)?;
            }
            Ok(())
        }
        GeometryDesc::Cube {} | GeometryDesc::Disk {} => Ok(()),
        GeometryDesc::Mesh {
            positions,
            indices,
            normals,
            uvs,
        } => {
            for (i, p) in positions.iter().enumerate() {
                finite3(&format!("{path}.positions[{i}]"), *p)?;
            }
            for (i, tri) in indices.iter().enumerate() {
                if let Some(&bad) = tri.iter().find(|&&k| k as usize >= positions.len()) {
                    return Err(SceneError::new(
                        format!("{path}.indices[{i}]"),
                        format!("vertex {bad} out of range ({} positions)", positions.len()),
                    ));
                }
            }
            if let Some(n) = normals {
                if n.len() != positions.len() {
                    return Err(SceneError::new(
                        format!("{path}.normals"),
                        format!("{} normals for {} positions", n.len(), positions.len()),
                    ));
                }
                for (i, v) in n.iter().enumerate() {
                    nonzero3(&format!("{path}.normals[{i}]"), *v)?;
                }
            }
            if let Some(t) = uvs {
                if t.len() != positions.len() {
                    return Err(SceneError::new(
                        format!("{path}.uvs"),
                        format!("{} uvs for {} positions", t.len(), positions.len()),
                    ));
                }
                if let Some(i) = t.iter().position(|c| !c.iter().all(|x| x.is_finite())) {
                    return Err(SceneError::new(
                        format!("{path}.uvs[{i}]"),
                        "must be finite",
                    ));
                }
            }
            Ok(())
        }
        GeometryDesc::Obj { filename } | GeometryDesc::Ply { filename } => {
            super::files::check_relative(&format!("{path}.filename"), filename).map(|_| ())
        }
    }
}

fn validate_light(path: &str, l: &LightDesc) -> Result<()> {
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
            super::files::check_relative(&format!("{path}.filename"), filename)?;
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
