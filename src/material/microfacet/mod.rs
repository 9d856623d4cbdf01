//! Microfacet distributions (Beckmann and GGX / Trowbridge-Reitz, isotropic or
//! anisotropic) with Smith masking and sampling of visible normals, as Mitsuba 3's
//! `MicrofacetDistribution` defines them: D normalised so that int D(m) cos(theta_m) dm
//! = 1, separable masking-shadowing G = G1(wo) G1(wi), and the density of visible
//! normals D_w(m) = G1(w, m) max(0, w.m) D(m) / cos(theta_w). The rough conductor and
//! dielectric share this one implementation.

pub mod albedo;
mod beckmann;
mod erf;
mod ggx;

use crate::math::{Vec2, Vec3};

/// Below this alpha (both axes) a surface is treated as perfectly smooth (a delta
/// lobe): a narrower lobe only adds floating-point trouble.
pub const SMOOTH_ALPHA: f32 = 1e-3;
/// Smallest alpha used on one axis of a rough surface (as Mitsuba 3 clamps it):
/// visible-normal sampling is unstable below.
const MIN_ALPHA: f32 = 1e-4;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    Beckmann,
    Ggx,
}

/// A microfacet distribution with roughness `alpha_u` along the shading frame's x
/// (tangent) axis and `alpha_v` along y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    pub kind: Distribution,
    pub alpha_u: f32,
    pub alpha_v: f32,
}

impl Microfacet {
    /// A distribution; each alpha is clamped to at least 1e-4 unless both are below
    /// `SMOOTH_ALPHA` (a smooth surface, which has no lobe to sample).
    pub fn new(kind: Distribution, alpha_u: f32, alpha_v: f32) -> Self {
        let smooth = alpha_u.max(alpha_v) < SMOOTH_ALPHA;
        let clamp = |a: f32| if smooth { a } else { a.max(MIN_ALPHA) };
        Microfacet {
            kind,
            alpha_u: clamp(alpha_u),
            alpha_v: clamp(alpha_v),
        }
    }

    pub fn is_smooth(&self) -> bool {
        self.alpha_u.max(self.alpha_v) < SMOOTH_ALPHA
    }

    /// D(m), zero below the surface (and where it would underflow, as in Mitsuba).
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let (au, av) = (self.alpha_u, self.alpha_v);
        let d = match self.kind {
            Distribution::Beckmann => beckmann::d(m, au, av),
            Distribution::Ggx => ggx::d(m, au, av),
        };
        if d * m.z > 1e-20 {
            d
        } else {
            0.0
        }
    }

    /// Smith's G1(v, m): the fraction of microfacets of normal `m` visible from `v`,
    /// zero when `v` would see the back of the facet.
    #[inline]
    pub fn g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        // tan^2 of v's polar angle, scaled by the alpha in v's azimuth.
        let xy = (self.alpha_u * v.x).powi(2) + (self.alpha_v * v.y).powi(2);
        if xy == 0.0 {
            return 1.0;
        }
        let tan2 = xy / (v.z * v.z);
        match self.kind {
            Distribution::Beckmann => beckmann::g1(tan2),
            Distribution::Ggx => 2.0 / (1.0 + (1.0 + tan2).sqrt()),
        }
    }

    /// Masking-shadowing G(wo, wi, m) = G1(wo, m) G1(wi, m), uncorrelated (Mitsuba 3).
    #[inline]
    pub fn g(&self, wo: Vec3, wi: Vec3, m: Vec3) -> f32 {
        self.g1(wo, m) * self.g1(wi, m)
    }

    /// A microfacet normal visible from `w` (w.z > 0), distributed as `pdf_visible`:
    /// Heitz 2018 for GGX, the inversion of the visible-slope CDF for Beckmann.
    #[inline]
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        let (au, av) = (self.alpha_u, self.alpha_v);
        match self.kind {
            Distribution::Beckmann => beckmann::sample_visible(w, au, av, u),
            Distribution::Ggx => ggx::sample_visible(w, au, av, u),
        }
    }

    /// Density of `m` under `sample_visible(w, .)`: G1(w, m) max(0, w.m) D(m) / w.z.
    #[inline]
    pub fn pdf_visible(&self, w: Vec3, m: Vec3) -> f32 {
        if w.z <= 0.0 {
            return 0.0;
        }
        self.g1(w, m) * w.dot(m).max(0.0) * self.d(m) / w.z
    }
}

/// The direction `w` stretched by the alphas, normalised: where both samplers work
/// with an isotropic distribution of unit roughness.
#[inline]
fn stretch(w: Vec3, au: f32, av: f32) -> Vec3 {
    Vec3::new(au * w.x, av * w.y, w.z).normalize()
}

#[cfg(test)]
mod tests;
