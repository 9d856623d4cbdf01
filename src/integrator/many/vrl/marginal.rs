//! The light-ray marginal of the joint samplers (Novák et al. 2012, "Virtual ray
//! lights for rendering scenes with participating media", sec. 4.2; Oppitz 2018, the
//! "simple joint" sampler).
//!
//! For a camera line of infinite extent the inverse squared distance integrates in
//! closed form over the camera parameter:
//!
//!   int_{-inf}^{inf} dt / (h(u)^2 + (t - delta(u))^2) = pi / h(u),
//!
//! where h(u) is the distance of the light point y(u) from the camera line. With the
//! lines crossing at angle theta and closest at u0, h(u)^2 = h0^2 + sin^2(theta)
//! (u - u0)^2, so the marginal density is proportional to 1 / h(u) and its CDF is an
//! inverse hyperbolic sine:
//!
//!   int du / sqrt(h0^2 + s^2 (u - u0)^2) = asinh(s (u - u0) / h0) / s.
//!
//! Degenerate pairs: when the lines are parallel 1/h is constant and the density is
//! the uniform one (`Pair::parallel`); when they meet (h0 -> 0) the density 1/|u - u0|
//! is not normalisable, so h0 is guarded from below by `Pair::h_min`. Both rules are
//! decided from the pair alone, so `sample`, `pdf` and `cdf` always agree.

use super::distance::{Distance, Uniform};
use super::pair::Pair;

/// The asinh marginal on the light segment [0, U] of a pair.
#[derive(Clone, Copy, Debug)]
pub struct Marginal {
    len: f64,
    /// None for a parallel pair: the uniform density.
    curve: Option<Curve>,
}

#[derive(Clone, Copy, Debug)]
struct Curve {
    u0: f64,
    /// The guarded closest-approach distance h0.
    h0: f64,
    sin: f64,
    /// asinh(s (u - u0) / h0) at both ends of the segment.
    a0: f64,
    a1: f64,
}

impl Curve {
    #[inline]
    fn asinh_at(&self, u: f64) -> f64 {
        (self.sin * (u - self.u0) / self.h0).asinh()
    }
}

impl Marginal {
    pub fn new(pair: &Pair) -> Self {
        let len = pair.light.tmax as f64;
        let curve = (!pair.parallel()).then(|| {
            let mut c = Curve {
                u0: pair.u0,
                h0: pair.h0_guarded(),
                sin: pair.sin,
                a0: 0.0,
                a1: 0.0,
            };
            c.a0 = c.asinh_at(0.0);
            c.a1 = c.asinh_at(len);
            c
        });
        // The parallel test bounds s U / h0 from below, so a1 - a0 > 0 here.
        Marginal { len, curve }
    }
}

impl Distance for Marginal {
    fn sample(&self, xi: f64) -> (f64, f64) {
        let Some(c) = self.curve else {
            return Uniform { len: self.len }.sample(xi);
        };
        // Inverse of the CDF: u = u0 + (h0 / s) sinh(a0 + xi (a1 - a0)).
        let a = c.a0 + xi * (c.a1 - c.a0);
        let u = (c.u0 + c.h0 / c.sin * a.sinh()).clamp(0.0, self.len);
        (u, self.pdf(u))
    }

    fn pdf(&self, u: f64) -> f64 {
        let Some(c) = self.curve else {
            return Uniform { len: self.len }.pdf(u);
        };
        if !(0.0..=self.len).contains(&u) {
            return 0.0;
        }
        let x = c.sin * (u - c.u0);
        // d/du asinh(s (u - u0) / h0) = s / sqrt(h0^2 + s^2 (u - u0)^2) = s / h(u).
        c.sin / ((c.h0 * c.h0 + x * x).sqrt() * (c.a1 - c.a0))
    }

    fn cdf(&self, u: f64) -> f64 {
        let Some(c) = self.curve else {
            return Uniform { len: self.len }.cdf(u);
        };
        let u = u.clamp(0.0, self.len);
        ((c.asinh_at(u) - c.a0) / (c.a1 - c.a0)).clamp(0.0, 1.0)
    }
}
