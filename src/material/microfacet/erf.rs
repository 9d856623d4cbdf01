//! The error functions Beckmann sampling and masking need, in f32 and without branches
//! on the hot path: the scaled complementary error function erfcx(z) = exp(z^2) erfc(z)
//! (so that erfc and the Gaussian exp(-z^2) share one exponential) and erfinv.

/// 1 / sqrt(pi).
pub(super) const INV_SQRT_PI: f32 = 0.564_189_6;

/// The largest f32 below one: erfinv's argument is clamped to it, so that u = 0 or 1
/// gives a finite slope (erfinv(1 - 2^-24) = 3.9).
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// exp(z^2) erfc(z) for z >= 0, as t Q(t) with t = 1 / (1 + 0.4 z) in (0, 1]: as z
/// grows erfcx(z) tends to 1 / (sqrt(pi) z) = t 0.4 / sqrt(pi) + O(t^2), so Q is smooth
/// on [0, 1]. Q is a degree-8 polynomial fitted for relative error (least squares in
/// f64 against exp(z^2) erfc(z) on Chebyshev nodes in t, reweighted towards minimax);
/// evaluated in f32 its relative error is below 5e-7 for all z >= 0 (the tests).
#[inline]
pub(super) fn erfcx(z: f32) -> f32 {
    const Q: [f32; 9] = [
        0.050_259_82,
        -0.182_892_63,
        0.169_071_76,
        -0.005_596_613,
        0.141_426_64,
        0.168_543_1,
        0.207_842_57,
        0.225_669_6,
        0.225_675_87,
    ];
    let t = 1.0 / (1.0 + 0.4 * z);
    horner(t, &Q) * t
}

/// Inverse error function on (-1, 1) (the argument clamped to it), by Giles' single
/// precision approximation (M. Giles 2010, "Approximating the erfinv function", GPU
/// Computing Gems Jade ed.): a polynomial in w = -ln(1 - x^2) for the centre and in
/// sqrt(w) for the tails, relative error about 4e-7.
#[inline]
pub(super) fn erfinv(x: f32) -> f32 {
    let x = x.clamp(-ONE_BELOW, ONE_BELOW);
    let w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        let w = w - 2.5;
        horner(
            w,
            &[
                2.810_226_4e-8,
                3.432_739_4e-7,
                -3.523_387_7e-6,
                -4.391_506_5e-6,
                2.185_808_8e-4,
                -1.253_725e-3,
                -4.177_681_6e-3,
                2.466_407_5e-1,
                1.501_409_4,
            ],
        )
    } else {
        let w = w.sqrt() - 3.0;
        horner(
            w,
            &[
                -2.002_142_6e-4,
                1.009_505_6e-4,
                1.349_343_2e-3,
                -3.673_428_4e-3,
                5.739_507_7e-3,
                -7.622_461_3e-3,
                9.438_870_5e-3,
                1.001_674_3,
                2.832_976_8,
            ],
        )
    };
    p * x
}

/// c[0] w^n + ... + c[n], by Horner's rule (without `mul_add`: the build targets
/// x86-64 without FMA, where it is a library call).
#[inline]
fn horner(w: f32, c: &[f32]) -> f32 {
    c[1..].iter().fold(c[0], |p, &k| p * w + k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erfcx_has_small_relative_error() {
        let mut worst = 0.0f64;
        for i in 0..=200_000 {
            // Dense on [0, 8], then geometric out to 1e4.
            let z = if i <= 100_000 {
                i as f64 * 8e-5
            } else {
                8.0 * 1250f64.powf((i - 100_000) as f64 / 100_000.0)
            };
            let exact = if z < 20.0 {
                (z * z).exp() * libm::erfc(z)
            } else {
                // Asymptotic series, exact to 1e-11 here.
                let s = 1.0 / (2.0 * z * z);
                (1.0 - s + 3.0 * s * s - 15.0 * s * s * s) / (z * std::f64::consts::PI.sqrt())
            };
            let rel = (erfcx(z as f32) as f64 / exact - 1.0).abs();
            worst = worst.max(rel);
        }
        assert!(worst < 6e-7, "relative error {worst}");
    }

    #[test]
    fn erfinv_inverts_erf() {
        for i in 1..20_000 {
            let y = -1.0 + i as f64 * 1e-4;
            let x = erfinv(y as f32) as f64;
            // x's relative error 4e-7 moves erf(x) by erf'(x) 4e-7 |x|; y's rounding to
            // f32 adds 6e-8.
            let back = libm::erf(x);
            let tol = 1e-7 + 1e-6 * x.abs() * (-x * x).exp();
            assert!((back - y).abs() < tol, "erf(erfinv({y})) = {back}");
        }
        for u in [0.0f32, 1.0, -1.0, f32::EPSILON] {
            assert!(erfinv(u).is_finite());
        }
        assert_eq!(erfinv(0.0), 0.0);
        assert!((erfinv(1.0) - 3.9).abs() < 0.1);
    }
}
