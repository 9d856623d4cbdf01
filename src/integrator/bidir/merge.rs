//! Merging's copy of the light vertices: per site (surfaces, media) their positions,
//! the hash grid over them, and what a merge reads of each vertex, in grid order.

use super::Workspace;
use crate::integrator::estimators::{huge, HashGrid};
use crate::integrator::paths::correlation::Link;
use crate::integrator::paths::light_vertex::LightVertex;
use crate::integrator::paths::partial::{Merge, Partial, Site};
use crate::integrator::paths::parts::Parts;
use crate::integrator::paths::store::links_to;
use crate::integrator::paths::Pass;
use crate::math::{Rgb, Vec3};

/// The stored vertices of one merge site and the grid over them.
#[derive(Default)]
pub(super) struct MergeSet {
    /// Every such vertex's position, chunk after chunk (only when merging).
    pub positions: Vec<Vec3>,
    pub grid: HashGrid,
    /// What merging needs of each vertex, in the grid's storage order.
    pub merge: Vec<MergeVertex>,
    /// With `radii` layers, each vertex's [`Parts`] in the same order (else empty).
    pub parts: Vec<Parts>,
    /// With correlation-aware MIS, each vertex's chunk and index in it, in the same
    /// order (else empty): where its links are.
    pub origins: Vec<(u32, u32)>,
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
    /// As `LightVertex::vol`.
    pub vol: f32,
}

const _: () = assert!(std::mem::size_of::<MergeVertex>() == 64);

impl MergeVertex {
    /// The part of `q`'s dvc and dvm that merges in media contribute.
    #[inline(always)]
    pub fn vol(&self) -> f64 {
        self.vol as f64 * self.q.dvc
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
            vol: v.vol,
        }
    }
}

impl Workspace {
    /// Gathers the positions of the light vertices each merge site uses into one
    /// array per site (connections and merging read the vertices where the chunks
    /// stored them; only the grid's positions are gathered).
    pub(super) fn gather_positions(&mut self, pass: &Pass) {
        let ws = self;
        let total: usize = ws.store.chunks.iter().map(|c| c.vertices.len()).sum();
        ws.surface.positions.clear();
        ws.medium.positions.clear();
        if pass.tracing.merges {
            // Only the sites whose estimator is in use.
            let keep = |site: Site| match site {
                Site::Surface => pass.uses(Merge::Surface),
                Site::Medium => pass.uses(Merge::Point3d),
            };
            let vertices = || {
                let all = ws.store.chunks.iter().flat_map(|c| c.vertices.iter());
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
    }

    /// The merging copy of every vertex, per site in its hash grid's storage order.
    pub(super) fn fill_merge(&mut self) {
        for (set, site) in [
            (&mut self.surface, Site::Surface),
            (&mut self.medium, Site::Medium),
        ] {
            let vertices = self.store.chunks.iter().flat_map(|c| c.vertices.iter());
            set.fill(vertices.filter(|v| v.site() == site));
            let chunks = self.store.chunks.iter();
            let parts = chunks.flat_map(|c| c.vertices.iter().zip(&c.parts));
            set.fill_parts(parts.filter(|(v, _)| v.site() == site).map(|(_, p)| p));
            set.origins.clear();
            if self.store.chunks.iter().any(|c| !c.links.is_empty()) {
                let chunks = self.store.chunks.iter().enumerate();
                let at = chunks.flat_map(|(c, chunk)| {
                    let vs = chunk.vertices.iter().enumerate();
                    vs.filter(move |(_, v)| v.site() == site)
                        .map(move |(i, _)| (c as u32, i as u32))
                });
                set.origins.resize(set.merge.len(), (0, 0));
                let rank = set.grid.rank();
                for (&r, o) in rank.iter().zip(at) {
                    set.origins[r as usize] = o;
                }
            }
        }
    }

    /// The links of merging copy `y` of `set` and its light subpath's before it.
    #[inline(always)]
    pub(super) fn links_of(&self, set: &MergeSet, y: &MergeVertex) -> &[Link] {
        let at = set.origins[super::radius_layers::index_in(&set.merge, y)];
        links_to(&self.store.chunks, at)
    }
}

impl MergeSet {
    /// The parts of `y`, a merging copy the grid handed back: its storage order
    /// indexes the copies and their parts alike.
    #[inline(always)]
    pub(super) fn parts_of(&self, y: &MergeVertex) -> &Parts {
        &self.parts[super::radius_layers::index_in(&self.merge, y)]
    }

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

    /// The vertices' [`Parts`] (empty without `radii` layers) in the grid's storage
    /// order, as [`MergeSet::fill`] orders the vertices.
    fn fill_parts<'a>(&mut self, parts: impl Iterator<Item = &'a Parts>) {
        self.parts.clear();
        let rank = self.grid.rank();
        for (&at, p) in rank.iter().zip(parts) {
            if self.parts.is_empty() {
                self.parts.resize(self.merge.len(), Parts::default());
            }
            self.parts[at as usize] = *p;
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
            + self.parts.capacity() * std::mem::size_of::<Parts>()
            + self.origins.capacity() * 8
            + self.grid.bytes()
    }
}
