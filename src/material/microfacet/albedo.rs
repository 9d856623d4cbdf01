//! Directional albedos of a rough dielectric interface, by the quadrature Mitsuba 3's
//! `roughplastic` uses to tabulate them (`eval_transmittance`, `eval_reflectance`):
//! a Gauss-Legendre rule over the unit square of visible-normal samples, so that the
//! integrand is the sampled weight, (1 - F) G1 or F G1, and the rule integrates it
//! against the density of visible normals.

use super::Microfacet;
use crate::material::fresnel;
use crate::math::{reflect, Vec2, Vec3};

/// Nodes on [0, 1] and weights (summing to one) of the `n`-point Gauss-Legendre rule,
/// by Newton's method on the Legendre polynomial P_n from Chebyshev starting points.
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                // P_n(x) and P_n'(x) by the three-term recurrence.
                let (mut p0, mut p1) = (1.0f64, x);
                for k in 2..=n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let step = p1 / dp;
                x -= step;
                if step.abs() < 1e-15 {
                    break;
                }
            }
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            (0.5 * x + 0.5, 0.5 * w)
        })
        .collect()
}

/// Mitsuba's resolution of the rule: finer when light leaves the denser side, where
/// total internal reflection makes the integrand discontinuous.
fn rule(eta: f32) -> Vec<(f64, f64)> {
    gauss_legendre(if eta > 1.0 { 32 } else { 128 })
}

/// Integral of `weight(m)` over the normals visible from `w`, by the product rule.
fn integrate(d: &Microfacet, w: Vec3, eta: f32, weight: impl Fn(Vec3) -> f64) -> f64 {
    let nodes = rule(eta);
    let mut sum = 0.0;
    for &(x, wx) in &nodes {
        for &(y, wy) in &nodes {
            let m = d.sample_visible(w, Vec2::new(x as f32, y as f32));
            sum += wx * wy * weight(m);
        }
    }
    sum
}

/// Fraction of the light arriving from `w` (w.z > 0) that refracts through the
/// interface of relative IOR `eta` on a single scattering event.
pub fn transmittance(d: &Microfacet, w: Vec3, eta: f32) -> f32 {
    integrate(d, w, eta, |m| {
        let (f, cos_t, eta_ti) = fresnel::dielectric(w.dot(m), eta);
        let t = fresnel::refract(w, m, cos_t, eta_ti);
        if t.z * w.z >= 0.0 {
            return 0.0;
        }
        ((1.0 - f) * d.g1(t, m)) as f64
    }) as f32
}

/// Fraction of the light arriving from `w` (w.z > 0) that reflects off the interface
/// of relative IOR `eta` on a single scattering event.
pub fn reflectance(d: &Microfacet, w: Vec3, eta: f32) -> f32 {
    integrate(d, w, eta, |m| {
        let r = reflect(w, m);
        if r.z <= 0.0 {
            return 0.0;
        }
        (fresnel::dielectric(w.dot(m), eta).0 * d.g1(r, m)) as f64
    }) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::microfacet::Distribution;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in [5, 32, 128] {
            let nodes = gauss_legendre(n);
            let w: f64 = nodes.iter().map(|p| p.1).sum();
            assert!((w - 1.0).abs() < 1e-13, "n {n}: weights sum to {w}");
            // int_0^1 x^9 dx = 1/10, exact for n >= 5.
            let i: f64 = nodes.iter().map(|&(x, w)| w * x.powi(9)).sum();
            assert!((i - 0.1).abs() < 1e-13, "n {n}: {i}");
        }
    }

    /// A nearly smooth interface reflects and transmits what Fresnel says, and the two
    /// sum to at most one (the rest is the light single scattering loses).
    #[test]
    fn albedos_of_a_nearly_smooth_interface_are_fresnel() {
        let d = Microfacet::new(Distribution::Beckmann, 0.01, 0.01);
        for cos in [0.2f32, 0.6, 1.0] {
            let w = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
            let (t, r) = (transmittance(&d, w, 1.5), reflectance(&d, w, 1.5));
            let f = fresnel::dielectric(cos, 1.5).0;
            assert!(
                (r - f).abs() < 2e-3 && (t - (1.0 - f)).abs() < 2e-3,
                "{cos}: {r} {t}"
            );
        }
        let rough = Microfacet::new(Distribution::Ggx, 0.5, 0.5);
        let w = Vec3::new(0.8, 0.0, 0.6);
        let sum = transmittance(&rough, w, 1.5) + reflectance(&rough, w, 1.5);
        assert!(sum > 0.9 && sum <= 1.0, "{sum}");
    }
}
