//! Compiling material descriptions to the closed `Material` enum. A textured
//! parameter compiles to its constant template here; `textures` sets it per hit.
//! Imports only `format`.

use super::format::*;
use crate::material::microfacet::{Distribution, Microfacet};
use crate::material::{
    Coating, Conductor, Dielectric, Diffuse, Material, Mirror, Mixture, Phong, Plastic,
    RoughDielectric, RoughPlastic, ThinDielectric,
};
use crate::math::Rgb;

pub(super) fn rgb(v: V3) -> Rgb {
    Rgb::from(v)
}

/// A parameter's constant; a texture's value is set per hit (`Textured`), and its
/// template value here is overwritten at compile time.
fn constant(p: &Param) -> Rgb {
    p.constant().map_or(Rgb::ZERO, rgb)
}

pub(super) fn material(m: &MaterialDesc) -> Material {
    match m {
        MaterialDesc::Diffuse {
            reflectance,
            two_sided,
        } => Material::Diffuse(Diffuse {
            reflectance: constant(reflectance),
            two_sided: *two_sided,
        }),
        MaterialDesc::Phong {
            kd,
            ks,
            exponent,
            two_sided,
        } => Material::Phong(Phong::new(rgb(*kd), rgb(*ks), *exponent, *two_sided)),
        MaterialDesc::Mirror {
            reflectance,
            two_sided,
        } => Material::Mirror(Mirror {
            reflectance: constant(reflectance),
            two_sided: *two_sided,
        }),
        MaterialDesc::Dielectric {
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        } => Material::Dielectric(Dielectric {
            eta: int_ior / ext_ior,
            specular_reflectance: constant(specular_reflectance),
            specular_transmittance: constant(specular_transmittance),
        }),
        MaterialDesc::Conductor {
            eta,
            k,
            roughness,
            specular_reflectance,
            two_sided,
        } => Material::Conductor(Conductor {
            eta: rgb(*eta),
            k: rgb(*k),
            distribution: Microfacet::new(Distribution::Ggx, *roughness, *roughness),
            specular_reflectance: constant(specular_reflectance),
            two_sided: *two_sided,
        }),
        MaterialDesc::RoughConductor {
            distribution,
            alpha,
            alpha_u,
            alpha_v,
            eta,
            k,
            specular_reflectance,
            two_sided,
        } => Material::Conductor(Conductor {
            eta: rgb(*eta),
            k: rgb(*k),
            distribution: microfacet(*distribution, alpha, alpha_u, alpha_v),
            specular_reflectance: constant(specular_reflectance),
            two_sided: *two_sided,
        }),
        MaterialDesc::RoughDielectric {
            distribution,
            alpha,
            alpha_u,
            alpha_v,
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        } => {
            let distribution = microfacet(*distribution, alpha, alpha_u, alpha_v);
            let (eta, r, t) = (
                int_ior / ext_ior,
                constant(specular_reflectance),
                constant(specular_transmittance),
            );
            // Below the smooth threshold the lobes are Dirac deltas: the smooth
            // interface renders the same image without the lobes' float trouble. (A
            // textured roughness decides per hit: `Textured::resolve`.)
            let textured = [alpha, alpha_u, alpha_v]
                .iter()
                .any(|a| a.as_ref().is_some_and(|a| a.0.is_texture()));
            if distribution.is_smooth() && !textured {
                Material::Dielectric(Dielectric {
                    eta,
                    specular_reflectance: r,
                    specular_transmittance: t,
                })
            } else {
                Material::RoughDielectric(RoughDielectric {
                    eta,
                    distribution,
                    specular_reflectance: r,
                    specular_transmittance: t,
                })
            }
        }
        MaterialDesc::Plastic {
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            nonlinear,
            two_sided,
        } => Material::Plastic(Plastic {
            coating: Coating {
                diffuse_reflectance: constant(diffuse_reflectance),
                specular_reflectance: rgb(*specular_reflectance),
                eta: int_ior / ext_ior,
                nonlinear: *nonlinear,
            },
            two_sided: *two_sided,
        }),
        MaterialDesc::RoughPlastic {
            distribution,
            alpha,
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            nonlinear,
            two_sided,
        } => {
            let coating = Coating {
                diffuse_reflectance: constant(diffuse_reflectance),
                specular_reflectance: rgb(*specular_reflectance),
                eta: int_ior / ext_ior,
                nonlinear: *nonlinear,
            };
            let d = microfacet(*distribution, &Some(Scalar::value(*alpha)), &None, &None);
            if d.is_smooth() {
                Material::Plastic(Plastic {
                    coating,
                    two_sided: *two_sided,
                })
            } else {
                Material::RoughPlastic(RoughPlastic::new(coating, d, *two_sided))
            }
        }
        MaterialDesc::ThinDielectric {
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        } => Material::ThinDielectric(ThinDielectric {
            eta: int_ior / ext_ior,
            specular_reflectance: rgb(*specular_reflectance),
            specular_transmittance: rgb(*specular_transmittance),
        }),
        MaterialDesc::Null {} => Material::Null,
        MaterialDesc::Mask { material: m, .. }
        | MaterialDesc::NormalMap { material: m, .. }
        | MaterialDesc::BumpMap { material: m, .. } => material(m),
        MaterialDesc::Mixture { weights, materials } => {
            // Mitsuba 0.x divides weights that sum past 1 by their sum.
            let sum: f32 = weights.iter().sum();
            let scale = if sum > 1.0 { 1.0 / sum } else { 1.0 };
            mixture(materials, weights.iter().map(|w| w * scale).collect())
        }
        MaterialDesc::Blend { weight, materials } => {
            // A textured weight's template value is set per hit.
            let w = weight.constant().unwrap_or(0.5);
            mixture(materials, vec![1.0 - w, w])
        }
    }
}

fn mixture(materials: &[MaterialDesc], weights: Vec<f32>) -> Material {
    Material::Mixture(Box::new(Mixture {
        components: materials.iter().map(material).collect(),
        weights,
    }))
}

fn microfacet(
    d: DistributionDesc,
    alpha: &Option<Scalar>,
    alpha_u: &Option<Scalar>,
    alpha_v: &Option<Scalar>,
) -> Microfacet {
    let kind = match d {
        DistributionDesc::Beckmann => Distribution::Beckmann,
        DistributionDesc::Ggx => Distribution::Ggx,
    };
    let (au, av) = alphas(alpha, alpha_u, alpha_v);
    Microfacet::new(kind, au, av)
}
