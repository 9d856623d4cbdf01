//! The single-sample estimators of one ray light in a homogeneous grey medium: against
//! a camera segment (volume to volume) and against a surface point (volume to surface).
//! The building block the integrator scales by the ray light's throughput and by
//! chromatic transmittance ratios; and the reference the tests check every sampler
//! against. Visibility is the caller's (a closure), not this module's.

use super::distance::{Distance, EquiAngular, Exponential, Uniform};
use super::pair::{foot, norm, sub, v64, Pair, Segment, H_MIN_REL};
use super::samplers::{PairMedia, Sampler};
use super::Phases;
use crate::math::{Vec3, INV_PI};
use crate::medium::Phase;

/// A homogeneous medium with one scattering and one extinction coefficient.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grey {
    pub sigma_s: f32,
    pub sigma_t: f32,
    pub phase: Phase,
}

impl Grey {
    /// Both ends in this medium; the exponential densities use its sigma_t.
    pub fn pair_media(&self) -> PairMedia {
        PairMedia {
            sigma_light: self.sigma_t,
            sigma_cam: self.sigma_t,
            phases: Phases {
                light: self.phase,
                cam: self.phase,
            },
        }
    }
}

/// The volume-to-volume integrand per unit of the ray light's power, visibility
/// aside (Novák et al. 2012, eq. 3):
///
///   f(u, t) = sigma_s f_p(d_l, w) sigma_s f_p(w, -d_c)
///             T(0, u) T(y(u), x(t)) T(0, t) / |x(t) - y(u)|^2,
///
/// with w the unit direction from y(u) to x(t): light arrives along the ray light,
/// scatters at y towards x, and at x into the camera ray (towards its origin).
pub fn volume_to_volume(pair: &Pair, m: &Grey, u: f32, t: f32) -> f32 {
    let (y, x) = (pair.light.at(u), pair.cam.at(t));
    let d = x - y;
    let w2 = d.length_squared();
    // Measure zero: only where the two lines meet exactly.
    if w2 <= 0.0 || w2.is_nan() {
        return 0.0;
    }
    let w = w2.sqrt();
    let dir = d / w;
    let fy = m.phase.eval(pair.light.d, dir);
    let fx = m.phase.eval(dir, -pair.cam.d);
    m.sigma_s * m.sigma_s * fy * fx * (-m.sigma_t * (u + w + t)).exp() / w2
}

/// One sample of the double integral of `volume_to_volume` over both segments:
/// f(u, t) V(y, x) / p(u, t).
pub fn estimate_volume_to_volume(
    sampler: &Sampler,
    pair: &Pair,
    m: &Grey,
    xi: [f32; 2],
    visible: impl FnOnce(Vec3, Vec3) -> bool,
) -> f32 {
    let s = sampler.sample(pair, &m.pair_media(), xi);
    let f = volume_to_volume(pair, m, s.u, s.t);
    if f == 0.0 || !visible(pair.light.at(s.u), pair.cam.at(s.t)) {
        return 0.0;
    }
    f / s.pdf
}

/// A Lambertian surface point (one-sided: lit from the side the normal points to).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub p: Vec3,
    pub n: Vec3,
    pub albedo: f32,
}

/// The volume-to-surface integrand per unit of the ray light's power, visibility
/// aside (Novák et al. 2012, eq. 2 with a surface receiver):
///
///   g(u) = sigma_s f_p(d_l, w) T(0, u) T(y(u), p) (albedo / pi) max(0, n . -w) / |p - y(u)|^2.
pub fn volume_to_surface(light: &Segment, m: &Grey, sp: &SurfacePoint, u: f32) -> f32 {
    let y = light.at(u);
    let d = sp.p - y;
    let r2 = d.length_squared();
    if r2 <= 0.0 || r2.is_nan() {
        return 0.0;
    }
    let r = r2.sqrt();
    let dir = d / r;
    let cos = sp.n.dot(-dir).max(0.0);
    let fp = m.phase.eval(light.d, dir);
    m.sigma_s * fp * (-m.sigma_t * (u + r)).exp() * sp.albedo * INV_PI * cos / r2
}

/// How the light ray is sampled against a surface point: one density on u.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SurfaceSampler {
    Uniform,
    Exponential,
    /// Equi-angular about the surface point: the marginal of 1 / |p - y(u)|^2 itself.
    EquiAngular,
}

impl Sampler {
    /// The light-ray density of this sampler against a surface point: the joint
    /// samplers' marginal of 1/w^2 becomes the exact equi-angular density about p.
    pub fn surface(&self) -> SurfaceSampler {
        match self {
            Sampler::Uniform | Sampler::UniformEquiangular => SurfaceSampler::Uniform,
            Sampler::Exponential => SurfaceSampler::Exponential,
            Sampler::JointSimple | Sampler::JointAdvanced { .. } => SurfaceSampler::EquiAngular,
        }
    }
}

impl SurfaceSampler {
    /// u for xi with its density; `sigma` is the exponential density's extinction.
    pub fn sample(&self, light: &Segment, sigma: f32, p: Vec3, xi: f32) -> (f32, f32) {
        let u = self.with(light, sigma, p, |d| d.sample(xi as f64).0) as f32;
        (u, self.pdf(light, sigma, p, u))
    }

    pub fn pdf(&self, light: &Segment, sigma: f32, p: Vec3, u: f32) -> f32 {
        self.with(light, sigma, p, |d| d.pdf(u as f64)) as f32
    }

    fn with(&self, light: &Segment, sigma: f32, p: Vec3, f: impl Fn(&dyn Distance) -> f64) -> f64 {
        let len = light.tmax as f64;
        match self {
            SurfaceSampler::Uniform => f(&Uniform { len }),
            SurfaceSampler::Exponential => f(&Exponential {
                sigma: sigma as f64,
                len,
            }),
            SurfaceSampler::EquiAngular => {
                let (delta, h, _) = foot(light, v64(p));
                let scale = len + norm(sub(v64(p), v64(light.o)));
                f(&EquiAngular::new(delta, h.max(H_MIN_REL * scale), len))
            }
        }
    }
}

/// One sample of the integral of `volume_to_surface` over the light segment.
pub fn estimate_volume_to_surface(
    sampler: SurfaceSampler,
    light: &Segment,
    m: &Grey,
    sp: &SurfacePoint,
    xi: f32,
    visible: impl FnOnce(Vec3, Vec3) -> bool,
) -> f32 {
    let (u, pdf) = sampler.sample(light, m.sigma_t, sp.p, xi);
    let g = volume_to_surface(light, m, sp, u);
    if g == 0.0 || !visible(light.at(u), sp.p) {
        return 0.0;
    }
    g / pdf
}
