//! Vectors (glam), colours, orthonormal frames, sample warps and the deterministic RNG.

pub mod frame;
pub mod rng;
pub mod warp;

pub use frame::Frame;
pub use glam::{vec2, vec3, Mat3, Mat4, Quat, Vec2, Vec3, Vec3A};
pub use rng::Rng;

/// Linear RGB radiance or reflectance: three independent channels.
pub type Rgb = Vec3;

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
pub const INV_2PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
pub const INV_4PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

/// Rec. 709 luminance of a linear RGB value.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
}

#[inline]
pub fn max_component(c: Rgb) -> f32 {
    c.x.max(c.y).max(c.z)
}

/// Power heuristic with beta = 2, written so that it never divides by zero. Squares
/// of densities above ~1.8e19 (a small light far away) overflow f32: those cases go
/// through the ratio of the two, so the answer is never inf / inf.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    let sum = a + b;
    if sum > 0.0 && sum.is_finite() {
        a / sum
    } else if pdf_a > pdf_b {
        let r = pdf_b / pdf_a;
        1.0 / (1.0 + r * r)
    } else if pdf_b > pdf_a {
        let r = pdf_a / pdf_b;
        r * r / (1.0 + r * r)
    } else if pdf_a > 0.0 {
        0.5
    } else {
        0.0
    }
}

/// Balance heuristic, safe against 0/0.
#[inline]
pub fn balance_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    if pdf_a + pdf_b > 0.0 {
        pdf_a / (pdf_a + pdf_b)
    } else {
        0.0
    }
}

/// Converts a solid-angle density at a point seen from distance `dist2.sqrt()` under
/// cosine `cos` into an area density: p_A = p_w |cos| / d^2 (Veach 1997, eq. 8.10).
#[inline]
pub fn pdf_w_to_a(pdf_w: f32, dist2: f32, cos: f32) -> f32 {
    pdf_w * cos.abs() / dist2
}

/// The smallest f32 greater than `v` (pbrt-v4's NextFloatUp).
#[inline]
pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v >= 0.0 { bits + 1 } else { bits - 1 };
    f32::from_bits(bits)
}

/// The largest f32 smaller than `v`.
#[inline]
pub fn next_float_down(v: f32) -> f32 {
    if v.is_infinite() && v < 0.0 {
        return v;
    }
    let v = if v == 0.0 { -0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v > 0.0 { bits - 1 } else { bits + 1 };
    f32::from_bits(bits)
}

/// Conservative bound on the relative error of n chained f32 operations (pbrt-v4 gamma(n)).
#[inline]
pub const fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5;
    (n as f32 * e) / (1.0 - n as f32 * e)
}

/// x^n for the cosine-power lobes (x in [0, 1], n >= 0). Whole exponents, the usual
/// case, go by repeated squaring: at most twenty multiplications with a relative error
/// of about n / 2 ulp (under 3e-6 for n = 90), several times cheaper than `powf`,
/// which takes the other exponents.
#[inline(always)]
pub fn pow_lobe(x: f32, n: f32) -> f32 {
    if (0.0..=1024.0).contains(&n) && n == n.trunc() {
        let mut k = n as u32;
        let (mut base, mut acc) = (x, 1.0f32);
        while k > 0 {
            if k & 1 != 0 {
                acc *= base;
            }
            base *= base;
            k >>= 1;
        }
        acc
    } else {
        x.powf(n)
    }
}

/// Reflects `w` about `n` (both pointing away from the surface).
#[inline]
pub fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    2.0 * w.dot(n) * n - w
}

/// sqrt that treats tiny negative rounding as zero.
#[inline]
pub fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// True when every channel is finite and non-negative.
#[inline]
pub fn is_valid_radiance(c: Rgb) -> bool {
    c.is_finite() && c.x >= 0.0 && c.y >= 0.0 && c.z >= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Densities whose squares overflow f32 still give the heuristic's value (found by
    /// the property test: a 1e-3 disk light lighting a floor 1e7 away gave NaN).
    #[test]
    fn power_heuristic_survives_densities_whose_squares_overflow() {
        for (a, b) in [
            (1e20f32, 1e19f32),
            (3e25, 3e25),
            (1e30, 1.0),
            (f32::INFINITY, 2.0),
        ] {
            let exact = |a: f64, b: f64| 1.0 / (1.0 + (b / a).powi(2));
            let w = power_heuristic(a, b);
            let w2 = power_heuristic(b, a);
            assert!(
                (w as f64 - exact(a as f64, b as f64)).abs() < 1e-6,
                "{a} {b}: {w}"
            );
            assert!((w + w2 - 1.0).abs() < 1e-6, "{a} {b}: {w} + {w2}");
        }
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(0.0, 1e30), 0.0);
        assert_eq!(power_heuristic(0.5, 0.5), 0.5);
    }

    #[test]
    fn pow_lobe_matches_double_precision_powers() {
        let mut rng = Rng::new(5, 0, 0);
        for n in [0.0f32, 1.0, 2.0, 7.0, 90.0, 1000.0, 2.5, 3000.0] {
            for _ in 0..2000 {
                let x = rng.next_f32();
                let exact = (x as f64).powf(n as f64);
                let got = pow_lobe(x, n) as f64;
                let tol = (n as f64 / 2.0 + 2.0) * f32::EPSILON as f64 * exact + 1e-37;
                assert!((got - exact).abs() <= tol, "{x}^{n}: {got} vs {exact}");
            }
        }
        assert_eq!(pow_lobe(0.0, 90.0), 0.0);
        assert_eq!(pow_lobe(1.0, 90.0), 1.0);
        assert_eq!(pow_lobe(0.3, 0.0), 1.0);
    }
}
