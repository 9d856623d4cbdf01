//! Materials whose parameters vary over the surface. The integrators keep working on
//! plain [`Material`] values: at a hit, a textured material is resolved into one
//! whose parameters are the textures' values at the hit's (u, v), so every BSDF stays
//! a closed, texture-free enum in the hot loops and untextured scenes pay one branch.

use super::texture::Texture;
use super::Material;
use crate::math::{Rgb, Vec2};

/// Which parameter of a material a texture drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    Reflectance,
    DiffuseReflectance,
    SpecularReflectance,
    SpecularTransmittance,
}

impl Slot {
    /// The slot of a scene-format field name (`MaterialDesc::params`).
    pub fn from_field(field: &str) -> Slot {
        match field {
            "reflectance" => Slot::Reflectance,
            "diffuse_reflectance" => Slot::DiffuseReflectance,
            "specular_reflectance" => Slot::SpecularReflectance,
            "specular_transmittance" => Slot::SpecularTransmittance,
            other => unreachable!("no texture slot for field {other}"),
        }
    }
}

/// The textures of one material, applied over its constant template.
#[derive(Clone, Debug, PartialEq)]
pub struct Textured {
    pub params: Vec<(Slot, Texture)>,
}

impl Textured {
    /// `template` with each textured parameter set to its value at `uv`.
    pub fn resolve(&self, template: &Material, uv: Vec2) -> Material {
        let mut m = template.clone();
        for (slot, t) in &self.params {
            m.set(*slot, t.eval(uv));
        }
        m
    }
}

impl Material {
    /// Sets one parameter (a slot the material does not have is a compile-time bug:
    /// `Slot::from_field` only names fields of the material's own description).
    fn set(&mut self, slot: Slot, v: Rgb) {
        match (self, slot) {
            (Material::Diffuse(m), Slot::Reflectance) => m.reflectance = v,
            (Material::Mirror(m), Slot::Reflectance) => m.reflectance = v,
            (Material::Dielectric(m), Slot::SpecularReflectance) => m.specular_reflectance = v,
            (Material::Dielectric(m), Slot::SpecularTransmittance) => m.specular_transmittance = v,
            (Material::Conductor(m), Slot::SpecularReflectance) => m.specular_reflectance = v,
            (Material::Plastic(m), Slot::DiffuseReflectance) => m.coating.diffuse_reflectance = v,
            (Material::RoughPlastic(m), Slot::DiffuseReflectance) => {
                m.coating.diffuse_reflectance = v
            }
            (m, slot) => unreachable!("{slot:?} on {m:?}"),
        }
    }
}

/// The material at a hit: the scene's own, or one resolved from its textures. Two
/// words, so untextured scenes move a pointer around as before (a `Cow` of a whole
/// material cost 17 % of `pt`'s time on the Cornell box, moving the value through
/// every bounce); textured hits pay one allocation.
pub enum MaterialRef<'a> {
    Plain(&'a Material),
    Textured(Box<Material>),
}

impl std::ops::Deref for MaterialRef<'_> {
    type Target = Material;

    #[inline(always)]
    fn deref(&self) -> &Material {
        match self {
            MaterialRef::Plain(m) => m,
            MaterialRef::Textured(m) => m,
        }
    }
}
