//! Emission sampling: where light paths start. Used by light tracing, bidirectional
//! path tracing and photon mapping; paired with `pdf_le`, which the bidirectional MIS
//! needs when a camera path reaches an emitter.

use super::{Light, SceneSphere};
use crate::math::warp::{square_to_disk, square_to_uniform_cone, uniform_cone_pdf};
use crate::math::{Frame, Rgb, Vec2, Vec3, PI};

/// The start of a light path.
#[derive(Clone, Copy, Debug)]
pub struct EmissionSample {
    /// Ray origin: on the light, or on a disk outside the scene for lights at infinity.
    pub p: Vec3,
    /// Front normal at `p` for area lights; zero otherwise.
    pub n: Vec3,
    /// Bound on the rounding error of `p` per component (area lights; zero for points
    /// that are not on a surface), for offsetting the ray off the light's surface as
    /// from a hit point.
    pub p_err: Vec3,
    /// Unit direction the light travels.
    pub d: Vec3,
    /// Radiance (area and environment lights), intensity (point and spot) or
    /// irradiance (directional) carried along `d`.
    pub le: Rgb,
    /// Area density of `p` (1 for point-like lights).
    pub pdf_pos: f32,
    /// Solid-angle density of `d` given `p` (1 for directional lights).
    pub pdf_dir: f32,
    /// |cos| between `d` and the light's normal (1 for lights without a surface).
    pub cos: f32,
}

impl EmissionSample {
    /// Power carried by the path per unit of light selection probability:
    /// Le cos / (p_pos p_dir).
    #[inline]
    pub fn weight(&self) -> Rgb {
        self.le * (self.cos / (self.pdf_pos * self.pdf_dir))
    }
}

impl Light {
    /// Samples a point and a direction of emission. Left out of line (so compiled for
    /// baseline x86-64): forced into the light-path kernel, its arms for every kind of
    /// light made gbs_b vcm 7% slower (CPU s/iteration .494 -> .529, medians of 5).
    #[inline]
    pub fn sample_le(
        &self,
        sphere: &SceneSphere,
        u_pos: Vec2,
        u_dir: Vec2,
    ) -> Option<EmissionSample> {
        match self {
            Light::Area(l) => l.sample_le(u_pos, u_dir),
            Light::Point(l) => {
                let d = crate::math::warp::square_to_uniform_sphere(u_dir);
                Some(point_like(l.position, d, l.intensity, crate::math::INV_4PI))
            }
            Light::Spot(l) => {
                let cos_max = l.cutoff.cos();
                let d = l.frame.to_world(square_to_uniform_cone(u_dir, cos_max));
                let f = l.falloff(d);
                (f > 0.0)
                    .then(|| point_like(l.position, d, l.intensity * f, uniform_cone_pdf(cos_max)))
            }
            Light::Directional(l) => {
                Some(from_infinity(sphere, l.direction, l.irradiance, 1.0, u_pos))
            }
            Light::Constant { .. } | Light::EnvMap(_) => {
                // Towards the light, as direct lighting samples it; light travels the other way.
                let s = self.sample_li(Vec3::ZERO, u_dir)?;
                Some(from_infinity(sphere, -s.wi(), s.li(), s.pdf, u_pos))
            }
        }
    }

    /// Densities with which `sample_le` emits light travelling along `d` from a point
    /// with front normal `n` (area lights), from the light's position (point and spot
    /// lights) or from infinity: (position, direction). Bidirectional MIS compares these
    /// with the densities of the other techniques.
    #[inline]
    pub fn pdf_le(&self, sphere: &SceneSphere, n: Vec3, d: Vec3) -> (f32, f32) {
        let disk = 1.0 / (PI * sphere.radius * sphere.radius);
        match self {
            Light::Area(l) => l.pdf_le(n, d),
            Light::Constant { .. } | Light::EnvMap(_) => {
                (disk, self.pdf_li(Vec3::ZERO, -d, Vec3::ZERO, Vec3::ZERO))
            }
            Light::Point(_) => (1.0, crate::math::INV_4PI),
            Light::Spot(l) => {
                let cos_max = l.cutoff.cos();
                let inside = d.dot(l.frame.n) > cos_max;
                (
                    1.0,
                    if inside {
                        uniform_cone_pdf(cos_max)
                    } else {
                        0.0
                    },
                )
            }
            Light::Directional(_) => (disk, 1.0),
        }
    }
}

#[inline]
fn point_like(p: Vec3, d: Vec3, intensity: Rgb, pdf_dir: f32) -> EmissionSample {
    EmissionSample {
        p,
        n: Vec3::ZERO,
        p_err: Vec3::ZERO,
        d,
        le: intensity,
        pdf_pos: 1.0,
        pdf_dir,
        cos: 1.0,
    }
}

/// Light arriving from infinity along `d`: the ray starts on a disk of the scene's
/// radius, facing `d`, just outside the bounding sphere.
#[inline]
fn from_infinity(sphere: &SceneSphere, d: Vec3, le: Rgb, pdf_dir: f32, u: Vec2) -> EmissionSample {
    let frame = Frame::from_normal(d);
    let q = square_to_disk(u) * sphere.radius;
    let p = sphere.center + frame.to_world(Vec3::new(q.x, q.y, -sphere.radius));
    EmissionSample {
        p,
        n: Vec3::ZERO,
        p_err: Vec3::ZERO,
        d,
        le,
        pdf_pos: 1.0 / (PI * sphere.radius * sphere.radius),
        pdf_dir,
        cos: 1.0,
    }
}
