//! Equi-angular sampling of a distance on a ray segment about a point (Kulla and
//! Fajardo 2012, "Importance sampling techniques for path tracing in participating
//! media", sec. 3): the density is proportional to the inverse squared distance to the
//! point, which cancels the 1 / d^2 of a connection to it. volpath uses it for point and
//! spot lights; the many-light methods use it about virtual lights.

use crate::geometry::Ray;
use crate::math::Vec3;

/// The largest f32 below pi / 2, the angle of a ray's far end at infinity. The f32
/// nearest pi / 2 lies above it, where tan turns negative: a sample near the end of
/// an unbounded segment would land at t = 0 with the density of another point.
const BELOW_HALF_PI: f32 = 1.570_796_2;

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
            BELOW_HALF_PI
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The last floats below 1 map beyond the closest approach, on every geometry
    /// (with the f32 nearest pi / 2 some of them wrapped round to t = 0).
    #[test]
    fn the_far_end_of_an_unbounded_segment_stays_far() {
        assert!((BELOW_HALF_PI as f64) < std::f64::consts::FRAC_PI_2);
        assert!(f32::from_bits(BELOW_HALF_PI.to_bits() + 1) as f64 > std::f64::consts::FRAC_PI_2);
        let ray = Ray::new(Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0));
        for i in 0..2000 {
            let h = 0.01 + i as f32 * 0.37 % 5.0;
            let delta = (i as f32 * 0.731) % 20.0 - 10.0;
            let ea = EquiAngular::new(&ray, f32::INFINITY, Vec3::new(h, 0.0, delta)).unwrap();
            for k in 1..8 {
                let u = f32::from_bits(1.0f32.to_bits() - k);
                let (t, pdf) = ea.sample(u);
                assert!(
                    t.is_finite() && t > delta.max(0.0),
                    "h {h} delta {delta} u {u}: t {t}"
                );
                assert!(pdf > 0.0 && pdf.is_finite(), "u {u}: pdf {pdf}");
            }
        }
    }
}
