//! The light paths of an iteration as the light tracer stores them: per chunk of
//! paths, its non-specular vertices, its segments through media (when kept) and its
//! splats, in path order, so that the store never depends on the thread count; and
//! what it costs in memory.

use super::correlation::{FlightLinks, Link};
use super::light_vertex::LightVertex;
use super::parts::Parts;
use super::segments::LightSegment;
use super::{Splat, Tracing};
use crate::integrator::drive::light::chunk_share;
use crate::integrator::memory::{self, array, budgeted, pushed, refilled, Estimate};
use crate::integrator::transport::PATHS_PER_TASK;
use crate::integrator::RenderStats;

/// The light paths of one iteration, kept between iterations to reuse the buffers.
#[derive(Default)]
pub(crate) struct Store {
    pub(crate) chunks: Vec<Chunk>,
    pub(crate) paths: usize,
}

/// The segments light path `path` kept, in the order it traced them (empty unless the
/// pass keeps segments).
pub(crate) fn path_segments(chunks: &[Chunk], path: usize) -> &[LightSegment] {
    let chunk = &chunks[path / PATHS_PER_TASK];
    let i = path % PATHS_PER_TASK;
    if chunk.segment_ends.is_empty() {
        return &[];
    }
    let begin = if i == 0 { 0 } else { chunk.segment_ends[i - 1] };
    &chunk.segments[begin as usize..chunk.segment_ends[i] as usize]
}

/// What a side array parallel to the segments (`side(chunk)`) holds for
/// [`path_segments`]`(chunks, path)`: empty where the array is.
fn path_segment_side<T>(chunks: &[Chunk], path: usize, side: impl Fn(&Chunk) -> &[T]) -> &[T] {
    let (chunk, i) = (&chunks[path / PATHS_PER_TASK], path % PATHS_PER_TASK);
    let all = side(chunk);
    if all.is_empty() {
        return &[];
    }
    let begin = if i == 0 { 0 } else { chunk.segment_ends[i - 1] };
    &all[begin as usize..chunk.segment_ends[i] as usize]
}

/// The [`Chunk::segment_parts`] of [`path_segments`]`(chunks, path)`: empty
/// without radius layers.
pub(crate) fn path_segment_parts(chunks: &[Chunk], path: usize) -> &[[Parts; 2]] {
    path_segment_side(chunks, path, |c| &c.segment_parts)
}

/// The [`Chunk::segment_links`] of [`path_segments`]`(chunks, path)`: empty
/// without correlation-aware MIS.
pub(crate) fn path_segment_links(chunks: &[Chunk], path: usize) -> &[FlightLinks] {
    path_segment_side(chunks, path, |c| &c.segment_links)
}

/// The links of vertex `index` of chunk `chunk` and of its light subpath's stored
/// vertices before it (the chunk's links must be kept).
#[inline(always)]
pub(crate) fn links_to(chunks: &[Chunk], (chunk, index): (u32, u32)) -> &[Link] {
    let links = &chunks[chunk as usize].links[..=index as usize];
    let first = links.iter().rposition(|l| l.first).unwrap_or(0);
    &links[first..]
}

/// How many vertices and segments one chunk may store (`max_vertex_mib` each).
#[derive(Clone, Copy)]
pub(crate) struct Budget {
    pub(crate) vertices: usize,
    pub(crate) segments: usize,
}

impl Budget {
    /// Each of `chunks` chunks' share of `max_vertex_mib`.
    pub(crate) fn new(max_vertex_mib: f32, chunks: usize) -> Budget {
        Budget {
            vertices: chunk_share::<LightVertex>(max_vertex_mib, chunks),
            segments: chunk_share::<LightSegment>(max_vertex_mib, chunks),
        }
    }
}

/// The first iteration's room per chunk, rather than growth by doubling, each step a
/// copy into freshly faulted pages: light paths store two or three vertices in closed
/// scenes, and splat about as many. Later iterations reuse it all.
pub(crate) const RESERVED_VERTICES: usize = PATHS_PER_TASK * 3;
pub(crate) const RESERVED_SPLATS: usize = PATHS_PER_TASK * 2;

/// One chunk's output, kept between iterations to reuse its buffers.
#[derive(Default)]
pub(crate) struct Chunk {
    pub(crate) vertices: Vec<LightVertex>,
    /// With `radii` layers, each vertex's [`Parts`] (else empty).
    pub(crate) parts: Vec<Parts>,
    /// With correlation-aware MIS, each vertex's [`Link`] (else empty).
    pub(crate) links: Vec<Link>,
    /// Per light path of the chunk, the end of its vertices within `vertices`.
    pub(crate) ends: Vec<u32>,
    /// Segments through media, when the pass keeps them, and per light path their end.
    pub(crate) segments: Vec<LightSegment>,
    pub(crate) segment_ends: Vec<u32>,
    /// With `radii` layers, each segment's [`FlightStart::parts`] (else empty).
    ///
    /// [`FlightStart::parts`]: super::segments::FlightStart::parts
    pub(crate) segment_parts: Vec<[Parts; 2]>,
    /// With correlation-aware MIS, each segment's [`FlightStart::links`] (else empty).
    ///
    /// [`FlightStart::links`]: super::segments::FlightStart::links
    pub(crate) segment_links: Vec<FlightLinks>,
    pub splats: Vec<Splat>,
    pub(crate) stats: RenderStats,
    /// A vertex was not stored because the budget was spent.
    pub(crate) over_budget: bool,
}

impl Store {
    /// Light paths traced (including those that stored nothing).
    pub fn paths(&self) -> usize {
        self.paths
    }

    /// Every stored vertex, path after path, each path's in order of length.
    pub fn vertices(&self) -> impl Iterator<Item = &LightVertex> {
        self.chunks.iter().flat_map(|c| c.vertices.iter())
    }

    /// Every kept segment through a medium, in the same order.
    pub fn segments(&self) -> impl Iterator<Item = &LightSegment> {
        self.chunks.iter().flat_map(|c| c.segments.iter())
    }

    /// The splats of every chunk, in chunk order.
    pub fn splats(&self) -> impl Iterator<Item = &Splat> {
        self.chunks.iter().flat_map(|c| c.splats.iter())
    }

    /// Light path `path`'s chunk and the range of its vertices there.
    #[inline(always)]
    fn path_range(&self, path: usize) -> (&Chunk, std::ops::Range<usize>) {
        let chunk = &self.chunks[path / PATHS_PER_TASK];
        let i = path % PATHS_PER_TASK;
        let begin = if i == 0 { 0 } else { chunk.ends[i - 1] };
        (chunk, begin as usize..chunk.ends[i] as usize)
    }

    /// The stored vertices of light path `path`, in order of length.
    #[inline(always)]
    pub(crate) fn light_path(&self, path: usize) -> &[LightVertex] {
        let (chunk, range) = self.path_range(path);
        &chunk.vertices[range]
    }

    /// Their links (empty without correlation-aware MIS).
    #[inline(always)]
    pub(crate) fn light_path_links(&self, path: usize) -> &[Link] {
        let (chunk, range) = self.path_range(path);
        chunk.links.get(range).unwrap_or(&[])
    }

    /// Their [`Parts`] (empty without `radii` layers).
    #[inline(always)]
    pub(crate) fn light_path_parts(&self, path: usize) -> &[Parts] {
        let (chunk, range) = self.path_range(path);
        chunk.parts.get(range).unwrap_or(&[])
    }

    /// The segments light path `path` kept, in the order it traced them (empty unless
    /// the pass keeps segments).
    #[allow(dead_code)] // read by the tests
    pub(crate) fn light_segments(&self, path: usize) -> &[LightSegment] {
        path_segments(&self.chunks, path)
    }

    /// Bytes held for light vertices and segments (the chunks' stores).
    pub(crate) fn vertex_store_bytes(&self) -> usize {
        let stores: usize = self
            .chunks
            .iter()
            .map(|c| {
                c.vertices.capacity() * std::mem::size_of::<LightVertex>()
                    + c.parts.capacity() * std::mem::size_of::<Parts>()
                    + c.links.capacity() * std::mem::size_of::<Link>()
                    + c.segment_links.capacity() * std::mem::size_of::<FlightLinks>()
                    + c.segments.capacity() * std::mem::size_of::<LightSegment>()
            })
            .sum();
        stores
    }
}

/// One iteration's light pass, as the memory estimate sees it.
pub(crate) struct StorePlan<'a> {
    pub tracing: Tracing,
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

/// Adds what [`super::light_path::trace_light_paths`] holds to `e`: per chunk of paths its vertices (the
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
    if plan.tracing.stores {
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
    if plan.tracing.splats {
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
