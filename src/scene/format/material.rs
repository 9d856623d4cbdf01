//! Material descriptions: the BSDFs a scene file names, with Mitsuba 3's parameters
//! and defaults, and the parameters of each that may be textures. Imports `param`.

use super::param::{Param, Scalar};
use super::{one, one3, V3};
use serde::{Deserialize, Serialize};

/// Surface scattering models. Reflectances are linear RGB in [0, 1].
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MaterialDesc {
    /// Lambertian: reflectance / pi, one-sided unless `two_sided`.
    Diffuse {
        reflectance: Param,
        #[serde(default)]
        two_sided: bool,
    },
    /// Energy-normalised modified Phong (Lafortune and Willems 1994):
    /// kd / pi + ks (n + 2) / (2 pi) cos^n(alpha). kd + ks must not exceed 1 per channel.
    Phong {
        #[serde(default)]
        kd: V3,
        ks: V3,
        exponent: f32,
        #[serde(default)]
        two_sided: bool,
    },
    /// Perfect specular reflection.
    Mirror {
        #[serde(default = "one_param")]
        reflectance: Param,
        #[serde(default)]
        two_sided: bool,
    },
    /// Smooth dielectric interface with exact Fresnel; `int_ior` is on the side opposite
    /// the normal.
    Dielectric {
        #[serde(default = "default_int_ior")]
        int_ior: f32,
        #[serde(default = "default_ext_ior")]
        ext_ior: f32,
        #[serde(default = "one_param")]
        specular_reflectance: Param,
        #[serde(default = "one_param")]
        specular_transmittance: Param,
    },
    /// Metal with complex IOR (eta, k) and GGX roughness `alpha` (0 = smooth).
    Conductor {
        #[serde(default = "gold_eta")]
        eta: V3,
        #[serde(default = "gold_k")]
        k: V3,
        #[serde(default)]
        roughness: f32,
        #[serde(default = "one_param")]
        specular_reflectance: Param,
        #[serde(default)]
        two_sided: bool,
    },
    /// Rough metal, as Mitsuba 3's `roughconductor`: a microfacet `distribution`
    /// (`beckmann` or `ggx`) of roughness `alpha`, or `alpha_u` and `alpha_v` (along
    /// the shading frame's two tangents) for an anisotropic one. `eta` and `k` default
    /// to Mitsuba's material "none", a perfect reflector (eta 0, k 1). The alphas and
    /// `specular_reflectance` may be textures, as in Mitsuba 3.
    #[serde(rename = "roughconductor")]
    RoughConductor {
        #[serde(default)]
        distribution: DistributionDesc,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha: Option<Scalar>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha_u: Option<Scalar>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha_v: Option<Scalar>,
        #[serde(default)]
        eta: V3,
        #[serde(default = "one3")]
        k: V3,
        #[serde(default = "one_param")]
        specular_reflectance: Param,
        #[serde(default)]
        two_sided: bool,
    },
    /// Rough dielectric interface, as Mitsuba 3's `roughdielectric` (Walter et al.
    /// 2007): the roughness parameters of `roughconductor`, the IORs of `dielectric`.
    /// The alphas and both colours may be textures, as in Mitsuba 3.
    #[serde(rename = "roughdielectric")]
    RoughDielectric {
        #[serde(default)]
        distribution: DistributionDesc,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha: Option<Scalar>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha_u: Option<Scalar>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        alpha_v: Option<Scalar>,
        #[serde(default = "default_int_ior")]
        int_ior: f32,
        #[serde(default = "default_ext_ior")]
        ext_ior: f32,
        #[serde(default = "one_param")]
        specular_reflectance: Param,
        #[serde(default = "one_param")]
        specular_transmittance: Param,
    },
    /// Smooth plastic, as Mitsuba 3's `plastic`: a dielectric coating (`int_ior`,
    /// default polypropylene 1.49, over `ext_ior`) on a Lambertian base of
    /// `diffuse_reflectance`, with the internal reflections of the coating's underside;
    /// `nonlinear` lets the base's colour tint them too. One-sided unless `two_sided`.
    Plastic {
        #[serde(default = "half_param")]
        diffuse_reflectance: Param,
        #[serde(default = "one3")]
        specular_reflectance: V3,
        #[serde(default = "default_plastic_ior")]
        int_ior: f32,
        #[serde(default = "default_ext_ior")]
        ext_ior: f32,
        #[serde(default)]
        nonlinear: bool,
        #[serde(default)]
        two_sided: bool,
    },
    /// Rough plastic, as Mitsuba 3's `roughplastic`: `plastic` with a rough coating of
    /// isotropic roughness `alpha` (default 0.1) and `distribution` (default
    /// `beckmann`).
    #[serde(rename = "roughplastic")]
    RoughPlastic {
        #[serde(default)]
        distribution: DistributionDesc,
        #[serde(default = "default_alpha")]
        alpha: f32,
        #[serde(default = "half_param")]
        diffuse_reflectance: Param,
        #[serde(default = "one3")]
        specular_reflectance: V3,
        #[serde(default = "default_plastic_ior")]
        int_ior: f32,
        #[serde(default = "default_ext_ior")]
        ext_ior: f32,
        #[serde(default)]
        nonlinear: bool,
        #[serde(default)]
        two_sided: bool,
    },
    /// Thin dielectric sheet, as Mitsuba 3's `thindielectric`: reflects with the
    /// reflectance of both faces and their inter-reflections, transmits without bending.
    #[serde(rename = "thindielectric")]
    ThinDielectric {
        #[serde(default = "default_int_ior")]
        int_ior: f32,
        #[serde(default = "default_ext_ior")]
        ext_ior: f32,
        #[serde(default = "one3")]
        specular_reflectance: V3,
        #[serde(default = "one3")]
        specular_transmittance: V3,
    },
    /// Index-matched boundary: rays pass straight through; only the medium changes.
    Null {},
    /// A cut-out (Mitsuba's `mask`): `material` where the surface is opaque, a hole
    /// elsewhere; `opacity` (a grey value or texture in [0, 1]) is the probability
    /// that a ray, a shadow ray or a light path stops at the surface.
    Mask {
        opacity: Param,
        material: Box<MaterialDesc>,
    },
    /// A weighted sum of `materials`, as Mitsuba 0.x's `mixturebsdf`: f = sum_k
    /// `weights[k]` f_k, one weight per material, each >= 0; weights summing past 1
    /// are divided by their sum (as Mitsuba does), below 1 the rest is absorbed.
    /// Sampling picks a material in proportion to its weight.
    Mixture {
        weights: Vec<f32>,
        materials: Vec<MaterialDesc>,
    },
    /// Mitsuba 3's `blendbsdf`: (1 - `weight`) times the first of two `materials`
    /// plus `weight` times the second. `weight` (default 0.5) is a number or a
    /// texture (a colour texture counts by its luminance), clamped to [0, 1].
    Blend {
        #[serde(default = "half_scalar")]
        weight: Scalar,
        materials: Vec<MaterialDesc>,
    },
    /// Mitsuba 3's `normalmap`: `material` shaded with the normal 2 rgb - 1 read from
    /// `normalmap`, in the shading frame (x along dp/du, z the unperturbed normal).
    /// Images are sRGB-decoded unless `raw`, as in Mitsuba, whose documentation asks
    /// for `raw: true`. An invalid normal (one the incoming direction sees from behind)
    /// is mirrored about the unperturbed normal and the result attenuated by Estevez et
    /// al.'s shadowing term, unless these are turned off, as in Mitsuba.
    #[serde(rename = "normalmap")]
    NormalMap {
        normalmap: Param,
        material: Box<MaterialDesc>,
        #[serde(default = "yes")]
        flip_invalid_normals: bool,
        #[serde(default = "yes")]
        use_shadowing_function: bool,
    },
    /// Mitsuba 3's `bumpmap`: `material` on the surface displaced along its normal by
    /// `scale` times `texture` (its luminance), in units where (u, v) span [0, 1]; the
    /// options of `normalmap`.
    #[serde(rename = "bumpmap")]
    BumpMap {
        texture: Param,
        #[serde(default = "one")]
        scale: f32,
        material: Box<MaterialDesc>,
        #[serde(default = "yes")]
        flip_invalid_normals: bool,
        #[serde(default = "yes")]
        use_shadowing_function: bool,
    },
}

fn yes() -> bool {
    true
}

/// Microfacet distribution of the rough materials (Mitsuba 3's default: Beckmann).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum DistributionDesc {
    #[default]
    Beckmann,
    Ggx,
}

/// Mitsuba 3's default roughness of the rough materials.
pub const DEFAULT_ALPHA: f32 = 0.1;

/// The (alpha_u, alpha_v) a rough material's `alpha`, `alpha_u` and `alpha_v` give
/// (after validation: `alpha` alone, both of the others, or none). A texture counts
/// as 0 here: its value is set per hit.
pub fn alphas(
    alpha: &Option<Scalar>,
    alpha_u: &Option<Scalar>,
    alpha_v: &Option<Scalar>,
) -> (f32, f32) {
    let c = |a: &Option<Scalar>| a.as_ref().map(|s| s.constant().unwrap_or(0.0));
    alphas_of(c(alpha), c(alpha_u), c(alpha_v))
}

fn alphas_of(alpha: Option<f32>, alpha_u: Option<f32>, alpha_v: Option<f32>) -> (f32, f32) {
    match (alpha, alpha_u, alpha_v) {
        (_, Some(u), Some(v)) => (u, v),
        (a, _, _) => {
            let a = a.unwrap_or(DEFAULT_ALPHA);
            (a, a)
        }
    }
}

/// A material's own parameters that may be textures (field, parameter), the one
/// material a mask or a map holds, and the materials a mixture or a blend holds:
/// written once for [`MaterialDesc::params`] and, with `mut`, for
/// [`MaterialDesc::params_mut`] (the same match, borrowing mutably).
macro_rules! own_params {
    ($m:expr $(, $mut:tt)?) => {{
        let mut own: Vec<(&'static str, &$($mut)? Param)> = Vec::new();
        let mut nested = None;
        let mut rough = None;
        let mut components: &$($mut)? [MaterialDesc] = &$($mut)? [];
        match $m {
            MaterialDesc::Diffuse { reflectance, .. }
            | MaterialDesc::Mirror { reflectance, .. } => own.push(("reflectance", reflectance)),
            MaterialDesc::Dielectric {
                specular_reflectance,
                specular_transmittance,
                ..
            } => {
                own.push(("specular_reflectance", specular_reflectance));
                own.push(("specular_transmittance", specular_transmittance));
            }
            MaterialDesc::Conductor {
                specular_reflectance,
                ..
            } => own.push(("specular_reflectance", specular_reflectance)),
            MaterialDesc::RoughConductor {
                alpha,
                alpha_u,
                alpha_v,
                specular_reflectance,
                ..
            } => {
                own.push(("specular_reflectance", specular_reflectance));
                rough = Some([alpha, alpha_u, alpha_v]);
            }
            MaterialDesc::RoughDielectric {
                alpha,
                alpha_u,
                alpha_v,
                specular_reflectance,
                specular_transmittance,
                ..
            } => {
                own.push(("specular_reflectance", specular_reflectance));
                own.push(("specular_transmittance", specular_transmittance));
                rough = Some([alpha, alpha_u, alpha_v]);
            }
            MaterialDesc::Plastic {
                diffuse_reflectance,
                ..
            }
            | MaterialDesc::RoughPlastic {
                diffuse_reflectance,
                ..
            } => own.push(("diffuse_reflectance", diffuse_reflectance)),
            MaterialDesc::Mask { opacity, material } => {
                own.push(("opacity", opacity));
                nested = Some(material);
            }
            MaterialDesc::NormalMap {
                normalmap,
                material,
                ..
            } => {
                own.push(("normalmap", normalmap));
                nested = Some(material);
            }
            MaterialDesc::BumpMap {
                texture, material, ..
            } => {
                own.push(("texture", texture));
                nested = Some(material);
            }
            MaterialDesc::Blend { weight, materials } => {
                own.push(("weight", &$($mut)? weight.0));
                components = &$($mut)? materials[..];
            }
            MaterialDesc::Mixture { materials, .. } => components = &$($mut)? materials[..],
            MaterialDesc::Phong { .. }
            | MaterialDesc::ThinDielectric { .. }
            | MaterialDesc::Null {} => {}
        }
        // The roughness fields that are given come last.
        for (k, a) in ALPHA_FIELDS.into_iter().zip(rough.into_iter().flatten()) {
            if let Some(a) = a {
                own.push((k, &$($mut)? a.0));
            }
        }
        (own, nested, components)
    }};
}

impl MaterialDesc {
    /// Whether the material reads a texture, so that its shapes need (u, v).
    pub fn reads_uv(&self) -> bool {
        match self {
            MaterialDesc::Mask { opacity, material } => opacity.is_texture() || material.reads_uv(),
            // Perturbed normals need (u, v) and dp/du, whatever the map is.
            MaterialDesc::NormalMap { .. } | MaterialDesc::BumpMap { .. } => true,
            _ => {
                self.params().iter().any(|(_, p)| p.is_texture())
                    || self.components().iter().any(MaterialDesc::reads_uv)
            }
        }
    }

    /// The materials a mixture or blend holds (none for others).
    pub fn components(&self) -> &[MaterialDesc] {
        match self {
            MaterialDesc::Mixture { materials, .. } | MaterialDesc::Blend { materials, .. } => {
                materials
            }
            _ => &[],
        }
    }

    /// The material that scatters: a mask's or a normal map's nested one, or the
    /// material itself.
    pub fn scattering(&self) -> &MaterialDesc {
        match self {
            MaterialDesc::Mask { material, .. }
            | MaterialDesc::NormalMap { material, .. }
            | MaterialDesc::BumpMap { material, .. } => material.scattering(),
            other => other,
        }
    }

    /// The parameters that may be textures, with their field names: a mask's or a
    /// map's nested material's first; none of a mixture's or a blend's materials
    /// (`components`).
    pub fn params(&self) -> Vec<(&'static str, &Param)> {
        let (own, nested, _) = own_params!(self);
        let mut v = nested.map(|m| m.params()).unwrap_or_default();
        v.extend(own);
        v
    }

    /// [`params`](Self::params) and those of the materials inside (named
    /// `materials[k].field`), to rewrite the file names inside.
    pub fn params_mut(&mut self) -> Vec<(String, &mut Param)> {
        let (own, nested, components) = own_params!(self, mut);
        let mut v = nested.map(|m| m.params_mut()).unwrap_or_default();
        v.extend(own.into_iter().map(|(k, p)| (k.to_string(), p)));
        for (k, m) in components.iter_mut().enumerate() {
            for (field, p) in m.params_mut() {
                v.push((format!("materials[{k}].{field}"), p));
            }
        }
        v
    }
}

const ALPHA_FIELDS: [&str; 3] = ["alpha", "alpha_u", "alpha_v"];

fn half_scalar() -> Scalar {
    Scalar::value(0.5)
}
fn default_alpha() -> f32 {
    DEFAULT_ALPHA
}
/// Polypropylene, Mitsuba 3's default interior of its plastics.
fn default_plastic_ior() -> f32 {
    1.49
}
fn half_param() -> Param {
    Param::grey(0.5)
}
fn one_param() -> Param {
    Param::grey(1.0)
}
fn default_int_ior() -> f32 {
    1.5046
}
fn default_ext_ior() -> f32 {
    1.000277
}
// Gold at roughly 650/550/450 nm, as the default conductor in Mitsuba is gold-like.
fn gold_eta() -> V3 {
    [0.143, 0.374, 1.442]
}
fn gold_k() -> V3 {
    [3.983, 2.385, 1.603]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn material(json: &str) -> MaterialDesc {
        serde_json::from_str(json).unwrap()
    }

    fn names(m: &MaterialDesc) -> Vec<&'static str> {
        m.params().into_iter().map(|(k, _)| k).collect()
    }

    fn names_mut(m: &mut MaterialDesc) -> Vec<String> {
        m.params_mut().into_iter().map(|(k, _)| k).collect()
    }

    #[test]
    fn params_list_nested_first_and_roughness_last() {
        let mut rough = material(
            r#"{"type": "roughdielectric", "alpha_u": 0.1, "alpha_v": 0.2,
                "specular_transmittance": [1, 1, 1]}"#,
        );
        let want = [
            "specular_reflectance",
            "specular_transmittance",
            "alpha_u",
            "alpha_v",
        ];
        assert_eq!(names(&rough), want);
        assert_eq!(names_mut(&mut rough), want);
        let mut mask = material(
            r#"{"type": "mask", "opacity": 0.5,
                "material": {"type": "roughconductor", "alpha": 0.3}}"#,
        );
        let want = ["specular_reflectance", "alpha", "opacity"];
        assert_eq!(names(&mask), want);
        assert_eq!(names_mut(&mut mask), want);
    }

    #[test]
    fn only_params_mut_reaches_into_mixtures_and_blends() {
        let mut blend = material(
            r#"{"type": "blend", "weight": 0.25, "materials": [
                {"type": "diffuse", "reflectance": 0.5},
                {"type": "mixture", "weights": [1], "materials": [
                    {"type": "plastic"}]}]}"#,
        );
        assert_eq!(names(&blend), ["weight"]);
        assert_eq!(
            names_mut(&mut blend),
            [
                "weight",
                "materials[0].reflectance",
                "materials[1].materials[0].diffuse_reflectance"
            ]
        );
        let mut phong = material(r#"{"type": "phong", "ks": [0.1, 0.1, 0.1], "exponent": 2}"#);
        assert!(names(&phong).is_empty() && names_mut(&mut phong).is_empty());
    }
}
