//! How bidirectional subpaths and their connections pass through participating media:
//! the walk to the next event along a ray (a surface, a scattering point in the
//! current medium, or escape) and the transmittance of connection segments, each with
//! the segment's MIS transmittance (see the media notes in [`super::partial`]).
//!
//! Both come in two compilations chosen once per path (`Media`, `Scene::has_media`):
//! without media the walk is `Scene::next_scattering` and a connection is a visibility
//! test, exactly the surface-only code, with MIS transmittance 1.

use super::partial as mis;
use super::segments::SegmentSink;
use super::vertex::Media;
use super::walk::Walk;
use crate::geometry::{Interaction, Ray};
use crate::integrator::transport::medium_walk::{MediumWalk, Segment, Segments, Step};
use crate::integrator::RenderStats;
use crate::material::textured::MaterialRef;
use crate::material::Material;
use crate::math::{Rgb, Rng, Vec3};
use crate::scene::{Scene, Surfacing};

/// What a subpath meets next along its ray. A surface's material is borrowed from
/// the caller's [`Owner`], so that no event or vertex needs dropping: one that did
/// (it held a textured hit's material) was kept in memory for the unwinding paths,
/// and every move of it was a copy (Cornell box `bpt`: 2.7 % more instructions).
pub(crate) enum Event<'a> {
    Surface(Interaction, &'a Material),
    /// A real scattering event at a point in medium `.1`.
    Medium(Vec3, u32),
    /// Left the scene (environment lights apply).
    Escaped,
    /// Absorbed, out of throughput, or lost between null boundaries.
    End,
}

/// Where the material of a vertex's surface lives while the vertex does: usually a
/// borrow of the scene's, a textured hit's own resolved material otherwise.
#[derive(Default)]
pub(crate) struct Owner<'s>(Option<MaterialRef<'s>>);

impl<'s> Owner<'s> {
    /// Keeps `m` (dropping the material kept before) and lends it out.
    #[inline(always)]
    pub fn keep(&mut self, m: MaterialRef<'s>) -> &Material {
        self.0.insert(m)
    }
}

/// Follows `ray` to the next event. With media, free flights are sampled in the
/// medium the walk is in (their weights go into `walk.throughput`, with the walk's
/// throughput choosing channels as in `volpath`) and null boundaries switch
/// `walk.medium`. Returns the event and the MIS transmittance of the segment traced
/// (for an escaping ray, of its part inside the scene). Extra rays count in `stats`.
#[inline(always)]
pub(crate) fn next_event<'a, 's, M: Media>(
    (scene, local): (&'s Scene, bool),
    ray: &mut Ray,
    walk: &mut Walk,
    rng: &mut Rng,
    stats: &mut RenderStats,
    keep: Option<&mut SegmentSink>,
    owner: &'a mut Owner<'s>,
) -> (Event<'a>, f32) {
    if !M::ON {
        let e = match scene.next_scattering(ray, &mut stats.rays) {
            Surfacing::Hit(it, m) => Event::Surface(it, owner.keep(m)),
            Surfacing::Escaped => Event::Escaped,
            Surfacing::Lost => Event::End,
        };
        return (e, 1.0);
    }
    let mut path = MediumWalk {
        beta: walk.throughput,
        medium: walk.medium,
    };
    let mut depth = MisDepth {
        scene,
        local,
        depth: 0.0,
        keep,
    };
    let step = path.next(scene, ray, &mut depth, rng, stats);
    (walk.throughput, walk.medium) = (path.beta, path.medium);
    match step {
        Step::Scatter { seg, t, .. } => {
            if let Some(keep) = depth.keep {
                keep.push(&seg, t, depth.depth);
            }
            if walk.throughput == Rgb::ZERO {
                return (Event::End, 1.0);
            }
            let med = &scene.media[seg.medium as usize];
            let piece = med.mis_depth(seg.ray.o, seg.ray.d, 0.0, t, depth.local);
            let tr = mis::transmittance(depth.depth + piece);
            (Event::Medium(seg.ray.at(t), seg.medium), tr)
        }
        Step::Surface(it, m) => {
            let tr = mis::transmittance(depth.depth);
            (Event::Surface(it, owner.keep(m)), tr)
        }
        Step::Escaped => (Event::Escaped, mis::transmittance(depth.depth)),
        Step::End => (Event::End, 1.0),
    }
}

/// The grey optical depth MIS assigns the segments a walk passed (`Medium::mis_depth`),
/// and where a light subpath keeps its segments.
struct MisDepth<'a, 'k, 's> {
    scene: &'a Scene,
    /// `Mis::local_media`.
    local: bool,
    depth: f32,
    keep: Option<&'k mut SegmentSink<'s>>,
}

impl Segments for MisDepth<'_, '_, '_> {
    #[inline(always)]
    fn passed(&mut self, seg: &Segment) {
        if let Some(keep) = self.keep.as_deref_mut() {
            keep.push(seg, seg.tmax, self.depth);
        }
        let med = &self.scene.media[seg.medium as usize];
        self.depth += med.mis_depth(seg.ray.o, seg.ray.d, 0.0, seg.tmax, self.local);
    }
}

/// [`next_event`] in a scene without media, with a pending shadow ray traced
/// alongside (`Scene::next_scattering_and_visible`: the two traversals overlap, as in
/// `pt`). Also returns whether the shadow ray is unblocked (true when there is none).
#[inline(always)]
pub(crate) fn next_event_with<'a, 's>(
    scene: &'s Scene,
    ray: &mut Ray,
    shadow: Option<&Ray>,
    rays: &mut u64,
    owner: &'a mut Owner<'s>,
) -> (Event<'a>, bool) {
    let (surfacing, visible) = scene.next_scattering_and_visible(ray, shadow, rays);
    let e = match surfacing {
        Surfacing::Hit(it, m) => Event::Surface(it, owner.keep(m)),
        Surfacing::Escaped => Event::Escaped,
        Surfacing::Lost => Event::End,
    };
    (e, visible)
}

/// A connection's shadow ray that starts in `medium`: its transmittance and MIS
/// transmittance, None when nothing gets through. `rays` counts rays beyond the first.
#[inline(always)]
pub(crate) fn shadow<M: Media>(
    (scene, local): (&Scene, bool),
    ray: &Ray,
    medium: Option<u32>,
    rng: &mut Rng,
    rays: &mut u64,
) -> Option<(Rgb, f32)> {
    if !M::ON {
        // Constants the compiler folds into the callers' products.
        return scene.visible(ray).then_some((Rgb::ONE, 1.0));
    }
    let (tr, depth) = scene.transmittance_mis(ray, medium, rng, rays, local);
    (tr != Rgb::ZERO).then(|| (tr, mis::transmittance(depth)))
}
