//! Beckmann: D, the exact Smith masking, and visible-normal sampling by inverting the
//! CDF of visible slopes (Heitz and d'Eon 2014, "Importance Sampling Microfacet-Based
//! BSDFs using the Distribution of Visible Normals"), with the Newton iteration
//! safeguarded by bisection that Mitsuba 3 uses instead of the paper's fit.
//!
//! Caustic's G1 is the exact erf form of Smith's Beckmann masking where Mitsuba 3 uses
//! Walter's rational fit (within 0.35 %): with the fit, the density of visible normals
//! would not integrate to one and sampling would disagree with `pdf`.

use super::stretch;
use crate::math::{Vec2, Vec3, PI};

const INV_SQRT_PI: f64 = 0.564_189_583_547_756_3;

/// D(m) = exp(-(x^2/au^2 + y^2/av^2) / z^2) / (pi au av z^4), for m.z > 0.
#[inline]
pub(super) fn d(m: Vec3, au: f32, av: f32) -> f32 {
    let z2 = m.z * m.z;
    let e = ((m.x / au).powi(2) + (m.y / av).powi(2)) / z2;
    (-e).exp() / (PI * au * av * z2 * z2)
}

/// G1 = 1 / (1 + Lambda) for the alpha-scaled tan^2 of the direction, Lambda(a) =
/// (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2 with a = 1 / (alpha tan theta).
#[inline]
pub(super) fn g1(tan2_alpha: f32) -> f32 {
    let a = 1.0 / (tan2_alpha as f64).sqrt();
    if a > 6.0 {
        // Lambda < 1e-18.
        return 1.0;
    }
    let lambda = 0.5 * ((-a * a).exp() * INV_SQRT_PI / a - libm::erfc(a));
    (1.0 / (1.0 + lambda.max(0.0))) as f32
}

/// A normal visible from `w`: in the space stretched to unit roughness, a visible slope
/// for the view rotated into the xz-plane, then rotated back and unstretched.
#[inline]
pub(super) fn sample_visible(w: Vec3, au: f32, av: f32, u: Vec2) -> Vec3 {
    let ws = stretch(w, au, av);
    let len = (ws.x * ws.x + ws.y * ws.y).sqrt();
    let (cos_phi, sin_phi) = if len > 0.0 {
        (ws.x / len, ws.y / len)
    } else {
        (1.0, 0.0)
    };
    let (sx, sy) = visible_slopes(ws.z as f64, u);
    let (sx, sy) = (sx as f32, sy as f32);
    let (rx, ry) = (cos_phi * sx - sin_phi * sy, sin_phi * sx + cos_phi * sy);
    Vec3::new(-au * rx, -av * ry, 1.0).normalize()
}

/// Slopes (x, y) of unit-roughness Beckmann facets visible from a direction at
/// `cos_theta` in the xz-plane (x towards the viewer). The facet normal is (-x, -y, 1),
/// so the projected area weights the slope density exp(-x^2 - y^2) / pi by
/// (1 - x tan theta) for x < cot theta; y is independent of x and normal.
fn visible_slopes(cos_theta: f64, u: Vec2) -> (f64, f64) {
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let tan = sin_theta / cos_theta;
    // The largest visible slope; beyond 10 the density is below 1e-43.
    let hi = if sin_theta > 0.0 {
        (cos_theta / sin_theta).min(10.0)
    } else {
        10.0
    };
    // Twice the CDF of x, unnormalised: erfc(-x) + tan exp(-x^2) / sqrt(pi); its
    // derivative 2 exp(-x^2) (1 - x tan) / sqrt(pi) is the density.
    let cdf = |x: f64| libm::erfc(-x) + tan * (-x * x).exp() * INV_SQRT_PI;
    let target = (u.x as f64).clamp(1e-7, 1.0 - 1e-7) * cdf(hi);
    let (mut lo, mut hi) = (-10.0f64, hi);
    let mut x = 0.0f64.clamp(lo, hi);
    for _ in 0..64 {
        let value = cdf(x) - target;
        if value > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let density = 2.0 * (-x * x).exp() * (1.0 - x * tan) * INV_SQRT_PI;
        let next = x - value / density;
        // Newton while it stays inside the bracket, bisection otherwise.
        let next = if next > lo && next < hi && next.is_finite() {
            next
        } else {
            0.5 * (lo + hi)
        };
        let done = (next - x).abs() <= 1e-9 * (1.0 + x.abs());
        x = next;
        if done || hi - lo <= 1e-12 {
            break;
        }
    }
    let y = erfinv(2.0 * (u.y as f64).clamp(1e-7, 1.0 - 1e-7) - 1.0);
    (x, y)
}

/// Inverse error function for |y| < 1: Winitzki's closed-form estimate (relative error
/// below 2e-3), polished by Newton steps on erf.
fn erfinv(y: f64) -> f64 {
    const A: f64 = 0.147;
    let l = (1.0 - y * y).ln();
    let b = 2.0 / (std::f64::consts::PI * A) + 0.5 * l;
    let mut x = ((b * b - l / A).sqrt() - b).sqrt().copysign(y);
    for _ in 0..4 {
        let step = (libm::erf(x) - y) / (2.0 * INV_SQRT_PI * (-x * x).exp());
        x -= step;
        if step.abs() <= 1e-13 * (1.0 + x.abs()) {
            break;
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erfinv_inverts_erf() {
        for y in [-0.999_999, -0.9, -0.3, 0.0, 1e-6, 0.5, 0.99, 0.999_999_8] {
            let x = erfinv(y);
            assert!(
                (libm::erf(x) - y).abs() < 1e-12,
                "erf(erfinv({y})) = {}",
                libm::erf(x)
            );
        }
    }

    #[test]
    fn g1_matches_walters_fit() {
        // Walter et al. 2007's rational fit of the same function, accurate to 0.35 %.
        for a in [0.1f64, 0.4, 0.9, 1.3, 1.59] {
            let fit = (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a);
            let exact = g1((1.0 / (a * a)) as f32) as f64;
            assert!((exact - fit).abs() < 0.004 * fit, "a {a}: {exact} vs {fit}");
        }
        assert_eq!(g1(1e-3), 1.0);
    }
}
