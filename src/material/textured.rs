//! Materials whose parameters vary over the surface. The integrators keep working on
//! plain [`Material`] values: at a hit, a textured material is resolved into one
//! whose parameters are the textures' values at the hit's (u, v), so every BSDF stays
//! a closed, texture-free enum in the hot loops and untextured scenes pay one branch.

use super::microfacet::Microfacet;
use super::texture::Texture;
use super::{Dielectric, Material};
use crate::math::{luminance, Rgb, Vec2};

/// Which parameter of a material a texture drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    Reflectance,
    DiffuseReflectance,
    SpecularReflectance,
    SpecularTransmittance,
    /// Roughness, both alphas (scalar: a colour texture's luminance, as Mitsuba's
    /// `eval_1`).
    Alpha,
    AlphaU,
    AlphaV,
    /// A blend's weight w of its second material (scalar, clamped to [0, 1]).
    Weight,
}

impl Slot {
    /// The slot of a scene-format field name (`MaterialDesc::params`).
    pub fn from_field(field: &str) -> Slot {
        match field {
            "reflectance" => Slot::Reflectance,
            "diffuse_reflectance" => Slot::DiffuseReflectance,
            "specular_reflectance" => Slot::SpecularReflectance,
            "specular_transmittance" => Slot::SpecularTransmittance,
            "alpha" => Slot::Alpha,
            "alpha_u" => Slot::AlphaU,
            "alpha_v" => Slot::AlphaV,
            "weight" => Slot::Weight,
            other => unreachable!("no texture slot for field {other}"),
        }
    }
}

/// The textures of one material, applied over its constant template: its own
/// parameters', and those of the materials it holds (a mixture's components, by
/// index), recursively.
#[derive(Clone, Debug, PartialEq)]
pub struct Textured {
    pub params: Vec<(Slot, Texture)>,
    pub nested: Vec<(usize, Textured)>,
}

impl Textured {
    /// `template` with each textured parameter set to its value at `uv`: the
    /// material at a hit.
    pub fn resolve(&self, template: &Material, uv: Vec2) -> Material {
        let mut m = template.clone();
        self.apply(&mut m, uv, true);
        m
    }

    /// `template` with its parameters at `uv`, still a template: a rough dielectric
    /// stays one whatever its roughness there, for `resolve` to set it again.
    pub fn template(&self, template: &Material, uv: Vec2) -> Material {
        let mut m = template.clone();
        self.apply(&mut m, uv, false);
        m
    }

    fn apply(&self, m: &mut Material, uv: Vec2, settle: bool) {
        for (slot, t) in &self.params {
            m.set(*slot, t.eval(uv));
        }
        if let Material::Mixture(mix) = m {
            for (k, t) in &self.nested {
                t.apply(&mut mix.components[*k], uv, settle);
            }
        }
        if settle {
            m.settle();
        }
    }
}

/// A scalar parameter's value from a texture's: a grey value itself, a colour's
/// luminance (Mitsuba's `eval_1`).
fn scalar(v: Rgb) -> f32 {
    if v.x == v.y && v.y == v.z {
        v.x
    } else {
        luminance(v)
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
            (Material::RoughDielectric(m), Slot::SpecularReflectance) => m.specular_reflectance = v,
            (Material::RoughDielectric(m), Slot::SpecularTransmittance) => {
                m.specular_transmittance = v
            }
            (Material::Conductor(m), slot @ (Slot::Alpha | Slot::AlphaU | Slot::AlphaV)) => {
                m.distribution = with_alpha(m.distribution, slot, scalar(v))
            }
            (Material::RoughDielectric(m), slot @ (Slot::Alpha | Slot::AlphaU | Slot::AlphaV)) => {
                m.distribution = with_alpha(m.distribution, slot, scalar(v))
            }
            (Material::Mixture(m), Slot::Weight) if m.weights.len() == 2 => {
                let w = scalar(v).clamp(0.0, 1.0);
                m.weights = vec![1.0 - w, w];
            }
            (m, slot) => unreachable!("{slot:?} on {m:?}"),
        }
    }

    /// After its parameters are set: a rough dielectric whose roughness came out
    /// smooth is the smooth interface, as a constant one is (`scene::shapes`).
    fn settle(&mut self) {
        if let Material::RoughDielectric(m) = self {
            if m.distribution.is_smooth() {
                *self = Material::Dielectric(Dielectric {
                    eta: m.eta,
                    specular_reflectance: m.specular_reflectance,
                    specular_transmittance: m.specular_transmittance,
                });
            }
        }
    }
}

/// `d` with the roughness of `slot` set to `a` (clamped as `Microfacet::new` does).
fn with_alpha(d: Microfacet, slot: Slot, a: f32) -> Microfacet {
    let (u, v) = match slot {
        Slot::Alpha => (a, a),
        Slot::AlphaU => (a, d.alpha_v),
        _ => (d.alpha_u, a),
    };
    Microfacet::new(d.kind, u, v)
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
