use crate::math::{reflect, Rgb, Vec2, Vec3, Vec3A};

use super::ggx::Ggx;
use super::{fresnel, BsdfSample};

/// Below this GGX alpha a conductor is treated as perfectly smooth (a delta lobe):
/// a narrower lobe only adds floating-point trouble.
const SMOOTH_ALPHA: f32 = 1e-3;

/// Metal: complex-IOR Fresnel, smooth or GGX-rough (Walter et al. 2007).
#[derive(Clone, Debug, PartialEq)]
pub struct Conductor {
    pub eta: Rgb,
    pub k: Rgb,
    /// GGX alpha.
    pub alpha: f32,
    pub specular_reflectance: Rgb,
    pub two_sided: bool,
}

impl Conductor {
    pub fn is_smooth(&self) -> bool {
        self.alpha < SMOOTH_ALPHA
    }

    fn ggx(&self) -> Ggx {
        Ggx { alpha: self.alpha }
    }

    pub fn normal_reflectance(&self) -> Rgb {
        fresnel::conductor(1.0, self.eta, self.k) * self.specular_reflectance
    }

    /// f cos_i = D G2 F / (4 cos_o).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if self.is_smooth() || wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let m = (wo + wi).normalize();
        let ggx = self.ggx();
        let f = fresnel::conductor(wo.dot(m), self.eta, self.k);
        f * self.specular_reflectance * (ggx.d(m) * ggx.g2(wo, wi) / (4.0 * wo.z))
    }

    /// Visible-normal density mapped through the reflection Jacobian 1 / (4 |wo.m|).
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_smooth() || wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let m = (wo + wi).normalize();
        let dot = wo.dot(m);
        if dot <= 0.0 {
            return 0.0;
        }
        self.ggx().pdf_visible(wo, m) / (4.0 * dot)
    }

    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        if self.is_smooth() {
            return Some(BsdfSample {
                wi: Vec3A::new(-wo.x, -wo.y, wo.z),
                weight: (fresnel::conductor(wo.z, self.eta, self.k) * self.specular_reflectance)
                    .into(),
                pdf: 1.0,
                delta: true,
            });
        }
        let ggx = self.ggx();
        let m = ggx.sample_visible(wo, u);
        let wi = reflect(wo, m);
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        if pdf <= 0.0 {
            return None;
        }
        // f cos / pdf simplifies to F G2 / G1(wo) (Heitz 2018, eq. 19).
        let f = fresnel::conductor(wo.dot(m), self.eta, self.k);
        let weight = f * self.specular_reflectance * (ggx.g2(wo, wi) / ggx.g1(wo));
        Some(BsdfSample {
            wi: wi.into(),
            weight: weight.into(),
            pdf,
            delta: false,
        })
    }
}
