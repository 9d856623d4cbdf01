//! Phase functions. Every one here is sampled exactly (its sample density equals its
//! value), so a phase-sampled direction carries weight 1.
//!
//! Convention: `d` is the direction light travels before scattering (the ray's
//! direction) and `wi` the direction after it; mu = d . wi is the cosine of the
//! scattering angle, so mu = 1 is straight on (forward scattering).

use crate::math::{Frame, Vec2, Vec3, INV_4PI, PI};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    Isotropic,
    /// Henyey and Greenstein (1941), asymmetry g in (-1, 1).
    HenyeyGreenstein {
        g: f32,
    },
    /// Schlick's rational approximation of Henyey-Greenstein (Blasi et al. 1993),
    /// k in (-1, 1); k = 1.55 g - 0.55 g^3 mimics HG with parameter g.
    Schlick {
        k: f32,
    },
    /// Scattering by particles much smaller than the wavelength: 3/(16 pi) (1 + mu^2).
    Rayleigh,
}

/// Below this |g| Henyey-Greenstein is sampled as isotropic (the inversion formula
/// divides by g).
const HG_ISOTROPIC: f64 = 1e-4;

impl Phase {
    /// Value (= sampling density per steradian) for scattering from `d` into `wi`.
    #[inline(always)]
    pub fn eval(&self, d: Vec3, wi: Vec3) -> f32 {
        self.eval_mu(d.dot(wi).clamp(-1.0, 1.0))
    }

    /// Value as a function of the cosine of the scattering angle.
    #[inline]
    pub fn eval_mu(&self, mu: f32) -> f32 {
        match *self {
            Phase::Isotropic => INV_4PI,
            Phase::HenyeyGreenstein { g } => hg(mu as f64, g as f64) as f32,
            Phase::Schlick { k } => {
                let den = 1.0 - k * mu;
                (1.0 - k * k) * INV_4PI / (den * den)
            }
            Phase::Rayleigh => 3.0 / (16.0 * PI) * (1.0 + mu * mu),
        }
    }

    /// Samples the direction after scattering; returns it with its density.
    #[inline(always)]
    pub fn sample(&self, d: Vec3, u: Vec2) -> (Vec3, f32) {
        let mu = self.sample_mu(u.x);
        let sin = (1.0 - mu * mu).max(0.0).sqrt();
        let (s, c) = crate::math::warp::sin_cos_2pi(u.y);
        let wi = Frame::from_normal(d).to_world(Vec3::new(sin * c, sin * s, mu));
        (wi, self.eval_mu(mu))
    }

    /// Inverse of the cumulative distribution of mu over [-1, 1].
    #[inline]
    fn sample_mu(&self, u: f32) -> f32 {
        let mu = match *self {
            Phase::Isotropic => 2.0 * u - 1.0,
            Phase::HenyeyGreenstein { g } => sample_hg(u as f64, g as f64) as f32,
            // F(mu) = (1 - k^2) / (2k) [1 / (1 - k mu) - 1 / (1 + k)] solved for mu;
            // this form has no division by k.
            Phase::Schlick { k } => (2.0 * u + k - 1.0) / (2.0 * k * u + 1.0 - k),
            Phase::Rayleigh => {
                // F(mu) = u is the cubic mu^3 + 3 mu = 8u - 4, whose one real root is
                // A - 1/A with A^3 = c/2 + sqrt(c^2/4 + 1) (Cardano).
                let c = 8.0 * u as f64 - 4.0;
                let a = (0.5 * c + (0.25 * c * c + 1.0).sqrt()).cbrt();
                (a - 1.0 / a) as f32
            }
        };
        mu.clamp(-1.0, 1.0)
    }

    /// The mean cosine of the scattering angle.
    pub fn mean_cosine(&self) -> f32 {
        match *self {
            Phase::Isotropic | Phase::Rayleigh => 0.0,
            Phase::HenyeyGreenstein { g } => g,
            // Integral of mu over the Schlick lobe, in closed form.
            Phase::Schlick { k } => {
                if k.abs() < 1e-4 {
                    return 2.0 * k / 3.0;
                }
                let k = k as f64;
                let l = ((1.0 + k) / (1.0 - k)).ln();
                (1.0 / k - (1.0 - k * k) / (2.0 * k * k) * l) as f32
            }
        }
    }
}

/// Henyey-Greenstein in f64: at |g| near 1 the lobe is a narrow spike and f32 loses
/// the 1 + g^2 - 2 g mu difference.
#[inline]
fn hg(mu: f64, g: f64) -> f64 {
    let den = 1.0 + g * g - 2.0 * g * mu;
    (1.0 - g * g) / (4.0 * std::f64::consts::PI * den * den.sqrt())
}

#[inline]
fn sample_hg(u: f64, g: f64) -> f64 {
    if g.abs() < HG_ISOTROPIC {
        return 2.0 * u - 1.0;
    }
    // Inverse CDF, written in terms of 1 - u so that u -> 1 gives the forward peak
    // for g > 0 (pbrt-v4 and Mitsuba use the same inversion).
    let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn phases() -> Vec<Phase> {
        vec![
            Phase::Isotropic,
            Phase::HenyeyGreenstein { g: 0.7 },
            Phase::HenyeyGreenstein { g: -0.3 },
            Phase::HenyeyGreenstein { g: 0.99 },
            Phase::HenyeyGreenstein { g: -0.99 },
            Phase::Schlick { k: 0.8 },
            Phase::Schlick { k: -0.5 },
            Phase::Rayleigh,
        ]
    }

    /// Integral of the value over the sphere, by quadrature in mu (2 pi from phi).
    fn integral(p: &Phase) -> f64 {
        // mu = +-(1 - x^4) on each half concentrates nodes at both poles, where the
        // g = +-0.99 lobes are spikes of width ~0.01.
        let n = 200_000;
        let mut s = 0.0;
        for i in 0..n {
            let x = (i as f64 + 0.5) / n as f64;
            let dmu = 4.0 * x.powi(3) / n as f64;
            for sign in [1.0f64, -1.0] {
                let mu = sign * (1.0 - x.powi(4));
                s += p.eval_mu(mu as f32) as f64 * dmu * 2.0 * std::f64::consts::PI;
            }
        }
        s
    }

    #[test]
    fn every_phase_function_integrates_to_one() {
        for p in phases() {
            let i = integral(&p);
            assert!((i - 1.0).abs() < 2e-3, "{p:?}: integral {i}");
        }
    }

    #[test]
    fn sampled_cosine_inverts_the_cdf() {
        // F(sample_mu(u)) = u, with F by quadrature of the value.
        for p in phases() {
            for &u in &[0.05f32, 0.3, 0.5, 0.77, 0.95] {
                let mu = p.sample_mu(u) as f64;
                let n = 100_000;
                let mut f = 0.0;
                for i in 0..n {
                    let t = -1.0 + (mu + 1.0) * (i as f64 + 0.5) / n as f64;
                    f += p.eval_mu(t as f32) as f64 * (mu + 1.0) / n as f64;
                }
                let f = f * 2.0 * std::f64::consts::PI;
                // The g = +-0.99 spikes make mid-point quadrature coarse near them.
                assert!((f - u as f64).abs() < 5e-3, "{p:?} u={u}: F={f}");
            }
        }
    }

    #[test]
    fn mean_cosines() {
        for p in phases() {
            let mut rng = crate::math::Rng::new(1, 2, 3);
            let d = Vec3::new(0.3, -0.5, 0.8).normalize();
            let n = 200_000;
            let mut s = 0.0f64;
            for _ in 0..n {
                let (wi, pdf) = p.sample(d, rng.next_2d());
                assert!(pdf > 0.0 && pdf.is_finite());
                assert!((wi.length() - 1.0).abs() < 1e-4);
                s += d.dot(wi) as f64;
            }
            let m = s / n as f64;
            assert!((m - p.mean_cosine() as f64).abs() < 0.01, "{p:?}: {m}");
        }
    }
}
