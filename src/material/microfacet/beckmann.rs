//! Beckmann: D, the exact Smith masking, and visible-normal sampling by inverting the
//! CDF of visible slopes (Heitz and d'Eon 2014, "Importance Sampling Microfacet-Based
//! BSDFs using the Distribution of Visible Normals"), in f32: a fitted first guess and
//! a few Newton steps safeguarded by bisection, as Mitsuba and pbrt do, but on the
//! slope itself rather than on its error function, so that the CDF keeps its relative
//! precision in both tails.
//!
//! Caustic's G1 is the exact erf form of Smith's Beckmann masking where Mitsuba 3 uses
//! Walter's rational fit (within 0.35 %): with the fit, the density of visible normals
//! would not integrate to one and sampling would disagree with `pdf`.

use super::erf::{erfcx, erfinv, INV_SQRT_PI};
use super::stretch;
use crate::math::{Vec2, Vec3, PI};

/// Slopes beyond this are never sampled: the visible-slope CDF is below 1e-15 at -6
/// for every view, and above 1 - 1e-15 at 6.
const SLOPE_MAX: f32 = 6.0;
/// Smallest and largest u: the slope CDF is inverted on [U_EDGE, 1 - U_EDGE].
const U_EDGE: f32 = 1e-7;
/// The Newton iteration stops once the CDF is this close to u (then takes one more
/// step, which it has already paid for).
const TOLERANCE: f32 = 1e-4;
/// Bound on the iterations; from the fitted guess three or fewer are the rule (over the
/// test grid of views and u: one in 3 %, two in 47 %, three in 50 %).
const MAX_STEPS: usize = 12;

/// D(m) = exp(-(x^2/au^2 + y^2/av^2) / z^2) / (pi au av z^4), for m.z > 0.
#[inline]
pub(super) fn d(m: Vec3, au: f32, av: f32) -> f32 {
    let z2 = m.z * m.z;
    let e = ((m.x / au).powi(2) + (m.y / av).powi(2)) / z2;
    (-e).exp() / (PI * au * av * z2 * z2)
}

/// G1 = 1 / (1 + Lambda) for the alpha-scaled tan^2 of the direction, Lambda(a) =
/// (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2 = exp(-a^2) (1 / (a sqrt(pi)) - erfcx(a)) / 2
/// with a = 1 / (alpha tan theta).
#[inline]
pub(super) fn g1(tan2_alpha: f32) -> f32 {
    let a = 1.0 / tan2_alpha.sqrt();
    if a > SLOPE_MAX {
        // Lambda < 1e-18.
        return 1.0;
    }
    let lambda = 0.5 * (-a * a).exp() * (INV_SQRT_PI / a - erfcx(a));
    1.0 / (1.0 + lambda.max(0.0))
}

/// A normal visible from `w`: in the space stretched to unit roughness, a visible slope
/// for the view rotated into the xz-plane, then rotated back and unstretched.
#[inline]
pub(super) fn sample_visible(w: Vec3, au: f32, av: f32, u: Vec2) -> Vec3 {
    let ws = stretch(w, au, av);
    let sin = (ws.x * ws.x + ws.y * ws.y).sqrt();
    let (cos_phi, sin_phi) = if sin > 0.0 {
        (ws.x / sin, ws.y / sin)
    } else {
        (1.0, 0.0)
    };
    let (sx, sy) = visible_slopes(ws.z.max(0.0), sin, u);
    let (rx, ry) = (cos_phi * sx - sin_phi * sy, sin_phi * sx + cos_phi * sy);
    Vec3::new(-au * rx, -av * ry, 1.0).normalize()
}

/// Slopes (x, y) of unit-roughness Beckmann facets visible from a direction at polar
/// angle theta (`cos`, `sin`) in the xz-plane, x towards the viewer. The facet normal
/// is (-x, -y, 1), so the projected area weights the slope density exp(-x^2 - y^2) / pi
/// by (1 - x tan theta) for x < cot theta; y is independent of x and normal.
fn visible_slopes(cos: f32, sin: f32, u: Vec2) -> (f32, f32) {
    let cdf = SlopeCdf { cos, sin };
    // The largest visible slope, cot theta.
    let top = if cos < SLOPE_MAX * sin {
        cos / sin
    } else {
        SLOPE_MAX
    };
    let ux = u.x.clamp(U_EDGE, 1.0 - U_EDGE);
    // C(top) (top >= 0) and erf(top) for the guess share exp(-top^2) and erfcx(top).
    let g_top = (-top * top).exp();
    let erfc_top = g_top * erfcx(top);
    let norm = 2.0 * cos + g_top * sin * INV_SQRT_PI - cos * erfc_top;
    let target = ux * norm;
    let (mut lo, mut hi) = (-SLOPE_MAX, top);
    let mut x = first_guess(cos, sin, ux, 1.0 - erfc_top).clamp(lo, hi);
    for _ in 0..MAX_STEPS {
        let (c, density) = cdf.eval(x);
        let value = c - target;
        if value > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let next = x - value / density;
        let converged = value.abs() <= TOLERANCE * norm;
        // Newton while it stays inside the bracket, bisection otherwise; a converged
        // x is kept where the density vanishes (at the top, seen at grazing angles).
        x = if next > lo && next < hi {
            next
        } else if converged {
            x
        } else {
            0.5 * (lo + hi)
        };
        if converged {
            break;
        }
    }
    (x, erfinv(2.0 * u.y - 1.0))
}

/// The unnormalised CDF of visible slopes, multiplied by cos theta so that it stays
/// finite at grazing angles: C(x) = cos erfc(-x) + sin exp(-x^2) / sqrt(pi), with the
/// density C'(x) = 2 exp(-x^2) (cos - x sin) / sqrt(pi).
struct SlopeCdf {
    cos: f32,
    sin: f32,
}

impl SlopeCdf {
    /// (C(x), C'(x)), sharing one exponential: erfc(|x|) = exp(-x^2) erfcx(|x|), and
    /// erfc(-x) = 2 - erfc(x) for x > 0.
    #[inline]
    fn eval(&self, x: f32) -> (f32, f32) {
        let g = (-x * x).exp();
        let tail = self.cos * erfcx(x.abs());
        let view = self.sin * INV_SQRT_PI;
        let c = if x < 0.0 {
            g * (view + tail)
        } else {
            2.0 * self.cos + g * (view - tail)
        };
        (c, 2.0 * INV_SQRT_PI * g * (self.cos - x * self.sin))
    }
}

/// A first slope for the Newton iteration, from Jakob's fit of the inverse CDF in the
/// error-function domain (W. Jakob, "An Improved Visible Normal Sampling Routine for
/// the Beckmann Distribution", 2014, as in Mitsuba 0.5 and pbrt-v3):
/// erf(x) = m - (1 + m) (1 - u)^p(theta), m = erf(cot theta), p a cubic in theta.
/// Exact at normal incidence (p = 1, x = erfinv(2u - 1)).
#[inline]
fn first_guess(cos: f32, sin: f32, u: f32, m: f32) -> f32 {
    let theta = polar_angle(cos, sin);
    let p = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta));
    erfinv(m - (1.0 + m) * (1.0 - u).powf(p))
}

/// atan2(sin, cos) for sin, cos >= 0 (not both zero), within 6e-4 rad, which is all a
/// first guess needs: an odd cubic in r = min / max (a least-squares fit of atan on
/// [0, 1], reweighted towards minimax) and atan(r) = pi/2 - atan(1/r).
#[inline]
fn polar_angle(cos: f32, sin: f32) -> f32 {
    let steep = sin > cos;
    let r = if steep { cos / sin } else { sin / cos };
    let r2 = r * r;
    let a = r * (0.995_358 + r2 * (-0.288_69 + r2 * 0.079_338_74));
    if steep {
        std::f32::consts::FRAC_PI_2 - a
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sampled slope's CDF, in f64 with libm's erfc, at the sample: it must give
    /// back u, over a grid of views from normal to grazing and of u including 0 and 1.
    #[test]
    fn slope_sampler_inverts_its_cdf() {
        let mut worst = (0.0f64, 0.0, 0.0);
        let cosines = [
            0.0, 1e-6, 1e-3, 0.01, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 0.99, 1.0,
        ];
        let angles = (0..=90).map(|d| (d as f64).to_radians().cos());
        for cos in cosines.into_iter().chain(angles) {
            let sin = (1.0 - cos * cos).sqrt();
            let cdf =
                |x: f64| cos * libm::erfc(-x) + sin * (-x * x).exp() / std::f64::consts::PI.sqrt();
            let top = if sin > 0.0 { (cos / sin).min(6.0) } else { 6.0 };
            for i in 0..=1000 {
                let u = i as f32 / 1000.0;
                let (x, y) = visible_slopes(cos as f32, sin as f32, Vec2::new(u, u));
                assert!(x.is_finite() && y.is_finite(), "cos {cos} u {u}: {x} {y}");
                assert!(x as f64 <= top + 1e-6, "cos {cos} u {u}: {x} above {top}");
                let u_used = u.clamp(U_EDGE, 1.0 - U_EDGE) as f64;
                let err = (cdf(x as f64) / cdf(top) - u_used).abs();
                if err > worst.0 {
                    worst = (err, cos, u as f64);
                }
            }
        }
        assert!(worst.0 < 1e-5, "CDF error {worst:?} (error, cos, u)");
    }

    #[test]
    fn polar_angle_is_close_to_atan2() {
        for i in 0..=10_000 {
            let t = i as f32 * std::f32::consts::FRAC_PI_2 / 10_000.0;
            let (sin, cos) = t.sin_cos();
            let err = (polar_angle(cos.max(0.0), sin) - t).abs();
            assert!(err < 7e-4, "theta {t}: error {err}");
        }
    }

    #[test]
    fn g1_matches_the_exact_form() {
        for i in 1..2000 {
            let a = i as f64 * 0.004;
            let lambda = 0.5 * ((-a * a).exp() / (a * std::f64::consts::PI.sqrt()) - libm::erfc(a));
            let exact = 1.0 / (1.0 + lambda);
            let got = g1((1.0 / (a * a)) as f32) as f64;
            assert!((got - exact).abs() < 1e-6, "a {a}: {got} vs {exact}");
        }
        assert_eq!(g1(f32::INFINITY), 0.0);
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
