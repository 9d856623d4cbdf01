//! Debug views: shading normals and albedo at the first visible surface.

use super::memory::{Estimate, Facts};
use super::{Integrator, RenderStats};
use crate::film::Film;
use crate::integrator::drive::pixels::{render_pixels, tile_memory};
use crate::math::Rgb;
use crate::scene::Scene;

pub enum DebugIntegrator {
    Normals,
    Albedo,
}

impl DebugIntegrator {
    /// A job's memory (module `memory`): the camera pass's tile buffers.
    pub fn memory(facts: &Facts) -> Estimate {
        let mut e = Estimate::default();
        tile_memory(&mut e, facts);
        e
    }
}

impl Integrator for DebugIntegrator {
    fn iterate(&self, scene: &Scene, seed: u64, iteration: u64, film: &mut Film) -> RenderStats {
        render_pixels(scene, seed, iteration, film, |mut ray, _, stats| {
            // Null boundaries are not surfaces: look through them.
            for _ in 0..64 {
                let Some(it) = scene.intersect(&ray) else {
                    return Rgb::ZERO;
                };
                if scene.passes(&it, &ray) {
                    ray = crate::geometry::spawn_ray(it.p, it.p_err, it.ng, ray.d);
                    stats.rays += 1;
                    continue;
                }
                return match self {
                    DebugIntegrator::Normals => (it.ns + Rgb::ONE) * 0.5,
                    DebugIntegrator::Albedo => scene.material(&it).albedo(),
                };
            }
            Rgb::ZERO
        })
    }
}
