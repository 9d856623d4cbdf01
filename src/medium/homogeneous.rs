//! A homogeneous medium: transmittance and free-flight sampling in closed form; no
//! tracking code runs for it.
//!
//! When sigma_t differs between channels, one channel's exponential is picked per
//! flight with probability proportional to the path throughput in it, and the sample is
//! weighted by the one-sample balance heuristic over channels (the mixture density
//! sum_c p_c sigma_t,c exp(-sigma_t,c t)), as in Mitsuba's and pbrt-v4's spectral MIS:
//! unbiased for every channel, and the weights stay bounded by 1 / p_c.

use super::{Flight, Phase};
use crate::math::{Rgb, Rng};

#[derive(Clone, Debug, PartialEq)]
pub struct Homogeneous {
    pub sigma_t: Rgb,
    pub sigma_s: Rgb,
    pub phase: Phase,
    /// sigma_t is the same in every channel: plain exponential sampling.
    grey: bool,
}

impl Homogeneous {
    pub fn new(sigma_a: Rgb, sigma_s: Rgb, phase: Phase) -> Self {
        let sigma_t = sigma_a + sigma_s;
        Homogeneous {
            sigma_t,
            sigma_s,
            phase,
            grey: sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z,
        }
    }

    /// Whether sigma_t is the same in every channel.
    #[inline]
    pub fn is_grey(&self) -> bool {
        self.grey
    }

    /// sigma_s / sigma_t per channel, zero where sigma_t is.
    #[inline]
    pub fn albedo(&self) -> Rgb {
        Rgb::select(
            self.sigma_t.cmpgt(Rgb::ZERO),
            self.sigma_s / self.sigma_t,
            Rgb::ZERO,
        )
    }

    #[inline(always)]
    pub fn transmittance(&self, dist: f32) -> Rgb {
        if dist == f32::INFINITY {
            // exp(-0 * inf) would be NaN; a channel without extinction passes everything.
            return Rgb::select(self.sigma_t.cmpgt(Rgb::ZERO), Rgb::ZERO, Rgb::ONE);
        }
        if self.grey {
            return Rgb::splat((-self.sigma_t.x * dist).exp());
        }
        (-self.sigma_t * dist).exp()
    }

    /// Samples where the ray of unit direction first interacts before `tmax`.
    #[inline(always)]
    pub fn sample_flight(&self, tmax: f32, beta: Rgb, rng: &mut Rng) -> Flight {
        if self.grey {
            let s = self.sigma_t.x;
            if s <= 0.0 {
                return Flight::Pass { weight: Rgb::ONE };
            }
            let t = -(1.0 - rng.next_f32()).ln() / s;
            return if t < tmax {
                Flight::Scatter {
                    t,
                    weight: self.sigma_s / s,
                }
            } else {
                Flight::Pass { weight: Rgb::ONE }
            };
        }
        let p = channel_probabilities(beta);
        let u = rng.next_f32();
        let c = if u < p.x {
            0
        } else if u < p.x + p.y {
            1
        } else {
            2
        };
        let s = self.sigma_t[c];
        let t = if s > 0.0 {
            -(1.0 - rng.next_f32()).ln() / s
        } else {
            f32::INFINITY
        };
        if t < tmax {
            let tr = self.transmittance(t);
            let pdf = (p * self.sigma_t * tr).element_sum();
            Flight::Scatter {
                t,
                weight: tr * self.sigma_s / pdf,
            }
        } else {
            // Passing has probability sum_c p_c T_c: dividing by anything else (such
            // as a floor on it) would bias every long segment.
            let tr = self.transmittance(tmax);
            let pass = (p * tr).element_sum();
            if pass > 0.0 {
                Flight::Pass { weight: tr / pass }
            } else {
                Flight::Absorbed
            }
        }
    }

    /// Density of `sample_flight` scattering at distance t (for MIS with other distance
    /// samplers); `beta` must be the throughput that sampling saw.
    #[inline]
    pub fn flight_pdf(&self, t: f32, beta: Rgb) -> f32 {
        if self.grey {
            let s = self.sigma_t.x;
            return s * (-s * t).exp();
        }
        let p = channel_probabilities(beta);
        (p * self.sigma_t * self.transmittance(t)).element_sum()
    }
}

/// Channel selection proportional to the throughput, uniform when it carries no
/// information (zero or not finite).
#[inline]
pub fn channel_probabilities(beta: Rgb) -> Rgb {
    let b = beta.abs();
    let sum = b.element_sum();
    if sum > 0.0 && sum.is_finite() {
        b / sum
    } else {
        Rgb::splat(1.0 / 3.0)
    }
}
