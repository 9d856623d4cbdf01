use std::sync::Arc;

use crate::math::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::math::{reflect, Rgb, Vec2, Vec3, INV_PI};

use super::coating::Coating;
use super::microfacet::{albedo, Microfacet};
use super::{fresnel, BsdfSample};

/// Entries of the table of the coating's transmittance, at cos theta = i / (N - 1).
const TABLE: usize = 64;

/// Rough plastic, as Mitsuba 3's `roughplastic`: a microfacet reflection off the
/// coating, F D G / (4 cos_o) (Walter et al. 2007), plus a diffuse lobe for the light
/// the rough coating transmits both ways,
/// f cos_i = base T(cos_o) T(cos_i) cos_i / (pi eta^2),
/// with T the coating's directional transmittance and base = rho / (1 - R_int) (or its
/// `nonlinear` form), R_int the cosine-weighted internal reflectance. Mitsuba tabulates
/// T on 64 cosines and R_int as twice the mean of R(mu) mu over them; so does this.
/// One-sided; isotropic roughness only, as in Mitsuba.
#[derive(Clone, Debug, PartialEq)]
pub struct RoughPlastic {
    pub coating: Coating,
    pub distribution: Microfacet,
    pub two_sided: bool,
    /// T at cos theta = i / 63, shared by the copies of one material.
    transmittance: Arc<[f32; TABLE]>,
    /// R_int.
    internal: f32,
}

impl RoughPlastic {
    pub fn new(coating: Coating, distribution: Microfacet, two_sided: bool) -> Self {
        let eta = coating.eta;
        let dir = |i: usize| {
            let mu = (i as f32 / (TABLE - 1) as f32).max(1e-6);
            Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu)
        };
        let t: [f32; TABLE] =
            std::array::from_fn(|i| albedo::transmittance(&distribution, dir(i), eta));
        let internal = 2.0
            * (0..TABLE)
                .map(|i| albedo::reflectance(&distribution, dir(i), 1.0 / eta) * dir(i).z)
                .sum::<f32>()
            / TABLE as f32;
        RoughPlastic {
            coating,
            distribution,
            two_sided,
            transmittance: Arc::new(t),
            internal,
        }
    }

    /// T(cos), linearly interpolated in the table.
    #[inline]
    fn t(&self, cos: f32) -> f32 {
        let x = cos.clamp(0.0, 1.0) * (TABLE - 1) as f32;
        let i = (x as usize).min(TABLE - 2);
        let t = &self.transmittance;
        t[i] + (t[i + 1] - t[i]) * (x - i as f32)
    }

    #[inline(never)]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.eval_upper(wo, wi).0
    }

    /// The specular lobe's visible-normal density through the reflection Jacobian,
    /// mixed with the cosine lobe by the coating's lobe probabilities.
    #[inline(never)]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let m = (wo + wi).normalize();
        let d = &self.distribution;
        self.pdf_given(wo, wi, m, d.g1(wo, m), d.d(m))
    }

    /// f cos_i for wo.z, wi.z > 0, with the half vector, G1(wo, m) and D(m), which
    /// `pdf_given` reuses when `sample` needs both.
    #[inline]
    fn eval_upper(&self, wo: Vec3, wi: Vec3) -> (Rgb, Vec3, f32, f32) {
        let (c, d) = (&self.coating, &self.distribution);
        let m = (wo + wi).normalize();
        let (dm, g1_o) = (d.d(m), d.g1(wo, m));
        let f = fresnel::dielectric(wo.dot(m), c.eta).0;
        let spec = c.specular_reflectance * (f * dm * (g1_o * d.g1(wi, m)) / (4.0 * wo.z));
        let t = self.t(wo.z) * self.t(wi.z);
        let value = spec + c.base(self.internal) * (t * c.inv_eta2() * INV_PI * wi.z);
        (value, m, g1_o, dm)
    }

    /// `pdf` for wo.z, wi.z > 0, from the half vector, G1(wo, m) and D(m).
    #[inline]
    fn pdf_given(&self, wo: Vec3, wi: Vec3, m: Vec3, g1_o: f32, dm: f32) -> f32 {
        let p = self.coating.prob_specular(1.0 - self.t(wo.z));
        let dot = wo.dot(m);
        let spec = if dot > 0.0 {
            // The visible-normal density, as `Microfacet::pdf_visible` forms it.
            g1_o * dot * dm / wo.z / (4.0 * dot)
        } else {
            0.0
        };
        p * spec + (1.0 - p) * cosine_hemisphere_pdf(wi.z)
    }

    #[inline(never)]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let p = self.coating.prob_specular(1.0 - self.t(wo.z));
        let wi = if u_lobe < p {
            reflect(wo, self.distribution.sample_visible(wo, u))
        } else {
            square_to_cosine_hemisphere(u)
        };
        if wi.z <= 0.0 {
            return None;
        }
        let (value, m, g1_o, dm) = self.eval_upper(wo, wi);
        let pdf = self.pdf_given(wo, wi, m, g1_o, dm);
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi: wi.into(),
            weight: (value / pdf).into(),
            pdf,
            delta: false,
        })
    }
}
