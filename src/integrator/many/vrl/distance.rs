//! One-dimensional densities on a segment [0, len]: uniform, exponential truncated to
//! the segment, and equi-angular about a point. Each inverts its CDF exactly, so the
//! density `sample` returns is `pdf` at the returned point. f64 inside: the truncated
//! exponential at sigma len ~ 1e-7 and the equi-angular angles of a point 1e-5 off the
//! line lose every digit in f32.
//!
//! The crate's `transport::equiangular::EquiAngular` refuses a point on the line (the
//! caller falls back) and has no CDF; ray lights need both a guarded distance and the
//! CDF, so this module keeps its own.

/// A density on [0, len] with its inverse CDF.
pub trait Distance {
    /// The point for the uniform number xi in [0, 1), with its density.
    fn sample(&self, xi: f64) -> (f64, f64);
    /// Density at t; 0 outside the segment.
    fn pdf(&self, t: f64) -> f64;
    /// Probability of [0, t].
    fn cdf(&self, t: f64) -> f64;
}

/// Uniform on [0, len].
#[derive(Clone, Copy, Debug)]
pub struct Uniform {
    pub len: f64,
}

impl Distance for Uniform {
    fn sample(&self, xi: f64) -> (f64, f64) {
        (xi * self.len, 1.0 / self.len)
    }

    fn pdf(&self, t: f64) -> f64 {
        if (0.0..=self.len).contains(&t) {
            1.0 / self.len
        } else {
            0.0
        }
    }

    fn cdf(&self, t: f64) -> f64 {
        (t / self.len).clamp(0.0, 1.0)
    }
}

/// Density proportional to the transmittance exp(-sigma t), truncated to [0, len]:
/// sigma exp(-sigma t) / (1 - exp(-sigma len)) (Novák et al. 2012, sec. 4.1, the
/// "exponential" sampler). A zero sigma is the uniform density, its limit.
#[derive(Clone, Copy, Debug)]
pub struct Exponential {
    pub sigma: f64,
    pub len: f64,
}

impl Exponential {
    /// 1 - exp(-sigma len), the probability the untruncated flight ends on the segment.
    #[inline]
    fn mass(&self) -> f64 {
        -(-self.sigma * self.len).exp_m1()
    }

    #[inline]
    fn flat(&self) -> bool {
        !(self.sigma > 0.0 && self.mass() > 0.0)
    }
}

impl Distance for Exponential {
    fn sample(&self, xi: f64) -> (f64, f64) {
        if self.flat() {
            return Uniform { len: self.len }.sample(xi);
        }
        // Inverse of the CDF below: t = -ln(1 - xi (1 - e^{-sigma len})) / sigma.
        let t = (-(-xi * self.mass()).ln_1p() / self.sigma).clamp(0.0, self.len);
        (t, self.pdf(t))
    }

    fn pdf(&self, t: f64) -> f64 {
        if self.flat() {
            return Uniform { len: self.len }.pdf(t);
        }
        if !(0.0..=self.len).contains(&t) {
            return 0.0;
        }
        self.sigma * (-self.sigma * t).exp() / self.mass()
    }

    fn cdf(&self, t: f64) -> f64 {
        if self.flat() {
            return Uniform { len: self.len }.cdf(t);
        }
        let t = t.clamp(0.0, self.len);
        -(-self.sigma * t).exp_m1() / self.mass()
    }
}

/// Equi-angular about a point at distance h from the line whose foot is at delta:
/// density h / ((theta_b - theta_a) (h^2 + (t - delta)^2)), uniform in the angle
/// theta = atan((t - delta) / h) the point subtends (Kulla and Fajardo 2012, eqs. 6-8).
/// h is the caller's guarded distance, never 0.
#[derive(Clone, Copy, Debug)]
pub struct EquiAngular {
    pub delta: f64,
    pub h: f64,
    pub theta_a: f64,
    pub theta_b: f64,
    pub len: f64,
}

impl EquiAngular {
    pub fn new(delta: f64, h: f64, len: f64) -> Self {
        debug_assert!(h > 0.0 && len.is_finite());
        EquiAngular {
            delta,
            h,
            theta_a: (-delta).atan2(h),
            theta_b: (len - delta).atan2(h),
            len,
        }
    }

    /// The angle subtended by the point t.
    #[inline]
    pub fn theta(&self, t: f64) -> f64 {
        (t - self.delta).atan2(self.h)
    }

    /// The point at angle theta.
    #[inline]
    pub fn t_of(&self, theta: f64) -> f64 {
        (self.delta + self.h * theta.tan()).clamp(0.0, self.len)
    }

    /// d theta / dt = h / (h^2 + (t - delta)^2): the equi-angular Jacobian.
    #[inline]
    pub fn dtheta_dt(&self, t: f64) -> f64 {
        let x = t - self.delta;
        self.h / (self.h * self.h + x * x)
    }
}

impl Distance for EquiAngular {
    fn sample(&self, xi: f64) -> (f64, f64) {
        let t = self.t_of(self.theta_a + xi * (self.theta_b - self.theta_a));
        (t, self.pdf(t))
    }

    fn pdf(&self, t: f64) -> f64 {
        if !(0.0..=self.len).contains(&t) {
            return 0.0;
        }
        self.dtheta_dt(t) / (self.theta_b - self.theta_a)
    }

    fn cdf(&self, t: f64) -> f64 {
        let t = t.clamp(0.0, self.len);
        ((self.theta(t) - self.theta_a) / (self.theta_b - self.theta_a)).clamp(0.0, 1.0)
    }
}
