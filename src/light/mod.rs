//! Lights as one closed enum, plus light selection. Area lights are emitting shapes;
//! the rest are points, spots, directional and environment lights.
//!
//! Below `scene`, which compiles lights: imports `math`, `geometry` (primitives, hits,
//! texture coordinates) and `material` (textures), never `scene`.

mod area;
pub mod distribution;
mod emission;
mod emitting;
mod environment;
mod point;
mod selection;
mod spot;

pub use area::AreaLight;
pub use distribution::{Distribution1D, Distribution2D};
pub use emission::EmissionSample;
pub use environment::{EnvMap, LatLong};
pub use point::{DirectionalLight, PointLight};
pub use selection::{LightSampler, LightSelection};
pub use spot::SpotLight;

use crate::math::{Rgb, Vec2, Vec3, Vec3A, PI};

/// A sphere bounding the scene, for lights at infinity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneSphere {
    pub center: Vec3,
    pub radius: f32,
}

/// A direct-lighting sample as seen from a reference point.
///
/// The vectors are kept in four lanes and read through accessors: integrators copy
/// the sample on its way out of the light's `match`, and a copy of three-float
/// fields, read with wider loads than they were written with, stalled on store
/// forwarding (perf: Cornell box `pt`, gbs_p `bpt`).
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Point on the light (for lights at infinity, unused: `dist` is infinite).
    p: Vec3A,
    /// Surface normal at `p` (zero for lights that are not surfaces).
    n: Vec3A,
    /// Unit direction from the reference point towards the light.
    wi: Vec3A,
    /// Incident radiance (or intensity / d^2 for point-like lights) along `wi`.
    li: Vec3A,
    pub dist: f32,
    /// Solid-angle density of `wi` for this light (1 for delta lights).
    pub pdf: f32,
    pub delta: bool,
}

impl LightSample {
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn new(p: Vec3, n: Vec3, wi: Vec3, dist: f32, li: Rgb, pdf: f32, delta: bool) -> Self {
        LightSample {
            p: p.into(),
            n: n.into(),
            wi: wi.into(),
            li: li.into(),
            dist,
            pdf,
            delta,
        }
    }

    #[inline(always)]
    pub fn p(&self) -> Vec3 {
        self.p.into()
    }

    #[inline(always)]
    pub fn n(&self) -> Vec3 {
        self.n.into()
    }

    #[inline(always)]
    pub fn wi(&self) -> Vec3 {
        self.wi.into()
    }

    #[inline(always)]
    pub fn li(&self) -> Rgb {
        self.li.into()
    }
}

#[derive(Clone, Debug)]
pub enum Light {
    Area(AreaLight),
    Point(PointLight),
    Spot(SpotLight),
    Directional(DirectionalLight),
    Constant { radiance: Rgb },
    EnvMap(EnvMap),
}

impl Light {
    /// Samples a direction towards the light from `p`.
    // Forced: callers in the AVX2 kernels otherwise get a baseline-x86 copy.
    #[inline(always)]
    pub fn sample_li(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        match self {
            Light::Area(l) => l.sample_li(p, u),
            Light::Point(l) => l.sample_li(p),
            Light::Spot(l) => l.sample_li(p),
            Light::Directional(l) => l.sample_li(),
            Light::Constant { radiance } => {
                let wi = crate::math::warp::square_to_uniform_sphere(u);
                Some(LightSample::new(
                    Vec3::ZERO,
                    Vec3::ZERO,
                    wi,
                    f32::INFINITY,
                    *radiance,
                    crate::math::warp::UNIFORM_SPHERE_PDF,
                    false,
                ))
            }
            Light::EnvMap(l) => l.sample_li(u),
        }
    }

    /// Solid-angle density with which `sample_li` from `p` picks direction `wi` that
    /// reaches the light at `p_light` with normal `n_light` (unused for infinite lights).
    /// Always inlined: called, it took its points by reference, and `bpt`'s light pass
    /// kept the vertex it was asked about in memory.
    #[inline(always)]
    pub fn pdf_li(&self, p: Vec3, wi: Vec3, p_light: Vec3, n_light: Vec3) -> f32 {
        match self {
            Light::Area(l) => l.pdf_li(p, p_light, n_light),
            Light::Constant { .. } => crate::math::warp::UNIFORM_SPHERE_PDF,
            Light::EnvMap(l) => l.pdf_li(wi),
            Light::Point(_) | Light::Spot(_) | Light::Directional(_) => 0.0,
        }
    }

    /// Radiance arriving along a ray that escapes the scene in direction `d`.
    #[inline]
    pub fn le_escaped(&self, d: Vec3) -> Rgb {
        match self {
            Light::Constant { radiance } => *radiance,
            Light::EnvMap(l) => l.eval(d),
            _ => Rgb::ZERO,
        }
    }

    pub fn is_infinite(&self) -> bool {
        matches!(
            self,
            Light::Constant { .. } | Light::EnvMap(_) | Light::Directional(_)
        )
    }

    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Light::Point(_) | Light::Spot(_) | Light::Directional(_)
        )
    }

    /// Emitted power (W per channel), for power-proportional light selection.
    pub fn power(&self, sphere: &SceneSphere) -> Rgb {
        let disk = PI * sphere.radius * sphere.radius;
        match self {
            Light::Area(l) => l.power(),
            Light::Point(l) => 4.0 * PI * l.intensity,
            Light::Spot(l) => l.power(),
            Light::Directional(l) => l.irradiance * disk,
            Light::Constant { radiance } => *radiance * (4.0 * PI * disk),
            Light::EnvMap(l) => l.mean_radiance() * (4.0 * PI * disk),
        }
    }
}
