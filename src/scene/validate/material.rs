//! Material checks: colours in range, interfaces with positive IORs, roughness
//! given one way only, nested materials. Imports `checks`.

use super::super::error::{Result, SceneError};
use super::super::format::*;
use super::checks::*;

pub(super) fn validate_material(path: &str, m: &MaterialDesc) -> Result<()> {
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
pub(super) fn perturbed(
    path: &str,
    m: &MaterialDesc,
    map: &Param,
    material: &MaterialDesc,
) -> Result<()> {
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
pub(super) fn components(path: &str, materials: &[MaterialDesc]) -> Result<()> {
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
pub(super) fn interface(
    path: &str,
    [int_ior, ext_ior]: [f32; 2],
    r: &Param,
    t: &Param,
) -> Result<()> {
    positive(&format!("{path}.int_ior"), int_ior)?;
    positive(&format!("{path}.ext_ior"), ext_ior)?;
    unit_param(&format!("{path}.specular_reflectance"), r)?;
    unit_param(&format!("{path}.specular_transmittance"), t)
}

/// A plastic's coating (IORs that differ, as Mitsuba requires) and base.
pub(super) fn coating(
    path: &str,
    [int_ior, ext_ior]: [f32; 2],
    diffuse: &Param,
    specular: V3,
) -> Result<()> {
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
pub(super) fn roughness(
    path: &str,
    a: &Option<Scalar>,
    u: &Option<Scalar>,
    v: &Option<Scalar>,
) -> Result<()> {
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
