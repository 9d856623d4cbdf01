//! Light subpaths: emission, random walk with importance transport (through media
//! when the scene has them), storage of non-specular vertices, and connections to the
//! camera (splats).

use super::media::{next_event, next_event_with, shadow, Event, Owner};
use super::mis::{Merge, Partial, Site};
use super::segments::{FlightStart, LightSegment, SegmentSink, NO_AREA};
use super::vertex::{mis_sigma, Media, MediumPoint, NoMedia, Scatterer, Vertex, WithMedia};
use super::walk::{Eval, Surface, Walk};
use super::{MergeSet, Pass, Splat, Workspace};
use crate::geometry::{spawn_ray_to, Ray};
use crate::integrator::accel::{huge, HashGrid};
use crate::integrator::common::emit::{sample_emission, LightStart};
use crate::integrator::common::{Stream, PATHS_PER_TASK};
use crate::integrator::memory::{self, array, budgeted, pushed, refilled, Estimate};
use crate::integrator::RenderStats;
use crate::light::Light;
use crate::material::textured::MaterialRef;
use crate::material::Mode;
use crate::math::{gamma, Frame, Rgb, Rng, Vec2, Vec3};
use rayon::prelude::*;

/// `LightVertex::material` of a scattering point in a medium.
pub(crate) const MEDIUM_VERTEX: u32 = u32::MAX;

/// `LightVertex::medium` of a vertex in vacuum.
const NO_MEDIUM: u32 = u32::MAX;

/// A stored light-subpath vertex (where connections and merges attach).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightVertex {
    pub p: Vec3,
    /// Error bound and normals of a surface vertex (zero for a medium vertex).
    pub p_err: Vec3,
    pub ng: Vec3,
    pub ns: Vec3,
    /// The shading frame's twist about `ns` (`Frame::twisted`): zero unless the
    /// material is anisotropic.
    pub twist: f32,
    /// Towards the previous vertex (where the light came from), world space.
    pub wo: Vec3,
    pub throughput: Rgb,
    /// The surface's material, or MEDIUM_VERTEX.
    pub material: u32,
    /// Texture coordinates of a surface vertex (zero where no texture is read).
    pub uv: Vec2,
    /// The medium the light arrived in (NO_MEDIUM: vacuum): a medium vertex's own,
    /// and at a surface the one on the side `wo` points to.
    pub medium: u32,
    /// Russian-roulette continuation probability of the material (or of the medium's
    /// albedo there).
    pub cont: f32,
    /// Segments from the light to this vertex.
    pub len: u32,
    pub q: Partial,
}

impl LightVertex {
    /// The medium of a medium vertex (None at a surface).
    #[inline]
    pub fn scattering_medium(&self) -> Option<u32> {
        (self.material == MEDIUM_VERTEX).then_some(self.medium)
    }

    /// The medium the light arrived in (None: vacuum).
    #[inline]
    pub fn arrival_medium(&self) -> Option<u32> {
        (self.medium != NO_MEDIUM).then_some(self.medium)
    }
}

/// The part of a light vertex that merging reads, stored in hash-grid order: a range
/// query then reads memory in runs instead of jumping across the path-ordered store.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct MergeVertex {
    pub wo: Vec3,
    pub throughput: Rgb,
    pub len: u32,
    pub cont: f32,
    /// As `LightVertex::medium` (a medium vertex merges only in its own medium).
    pub medium: u32,
    pub q: Partial,
}

impl LightVertex {
    /// Where a merge at the vertex would sit.
    #[inline(always)]
    pub fn site(&self) -> Site {
        if self.material == MEDIUM_VERTEX {
            Site::Medium
        } else {
            Site::Surface
        }
    }

    /// What scatters at the vertex, for connections (only surfaces without media); a
    /// textured surface's material is kept in `owner`.
    #[inline(always)]
    pub fn scatterer<'a, 's: 'a, M: Media>(
        &self,
        pass: &Pass<'s>,
        owner: &'a mut Owner<'s>,
    ) -> Scatterer<'a, M> {
        if M::ON && self.material == MEDIUM_VERTEX {
            let medium = &pass.scene.media[self.medium as usize];
            let m: MediumPoint<'a> = MediumPoint {
                phase: medium.phase(),
                wo: self.wo,
                sigma: mis_sigma(pass, self.medium),
                cont: self.cont,
            };
            if let Some(m) = M::wrap(m) {
                return Scatterer::Medium(m);
            }
        }
        let m = match pass.scene.plain_material(self.material) {
            Some(m) => m,
            None => owner.keep(self.material_on(pass.scene)),
        };
        let frame = Frame::twisted(self.ns, self.twist);
        Scatterer::Surface(Surface {
            m,
            frame,
            ng: self.ng,
            wo: frame.to_local(self.wo),
            cont: self.cont,
        })
    }
}

impl LightVertex {
    /// The material of a textured or shadowed surface vertex. Out of line, its frame
    /// rebuilt here: handing the caller's frame to `Scene::material_on` kept it (and
    /// the connection's scatterer) in memory on every connection.
    #[cold]
    #[inline(never)]
    fn material_on<'a>(&self, scene: &'a crate::scene::Scene) -> MaterialRef<'a> {
        let frame = Frame::twisted(self.ns, self.twist);
        scene.material_on(self.material, self.uv, self.ng, &frame)
    }
}

impl From<&LightVertex> for MergeVertex {
    #[inline(always)]
    fn from(v: &LightVertex) -> Self {
        MergeVertex {
            wo: v.wo,
            throughput: v.throughput,
            len: v.len,
            cont: v.cont,
            medium: v.medium,
            q: v.q,
        }
    }
}

/// The segments light path `path` kept, in the order it traced them (empty unless the
/// pass keeps segments).
pub(super) fn path_segments(chunks: &[Chunk], path: usize) -> &[LightSegment] {
    let chunk = &chunks[path / PATHS_PER_TASK];
    let i = path % PATHS_PER_TASK;
    if chunk.segment_ends.is_empty() {
        return &[];
    }
    let begin = if i == 0 { 0 } else { chunk.segment_ends[i - 1] };
    &chunk.segments[begin as usize..chunk.segment_ends[i] as usize]
}

/// How many vertices and segments one chunk may store (`max_vertex_mib` each).
#[derive(Clone, Copy)]
struct Budget {
    vertices: usize,
    segments: usize,
}

impl Budget {
    /// Each of `chunks` chunks' share of `max_vertex_mib`.
    fn new(max_vertex_mib: f32, chunks: usize) -> Budget {
        let per_chunk = |size: usize| {
            (max_vertex_mib as f64 * 1048576.0 / size as f64 / chunks as f64) as usize
        };
        Budget {
            vertices: per_chunk(std::mem::size_of::<LightVertex>()),
            segments: per_chunk(std::mem::size_of::<LightSegment>()),
        }
    }
}

/// The first iteration's room per chunk, rather than growth by doubling, each step a
/// copy into freshly faulted pages: light paths store two or three vertices in closed
/// scenes, and splat about as many. Later iterations reuse it all.
const RESERVED_VERTICES: usize = PATHS_PER_TASK * 3;
const RESERVED_SPLATS: usize = PATHS_PER_TASK * 2;

/// One chunk's output, kept between iterations to reuse its buffers.
#[derive(Default)]
pub(crate) struct Chunk {
    pub(super) vertices: Vec<LightVertex>,
    /// Per light path of the chunk, the end of its vertices within `vertices`.
    ends: Vec<u32>,
    /// Segments through media, when the pass keeps them, and per light path their end.
    pub(super) segments: Vec<LightSegment>,
    pub(super) segment_ends: Vec<u32>,
    pub splats: Vec<Splat>,
    stats: RenderStats,
    /// A vertex was not stored because the budget was spent.
    over_budget: bool,
}

pub(super) fn trace_light_paths(
    pass: &Pass,
    seed: u64,
    iteration: u64,
    ws: &mut Workspace,
) -> RenderStats {
    let n = pass.light_paths;
    let chunks = n.div_ceil(PATHS_PER_TASK);
    ws.chunks.resize_with(chunks, Chunk::default);
    ws.chunks.truncate(chunks);
    let budget = Budget::new(pass.s.max_vertex_mib, chunks);
    let t = pass.technique;
    ws.chunks.par_iter_mut().enumerate().for_each(|(c, chunk)| {
        if chunk.ends.capacity() == 0 {
            // Only what the technique fills: a light pass that stores no vertex (`lt`)
            // or splats none (the merging and many-light passes) reserves none.
            if t.stores() {
                chunk
                    .vertices
                    .reserve(RESERVED_VERTICES.min(budget.vertices));
            }
            chunk.ends.reserve(PATHS_PER_TASK);
            if t.splats() {
                chunk.splats.reserve(RESERVED_SPLATS);
            }
        }
        chunk.vertices.clear();
        chunk.ends.clear();
        chunk.segments.clear();
        chunk.segment_ends.clear();
        chunk.splats.clear();
        chunk.stats = RenderStats::default();
        chunk.over_budget = false;
        let paths = c * PATHS_PER_TASK..((c + 1) * PATHS_PER_TASK).min(n);
        trace_chunk(pass, seed, iteration, paths, chunk, budget);
    });
    // Connections and merging read the vertices where the chunks stored them; only
    // the grid's positions are gathered into one array.
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
            pass.s.max_vertex_mib
        );
    }
    ws.surface.positions.clear();
    ws.medium.positions.clear();
    if pass.technique.merges() {
        // Only the sites whose estimator is in use.
        let keep = |site: Site| match site {
            Site::Surface => pass.uses(Merge::Surface),
            Site::Medium => pass.uses(Merge::Point3d),
        };
        let vertices = || {
            let all = ws.chunks.iter().flat_map(|c| c.vertices.iter());
            all.filter(move |v| keep(v.site()))
        };
        let media = vertices().filter(|v| v.site() == Site::Medium).count();
        huge::reserve(&mut ws.surface.positions, total - media);
        huge::reserve(&mut ws.medium.positions, media);
        for v in vertices() {
            match v.site() {
                Site::Surface => ws.surface.positions.push(v.p),
                Site::Medium => ws.medium.positions.push(v.p),
            }
        }
    }
    stats.light_vertices = total as u64;
    stats
}

impl Workspace {
    /// The stored vertices of light path `path`, in order of length.
    #[inline(always)]
    pub(super) fn light_path(&self, path: usize) -> &[LightVertex] {
        let chunk = &self.chunks[path / PATHS_PER_TASK];
        let i = path % PATHS_PER_TASK;
        let begin = if i == 0 { 0 } else { chunk.ends[i - 1] };
        &chunk.vertices[begin as usize..chunk.ends[i] as usize]
    }

    /// The segments light path `path` kept, in the order it traced them (empty unless
    /// the pass keeps segments).
    #[allow(dead_code)] // read by the tests
    pub(super) fn light_segments(&self, path: usize) -> &[LightSegment] {
        path_segments(&self.chunks, path)
    }

    /// The merging copy of every vertex, per site in its hash grid's storage order.
    pub(super) fn fill_merge(&mut self) {
        for (set, site) in [
            (&mut self.surface, Site::Surface),
            (&mut self.medium, Site::Medium),
        ] {
            let vertices = self.chunks.iter().flat_map(|c| c.vertices.iter());
            set.fill(vertices.filter(|v| v.site() == site));
        }
    }

    /// Bytes held for light vertices and segments (the chunks' stores).
    pub(super) fn vertex_store_bytes(&self) -> usize {
        let stores: usize = self
            .chunks
            .iter()
            .map(|c| {
                c.vertices.capacity() * std::mem::size_of::<LightVertex>()
                    + c.segments.capacity() * std::mem::size_of::<LightSegment>()
            })
            .sum();
        stores
    }
}

/// One iteration's light pass, as the memory estimate sees it.
pub(crate) struct StorePlan<'a> {
    pub technique: super::Technique,
    pub paths: usize,
    /// What a path stores on average (the pilot's).
    pub walk: memory::Walk,
    pub keep_segments: bool,
    pub max_vertex_mib: f32,
    /// How the client set the number of paths, and the budget's parameter name.
    pub driver: &'a str,
    pub budget_field: &'static str,
}

/// What the light store holds after the budget, per iteration: the vertices of each
/// kind and the segments.
pub(crate) struct Stored {
    pub surface: f64,
    pub medium: f64,
    pub segments: f64,
}

/// Adds what [`trace_light_paths`] holds to `e`: per chunk of paths its vertices (the
/// first iteration's reservation, then doubling, at most the chunk's share of the
/// budget), path ends, segments when kept, and splats (at most one per vertex and one
/// for the emitter, per path). Returns what was stored.
pub(crate) fn store_memory(e: &mut Estimate, plan: &StorePlan, has_media: bool) -> Stored {
    let chunks = plan.paths.div_ceil(PATHS_PER_TASK);
    let budget = Budget::new(plan.max_vertex_mib, chunks);
    let per_chunk = plan.paths as f64 / chunks as f64;
    let cap = |what: f64, budget: usize| -> (f64, bool) {
        let over = what > budget as f64;
        (what.min(budget as f64), over)
    };
    let driver = |over| memory::capped(plan.driver, over, plan.budget_field, plan.max_vertex_mib);
    let w = plan.walk;
    let mut kept = 0.0;
    if plan.technique.stores() {
        let (v, over) = cap(per_chunk * w.vertices(), budget.vertices);
        let room = RESERVED_VERTICES.min(budget.vertices) as f64;
        let capacity = budgeted(v, room, budget.vertices as f64);
        let bytes = chunks as f64 * array::<LightVertex>(capacity);
        e.add("light vertices", driver(over), bytes);
        kept = if w.vertices() > 0.0 {
            v / (per_chunk * w.vertices())
        } else {
            0.0
        };
    }
    let keep_segments = plan.keep_segments && has_media;
    let (sv, s_over) = cap(per_chunk * w.segments, budget.segments);
    if keep_segments {
        let capacity = budgeted(sv, 0.0, budget.segments as f64);
        let bytes = chunks as f64 * array::<LightSegment>(capacity);
        e.add("light segments", driver(s_over), bytes);
    }
    let mut ends = array::<Chunk>(chunks as f64) + array::<u32>((chunks * PATHS_PER_TASK) as f64);
    if plan.keep_segments {
        ends += chunks as f64 * array::<u32>(pushed(per_chunk, 0.0));
    }
    e.add("light path ends", plan.driver, ends);
    if plan.technique.splats() {
        let splats = per_chunk * (w.vertices() + 1.0);
        let bytes = chunks as f64 * array::<Splat>(refilled(splats, RESERVED_SPLATS as f64));
        e.add("splats", plan.driver, bytes);
    }
    let paths = plan.paths as f64;
    Stored {
        surface: paths * w.surface * kept,
        medium: paths * w.medium * kept,
        segments: if keep_segments {
            chunks as f64 * sv
        } else {
            0.0
        },
    }
}

impl MergeSet {
    /// The merging copies of `vertices` (this set's, in store order), in the grid's
    /// storage order. The store is read in order and the copies written where the grid
    /// ranks them: scattered writes overlap their cache misses, where gathering reads
    /// would wait on each.
    fn fill<'a>(&mut self, vertices: impl Iterator<Item = &'a LightVertex>) {
        let n = self.positions.len();
        self.merge.clear();
        huge::reserve(&mut self.merge, n);
        self.merge.resize(n, MergeVertex::default());
        let rank = self.grid.rank();
        for (&at, v) in rank.iter().zip(vertices) {
            self.merge[at as usize] = MergeVertex::from(v);
        }
    }

    /// Bytes a set over `n` vertices holds once filled (what
    /// [`MergeSet::index_bytes`] then reports).
    pub(super) fn bytes_for(n: f64) -> f64 {
        let copies = std::mem::size_of::<Vec3>() + std::mem::size_of::<MergeVertex>();
        (huge::reserved(n as usize) * copies) as f64 + HashGrid::bytes_for(n)
    }

    /// Bytes held for positions, grid and merging copies.
    pub(super) fn index_bytes(&self) -> usize {
        self.positions.capacity() * std::mem::size_of::<Vec3>()
            + self.merge.capacity() * std::mem::size_of::<MergeVertex>()
            + self.grid.bytes()
    }
}

/// One chunk of light paths, compiled for AVX2 + FMA processors (chosen at run time)
/// and for baseline x86-64, as the camera pass is (see `pixels.rs`).
fn trace_chunk(
    pass: &Pass,
    seed: u64,
    iteration: u64,
    paths: std::ops::Range<usize>,
    chunk: &mut Chunk,
    budget: Budget,
) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            // SAFETY: the features were detected on this processor just above.
            return unsafe { trace_chunk_avx2(pass, seed, iteration, paths, chunk, budget) };
        }
    }
    trace_chunk_body(pass, seed, iteration, paths, chunk, budget)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
unsafe fn trace_chunk_avx2(
    pass: &Pass,
    seed: u64,
    iteration: u64,
    paths: std::ops::Range<usize>,
    chunk: &mut Chunk,
    budget: Budget,
) {
    trace_chunk_body(pass, seed, iteration, paths, chunk, budget)
}

#[inline(always)]
fn trace_chunk_body(
    pass: &Pass,
    seed: u64,
    iteration: u64,
    paths: std::ops::Range<usize>,
    chunk: &mut Chunk,
    budget: Budget,
) {
    for i in paths {
        let mut rng = Stream::LightSubpaths.rng(seed, iteration, i as u64);
        if pass.scene.has_media {
            trace_one::<WithMedia>(pass, &mut rng, chunk, budget);
        } else {
            trace_one::<NoMedia>(pass, &mut rng, chunk, budget);
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
    /// (light, pick probability, emission density, origin, normal, cos) for area
    /// lights, whose light-sampling density depends on the receiving point.
    area: Option<(usize, f32, f32, Vec3, Vec3, f32)>,
}

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
        specular: true,
        medium: None,
    };
    let st = Start {
        ray: ls.ray,
        walk,
        finite,
        area,
    };
    Some((st, ls))
}

/// One light subpath; `M` (whether the scene has media) is decided once per path.
#[inline(always)]
fn trace_one<M: Media>(pass: &Pass, rng: &mut Rng, chunk: &mut Chunk, budget: Budget) {
    let scene = pass.scene;
    let Some((st, ls)) = start(pass, rng) else {
        return;
    };
    let (es, li, pick) = (&ls.sample, ls.light, ls.pick);
    chunk.stats.samples += 1;
    if pass.technique == super::Technique::Lt {
        splat_emitter::<M>(pass, rng, chunk, es, li, pick);
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
    let store = pass.technique.stores();
    let to_camera = pass.technique.splats();
    // The last vertex's connection to the lens, whose shadow ray (without media) is
    // traced together with the ray that continues the path.
    let mut lens: Option<LensShadow> = None;
    loop {
        chunk.stats.rays += 1;
        let mut owner = Owner::default();
        let (event, tr) = if M::ON {
            let Chunk {
                segments,
                over_budget,
                stats,
                ..
            } = chunk;
            let area = match area {
                Some((l, _, _, _, n0, _)) if walk.len == 1 => (l as u32, n0),
                _ => NO_AREA,
            };
            let mut sink = SegmentSink {
                out: segments,
                budget: budget.segments,
                over_budget,
                start: FlightStart {
                    len: walk.len,
                    q: walk.q,
                    from: walk.origin,
                    area,
                },
            };
            let keep = pass.keep_segments.then_some(&mut sink);
            next_event::<M>(scene, &mut ray, &mut walk, rng, stats, keep, &mut owner)
        } else {
            // Read in place, then cleared: `take` copied the whole lens connection.
            let shadow = lens.as_ref().map(|l| &l.ray);
            let rays = &mut chunk.stats.rays;
            let (event, visible) = next_event_with(scene, &mut ray, shadow, rays, &mut owner);
            if let Some(l) = lens.as_ref().filter(|_| visible) {
                push_splat(chunk, l.raster, l.value, l.layer);
            }
            lens = None;
            (event, 1.0)
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
            if let Some((l, pick, emission, p0, n0, cos0)) = area {
                // The density with which light sampling from this point picks the
                // origin, in area measure ([TR] eq. 31); geometric, no transmittance.
                let pdf_w = scene.lights[l].pdf_li(v.p(), -ray.d, p0, n0);
                walk.q.dvcm = pass
                    .mis
                    .f(pick as f64 * pdf_w as f64 * cos0 as f64 / (dist2 as f64 * emission as f64));
            }
        }
        // A ray from a light at infinity has no distance ([TR] sec. 5.1), only T.
        let d2 = if walk.len > 1 || finite { dist2 } else { 1.0 };
        walk.q = pass.mis.on_hit(walk.q, d2 / tr, v.d_in());
        if !v.skips_connections() {
            if store && chunk.vertices.len() >= budget.vertices {
                chunk.over_budget = true;
            } else if store {
                chunk.vertices.push(stored(v, &walk, ray.d, scene));
            }
            if to_camera {
                lens = connect_to_camera(pass, rng, chunk, &walk, v);
            }
        }
        if walk.len + 2 > pass.s.max_depth {
            break;
        }
        let Some(next) = v.scatter(pass, rng, &mut walk, Mode::Importance, None) else {
            break;
        };
        ray = next;
    }
    // A path that ends at a vertex with a lens connection traces its shadow ray alone.
    if let Some(l) = lens {
        if scene.visible(&l.ray) {
            push_splat(chunk, l.raster, l.value, l.layer);
        }
    }
}

/// A light vertex's connection to the lens, its shadow ray not yet traced.
struct LensShadow {
    ray: Ray,
    raster: crate::math::Vec2,
    /// The splat if nothing blocks the ray.
    value: Rgb,
    layer: Option<usize>,
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
    }
}

/// Connects a light vertex to a point on the lens and splats the result, through
/// the media between them ([TR] eqs. 46-47; SmallVCM's ConnectToCamera). Without
/// media the shadow ray is returned untraced, with the splat it decides.
#[inline(always)]
fn connect_to_camera<M: Media>(
    pass: &Pass,
    rng: &mut Rng,
    chunk: &mut Chunk,
    walk: &Walk,
    v: &Vertex<M>,
) -> Option<LensShadow> {
    let LensLink {
        lens,
        raster,
        dir,
        dist2,
        camera_pdf,
    } = lens_link(pass, rng, v.p())?;
    let e = v.eval(dir, Mode::Importance)?;
    chunk.stats.connections += 1;
    chunk.stats.shadow_rays += 1;
    let (ray, medium) = v.ray_to(pass, walk.medium, lens, Vec3::ZERO, Vec3::ZERO);
    let layer = pass.layers.connection(walk.len + 1, 1);
    let link = (camera_pdf, dist2);
    // Seen from the lens, the vertex would be the first camera vertex.
    let vm = v.merges(pass, dir, Some(1));
    if !M::ON {
        return Some(LensShadow {
            ray,
            raster,
            value: lens_value(pass, walk, (&e, vm), v.cont(), link, Rgb::ONE, 1.0),
            layer,
        });
    }
    let rays = &mut chunk.stats.shadow_rays;
    let (tr, tr_mis) = shadow::<M>(pass.scene, &ray, medium, rng, rays)?;
    let value = lens_value(pass, walk, (&e, vm), v.cont(), link, tr, tr_mis);
    push_splat(chunk, raster, value, layer);
    None
}

/// The splat of a light vertex connected to the lens: `e` is its scattering towards
/// the lens, `link` the camera ray's density per unit pixel area and the squared
/// distance, `tr` and `tr_mis` the segment's transmittance and MIS transmittance.
#[inline(always)]
fn lens_value(
    pass: &Pass,
    walk: &Walk,
    (e, vm): (&Eval, f64),
    cont: f32,
    (camera_pdf, dist2): (f32, f32),
    tr: Rgb,
    tr_mis: f32,
) -> Rgb {
    let camera_a = camera_pdf * e.cos / (dist2 / tr_mis);
    let w = if pass.technique == super::Technique::Lt {
        1.0
    } else {
        pass.mis
            .weight_camera_connection((walk.q, vm), camera_a, e.pdf_rev * cont)
    };
    // The pixel integral is over unit pixel area: divide the area density by
    // camera_a's conversion, i.e. multiply by camera_pdf / dist2.
    walk.throughput * e.f * (w * camera_pdf / dist2 / pass.light_paths as f32) * tr
}

/// A point connected to a sampled lens point.
struct LensLink {
    lens: Vec3,
    raster: crate::math::Vec2,
    /// Unit direction from the point towards the lens.
    dir: Vec3,
    dist2: f32,
    /// The camera ray's solid-angle density per unit pixel area.
    camera_pdf: f32,
}

#[inline(always)]
fn lens_link(pass: &Pass, rng: &mut Rng, p: Vec3) -> Option<LensLink> {
    let cam = &pass.scene.camera;
    let lens = cam.sample_lens(rng.next_2d());
    let raster = cam.raster(p, lens)?;
    let to_cam = lens - p;
    let dist2 = to_cam.length_squared();
    let dir = to_cam / dist2.sqrt();
    Some(LensLink {
        lens,
        raster,
        dir,
        dist2,
        camera_pdf: cam.pdf_dir(-dir),
    })
}

/// Light tracing alone sees emitters through their own emission: connect the light
/// path's origin to the lens (other techniques see emitters from the camera side),
/// through the media from the camera's.
fn splat_emitter<M: Media>(
    pass: &Pass,
    rng: &mut Rng,
    chunk: &mut Chunk,
    es: &crate::light::EmissionSample,
    li: usize,
    pick: f32,
) {
    let Light::Area(area) = &pass.scene.lights[li] else {
        return;
    };
    let Some(LensLink {
        lens,
        raster,
        dir,
        dist2,
        camera_pdf,
    }) = lens_link(pass, rng, es.p)
    else {
        return;
    };
    let le = area.le_sampled(es, dir);
    let cos = es.n.dot(dir).abs();
    if le == Rgb::ZERO || cos <= 0.0 {
        return;
    }
    let v = le * (cos * camera_pdf / (dist2 * pick * es.pdf_pos * pass.light_paths as f32));
    chunk.stats.shadow_rays += 1;
    let ray = spawn_ray_to(
        lens,
        Vec3::ZERO,
        Vec3::ZERO,
        es.p,
        es.p.abs() * gamma(6),
        es.n,
    );
    let scene = pass.scene;
    let medium = scene.camera_medium;
    let rays = &mut chunk.stats.shadow_rays;
    if let Some((tr, _)) = shadow::<M>(scene, &ray, medium, rng, rays) {
        push_splat(chunk, raster, v * tr, pass.layers.connection(1, 1));
    }
}

/// Keeps a splat at film position `raster`; the film spreads it by its filter.
#[inline(always)]
fn push_splat(chunk: &mut Chunk, raster: crate::math::Vec2, v: Rgb, layer: Option<usize>) {
    let layer = layer.map_or(u16::MAX, |l| l as u16);
    chunk.splats.push((raster, v, layer));
}
