//! The scene file format (JSON, `"format": 1`). These serde types are the contract with
//! users: every field is documented here and in README.md. Unknown fields are errors.

pub use super::param::{Param, Scalar, TextureDesc};
pub use crate::film::Filter;
pub use crate::light::LightSelection;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub type V3 = [f32; 3];

/// The whole scene file.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Format version; only 1 exists.
    pub format: u32,
    pub camera: CameraDesc,
    pub film: FilmDesc,
    /// Named materials, referred to by shapes.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialDesc>,
    /// Named participating media, referred to by shapes' `interior` / `exterior` and by
    /// the camera's `medium`.
    #[serde(default)]
    pub media: BTreeMap<String, MediumDesc>,
    #[serde(default)]
    pub shapes: Vec<ShapeDesc>,
    /// Lights that are not shapes (area lights are shapes with `emission`).
    #[serde(default)]
    pub lights: Vec<LightDesc>,
    /// How a light is picked for next-event estimation and emission sampling.
    #[serde(default)]
    pub light_selection: LightSelection,
    /// Default integrator settings (`{"algorithm": "pt", ...}`); requests may override.
    #[serde(default)]
    pub integrator: Option<serde_json::Value>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LookAt {
    pub origin: V3,
    pub target: V3,
    pub up: V3,
}

#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FovAxis {
    #[default]
    X,
    Y,
}

/// A pinhole camera, or a thin lens when `aperture_radius` > 0.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    #[serde(rename = "type", default = "default_camera_type")]
    pub kind: String,
    pub look_at: LookAt,
    /// Field of view in degrees across `fov_axis`.
    pub fov: f32,
    #[serde(default)]
    pub fov_axis: FovAxis,
    /// Thin-lens aperture radius in scene units (0 = pinhole).
    #[serde(default)]
    pub aperture_radius: f32,
    /// Distance to the plane in focus; defaults to |target - origin|.
    #[serde(default)]
    pub focus_distance: Option<f32>,
    /// Medium the camera sits in, if any.
    #[serde(default)]
    pub medium: Option<String>,
}

fn default_camera_type() -> String {
    "pinhole".into()
}

/// The pixel filter: a filter's name (`"box"`, one pixel wide, is the default; another
/// name takes its default parameters) or an object, `{"type": "gaussian", "stddev":
/// 0.25}`, with Mitsuba 3's parameters ([`Filter`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilterDesc(pub Filter);

impl Serialize for FilterDesc {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.0.is_pixel_box() {
            s.serialize_str("box")
        } else {
            self.0.serialize(s)
        }
    }
}

impl<'de> Deserialize<'de> for FilterDesc {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let v = match serde_json::Value::deserialize(d)? {
            serde_json::Value::String(name) => serde_json::json!({ "type": name }),
            v => v,
        };
        Filter::deserialize(v)
            .map(FilterDesc)
            .map_err(D::Error::custom)
    }
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FilmDesc {
    pub width: u32,
    pub height: u32,
    #[serde(default)]
    pub filter: FilterDesc,
}

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

    /// The parameters that may be textures, with their field names.
    pub fn params(&self) -> Vec<(&'static str, &Param)> {
        match self {
            MaterialDesc::Diffuse { reflectance, .. }
            | MaterialDesc::Mirror { reflectance, .. } => {
                vec![("reflectance", reflectance)]
            }
            MaterialDesc::Dielectric {
                specular_reflectance,
                specular_transmittance,
                ..
            } => vec![
                ("specular_reflectance", specular_reflectance),
                ("specular_transmittance", specular_transmittance),
            ],
            MaterialDesc::Conductor {
                specular_reflectance,
                ..
            } => vec![("specular_reflectance", specular_reflectance)],
            MaterialDesc::Plastic {
                diffuse_reflectance,
                ..
            }
            | MaterialDesc::RoughPlastic {
                diffuse_reflectance,
                ..
            } => vec![("diffuse_reflectance", diffuse_reflectance)],
            MaterialDesc::Mask { opacity, material } => {
                let mut v = material.params();
                v.push(("opacity", opacity));
                v
            }
            MaterialDesc::NormalMap {
                normalmap,
                material,
                ..
            } => {
                let mut v = material.params();
                v.push(("normalmap", normalmap));
                v
            }
            MaterialDesc::BumpMap {
                texture, material, ..
            } => {
                let mut v = material.params();
                v.push(("texture", texture));
                v
            }
            MaterialDesc::RoughConductor {
                alpha,
                alpha_u,
                alpha_v,
                specular_reflectance,
                ..
            } => {
                let mut v = vec![("specular_reflectance", specular_reflectance)];
                v.extend(roughness_params([alpha, alpha_u, alpha_v]));
                v
            }
            MaterialDesc::RoughDielectric {
                alpha,
                alpha_u,
                alpha_v,
                specular_reflectance,
                specular_transmittance,
                ..
            } => {
                let mut v = vec![
                    ("specular_reflectance", specular_reflectance),
                    ("specular_transmittance", specular_transmittance),
                ];
                v.extend(roughness_params([alpha, alpha_u, alpha_v]));
                v
            }
            // A mixture's own; its materials' are theirs (`components`).
            MaterialDesc::Blend { weight, .. } => vec![("weight", &weight.0)],
            _ => Vec::new(),
        }
    }

    /// [`params`](Self::params) and those of the materials inside (named
    /// `materials[k].field`), to rewrite the file names inside.
    pub fn params_mut(&mut self) -> Vec<(String, &mut Param)> {
        match self {
            MaterialDesc::Diffuse { reflectance, .. }
            | MaterialDesc::Mirror { reflectance, .. } => own(vec![("reflectance", reflectance)]),
            MaterialDesc::Dielectric {
                specular_reflectance,
                specular_transmittance,
                ..
            } => own(vec![
                ("specular_reflectance", specular_reflectance),
                ("specular_transmittance", specular_transmittance),
            ]),
            MaterialDesc::Conductor {
                specular_reflectance,
                ..
            } => own(vec![("specular_reflectance", specular_reflectance)]),
            MaterialDesc::Plastic {
                diffuse_reflectance,
                ..
            }
            | MaterialDesc::RoughPlastic {
                diffuse_reflectance,
                ..
            } => own(vec![("diffuse_reflectance", diffuse_reflectance)]),
            MaterialDesc::Mask { opacity, material } => {
                let mut v = material.params_mut();
                v.push(("opacity".to_string(), opacity));
                v
            }
            MaterialDesc::NormalMap {
                normalmap,
                material,
                ..
            } => {
                let mut v = material.params_mut();
                v.push(("normalmap".to_string(), normalmap));
                v
            }
            MaterialDesc::BumpMap {
                texture, material, ..
            } => {
                let mut v = material.params_mut();
                v.push(("texture".to_string(), texture));
                v
            }
            MaterialDesc::RoughConductor {
                alpha,
                alpha_u,
                alpha_v,
                specular_reflectance,
                ..
            } => {
                let mut v = vec![("specular_reflectance", specular_reflectance)];
                v.extend(roughness_params_mut([alpha, alpha_u, alpha_v]));
                own(v)
            }
            MaterialDesc::RoughDielectric {
                alpha,
                alpha_u,
                alpha_v,
                specular_reflectance,
                specular_transmittance,
                ..
            } => {
                let mut v = vec![
                    ("specular_reflectance", specular_reflectance),
                    ("specular_transmittance", specular_transmittance),
                ];
                v.extend(roughness_params_mut([alpha, alpha_u, alpha_v]));
                own(v)
            }
            MaterialDesc::Mixture { materials, .. } => nested_params_mut(materials),
            MaterialDesc::Blend { weight, materials } => {
                let mut v = vec![("weight".to_string(), &mut weight.0)];
                v.extend(nested_params_mut(materials));
                v
            }
            MaterialDesc::Phong { .. }
            | MaterialDesc::ThinDielectric { .. }
            | MaterialDesc::Null {} => Vec::new(),
        }
    }
}

const ALPHA_FIELDS: [&str; 3] = ["alpha", "alpha_u", "alpha_v"];

/// The roughness fields that are given, as parameters.
fn roughness_params(alphas: [&Option<Scalar>; 3]) -> impl Iterator<Item = (&'static str, &Param)> {
    (ALPHA_FIELDS.into_iter().zip(alphas)).filter_map(|(k, a)| a.as_ref().map(|a| (k, &a.0)))
}

fn roughness_params_mut(
    alphas: [&mut Option<Scalar>; 3],
) -> impl Iterator<Item = (&'static str, &mut Param)> {
    (ALPHA_FIELDS.into_iter().zip(alphas)).filter_map(|(k, a)| a.as_mut().map(|a| (k, &mut a.0)))
}

fn own<'a>(v: Vec<(&'static str, &'a mut Param)>) -> Vec<(String, &'a mut Param)> {
    v.into_iter().map(|(k, p)| (k.to_string(), p)).collect()
}

fn nested_params_mut(materials: &mut [MaterialDesc]) -> Vec<(String, &mut Param)> {
    let mut v = Vec::new();
    for (k, m) in materials.iter_mut().enumerate() {
        for (field, p) in m.params_mut() {
            v.push((format!("materials[{k}].{field}"), p));
        }
    }
    v
}

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
fn one3() -> V3 {
    [1.0; 3]
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

/// Participating media (per unit length of scene units). Shapes name them as
/// `interior` / `exterior`, the camera as `medium`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MediumDesc {
    /// Constant coefficients: `sigma_a` + `sigma_s`, or `sigma_t` + `albedo`.
    Homogeneous {
        #[serde(default)]
        sigma_a: Option<V3>,
        #[serde(default)]
        sigma_s: Option<V3>,
        #[serde(default)]
        sigma_t: Option<V3>,
        #[serde(default)]
        albedo: Option<V3>,
        /// Multiplies the coefficients (a unit change).
        #[serde(default = "one")]
        scale: f32,
        #[serde(default)]
        phase: PhaseDesc,
    },
    /// A voxel grid of density: sigma_t(x) = density(x) * sigma_t * scale, trilinear
    /// between voxel centres. `file` is a Mitsuba `.vol`, an OpenVDB `.vdb` (grid
    /// `grid`, default "density") or a `.json` header of a raw float32 file.
    Grid {
        file: String,
        #[serde(default)]
        grid: Option<String>,
        sigma_t: V3,
        #[serde(default = "one3")]
        albedo: V3,
        /// Optional grey albedo grid (same formats), multiplying `albedo`.
        #[serde(default)]
        albedo_file: Option<String>,
        #[serde(default = "one")]
        scale: f32,
        /// World box of the volume (or give `transform`; grids whose file has
        /// bounds may omit both).
        #[serde(default)]
        bounds: Option<BoundsDesc>,
        /// Maps the unit cube [0, 1]^3 to the world.
        #[serde(default)]
        transform: Option<TransformDesc>,
        #[serde(default)]
        phase: PhaseDesc,
    },
    /// Fractal Perlin noise: density = clamp((1/2 + v - threshold) / (1 - threshold),
    /// 0, 1), v the octave sum divided by the sum of octave amplitudes (|v| < ~0.6).
    Procedural {
        sigma_t: V3,
        #[serde(default = "one3")]
        albedo: V3,
        #[serde(default = "one")]
        scale: f32,
        #[serde(default = "default_octaves")]
        octaves: u32,
        #[serde(default = "two")]
        lacunarity: f32,
        #[serde(default = "half")]
        gain: f32,
        /// Cycles of the first octave across the volume.
        #[serde(default = "four")]
        frequency: f32,
        #[serde(default)]
        seed: u64,
        #[serde(default)]
        threshold: f32,
        /// World box of the volume (or give `transform`; grids whose file has
        /// bounds may omit both).
        #[serde(default)]
        bounds: Option<BoundsDesc>,
        /// Maps the unit cube [0, 1]^3 to the world.
        #[serde(default)]
        transform: Option<TransformDesc>,
        #[serde(default)]
        phase: PhaseDesc,
    },
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BoundsDesc {
    pub min: V3,
    pub max: V3,
}

/// Phase functions; isotropic by default.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum PhaseDesc {
    #[default]
    Isotropic,
    /// Henyey-Greenstein with asymmetry g in (-1, 1) (g > 0 scatters forward).
    #[serde(alias = "hg")]
    HenyeyGreenstein {
        g: f32,
    },
    /// Schlick's approximation with k in (-1, 1) (k ~ 1.55 g - 0.55 g^3).
    Schlick {
        k: f32,
    },
    Rayleigh,
}

fn default_octaves() -> u32 {
    4
}
fn two() -> f32 {
    2.0
}
fn half() -> f32 {
    0.5
}
fn four() -> f32 {
    4.0
}

fn one() -> f32 {
    1.0
}

/// A rotation: `axis` and `angle` in degrees (right-handed).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Rotation {
    pub axis: V3,
    pub angle: f32,
}

/// Either a row-major 4x4 `matrix`, or `translate * rotate[0] * rotate[1] ... * scale`.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TransformDesc {
    #[serde(default)]
    pub matrix: Option<[f32; 16]>,
    #[serde(default)]
    pub translate: Option<V3>,
    /// Applied right to left, like matrices: the last rotation acts first.
    #[serde(default)]
    pub rotate: Vec<Rotation>,
    /// A number (uniform) or three numbers.
    #[serde(default)]
    pub scale: Option<Scale>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum Scale {
    Uniform(f32),
    PerAxis(V3),
}

/// Area emission of a shape: Lambertian, on the side its normal points to.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EmissionDesc {
    /// A colour, or a texture over the shape's (u, v) (Mitsuba's textured `area`).
    pub radiance: Param,
    #[serde(default)]
    pub two_sided: bool,
}

/// A shape: its geometry (tagged by `type`) and the fields every shape has.
/// Deserialised by hand because serde cannot combine `flatten` with
/// `deny_unknown_fields`, and a misspelt field must be an error.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ShapeDesc {
    #[serde(flatten)]
    pub geometry: GeometryDesc,
    #[serde(flatten)]
    pub common: ShapeCommon,
}

/// Fields every shape has.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ShapeCommon {
    /// Name of a material in `materials`.
    pub material: String,
    #[serde(default)]
    pub transform: Option<TransformDesc>,
    #[serde(default)]
    pub emission: Option<EmissionDesc>,
    /// Reverses the normals (and so the emitting / front side).
    #[serde(default)]
    pub flip_normals: bool,
    /// Medium on the side opposite the normal.
    #[serde(default)]
    pub interior: Option<String>,
    /// Medium on the side the normal points to.
    #[serde(default)]
    pub exterior: Option<String>,
    /// Optional label for error messages and statistics.
    #[serde(default)]
    pub name: Option<String>,
}

const COMMON_SHAPE_FIELDS: [&str; 7] = [
    "material",
    "transform",
    "emission",
    "flip_normals",
    "interior",
    "exterior",
    "name",
];

impl<'de> Deserialize<'de> for ShapeDesc {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let mut geometry = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
        let mut common = serde_json::Map::new();
        for key in COMMON_SHAPE_FIELDS {
            if let Some(v) = geometry.remove(key) {
                common.insert(key.to_string(), v);
            }
        }
        let common = ShapeCommon::deserialize(serde_json::Value::Object(common))
            .map_err(D::Error::custom)?;
        let geometry = GeometryDesc::deserialize(serde_json::Value::Object(geometry))
            .map_err(D::Error::custom)?;
        Ok(ShapeDesc { geometry, common })
    }
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum GeometryDesc {
    /// Analytic sphere (not tessellated). A transform may only translate, rotate and
    /// scale uniformly.
    Sphere {
        #[serde(default)]
        center: V3,
        #[serde(default = "one")]
        radius: f32,
    },
    /// A quad. With `corners` (counter-clockwise seen from the front), the quad is
    /// exactly those four points; without, it is [-1,1]^2 at z = 0 facing +z.
    Rectangle {
        #[serde(default)]
        corners: Option<[V3; 4]>,
    },
    /// [-1,1]^3 with outward normals. (Struct variants with no fields, so that serde
    /// refuses unknown fields on them too.)
    Cube {},
    /// Unit disk at z = 0 facing +z (analytic, not tessellated).
    Disk {},
    /// Inline triangle mesh.
    Mesh {
        positions: Vec<V3>,
        /// Triangles as vertex index triples, counter-clockwise = front.
        indices: Vec<[u32; 3]>,
        #[serde(default)]
        normals: Option<Vec<V3>>,
        /// Texture coordinates per vertex, Mitsuba's convention (v grows downwards
        /// in the image).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        uvs: Option<Vec<[f32; 2]>>,
    },
    /// Wavefront OBJ file, relative to the scene file.
    Obj { filename: String },
    /// PLY file (ASCII or binary), relative to the scene file.
    Ply { filename: String },
}

/// Lights that are not shapes.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum LightDesc {
    /// Isotropic point light; `intensity` in W/sr per channel.
    Point { position: V3, intensity: V3 },
    /// Spot light with Mitsuba's falloff: full intensity inside `beam_width`, falling
    /// linearly in angle to zero at `cutoff_angle` (degrees, half-angles).
    Spot {
        position: V3,
        target: V3,
        intensity: V3,
        #[serde(default = "default_cutoff")]
        cutoff_angle: f32,
        /// Defaults to 3/4 of the cutoff angle.
        #[serde(default)]
        beam_width: Option<f32>,
    },
    /// Distant light: photons travel along `direction`; `irradiance` on a surface
    /// facing it.
    Directional { direction: V3, irradiance: V3 },
    /// Uniform radiance from every direction at infinity.
    Constant { radiance: V3 },
    /// Lat-long environment map from an EXR file, importance sampled. With the identity
    /// transform, +y is up and the image centre looks along -z.
    Envmap {
        filename: String,
        #[serde(default = "one")]
        scale: f32,
        #[serde(default)]
        transform: Option<TransformDesc>,
    },
}

fn default_cutoff() -> f32 {
    20.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_round_trip_through_json() {
        let text = r#"{"type":"sphere","center":[1,2,3],"radius":0.5,"material":"m",
            "emission":{"radiance":[1,1,1]},"interior":"fog"}"#;
        let s: ShapeDesc = serde_json::from_str(text).unwrap();
        let back: ShapeDesc = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        assert_eq!(s, back);
    }
}
