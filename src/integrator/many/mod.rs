//! Many-light methods in participating media: virtual point lights (`vpl`, Keller 1997,
//! "Instant radiosity"), virtual ray lights (`vrl`, Novák et al. 2012, "Virtual ray
//! lights for rendering scenes with participating media") and progressive virtual
//! beam lights (`vbl`, Novák et al. 2012, "Progressive virtual beam lights").
//!
//! ## An iteration
//! 1. Light pass: N light subpaths of the one light tracer, run alone
//!    ([`crate::integrator::paths::light_pass::LightPass`]), storing their non-specular vertices and, for ray lights,
//!    their segments through media. These become the iteration's virtual lights
//!    ([`lights`]): VPLs at vertices (every vertex for `vpl`; surface vertices only for
//!    `vrl` and `vbl`, whose media light by ray lights) and ray lights along segments.
//! 2. Camera pass: one path per pixel ([`camera`]), following specular chains. Each
//!    segment it crosses in a medium gathers direct light, VPLs and ray lights along
//!    its length; the first non-specular surface gathers direct light (next-event
//!    estimation), VPLs and ray lights, and the path ends ([`gather`]).
//!
//! ## Each path counted once
//! A full path is light ... y -> x -> ... camera, x the camera path's gathering point
//! (on a surface, or on a camera segment in a medium). Its vertex y before x is the
//! light itself (next-event estimation at x), a surface vertex of a light path (a VPL),
//! or a point of a medium: a VPL (`vpl`) or a point on a ray light (`vrl`, `vbl`, whose
//! medium vertices are not VPLs). Emission is counted only along purely specular
//! camera chains. Paths whose vertices between x and the light are specular (caustics
//! seen at x) have no estimator here, as in every VPL method.
//!
//! ## Beams (`vbl`)
//! A virtual beam light of radius r is its ray light with the power spread evenly over
//! the disk of radius r perpendicular to it (Novák, Nowrouzezahrai, Dachsbacher and
//! Jarosz 2012, "Progressive virtual beam lights": the beam is the ray light blurred by a
//! normalised 2D kernel across the beam). A gather estimates it by displacing the ray
//! light by one offset v drawn in the disk with density p(v) and multiplying the
//! ray-light estimate on the displaced line by (1 / (pi r^2)) / p(v)
//! ([`crate::integrator::many::vrl::Beam`]). The displaced line keeps the ray light's medium: where the
//! disk crosses a wall or a medium's boundary the beam is not exactly the blurred
//! ray light, a bias of order r that the shrinking radius removes. With r = 0 the
//! weight is 1 and the estimate is `vrl`'s.
//!
//! `max_depth` counts segments over both halves: a virtual light after k light
//! segments lights a point after j camera segments when k + 1 + j <= max_depth.

mod camera;
mod gather;
mod lights;
mod settings;
pub mod vrl;

pub use settings::{Clamp, LightPaths, VblSettings, VplSettings, VrlSettings};

use super::{Integrator, RenderStats};
use crate::film::Film;
use crate::integrator::drive::pixels::render_pixels;
use crate::integrator::many::vrl::Sampler;
use crate::integrator::paths::light_pass::LightPass;
use crate::integrator::transport::radius::radius_schedule;
use crate::scene::Scene;
use gather::Gather;
use lights::{Kinds, Lights};
use std::sync::Mutex;

/// What distinguishes the three methods.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Method {
    Vpl {
        clamp: Clamp,
        limit: Option<f32>,
    },
    Vrl {
        sampler: Sampler,
    },
    Vbl {
        sampler: Sampler,
        radius: Option<f32>,
        radius_factor: f32,
        alpha: f32,
    },
}

/// `vpl`, `vrl` and `vbl`.
pub struct ManyLights {
    method: Method,
    max_depth: u32,
    vl_samples: u32,
    light: LightPass,
    lights: Mutex<Lights>,
}

impl ManyLights {
    fn new(
        method: Method,
        max_depth: u32,
        light_paths: LightPaths,
        vl_samples: u32,
        mib: f32,
    ) -> Self {
        // The light pass: the core's walk with its defaults (roulette by albedo), every
        // vertex stored, no connection.
        let mut light = LightPass::new(max_depth, light_paths, mib);
        if !matches!(method, Method::Vpl { .. }) {
            light = light.keeping_segments();
        }
        ManyLights {
            method,
            max_depth,
            vl_samples,
            light,
            lights: Mutex::new(Lights::default()),
        }
    }

    pub fn vpl(s: VplSettings) -> Self {
        let method = Method::Vpl {
            clamp: s.clamp,
            limit: s.clamp_limit,
        };
        Self::new(
            method,
            s.max_depth,
            s.light_paths,
            s.vl_samples,
            s.max_vertex_mib,
        )
    }

    pub fn vrl(s: VrlSettings) -> Self {
        let method = Method::Vrl { sampler: s.sampler };
        Self::new(
            method,
            s.max_depth,
            s.light_paths,
            s.vl_samples,
            s.max_vertex_mib,
        )
    }

    pub fn vbl(s: VblSettings) -> Self {
        let method = Method::Vbl {
            sampler: s.sampler,
            radius: s.radius,
            radius_factor: s.radius_factor,
            alpha: s.alpha,
        };
        Self::new(
            method,
            s.max_depth,
            s.light_paths,
            s.vl_samples,
            s.max_vertex_mib,
        )
    }

    fn kinds(&self) -> Kinds {
        Kinds::of_vpl(matches!(self.method, Method::Vpl { .. }))
    }

    /// `vpl`'s cap on G and whether it is compensated.
    fn clamp(&self, scene: &Scene) -> Option<(f32, bool)> {
        let Method::Vpl { clamp, limit } = self.method else {
            return None;
        };
        let b = limit.unwrap_or_else(|| {
            let d = 0.1 * scene.sphere.radius;
            1.0 / (d * d)
        });
        match clamp {
            Clamp::None => None,
            Clamp::Clamp => Some((b, false)),
            Clamp::Compensate => Some((b, true)),
        }
    }

    /// `vbl`'s radius at `iteration` (0-based): r_1 from `radius` or `radius_factor`,
    /// then r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1) (Knaus and Zwicker 2011 for a 2D
    /// kernel, as progressive photon beams shrink theirs). 0 for the other methods.
    fn beam_radius(&self, scene: &Scene, iteration: u64) -> f32 {
        let Method::Vbl {
            radius,
            radius_factor,
            alpha,
            ..
        } = self.method
        else {
            return 0.0;
        };
        let r1 = radius.unwrap_or(radius_factor * scene.sphere.radius);
        radius_schedule(r1, alpha, 2, iteration)
    }

    fn sampler(&self) -> Option<Sampler> {
        match self.method {
            Method::Vpl { .. } => None,
            Method::Vrl { sampler } | Method::Vbl { sampler, .. } => Some(sampler),
        }
    }
}

impl Integrator for ManyLights {
    fn iterate(&self, scene: &Scene, seed: u64, iteration: u64, film: &mut Film) -> RenderStats {
        let mut lights = self.lights.lock().unwrap_or_else(|e| e.into_inner());
        let kinds = self.kinds();
        let ((), mut stats) = self.light.run(scene, seed, iteration, |store| {
            lights.build(scene, store, kinds, seed, iteration)
        });
        stats.light_vertices = (lights.vpls.len() + lights.rays.len()) as u64;
        stats.vertex_bytes += lights.bytes() as u64;
        let g = Gather {
            scene,
            lights: &lights,
            max_depth: self.max_depth,
            vl_samples: self.vl_samples,
            clamp: self.clamp(scene),
            sampler: self.sampler(),
            beam_radius: self.beam_radius(scene, iteration),
        };
        stats += render_pixels(
            scene,
            seed,
            iteration,
            film,
            #[inline(always)]
            |ray, rng, st| camera::li(&g, ray, rng, st),
        );
        stats
    }
}
