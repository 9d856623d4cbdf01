//! Path tracing with next-event estimation and BSDF sampling combined by multiple
//! importance sampling (Veach 1997, ch. 9), Russian roulette, and Mitsuba's `max_depth`:
//! an emitter reached after k scattering events counts when k <= max_depth - 1.

use super::memory::{Estimate, Facts};
use super::volpath::{VolPath, VolpathSettings};
use super::{Integrator, RenderStats};
use crate::film::Film;
use crate::geometry::{spawn_ray, Interaction, Ray};
use crate::integrator::drive::pixels::{render_paths, PathKernel};
use crate::integrator::transport::camera::sample_bsdf;
use crate::integrator::transport::nee::{sample_light, Origin};
use crate::integrator::transport::params::ParamError;
use crate::integrator::transport::{emitted, escaped, Heuristic};
use crate::material::Material;
use crate::math::{max_component, Frame, Rgb, Rng, Vec3};
use crate::scene::{Scene, Surfacing};
use serde::{Deserialize, Serialize};

/// How Russian roulette picks a path's survival probability.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Roulette {
    /// min(largest throughput channel, 0.95), as Mitsuba and pbrt: paths that carry
    /// little are ended, whatever they hit.
    #[default]
    Throughput,
    /// min(1, largest albedo channel of the material), as SmallVCM's path tracer: a
    /// property of the vertex alone, so the BSDF's density in the MIS weights includes
    /// it (the density of continuing in a direction is pdf x survival).
    Albedo,
}

/// Path tracer parameters.
///
/// | field | default | meaning |
/// |---|---|---|
/// | `max_depth` | 64 | longest path, in Mitsuba's sense (1 = emitters seen directly) |
/// | `rr_depth` | 5 | scattering events before Russian roulette starts |
/// | `roulette` | `throughput` | survival probability: `throughput` (min(largest throughput channel, 0.95)) or `albedo` (min(1, largest albedo channel) at each vertex, as SmallVCM; scenes without media only: with media `pt` renders as `volpath`, which has throughput roulette alone) |
/// | `heuristic` | `power` | MIS weights: `power` (beta = 2) or `balance` |
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct PtSettings {
    pub max_depth: u32,
    pub rr_depth: u32,
    pub roulette: Roulette,
    pub heuristic: Heuristic,
}

impl Default for PtSettings {
    fn default() -> Self {
        PtSettings {
            max_depth: 64,
            rr_depth: 5,
            roulette: Roulette::Throughput,
            heuristic: Heuristic::Power,
        }
    }
}

// `pt` renders scenes with media as `volpath` with the same depths and heuristic, so
// `volpath`'s checks and memory are `pt`'s (its own paths also keep nothing between
// pixels: the camera pass's tile buffers alone).
impl PtSettings {
    /// A job's memory (module `memory`): as `volpath`'s.
    pub fn memory(&self, facts: &Facts) -> Estimate {
        self.volpath().memory(facts)
    }

    /// As `volpath`'s (`max_depth`); `roulette` takes any of its values.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.volpath().validate()
    }

    /// The settings of the `volpath` that renders scenes with media for `pt`.
    fn volpath(&self) -> VolpathSettings {
        VolpathSettings {
            max_depth: self.max_depth,
            rr_depth: self.rr_depth,
            heuristic: self.heuristic,
            equiangular: true,
        }
    }
}

/// A scattering point, as next-event estimation sees it.
#[derive(Clone, Copy)]
struct Vertex<'a, 'm> {
    it: &'a Interaction,
    frame: &'a Frame,
    /// Towards the previous vertex, local frame.
    wo: Vec3,
    m: &'m Material,
}

pub struct PathTracer {
    s: PtSettings,
    /// What renders scenes with media: the volumetric path tracer with these settings
    /// (built once; scenes without media pay nothing for it, not even a branch per ray).
    media: VolPath,
}

impl PathTracer {
    pub fn new(s: PtSettings) -> Self {
        let media = VolPath::new(s.volpath());
        PathTracer { s, media }
    }

    #[inline]
    fn mis(&self, a: f32, b: f32) -> f32 {
        self.s.heuristic.weight(a, b)
    }

    /// Albedo roulette's survival probability at a vertex of material `m` that is the
    /// path's scattering event number `event` (1 for the first); 1 where it does not
    /// apply.
    #[inline(always)]
    fn albedo_survival(&self, m: &Material, event: u32) -> f32 {
        if self.s.roulette == Roulette::Albedo && event >= self.s.rr_depth {
            max_component(m.albedo()).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }

    /// Next-event estimation at a non-delta vertex: one light sample and the shadow
    /// ray that decides it, not yet traced.
    #[inline(always)]
    fn direct(
        &self,
        scene: &Scene,
        v: Vertex<'_, '_>,
        beta: Rgb,
        survival: f32,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> Option<Shadow> {
        let Vertex { it, frame, wo, m } = v;
        let at = Origin::Surface { it, frame, wo, m };
        let link = sample_light(scene, &at, rng, stats)?;
        let pdf_bsdf = if link.delta {
            0.0
        } else {
            link.pdf_scatter * survival
        };
        Some(Shadow {
            ray: link.ray,
            fl: link.f * link.li,
            pdf_light: link.pdf_light,
            pdf_bsdf,
            delta: link.delta,
            beta,
        })
    }

    /// What an unblocked shadow ray adds: the MIS weight is only worked out then.
    #[inline(always)]
    fn unblocked(&self, s: &Shadow) -> Rgb {
        let w = if s.delta {
            1.0
        } else {
            self.mis(s.pdf_light, s.pdf_bsdf)
        };
        s.beta * (s.fl * (w / s.pdf_light))
    }

    /// Traces a shadow ray on its own, where the path ends at its vertex.
    #[inline(always)]
    fn resolve(&self, scene: &Scene, shadow: Option<&Shadow>) -> Rgb {
        match shadow {
            Some(s) if scene.visible(&s.ray) => self.unblocked(s),
            _ => Rgb::ZERO,
        }
    }
}

/// A camera path in flight: what carries over from one traced segment to the next.
pub struct Path {
    ray: Ray,
    /// The last vertex's shadow ray, traced together with `ray`.
    shadow: Option<Shadow>,
    l: Rgb,
    beta: Rgb,
    /// Towards the previous vertex (the ray's origin), for emission's MIS weight.
    prev_p: Vec3,
    /// Density of the BSDF sample that chose `ray`, survival included.
    pdf_bsdf: f32,
    /// Scattering events so far.
    depth: u32,
    /// The last event was a delta lobe (or the camera).
    specular: bool,
}

/// The path tracer bound to a scene, as [`render_paths`] drives it.
struct PtPass<'a> {
    t: &'a PathTracer,
    scene: &'a Scene,
}

impl PathKernel for PtPass<'_> {
    type Path = Path;

    #[inline(always)]
    fn start(&self, _: u64, ray: Ray) -> Path {
        Path {
            prev_p: ray.o,
            ray,
            shadow: None,
            l: Rgb::ZERO,
            beta: Rgb::ONE,
            pdf_bsdf: 0.0,
            depth: 0,
            specular: true,
        }
    }

    /// A vertex's shadow ray is traced together with the ray that continues the path
    /// (`Scene::next_scattering_and_visible`): the two traversals overlap.
    #[inline(always)]
    fn advance(&self, p: &mut Path, rng: &mut Rng, stats: &mut RenderStats) -> Option<Rgb> {
        let scene = self.scene;
        let to_light = p.shadow.as_ref().map(|s| &s.ray);
        let (surfacing, visible) =
            scene.next_scattering_and_visible(&mut p.ray, to_light, &mut stats.rays);
        // Read in place and overwritten below, never moved: `take` and the store of
        // the next one copied the whole shadow (6% of the kernel's instructions).
        if let Some(s) = &p.shadow {
            if visible {
                p.l += self.t.unblocked(s);
            }
        }
        let (it, m) = match surfacing {
            Surfacing::Hit(it, m) => (it, m),
            Surfacing::Escaped => {
                let le = escaped(scene, p.ray.d, p.specular, p.pdf_bsdf, self.t.s.heuristic);
                return Some(p.l + p.beta * le);
            }
            Surfacing::Lost => return Some(p.l),
        };
        p.l += p.beta
            * emitted(
                scene,
                &it,
                p.ray.d,
                p.prev_p,
                p.specular,
                p.pdf_bsdf,
                self.t.s.heuristic,
            );
        if p.depth + 1 >= self.t.s.max_depth {
            return Some(p.l);
        }
        let frame = scene.shading_frame(&it);
        let wo = frame.to_local(-p.ray.d);
        let survival = self.t.albedo_survival(&m, p.depth + 1);
        let v = Vertex {
            it: &it,
            frame: &frame,
            wo,
            m: &m,
        };
        p.shadow = if !m.is_delta() && !scene.lights.is_empty() {
            self.t.direct(scene, v, p.beta, survival, rng, stats)
        } else {
            None
        };
        let scattered = self.scatter(p, &v, survival, rng);
        if !scattered {
            // A path that ends at a vertex with a shadow ray traces it alone.
            return Some(p.l + self.t.resolve(scene, p.shadow.as_ref()));
        }
        stats.rays += 1;
        None
    }
}

impl PtPass<'_> {
    /// Samples the BSDF at `v` and moves the path on: false when it ends there (no
    /// sample, a sample through the geometric surface, Russian roulette, or zero
    /// throughput).
    #[inline(always)]
    fn scatter(&self, p: &mut Path, v: &Vertex, survival: f32, rng: &mut Rng) -> bool {
        let &Vertex { it, frame, wo, m } = v;
        let Some((wi, s)) = sample_bsdf(it, frame, wo, m, rng) else {
            return false;
        };
        p.beta *= Rgb::from(s.weight);
        p.specular = s.delta;
        p.pdf_bsdf = s.pdf * survival;
        p.prev_p = it.p;
        p.depth += 1;
        let q = match self.t.s.roulette {
            Roulette::Throughput if p.depth >= self.t.s.rr_depth => max_component(p.beta).min(0.95),
            _ => survival,
        };
        if q < 1.0 {
            if rng.next_f32() >= q {
                return false;
            }
            p.beta /= q;
        }
        if p.beta == Rgb::ZERO {
            return false;
        }
        p.ray = spawn_ray(it.p, it.p_err, it.ng, wi);
        true
    }
}

/// A shadow ray waiting to be traced, with what it adds if nothing blocks it. It
/// lives across the traversal, so it holds finished numbers rather than the
/// directions they come from: copying a vertex's direction into it stalled on store
/// forwarding (perf, Cornell box).
struct Shadow {
    ray: Ray,
    /// f times the light's radiance.
    fl: Rgb,
    pdf_light: f32,
    /// The BSDF strategy's density towards the light, albedo roulette's survival
    /// included; unused for delta lights.
    pdf_bsdf: f32,
    delta: bool,
    /// Path throughput at the vertex.
    beta: Rgb,
}

impl Integrator for PathTracer {
    fn iterate(&self, scene: &Scene, seed: u64, iteration: u64, film: &mut Film) -> RenderStats {
        if scene.has_media {
            return self.media.iterate(scene, seed, iteration, film);
        }
        // Inlined into render_paths' per-processor copies of the tile loop, so that the
        // whole kernel, not just the loop around it, is compiled with AVX2 and FMA.
        render_paths(scene, seed, iteration, film, &PtPass { t: self, scene })
    }
}
