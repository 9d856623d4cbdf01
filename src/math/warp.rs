//! Warps from the unit square to directions and points, each with its density.

use super::{pow_lobe, safe_sqrt, INV_2PI, INV_4PI, INV_PI, PI};
use glam::{Vec2, Vec3};

/// Shirley-Chiu concentric map to the unit disk (area preserving, low distortion).
#[inline]
pub fn square_to_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    // The angle is pi/4 (y/x), or pi/2 - pi/4 (x/y) whose cosine and sine are the
    // sine and cosine of pi/4 (x/y): either way a sine and cosine within [-pi/4, pi/4].
    if o.x.abs() > o.y.abs() {
        let (s, c) = sin_cos_quarter((PI / 4.0) * (o.y / o.x));
        o.x * Vec2::new(c, s)
    } else {
        let (s, c) = sin_cos_quarter((PI / 4.0) * (o.x / o.y));
        o.y * Vec2::new(s, c)
    }
}

/// Sine and cosine for |x| <= pi/4 by their Taylor series, cut where the next term is
/// below 2e-9 (under f32 rounding), evaluated by Horner's rule. Sampling every camera
/// path's bounce calls this, and libm's general `sincosf` (range reduction, call)
/// cost several percent of render time.
#[inline]
pub fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let x2 = x * x;
    let s = x
        * (1.0
            + x2 * (-1.0 / 6.0
                + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0)))));
    let c = 1.0
        + x2 * (-0.5
            + x2 * (1.0 / 24.0
                + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0 + x2 * (-1.0 / 3_628_800.0)))));
    (s, c)
}

/// Sine and cosine of 2 pi u for u in [0, 1] (a sampled azimuth): the nearest
/// quarter turn q / 4 is taken off exactly (4 u - q is exact in f32), the rest is an
/// angle within [-pi/4, pi/4] for [`sin_cos_quarter`], and the quarter turn is a swap
/// and sign changes. Inlined where libm's `sincosf` is a call compiled for baseline
/// x86 (3-4% of `pt` on SmallVCM's sky scene).
#[inline(always)]
pub fn sin_cos_2pi(u: f32) -> (f32, f32) {
    let q = (4.0 * u).round();
    let (s, c) = sin_cos_quarter((PI / 2.0) * (4.0 * u - q));
    match q as i32 & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Cosine-weighted hemisphere about +z (Malley's method).
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_disk(u);
    let z = safe_sqrt(1.0 - d.length_squared());
    Vec3::new(d.x, d.y, z)
}

#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * INV_PI
}

#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = safe_sqrt(1.0 - z * z);
    let (sin_phi, cos_phi) = sin_cos_2pi(u.y);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

pub const UNIFORM_SPHERE_PDF: f32 = INV_4PI;

/// Uniform directions in the cone of half-angle acos(cos_max) about +z.
#[inline]
pub fn square_to_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos_t = 1.0 - u.x * (1.0 - cos_max);
    let sin_t = safe_sqrt(1.0 - cos_t * cos_t);
    let (sin_phi, cos_phi) = sin_cos_2pi(u.y);
    Vec3::new(sin_t * cos_phi, sin_t * sin_phi, cos_t)
}

#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    INV_2PI / (1.0 - cos_max)
}

/// Directions about +z with density (n+1)/(2 pi) cos^n (Phong lobe).
#[inline]
pub fn square_to_cosine_power(u: Vec2, exponent: f32) -> Vec3 {
    let cos_t = u.x.powf(1.0 / (exponent + 1.0));
    let sin_t = safe_sqrt(1.0 - cos_t * cos_t);
    let (sin_phi, cos_phi) = sin_cos_2pi(u.y);
    Vec3::new(sin_t * cos_phi, sin_t * sin_phi, cos_t)
}

#[inline]
pub fn cosine_power_pdf(cos_theta: f32, exponent: f32) -> f32 {
    if cos_theta <= 0.0 {
        0.0
    } else {
        (exponent + 1.0) * INV_2PI * pow_lobe(cos_theta, exponent)
    }
}

/// Uniform barycentrics (b1, b2) on a triangle (Heitz 2019's low-distortion map).
#[inline]
pub fn square_to_triangle(u: Vec2) -> Vec2 {
    let (b0, b1);
    if u.x < u.y {
        b0 = u.x / 2.0;
        b1 = u.y - b0;
    } else {
        b1 = u.y / 2.0;
        b0 = u.x - b1;
    }
    Vec2::new(b1, 1.0 - b0 - b1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quarter_sin_cos_agrees_with_libm() {
        for i in -10_000..=10_000 {
            let x = (PI / 4.0) * (i as f32 / 10_000.0);
            let (s, c) = sin_cos_quarter(x);
            let (s64, c64) = (x as f64).sin_cos();
            assert!((s as f64 - s64).abs() < 2e-7, "sin {x}: {s} vs {s64}");
            assert!((c as f64 - c64).abs() < 2e-7, "cos {x}: {c} vs {c64}");
        }
        // Points on the disk's boundary stay on it.
        for u in [0.0f32, 0.1, 0.37, 0.5, 0.81, 1.0] {
            let p = square_to_disk(Vec2::new(1.0, u));
            assert!((p.length() - 1.0).abs() < 3e-7, "{p}");
        }
    }

    #[test]
    fn full_turn_sin_cos_agrees_with_libm() {
        let mut worst = 0.0f64;
        for i in 0..=100_000 {
            let u = i as f32 / 100_000.0;
            let (s, c) = sin_cos_2pi(u);
            let (s64, c64) = (2.0 * std::f64::consts::PI * u as f64).sin_cos();
            worst = worst
                .max((s as f64 - s64).abs())
                .max((c as f64 - c64).abs());
        }
        // Within a few f32 ulps of 1 everywhere, quarter-turn boundaries included.
        assert!(worst < 3e-7, "worst error {worst}");
        let largest_below_one = 1.0 - f32::EPSILON / 2.0;
        for u in [
            0.0f32,
            0.125,
            0.25,
            0.375,
            0.5,
            0.625,
            0.75,
            0.875,
            largest_below_one,
        ] {
            let (s, c) = sin_cos_2pi(u);
            let (s64, c64) = (2.0 * std::f64::consts::PI * u as f64).sin_cos();
            assert!(
                (s as f64 - s64).abs() < 3e-7 && (c as f64 - c64).abs() < 3e-7,
                "{u}"
            );
        }
    }

    #[test]
    fn warps_land_in_their_domains() {
        let mut rng = crate::math::Rng::new(3, 0, 0);
        for _ in 0..10_000 {
            let u = rng.next_2d();
            assert!(square_to_disk(u).length() <= 1.0 + 1e-6);
            let h = square_to_cosine_hemisphere(u);
            assert!(h.z >= 0.0 && (h.length() - 1.0).abs() < 1e-5);
            let c = square_to_uniform_cone(u, 0.9);
            assert!(c.z >= 0.9 - 1e-6);
            let b = square_to_triangle(u);
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
        }
    }
}
