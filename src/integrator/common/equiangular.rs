//! Equi-angular sampling of a distance on a ray segment about a point (Kulla and
//! Fajardo 2012, "Importance sampling techniques for path tracing in participating
//! media", sec. 3): the density is proportional to the inverse squared distance to the
//! point, which cancels the 1 / d^2 of a connection to it. volpath uses it for point and
//! spot lights; the many-light methods use it about virtual lights.

use crate::geometry::Ray;
use crate::math::Vec3;

/// Equi-angular sampling of t on a segment [0, tmax] of a ray towards a point c: the
/// density is proportional to 1 / |x(t) - c|^2 (Kulla and Fajardo, eq. 6-8).
#[derive(Clone, Copy, Debug)]
pub struct EquiAngular {
    /// Distance along the ray to the point closest to c.
    delta: f32,
    /// Distance of c from the ray's line.
    h: f32,
    theta_a: f32,
    theta_b: f32,
    tmax: f32,
}

impl EquiAngular {
    pub fn new(ray: &Ray, tmax: f32, c: Vec3) -> Option<Self> {
        let oc = c - ray.o;
        let delta = oc.dot(ray.d);
        let h = (oc - ray.d * delta).length();
        // On (or numerically on) the line the density degenerates to a spike.
        if h.is_nan() || h <= 1e-6 * (1.0 + oc.length()) {
            return None;
        }
        let theta_a = (-delta).atan2(h);
        let theta_b = if tmax.is_finite() {
            (tmax - delta).atan2(h)
        } else {
            std::f32::consts::FRAC_PI_2
        };
        (theta_b - theta_a > 1e-7).then_some(EquiAngular {
            delta,
            h,
            theta_a,
            theta_b,
            tmax,
        })
    }

    #[inline]
    pub fn pdf(&self, t: f32) -> f32 {
        if !(0.0..self.tmax).contains(&t) {
            return 0.0;
        }
        let x = t - self.delta;
        self.h / ((self.theta_b - self.theta_a) * (self.h * self.h + x * x))
    }

    #[inline]
    pub fn sample(&self, u: f32) -> (f32, f32) {
        let theta = self.theta_a + u * (self.theta_b - self.theta_a);
        let t = (self.delta + self.h * theta.tan()).clamp(0.0, self.tmax);
        (t, self.pdf(t))
    }
}
