//! Fresnel equations for dielectrics and conductors (unpolarised light).

use crate::math::{safe_sqrt, Rgb, Vec3};

/// Dielectric Fresnel reflectance for incidence cosine `cos_i` (signed: negative means
/// the incident direction is inside) and relative IOR `eta` = interior / exterior.
/// Returns (R, cos_t) with cos_t signed to lie on the opposite side of `cos_i`, and the
/// ratio eta_ti = n_incident / n_transmitted used by the refraction formula.
#[inline]
pub fn dielectric(cos_i: f32, eta: f32) -> (f32, f32, f32) {
    if eta == 1.0 {
        return (0.0, -cos_i, 1.0);
    }
    let outside = cos_i >= 0.0;
    let (eta_it, eta_ti) = if outside {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let cos_t2 = 1.0 - eta_ti * eta_ti * (1.0 - cos_i * cos_i);
    let ci = cos_i.abs();
    if cos_t2 <= 0.0 {
        return (1.0, 0.0, eta_ti);
    }
    let ct = cos_t2.sqrt();
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    let r = 0.5 * (a_s * a_s + a_p * a_p);
    (r, if outside { -ct } else { ct }, eta_ti)
}

/// Conductor Fresnel reflectance with complex IOR eta + i k, per channel (exact
/// unpolarised formula, as in Mitsuba 3's `fresnel_conductor`).
#[inline]
pub fn conductor(cos_i: f32, eta: Rgb, k: Rgb) -> Rgb {
    let f = |eta: f32, k: f32| {
        let c2 = cos_i * cos_i;
        let s2 = 1.0 - c2;
        let s4 = s2 * s2;
        let t1 = eta * eta - k * k - s2;
        let a2b2 = safe_sqrt(t1 * t1 + 4.0 * k * k * eta * eta);
        let a = safe_sqrt(0.5 * (a2b2 + t1));
        let term1 = a2b2 + c2;
        let term2 = 2.0 * cos_i * a;
        let rs = (term1 - term2) / (term1 + term2);
        let term3 = a2b2 * c2 + s4;
        let term4 = term2 * s2;
        let rp = rs * (term3 - term4) / (term3 + term4);
        (0.5 * (rs + rp)).clamp(0.0, 1.0)
    };
    Rgb::new(f(eta.x, k.x), f(eta.y, k.y), f(eta.z, k.z))
}

/// `w` refracted through an interface of normal `m`, given the `cos_t` and `eta_ti`
/// that `dielectric(w.m, eta)` returned: -eta_ti w + (eta_ti (w.m) + cos_t) m.
#[inline]
pub fn refract(w: Vec3, m: Vec3, cos_t: f32, eta_ti: f32) -> Vec3 {
    m * (w.dot(m) * eta_ti + cos_t) - w * eta_ti
}

/// Diffuse Fresnel reflectance: the Fresnel reflectance for relative IOR `eta` averaged
/// over cosine-weighted incidence, by the fits Mitsuba 3 uses (`fresnel_diffuse_reflectance`):
/// Egan and Hilgeman 1973 for eta < 1, d'Eon and Irving 2011 ("A quantized-diffusion
/// model for rendering translucent materials", eq. 35) otherwise.
pub fn diffuse_reflectance(eta: f32) -> f32 {
    if eta < 1.0 {
        0.0636 / eta + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        let x = 1.0 / eta;
        let c = [0.919317, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881];
        c.iter().rev().fold(0.0, |acc, &k| acc * x + k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_normal_incidence_and_total_internal_reflection() {
        let (r, ct, _) = dielectric(1.0, 1.5);
        assert!((r - 0.04).abs() < 1e-6);
        assert!((ct + 1.0).abs() < 1e-6);
        // From inside glass at 60 degrees: beyond the critical angle (41.8 deg).
        let (r, _, _) = dielectric(-0.5, 1.5);
        assert_eq!(r, 1.0);
        // Reciprocity of the interface: the same R from both sides along a refracted pair.
        let (r1, ct, _) = dielectric(0.8, 1.5);
        let (r2, _, _) = dielectric(ct, 1.5);
        assert!((r1 - r2).abs() < 1e-5);
    }

    /// The fits against cosine-weighted quadrature of the exact Fresnel reflectance,
    /// 2 int R(mu) mu dmu, within the accuracy their authors give (0.1 to 0.6 %).
    #[test]
    fn diffuse_reflectance_matches_quadrature() {
        for eta in [1.0 / 1.8f32, 1.0 / 1.5, 1.0 / 1.33, 1.33, 1.5, 1.8] {
            let n = 200_000;
            let q: f64 = (0..n)
                .map(|i| {
                    let mu = (i as f64 + 0.5) / n as f64;
                    2.0 * dielectric(mu as f32, eta).0 as f64 * mu / n as f64
                })
                .sum();
            let fit = diffuse_reflectance(eta) as f64;
            assert!(
                (fit - q).abs() < 0.007 * q,
                "eta {eta}: fit {fit}, quadrature {q}"
            );
        }
    }

    #[test]
    fn conductor_reduces_to_dielectric_when_k_is_zero() {
        for &c in &[0.05f32, 0.3, 0.7, 1.0] {
            let rc = conductor(c, Rgb::splat(1.5), Rgb::ZERO).x;
            let (rd, _, _) = dielectric(c, 1.5);
            assert!((rc - rd).abs() < 1e-4, "cos {c}: {rc} vs {rd}");
        }
    }
}
