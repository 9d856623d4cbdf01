use crate::math::{reflect, Rgb, Vec2, Vec3, Vec3A};

use super::microfacet::Microfacet;
use super::{fresnel, BsdfSample};

/// Metal: complex-IOR Fresnel, smooth or microfacet-rough (Mitsuba 3's `conductor` and
/// `roughconductor`; Walter et al. 2007 with visible-normal sampling).
#[derive(Clone, Debug, PartialEq)]
pub struct Conductor {
    pub eta: Rgb,
    pub k: Rgb,
    /// Smooth when both alphas are below `microfacet::SMOOTH_ALPHA`.
    pub distribution: Microfacet,
    pub specular_reflectance: Rgb,
    pub two_sided: bool,
}

impl Conductor {
    pub fn is_smooth(&self) -> bool {
        self.distribution.is_smooth()
    }

    pub fn normal_reflectance(&self) -> Rgb {
        fresnel::conductor(1.0, self.eta, self.k) * self.specular_reflectance
    }

    /// f cos_i = F D G / (4 cos_o).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if self.is_smooth() || wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let m = (wo + wi).normalize();
        let d = &self.distribution;
        let f = fresnel::conductor(wo.dot(m), self.eta, self.k);
        f * self.specular_reflectance * (d.d(m) * d.g(wo, wi, m) / (4.0 * wo.z))
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
        self.distribution.pdf_visible(wo, m) / (4.0 * dot)
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
        let d = &self.distribution;
        let m = d.sample_visible(wo, u);
        let wi = reflect(wo, m);
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        if pdf <= 0.0 {
            return None;
        }
        // f cos / pdf simplifies to F G1(wi) (Heitz 2018, eq. 19, separable G).
        let f = fresnel::conductor(wo.dot(m), self.eta, self.k);
        let weight = f * self.specular_reflectance * d.g1(wi, m);
        Some(BsdfSample {
            wi: wi.into(),
            weight: weight.into(),
            pdf,
            delta: false,
        })
    }
}
