use crate::math::{reflect, Rgb, Vec2, Vec3};

use super::microfacet::Microfacet;
use super::{fresnel, BsdfSample, Mode};

/// Rough dielectric interface (Walter et al. 2007, "Microfacet Models for Refraction
/// through Rough Surfaces"; Mitsuba 3's `roughdielectric`): reflection and refraction
/// off microfacets, from either side, sampled from the visible normals of the side
/// `wo` is on and a Fresnel choice between the two.
///
/// With n_o and n_i the indices on the sides of `wo` and `wi` and m the generalised
/// half vector (parallel to n_o wo + n_i wi), refraction in radiance mode is
/// f cos_i = (1 - F) D G |wo.m| |wi.m| n_o^2 / (|cos_o| (n_o wo.m + n_i wi.m)^2), and in
/// importance mode n_i^2 replaces n_o^2: f_importance(wo, wi) = f_radiance(wi, wo),
/// the adjoint (Veach 1997, sec. 5.2).
#[derive(Clone, Debug, PartialEq)]
pub struct RoughDielectric {
    /// interior IOR / exterior IOR.
    pub eta: f32,
    pub distribution: Microfacet,
    pub specular_reflectance: Rgb,
    pub specular_transmittance: Rgb,
}

/// The microfacet normal joining `wo` and `wi`, on the upper side, with
/// `n_i / n_o` (1 for a reflection); None where no facet joins them (grazing
/// directions, or a half vector that would see a facet from behind).
#[inline]
fn half_vector(eta: f32, wo: Vec3, wi: Vec3) -> Option<(Vec3, f32)> {
    if wo.z == 0.0 || wi.z == 0.0 {
        return None;
    }
    let reflect = wo.z * wi.z > 0.0;
    let eta_io = match (reflect, wo.z > 0.0) {
        (true, _) => 1.0,
        (false, true) => eta,
        (false, false) => 1.0 / eta,
    };
    let h = wo + wi * eta_io;
    let m = h.normalize_or_zero();
    let m = if m.z < 0.0 { -m } else { m };
    // Each direction sees the front of the facet from its side.
    let sided = wo.dot(m) * wo.z > 0.0 && wi.dot(m) * wi.z > 0.0;
    (m.z > 0.0 && sided).then_some((m, eta_io))
}

impl RoughDielectric {
    /// `wo` turned to the upper side: the view visible normals are sampled for.
    #[inline]
    fn up(wo: Vec3) -> Vec3 {
        if wo.z < 0.0 {
            -wo
        } else {
            wo
        }
    }

    #[inline(never)]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: Mode) -> Rgb {
        let Some((m, eta_io)) = half_vector(self.eta, wo, wi) else {
            return Rgb::ZERO;
        };
        let dist = &self.distribution;
        let dg = dist.d(m) * dist.g(wo, wi, m);
        if dg == 0.0 {
            return Rgb::ZERO;
        }
        let (dot_o, dot_i) = (wo.dot(m), wi.dot(m));
        let (f, _, _) = fresnel::dielectric(dot_o, self.eta);
        if wo.z * wi.z > 0.0 {
            return self.specular_reflectance * (f * dg / (4.0 * wo.z.abs()));
        }
        let denom = dot_o + eta_io * dot_i;
        let scale = match mode {
            Mode::Radiance => 1.0,
            Mode::Importance => eta_io * eta_io,
        };
        let t = (1.0 - f) * dg * (dot_o * dot_i).abs() * scale / (wo.z.abs() * denom * denom);
        self.specular_transmittance * t
    }

    /// The visible-normal density of m times the lobe's Fresnel probability, through
    /// the Jacobian of the reflection (1 / (4 |wo.m|)) or refraction
    /// (n_i^2 |wi.m| / (n_o wo.m + n_i wi.m)^2) mapping.
    #[inline(never)]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((m, eta_io)) = half_vector(self.eta, wo, wi) else {
            return 0.0;
        };
        let pm = self.distribution.pdf_visible(Self::up(wo), m);
        let dot_o = wo.dot(m);
        let (f, _, _) = fresnel::dielectric(dot_o, self.eta);
        if wo.z * wi.z > 0.0 {
            return pm * f / (4.0 * dot_o.abs());
        }
        let dot_i = wi.dot(m);
        let denom = dot_o + eta_io * dot_i;
        pm * (1.0 - f) * eta_io * eta_io * dot_i.abs() / (denom * denom)
    }

    #[inline(never)]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: Mode) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let dist = &self.distribution;
        let m = dist.sample_visible(Self::up(wo), u);
        let dot_o = wo.dot(m);
        let (f, cos_t, eta_ti) = fresnel::dielectric(dot_o, self.eta);
        let reflected = u_lobe < f;
        let (wi, weight) = if reflected {
            (reflect(wo, m), self.specular_reflectance)
        } else {
            // Radiance is compressed into a narrower cone when it enters a denser
            // medium: (n_o / n_i)^2, as for the smooth dielectric.
            let scale = match mode {
                Mode::Radiance => eta_ti * eta_ti,
                Mode::Importance => 1.0,
            };
            let wi = fresnel::refract(wo, m, cos_t, eta_ti);
            (wi, self.specular_transmittance * scale)
        };
        if (wi.z * wo.z > 0.0) != reflected {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        // f cos / pdf simplifies to G1(wi, m) (times the colour and the scale).
        let g1 = dist.g1(wi, m);
        if pdf <= 0.0 || g1 <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi: wi.into(),
            weight: (weight * g1).into(),
            pdf,
            delta: false,
        })
    }
}
