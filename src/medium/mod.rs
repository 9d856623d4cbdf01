//! Participating media: homogeneous (closed form), heterogeneous grids and procedural
//! noise (null-collision tracking over a majorant grid), and phase functions.
//!
//! Media are attached to shapes (`interior` / `exterior`) and to the camera, as in
//! Mitsuba; the compiled scene tracks which medium a ray is in. All distances here are
//! world-space lengths along unit directions.

pub mod grid_io;
mod heterogeneous;
mod homogeneous;
pub mod noise;
mod phase;
pub mod voxels;

pub use heterogeneous::Heterogeneous;
pub use homogeneous::{channel_probabilities, Homogeneous};
pub use phase::Phase;

use crate::math::{Rgb, Rng, Vec3};

/// Outcome of free-flight sampling along a segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flight {
    /// A real scattering event at distance t; multiply the throughput by `weight`
    /// (which already holds sigma_s / pdf).
    Scatter { t: f32, weight: Rgb },
    /// The flight reached the end of the segment; multiply the throughput by `weight`.
    Pass { weight: Rgb },
    /// The path ends here (a medium that only absorbs where the flight stopped).
    Absorbed,
}

#[derive(Clone, Debug)]
pub enum Medium {
    Homogeneous(Homogeneous),
    Heterogeneous(Box<Heterogeneous>),
}

// The methods below are forced inline (with those of `Homogeneous` and `Phase`): the
// integrators' AVX2 kernels otherwise call baseline-x86 copies, out of line.
impl Medium {
    #[inline(always)]
    pub fn phase(&self) -> &Phase {
        match self {
            Medium::Homogeneous(m) => &m.phase,
            Medium::Heterogeneous(m) => &m.phase,
        }
    }

    /// Samples the first interaction along o + t d (unit d), t in [0, tmax).
    #[inline(always)]
    pub fn sample_flight(&self, o: Vec3, d: Vec3, tmax: f32, beta: Rgb, rng: &mut Rng) -> Flight {
        match self {
            Medium::Homogeneous(m) => m.sample_flight(tmax, beta, rng),
            Medium::Heterogeneous(m) => m.sample_flight(o, d, tmax, beta, rng),
        }
    }

    /// Transmittance over t in [0, tmax]: exact for homogeneous media, an unbiased
    /// estimate otherwise.
    #[inline(always)]
    pub fn transmittance(&self, o: Vec3, d: Vec3, tmax: f32, rng: &mut Rng) -> Rgb {
        match self {
            Medium::Homogeneous(m) => m.transmittance(tmax),
            Medium::Heterogeneous(m) => m.transmittance(o, d, tmax, rng),
        }
    }

    /// Scattering coefficient at world point `p`, for estimators that divide it out of a
    /// free flight's weight (the volumetric photon map's point query).
    #[inline]
    pub fn sigma_s_at(&self, p: Vec3) -> Rgb {
        match self {
            Medium::Homogeneous(m) => m.sigma_s,
            Medium::Heterogeneous(m) => m.sigma_s_at(p),
        }
    }

    /// Single-scattering albedo sigma_s / sigma_t at `p` (zero in channels that do not
    /// scatter); a point where the medium has no density gets the medium's nominal
    /// albedo. Bidirectional subpaths continue with probability max(albedo).
    #[inline]
    pub fn albedo_at(&self, p: Vec3) -> Rgb {
        match self {
            Medium::Homogeneous(m) => m.albedo(),
            Medium::Heterogeneous(m) => m.albedo_at(p),
        }
    }

    /// The grey extinction coefficient bidirectional MIS assumes for distance sampling
    /// in this medium: the channel mean of sigma_t when homogeneous (exact for grey
    /// media), None when heterogeneous (see [`Medium::mis_sigma_at`]).
    #[inline(always)]
    pub fn mis_sigma_t(&self) -> Option<f32> {
        match self {
            Medium::Homogeneous(m) => Some(m.sigma_t.element_sum() / 3.0),
            Medium::Heterogeneous(_) => None,
        }
    }

    /// The grey sigma_t the MIS takes at `p` (its factor D of a vertex there): the
    /// channel mean, at `p` in a heterogeneous medium when `local` (0 where it has no
    /// density), else 0 there (no proxy: the caller's D = 1).
    #[inline]
    pub fn mis_sigma_at(&self, p: Vec3, local: bool) -> f32 {
        match self {
            Medium::Homogeneous(m) => m.sigma_t.element_sum() / 3.0,
            Medium::Heterogeneous(m) if local => m.mis_sigma_at(p),
            Medium::Heterogeneous(_) => 0.0,
        }
    }

    /// The grey optical depth the MIS takes along o + t d (unit d), t in [t0, t1]:
    /// [`Medium::mis_sigma_t`] times the length when homogeneous; when heterogeneous a
    /// deterministic quadrature of [`Medium::mis_sigma_at`] (a random estimate in a
    /// weight would bias it), the same from either end of the piece, so every
    /// technique finds the same transmittance for the same path; 0 (T = 1) there
    /// unless `local`.
    #[inline]
    pub fn mis_depth(&self, o: Vec3, d: Vec3, t0: f32, t1: f32, local: bool) -> f32 {
        match self {
            Medium::Homogeneous(m) => {
                let sigma = m.sigma_t.element_sum() / 3.0;
                // No 0 x inf for a clear medium along a ray that leaves the scene.
                if sigma > 0.0 {
                    sigma * (t1 - t0)
                } else {
                    0.0
                }
            }
            Medium::Heterogeneous(m) if local => m.mis_depth(o, d, t0, t1),
            Medium::Heterogeneous(_) => 0.0,
        }
    }

    /// Where the medium can last interact along o + t d (unit d) within [0, tmax]: a
    /// heterogeneous medium has no density outside its field's box, so an unbounded ray
    /// ends there for every estimator; a homogeneous one fills the whole segment.
    #[inline]
    pub fn support_end(&self, o: Vec3, d: Vec3, tmax: f32) -> f32 {
        match self {
            Medium::Homogeneous(_) => tmax,
            Medium::Heterogeneous(m) => m.support_end(o, d, tmax),
        }
    }

    /// A grey extinction coefficient for drawing distances (estimators divide by the
    /// density they used, so any positive value is unbiased): the channel mean when
    /// homogeneous, the mean of the majorant grid otherwise (not its maximum, whose
    /// densities fall far faster than the transmittance in thin regions).
    #[inline]
    pub fn sampling_sigma_t(&self) -> f32 {
        match self {
            Medium::Homogeneous(m) => m.sigma_t.element_sum() / 3.0,
            Medium::Heterogeneous(m) => m.mean_sigma_t(),
        }
    }

    #[inline(always)]
    pub fn as_homogeneous(&self) -> Option<&Homogeneous> {
        match self {
            Medium::Homogeneous(m) => Some(m),
            Medium::Heterogeneous(_) => None,
        }
    }
}
