//! Light subpaths: emission, random walk with importance transport (through media
//! when the scene has them), storage of non-specular vertices, and connections to the
//! camera (splats).

use super::correlation::{light_origin, Carry, FlightLinks, Link};
use super::lens::{connect_to_camera, push_lens, splat_emitter, LensShadow};
use super::light_vertex::{LightVertex, MEDIUM_VERTEX, NO_MEDIUM};
use super::media::{next_event, next_event_with, Event, Owner};
use super::parts::Parts;
use super::segments::{FlightOrigin, FlightStart, SegmentSink};
use super::store::{Budget, Chunk, Store, RESERVED_SPLATS, RESERVED_VERTICES};
use super::vertex::{Media, NoMedia, Vertex, WithMedia};
use super::walk::Walk;
use super::Pass;
use crate::geometry::Ray;
use crate::integrator::drive::light::{chunk_count, trace_chunks, ChunkTracer};
use crate::integrator::transport::emit::{sample_emission, LightStart};
use crate::integrator::transport::{Stream, PATHS_PER_TASK};
use crate::integrator::RenderStats;
use crate::light::Light;
use crate::material::Mode;
use crate::math::{Rng, Vec2, Vec3};

/// Traces the iteration's light paths into `store`, chunk by chunk in parallel (the
/// store never depends on the thread count).
pub(crate) fn trace_light_paths(
    pass: &Pass,
    seed: u64,
    iteration: u64,
    ws: &mut Store,
) -> RenderStats {
    let n = pass.light_paths;
    let paths = 0..n as u64;
    let tracer = Subpaths {
        pass,
        seed,
        iteration,
        budget: Budget::new(pass.max_vertex_mib, chunk_count(&paths)),
    };
    trace_chunks(&tracer, &mut ws.chunks, paths);
    ws.paths = n;
    let mut total = 0;
    let mut stats = RenderStats::default();
    for chunk in &ws.chunks {
        total += chunk.vertices.len();
        stats += chunk.stats;
    }
    if ws.chunks.iter().any(|c| c.over_budget) {
        tracing::warn!(
            "light vertices or segments beyond max_vertex_mib = {} were not stored this iteration; raise it or lower light_paths",
            pass.max_vertex_mib
        );
    }
    stats.light_vertices = total as u64;
    stats
}

/// The bidirectional family's light subpaths, for the light-path loop.
struct Subpaths<'a, 'p> {
    pass: &'a Pass<'p>,
    seed: u64,
    iteration: u64,
    budget: Budget,
}

impl ChunkTracer for Subpaths<'_, '_> {
    type Chunk = Chunk;

    fn clear(&self, chunk: &mut Chunk) {
        if chunk.ends.capacity() == 0 {
            // Only what the technique fills: a light pass that stores no vertex (`lt`)
            // or splats none (the merging and many-light passes) reserves none.
            let t = self.pass.tracing;
            if t.stores {
                chunk
                    .vertices
                    .reserve(RESERVED_VERTICES.min(self.budget.vertices));
            }
            chunk.ends.reserve(PATHS_PER_TASK);
            if t.splats {
                chunk.splats.reserve(RESERVED_SPLATS);
            }
        }
        chunk.vertices.clear();
        chunk.parts.clear();
        chunk.links.clear();
        chunk.ends.clear();
        chunk.segments.clear();
        chunk.segment_ends.clear();
        chunk.segment_parts.clear();
        chunk.segment_links.clear();
        chunk.splats.clear();
        chunk.stats = RenderStats::default();
        chunk.over_budget = false;
    }

    /// One subpath, then where it ends in the chunk's arrays.
    #[inline(always)]
    fn trace(&self, index: u64, chunk: &mut Chunk) {
        let pass = self.pass;
        let mut rng = Stream::LightSubpaths.rng(self.seed, self.iteration, index);
        let (media, radii) = (pass.scene.has_media, pass.reweights());
        match (media, radii) {
            (true, false) => trace_one::<WithMedia, false>(pass, &mut rng, chunk, self.budget),
            (false, false) => trace_one::<NoMedia, false>(pass, &mut rng, chunk, self.budget),
            (true, true) => trace_one::<WithMedia, true>(pass, &mut rng, chunk, self.budget),
            (false, true) => trace_one::<NoMedia, true>(pass, &mut rng, chunk, self.budget),
        }
        chunk.ends.push(chunk.vertices.len() as u32);
        if pass.keep_segments {
            chunk.segment_ends.push(chunk.segments.len() as u32);
        }
    }
}

/// Where a light subpath starts: the ray, its throughput and MIS state, and (for area
/// lights) what is needed to finish the MIS state at the first hit.
struct Start {
    ray: Ray,
    walk: Walk,
    finite: bool,
    /// Area lights, whose light-sampling density depends on the receiving point.
    area: Option<AreaStart>,
}

/// An area light's start: (light, pick probability, emission density, origin,
/// normal, cos).
type AreaStart = (usize, f32, f32, Vec3, Vec3, f32);

#[inline(always)]
fn start(pass: &Pass, rng: &mut Rng) -> Option<(Start, LightStart)> {
    let scene = pass.scene;
    let ls = sample_emission(scene, rng)?;
    let (li, pick, es) = (ls.light, ls.pick, &ls.sample);
    let light = &scene.lights[li];
    let emission = pick * es.pdf_pos * es.pdf_dir;
    if emission.is_nan() || emission <= 0.0 {
        return None;
    }
    let finite = !light.is_infinite();
    let direct = match light {
        // Filled in at the first hit.
        Light::Area(_) => 1.0,
        Light::Point(_) | Light::Spot(_) | Light::Directional(_) => pick,
        Light::Constant { .. } | Light::EnvMap(_) => {
            pick * light.pdf_li(Vec3::ZERO, -es.d, Vec3::ZERO, Vec3::ZERO)
        }
    };
    let q = pass
        .mis
        .light_start(direct, emission, es.cos, light.is_delta(), finite);
    let area = matches!(light, Light::Area(_)).then_some((li, pick, emission, es.p, es.n, es.cos));
    let walk = Walk {
        origin: es.p,
        throughput: es.le * (es.cos / emission),
        len: 1,
        q,
        pending: Parts::default(),
        parts: Parts::default(),
        medium_seen: false,
        tr: 1.0,
        specular: true,
        medium: None,
        carry: carry_start(pass, light, (pick, es)),
    };
    let st = Start {
        ray: ls.ray,
        walk,
        finite,
        area,
    };
    Some((st, ls))
}

/// The carry of a light subpath leaving light `light` (picked with probability
/// `pick`) by emission sample `es` (see [`Carry`]).
#[inline(always)]
fn carry_start(
    pass: &Pass,
    light: &Light,
    (pick, es): (f32, &crate::light::EmissionSample),
) -> Carry {
    if !pass.mis.correlated {
        return Carry::start(0.0, 0.0, 0.0);
    }
    let infinite = light.is_infinite();
    let (origin, first) = light_origin(infinite, light.is_delta(), pick, (es.pdf_pos, es.pdf_dir));
    // No cosine leaves a light at infinity: the disk's density is the first hit's.
    Carry::start(first, if infinite { 1.0 } else { es.cos }, origin)
}

/// One light subpath; `M` (whether the scene has media) and `RADII` (whether the pass
/// has radius layers) are decided once per path.
#[inline(always)]
fn trace_one<M: Media, const RADII: bool>(
    pass: &Pass,
    rng: &mut Rng,
    chunk: &mut Chunk,
    budget: Budget,
) {
    let scene = pass.scene;
    let Some((st, ls)) = start(pass, rng) else {
        return;
    };
    chunk.stats.samples += 1;
    if pass.tracing.lt {
        splat_emitter::<M>(pass, rng, chunk, &ls.sample, ls.light, ls.pick);
    }
    let Start {
        mut ray,
        mut walk,
        finite,
        area,
    } = st;
    if M::ON {
        walk.medium = ls.medium;
    }
    // The last vertex's connection to the lens, whose shadow ray (without media) is
    // traced together with the ray that continues the path.
    let mut lens: Option<LensShadow> = None;
    loop {
        chunk.stats.rays += 1;
        let mut owner = Owner::default();
        let (event, tr) = if M::ON {
            let origin = match area {
                _ if walk.len > 1 => FlightOrigin::Vertex,
                Some((l, _, _, _, n0, _)) => FlightOrigin::Area(l as u32, n0),
                None if !finite => FlightOrigin::Infinite,
                None => FlightOrigin::Vertex,
            };
            flight::<M, RADII>(
                pass,
                rng,
                chunk,
                budget,
                (&mut ray, &mut walk),
                origin,
                &mut owner,
            )
        } else {
            (
                flight_and_lens(pass, chunk, &mut ray, &mut lens, &mut owner),
                1.0,
            )
        };
        let v = match event {
            Event::Surface(it, m) => Vertex::<M>::surface(pass, it, m, ray.d),
            Event::Medium(p, medium) => Vertex::medium(pass, medium, p, ray.d),
            Event::Escaped | Event::End => break,
        };
        // By reference, as in the camera pass: moving it out copied the vertex.
        let Some(v) = &v else {
            break;
        };
        let dist2 = (v.p() - walk.origin).length_squared();
        if walk.len == 1 {
            if let Some(area) = area {
                finish_area_start(pass, &mut walk, area, v.p(), ray.d, dist2);
            }
        }
        // A ray from a light at infinity has no distance ([TR] sec. 5.1), only T.
        let d2 = if walk.len > 1 || finite { dist2 } else { 1.0 };
        let mis = &pass.mis;
        walk.q = mis.light_hit(walk.q, walk.pending.sum(), d2 / tr, tr, v.d_in());
        let medium = matches!(v, Vertex::Medium { .. });
        let link = pass.correlates::<RADII>().then(|| {
            let hit = (d2 / tr, tr, v.d_in());
            mis.carry_hit(walk.carry, walk.pending.sum(), hit, medium)
        });
        let track = pass.tracks_parts::<M, RADII>(false);
        if track {
            walk.parts = mis.hit_parts(walk.parts, walk.pending, tr, v.d_in());
        }
        (walk.pending, walk.tr) = (Parts::default(), tr);
        let count = chunk.vertices.len();
        if !v.skips_connections() {
            let at = (&walk, link);
            lens = keep_vertex::<M, RADII>(pass, rng, chunk, budget, at, v, ray.d);
        }
        let stored = link.is_some() && chunk.vertices.len() > count;
        if let Some(link) = link {
            walk.carry = match stored {
                true => link.carry_on(),
                false => link.carry_through(&walk.carry),
            };
        }
        if walk.len + 2 > pass.max_depth {
            break;
        }
        let Some(next) = v.scatter(pass, rng, &mut walk, Mode::Importance, None, track) else {
            break;
        };
        if let (Some(l), true) = (chunk.links.last_mut(), stored) {
            l.back_pdf = walk.carry.rev;
        }
        ray = next;
    }
    // A path that ends at a vertex with a lens connection traces its shadow ray alone.
    if let Some(l) = lens {
        if scene.visible(&l.ray) {
            push_lens(chunk, &l);
        }
    }
}

/// In media: the walk to the next event, keeping the segments it crosses when the
/// pass asks for them; the event and its MIS transmittance.
#[inline(always)]
fn flight<'a, 's, M: Media, const RADII: bool>(
    pass: &Pass<'s>,
    rng: &mut Rng,
    chunk: &mut Chunk,
    budget: Budget,
    (ray, walk): (&mut Ray, &mut Walk),
    origin: FlightOrigin,
    owner: &'a mut Owner<'s>,
) -> (Event<'a>, f32) {
    let correlates = pass.correlates::<RADII>();
    let links = match correlates {
        // The subpath's links so far: its vertices' (stored in parallel).
        true => FlightLinks {
            carry: walk.carry,
            links: (
                chunk.ends.last().map_or(0, |&e| e),
                chunk.links.len() as u32,
            ),
        },
        false => FlightLinks::NONE,
    };
    let Chunk {
        segments,
        segment_parts,
        segment_links,
        over_budget,
        stats,
        ..
    } = chunk;
    let mut sink = SegmentSink {
        out: segments,
        parts: RADII.then_some(segment_parts),
        links: correlates.then_some(segment_links),
        budget: budget.segments,
        over_budget,
        start: FlightStart {
            len: walk.len,
            q: walk.q,
            pending: walk.pending.sum(),
            vol: walk.parts.media(),
            from: walk.origin,
            origin,
            parts: [walk.parts, walk.pending],
            links,
        },
    };
    let keep = pass.keep_segments.then_some(&mut sink);
    let at = (pass.scene, pass.mis.local_media);
    next_event::<M>(at, ray, walk, rng, stats, keep, owner)
}

/// Without media: the walk to the next surface, traced together with the pending lens
/// connection's shadow ray, whose splat is kept if nothing blocks it.
#[inline(always)]
fn flight_and_lens<'a, 's>(
    pass: &Pass<'s>,
    chunk: &mut Chunk,
    ray: &mut Ray,
    lens: &mut Option<LensShadow>,
    owner: &'a mut Owner<'s>,
) -> Event<'a> {
    // Read in place, then cleared: `take` copied the whole lens connection.
    let shadow = lens.as_ref().map(|l| &l.ray);
    let rays = &mut chunk.stats.rays;
    let (event, visible) = next_event_with(pass.scene, ray, shadow, rays, owner);
    if let Some(l) = lens.as_ref().filter(|_| visible) {
        push_lens(chunk, l);
    }
    *lens = None;
    event
}

/// At an area light's first hit `p`, reached along `d` at squared distance `dist2`:
/// the density with which light sampling from `p` picks the origin, in area measure
/// ([TR] eq. 31); geometric, no transmittance.
#[inline(always)]
fn finish_area_start(pass: &Pass, walk: &mut Walk, area: AreaStart, p: Vec3, d: Vec3, dist2: f32) {
    let (l, pick, emission, p0, n0, cos0) = area;
    let pdf_w = pass.scene.lights[l].pdf_li(p, -d, p0, n0);
    walk.q.dvcm = pass
        .mis
        .f(pick as f64 * pdf_w as f64 * cos0 as f64 / (dist2 as f64 * emission as f64));
}

/// A vertex that takes connections, reached along `d`: stored when the pass keeps
/// vertices (within the budget), and connected to the lens when it splats; the lens
/// connection whose shadow ray is still to trace.
#[inline(always)]
fn keep_vertex<M: Media, const RADII: bool>(
    pass: &Pass,
    rng: &mut Rng,
    chunk: &mut Chunk,
    budget: Budget,
    (walk, link): (&Walk, Option<Link>),
    v: &Vertex<M>,
    d: Vec3,
) -> Option<LensShadow> {
    // The path's links before this vertex's (with correlation-aware MIS).
    let before = link.map(|_| chunk.ends.last().map_or(0, |&e| e as usize)..chunk.links.len());
    if pass.tracing.stores {
        if chunk.vertices.len() >= budget.vertices {
            chunk.over_budget = true;
        } else {
            chunk.vertices.push(stored(v, walk, d, pass.scene));
            if RADII {
                chunk.parts.push(walk.parts);
            }
            if let Some(link) = link {
                chunk.links.push(link);
            }
        }
    }
    if pass.tracing.splats {
        let link = link.zip(before).map(|(l, before)| (before, l));
        connect_to_camera::<M, RADII>(pass, rng, chunk, (walk, link), v)
    } else {
        None
    }
}

/// The stored form of vertex `v`, reached along `d`.
#[inline(always)]
fn stored<M: Media>(
    v: &Vertex<M>,
    walk: &Walk,
    d: Vec3,
    scene: &crate::scene::Scene,
) -> LightVertex {
    let (p_err, ng, ns, twist, material, uv) = match v {
        Vertex::Surface { it, s, .. } => (
            it.p_err,
            it.ng,
            it.ns,
            scene.frame_twist(it, &s.frame),
            scene.shapes[it.shape as usize].material,
            scene.uv(it),
        ),
        Vertex::Medium { .. } => (
            Vec3::ZERO,
            Vec3::ZERO,
            Vec3::ZERO,
            0.0,
            MEDIUM_VERTEX,
            Vec2::ZERO,
        ),
    };
    LightVertex {
        p: v.p(),
        p_err,
        ng,
        ns,
        twist,
        wo: -d,
        throughput: walk.throughput,
        material,
        uv,
        medium: walk.medium.unwrap_or(NO_MEDIUM),
        cont: v.cont(),
        len: walk.len,
        q: walk.q,
        vol: if M::ON && walk.q.dvc > 0.0 {
            (walk.parts.media() / walk.q.dvc) as f32
        } else {
            0.0
        },
    }
}
