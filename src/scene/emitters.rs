//! Area lights of emitting shapes: a constant radiance, or a texture over the shape's
//! (u, v) as Mitsuba 3's `area` emitter allows.

use super::error::{Result, SceneError};
use super::format::{EmissionDesc, Param};
use super::textures::Textures;
use crate::geometry::{Prim, TexCoords};
use crate::light::{AreaLight, Light};
use crate::math::Rgb;

/// Whether the shape's emission reads texture coordinates.
pub(super) fn reads_uv(emission: &Option<EmissionDesc>) -> bool {
    emission.as_ref().is_some_and(|e| e.radiance.is_texture())
}

/// The area light of shape `shape` (at `path`) with primitives `prims` and, when its
/// emission is textured, texture coordinates `uvs`; None when it does not emit.
pub(super) fn area_light(
    textures: &mut Textures,
    path: &str,
    shape: u32,
    common: &super::format::ShapeCommon,
    prims: Vec<Prim>,
    uvs: &Option<TexCoords>,
) -> Result<Option<Light>> {
    let Some(e) = &common.emission else {
        return Ok(None);
    };
    let light = |radiance: Rgb, prims| {
        AreaLight::new(shape, prims, common.flip_normals, radiance, e.two_sided)
    };
    if prims.is_empty() {
        return Ok(None);
    }
    let field = format!("{path}.emission.radiance");
    let texture = match &e.radiance {
        Param::Value(v) => {
            let on = v.iter().any(|&x| x > 0.0);
            return Ok(on.then(|| Light::Area(light(Rgb::from(*v), prims))));
        }
        Param::Texture(_) => textures.texture(&field, &e.radiance)?,
    };
    if let Some(c) = texture.constant() {
        let on = c.max_element() > 0.0;
        return Ok(on.then(|| Light::Area(light(c, prims))));
    }
    if !texture.is_valid_radiance() {
        return Err(SceneError::new(
            field,
            "the image holds NaN, infinite or negative values",
        ));
    }
    if texture.max_value() <= 0.0 {
        return Ok(None);
    }
    let uvs = uvs
        .clone()
        .expect("textured emitters get texture coordinates");
    Ok(Some(Light::Area(
        light(Rgb::ZERO, prims).with_texture(texture, uvs),
    )))
}
