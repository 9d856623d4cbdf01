//! The anisotropic camera-ray sampler of the advanced joint sampler (Oppitz 2018,
//! "joint advanced"; after Novák et al. 2012, sec. 4.3, who sample the product of the
//! phase functions along the camera ray).
//!
//! About a light point y the camera ray is parametrised by the equi-angular angle:
//! t = delta + h tan(theta), theta in [theta_a, theta_b], so dt / (h^2 + (t-delta)^2)
//! = d theta / h and the inverse squared distance of the integrand is gone. What is
//! left in theta is the product of the two phase functions,
//!
//!   f(theta) = f_p,y(d_l . w(theta)) f_p,x(w(theta) . (-d_c)),
//!   w(theta) = sin(theta) d_c - cos(theta) n,
//!
//! with w the direction from y to x(theta) and n the unit vector from the camera line
//! to y. f is fitted piecewise linearly through `nodes` equally spaced angles and
//! theta drawn from that density by inverting its piecewise-quadratic CDF; the density
//! in t is p(theta) d theta / dt.

use super::distance::{Distance, EquiAngular};
use super::pair::dot;
use crate::medium::Phase;

/// Most nodes a fit may have (the table lives on the stack).
pub const MAX_NODES: usize = 64;
/// The share of the density that is uniform in theta (the equi-angular density of
/// `joint_simple`): a defensive mixture (Hesterberg 1995). Ten nodes over the angle a
/// long camera segment subtends are ~0.3 rad apart, wider than the lobe of a g = 0.9
/// phase function (~0.1 rad), so the fit can miss the peak that carries most of the
/// integral; the mixture bounds the weight there by 1 / DEFENSIVE times
/// `joint_simple`'s, where a floor relative to the fit's maximum left it ~1e3 times
/// larger (a heavy tail the renders showed as rare bright pixels).
const DEFENSIVE: f64 = 0.2;

/// The phases at both ends of a connection: at the light point y and the camera point x.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phases {
    pub light: Phase,
    pub cam: Phase,
}

/// The piecewise-linear density in theta about one light point.
#[derive(Clone, Copy, Debug)]
pub struct Advanced {
    ea: EquiAngular,
    nodes: usize,
    /// Node spacing in theta.
    step: f64,
    /// Fitted values at the nodes.
    v: [f64; MAX_NODES],
    /// Integral of the fit from theta_a to each node.
    cum: [f64; MAX_NODES],
}

impl Advanced {
    /// `ea`: the equi-angular parametrisation about y; `dl`: the ray light's direction;
    /// `dc`: the camera segment's; `n`: unit direction from the camera line to y.
    pub fn new(
        ea: EquiAngular,
        dl: [f64; 3],
        dc: [f64; 3],
        n: [f64; 3],
        phases: &Phases,
        nodes: usize,
    ) -> Self {
        debug_assert!((2..=MAX_NODES).contains(&nodes));
        let (cos_lc, cos_ln) = (dot(dl, dc), dot(dl, n));
        let step = (ea.theta_b - ea.theta_a) / (nodes - 1) as f64;
        let mut v = [0.0; MAX_NODES];
        for (i, vi) in v.iter_mut().enumerate().take(nodes) {
            let (s, c) = (ea.theta_a + step * i as f64).sin_cos();
            let mu_y = (s * cos_lc - c * cos_ln).clamp(-1.0, 1.0);
            let at_y = phases.light.eval_mu(mu_y as f32);
            let at_x = phases.cam.eval_mu(-s as f32);
            *vi = at_y as f64 * at_x as f64;
        }
        // The fit's mean over the angle; the uniform part adds DEFENSIVE of the total.
        let mean = (0.5 * (v[0] + v[nodes - 1]) + v[1..nodes - 1].iter().sum::<f64>())
            / (nodes - 1) as f64;
        let floor = DEFENSIVE / (1.0 - DEFENSIVE) * mean;
        for vi in &mut v[..nodes] {
            // A phase that vanishes everywhere leaves the equi-angular density.
            *vi = if mean > 0.0 && mean.is_finite() {
                *vi + floor
            } else {
                1.0
            };
        }
        let mut cum = [0.0; MAX_NODES];
        for i in 1..nodes {
            cum[i] = cum[i - 1] + 0.5 * (v[i - 1] + v[i]) * step;
        }
        Advanced {
            ea,
            nodes,
            step,
            v,
            cum,
        }
    }

    #[inline]
    fn total(&self) -> f64 {
        self.cum[self.nodes - 1]
    }

    /// The interval of theta and the offset into it.
    #[inline]
    fn locate(&self, theta: f64) -> (usize, f64) {
        let x = (theta - self.ea.theta_a).max(0.0);
        let i = ((x / self.step) as usize).min(self.nodes - 2);
        (i, (x - i as f64 * self.step).min(self.step))
    }

    /// Density in theta.
    fn pdf_theta(&self, theta: f64) -> f64 {
        let (i, x) = self.locate(theta);
        let f = x / self.step;
        (self.v[i] * (1.0 - f) + self.v[i + 1] * f) / self.total()
    }
}

#[cfg(test)]
impl Advanced {
    /// The points of the camera segment where the fit has its nodes (its kinks), and
    /// the foot of the perpendicular, for the tests' quadrature.
    pub(super) fn kinks(&self) -> Vec<f64> {
        let mut k: Vec<f64> = (0..self.nodes)
            .map(|i| self.ea.t_of(self.ea.theta_a + self.step * i as f64))
            .collect();
        k.push(self.ea.delta);
        k
    }
}

impl Distance for Advanced {
    fn sample(&self, xi: f64) -> (f64, f64) {
        let r = xi * self.total();
        // The interval whose cumulative area brackets r (at most 63 comparisons).
        let i = (1..self.nodes - 1)
            .take_while(|&j| self.cum[j] <= r)
            .last()
            .unwrap_or(0);
        let (v0, v1) = (self.v[i], self.v[i + 1]);
        let k = (v1 - v0) / self.step;
        let r = r - self.cum[i];
        // v0 x + k x^2 / 2 = r, in the form without cancellation for either sign of k.
        let x = (2.0 * r / (v0 + (v0 * v0 + 2.0 * k * r).max(0.0).sqrt())).clamp(0.0, self.step);
        let t = self.ea.t_of(self.ea.theta_a + i as f64 * self.step + x);
        (t, self.pdf(t))
    }

    fn pdf(&self, t: f64) -> f64 {
        if !(0.0..=self.ea.len).contains(&t) {
            return 0.0;
        }
        self.pdf_theta(self.ea.theta(t)) * self.ea.dtheta_dt(t)
    }

    fn cdf(&self, t: f64) -> f64 {
        let t = t.clamp(0.0, self.ea.len);
        let (i, x) = self.locate(self.ea.theta(t));
        let k = (self.v[i + 1] - self.v[i]) / self.step;
        ((self.cum[i] + self.v[i] * x + 0.5 * k * x * x) / self.total()).clamp(0.0, 1.0)
    }
}
