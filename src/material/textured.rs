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

/// The material at a hit: the scene's own, or one resolved from its textures. A
/// pointer to the material and the box that owns a resolved one: untextured scenes
/// move two words around and read through the pointer without a branch (a `Cow` of
/// the whole material cost `pt` 17 % on the Cornell box, and an enum of a reference
/// or a box still cost `bpt` 10 % more instructions, in the branch of every access);
/// textured hits pay one allocation.
pub struct MaterialRef<'a> {
    ptr: std::ptr::NonNull<Material>,
    _owned: Option<Box<Material>>,
    _scene: std::marker::PhantomData<&'a Material>,
}

impl<'a> MaterialRef<'a> {
    #[inline(always)]
    pub fn plain(m: &'a Material) -> Self {
        MaterialRef {
            ptr: std::ptr::NonNull::from(m),
            _owned: None,
            _scene: std::marker::PhantomData,
        }
    }

    pub fn owned(m: Material) -> Self {
        let b = Box::new(m);
        MaterialRef {
            ptr: std::ptr::NonNull::from(&*b),
            _owned: Some(b),
            _scene: std::marker::PhantomData,
        }
    }
}

impl std::ops::Deref for MaterialRef<'_> {
    type Target = Material;

    #[inline(always)]
    fn deref(&self) -> &Material {
        // SAFETY: `ptr` points either at a material borrowed for 'a or into `_owned`,
        // a heap allocation that this value keeps alive and never mutates (moving the
        // box moves the pointer to it, not the material).
        unsafe { self.ptr.as_ref() }
    }
}

// SAFETY: a shared reference to a material or an owned box of one, both of which are
// Send and Sync.
unsafe impl Send for MaterialRef<'_> {}
unsafe impl Sync for MaterialRef<'_> {}
