//! The start of every light path (photons and light subpaths alike): a light picked by
//! the scene's light sampler, a point and a direction from its emission sampling, the
//! first ray, and the medium it travels in. Random numbers: one for the light, two for
//! the point, two for the direction.

use crate::geometry::{spawn_ray, Ray};
use crate::light::{EmissionSample, Light};
use crate::math::{Rgb, Rng};
use crate::scene::Scene;

/// A sampled light-path origin.
#[derive(Clone, Copy, Debug)]
pub struct LightStart {
    /// The light's index in the scene.
    pub light: usize,
    /// Its selection probability.
    pub pick: f32,
    pub sample: EmissionSample,
    /// The first ray: off the light's surface as a ray leaving a hit point would be
    /// (one offset rule for every tracer: the light's own bound on the point's
    /// rounding error), or straight from a point that is on no surface.
    pub ray: Ray,
    /// The medium the light emits into.
    pub medium: Option<u32>,
}

/// Samples where a light path starts; None when the scene has no light or the sample
/// has no density.
#[inline(always)]
pub fn sample_emission(scene: &Scene, rng: &mut Rng) -> Option<LightStart> {
    if scene.lights.is_empty() {
        return None;
    }
    let (light, pick, _) = scene.light_sampler.sample(rng.next_f32());
    let (u_pos, u_dir) = (rng.next_2d(), rng.next_2d());
    let es = scene.lights[light].sample_le(&scene.sphere, u_pos, u_dir)?;
    if !(es.pdf_pos > 0.0 && es.pdf_dir > 0.0 && pick > 0.0) {
        return None;
    }
    let ray = if es.n == crate::math::Vec3::ZERO {
        Ray::new(es.p, es.d)
    } else {
        spawn_ray(es.p, es.p_err, es.n, es.d)
    };
    Some(LightStart {
        light,
        pick,
        sample: es,
        ray,
        medium: emission_medium(scene, light, &es),
    })
}

impl LightStart {
    /// The path's starting power, Le cos / (p_pos p_dir p_select): what a photon
    /// carries.
    #[inline]
    pub fn power(&self) -> Rgb {
        self.sample.weight() / self.pick
    }
}

/// The medium a light emits into: the one it is placed in, except that a two-sided
/// emitter on a medium boundary emits into the medium on the side the light leaves by.
#[inline(always)]
fn emission_medium(scene: &Scene, light: usize, es: &EmissionSample) -> Option<u32> {
    if let Light::Area(a) = &scene.lights[light] {
        let shape = &scene.shapes[a.shape as usize];
        if shape.is_medium_boundary() {
            return if es.d.dot(es.n) > 0.0 {
                shape.exterior
            } else {
                shape.interior
            };
        }
    }
    scene.light_media[light]
}
