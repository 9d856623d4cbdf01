//! A four-wide BVH flattened from obvhs's binary tree, traversed with four-lane slab
//! tests (Embree's BVH4 layout: each node holds its children's boxes plane by plane, so
//! one SIMD test decides all four) and Moeller-Trumbore on packs of two to eight
//! triangles and parallelograms, and on packs of spheres (eight AVX lanes, or two
//! groups of four; see `pack`). Other leaves (disks, mixed, single primitives) are
//! runs of primitives tested one at a time through [`Prim::intersect`]; see `build`
//! for how leaves and nodes are chosen.
//!
//! - Closest hit visits children nearest first and skips stack entries beyond the
//!   closest hit so far; any hit (shadow rays) takes them in slot order and stops at
//!   the first hit.
//! - A closest-hit and an any-hit query can run as one interleaved walk
//!   ([`Bvh4::intersect_and_any`]): a path tracer's continuation ray and its shadow
//!   ray are independent, and alternating their steps lets the processor overlap two
//!   dependency chains where one walk alone leaves it waiting on loads and compares
//!   (Cornell box `pt`: 3% more instructions, 11% less time).
//! - Robustness: the slab test keeps every box a ray touches, for axis-parallel rays
//!   too (see [`ray::RayLanes::slab`]), with Ize's widening of the exit distance; hit
//!   distances are the primitives' own, bit for bit.
//! - The stack lives on the machine stack, its bound taken from the tree's depth.
//! - x86_64 needs nothing beyond SSE2; where the processor has AVX the same kernels
//!   run compiled with its three-operand encodings (fewer register copies) and with
//!   eight-lane pack tests, and where
//!   it has AVX-512VL, compiled again for its 32 vector registers (the ray's nine
//!   broadcast lanes and the node's planes then stay in registers instead of being
//!   spilled and reloaded on every node). The kernel is chosen once, when the tree is
//!   built. Other targets use the portable lanes.

use super::lanes::F4;
#[cfg(target_arch = "x86_64")]
use super::lanes::F8;
use super::primitive::Prim;
use super::{Hit, Ray};
use obvhs::bvh2::Bvh2;

mod build;
mod pack;
mod ray;
mod stack;
mod walk;

use pack::{Sphere8, Tri8};
use ray::TraceRay;
#[cfg(test)]
use stack::STACK;

// A child reference is one u32: an inner node index (top bit clear), or a leaf: a run
// of triangle packs, (with SPHERES set) of sphere packs, or (with PRIMS set) of
// primitives tested one at a time. The run's length sits above SPHERES, its first
// index below.
const LEAF: u32 = 1 << 31;
const PRIMS: u32 = 1 << 30;
const COUNT_SHIFT: u32 = 27;
const SPHERES: u32 = 1 << 26;
const INDEX_MASK: u32 = SPHERES - 1;
/// Most primitives a tree can hold: a leaf names its first primitive (or pack) in the
/// bits below SPHERES.
pub const MAX_PRIMITIVES: usize = INDEX_MASK as usize;
/// Most packs or primitives one leaf reference can hold.
const MAX_RUN: usize = 7;
/// An unused slot: its box is empty, so no ray reaches it, and should a NaN ray get
/// through the slab test anyway it is a run of no primitives.
const EMPTY: u32 = LEAF | PRIMS;

/// Four children: their boxes plane by plane (per axis lo, hi; an empty slot has
/// lo = +inf, hi = -inf) and their references. Two cache lines.
#[repr(C, align(64))]
struct Node4 {
    planes: [[F4; 2]; 3],
    child: [u32; 4],
}

pub struct Bvh4 {
    nodes: Vec<Node4>,
    tris: Vec<Tri8>,
    spheres: Vec<Sphere8>,
    root: u32,
    /// Stack entries a traversal can need: at most three per inner level.
    stack_len: usize,
    /// The root's leaves, when the tree is one node with only leaves below it and
    /// testing them all costs less than the slab test that picks among them (see
    /// `build`): walks then start with them stacked. `flat_len` is 0 otherwise. A
    /// copy of the root's first slots, kept here because reading them through
    /// `nodes` cost every walk 1% more instructions (bounds checks; gbs_p `bpt`).
    flat: [u32; 4],
    flat_len: usize,
    /// Which compilation of the kernels to run (detected when built).
    isa: Isa,
}

/// The instruction sets the kernels are compiled for, best last.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Isa {
    Base,
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    Avx,
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    Avx512,
}

impl Isa {
    fn detect() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512vl")
            {
                return Isa::Avx512;
            }
            if std::is_x86_feature_detected!("avx") {
                return Isa::Avx;
            }
        }
        Isa::Base
    }
}

impl Bvh4 {
    /// Closest hit in (0, ray.tmax), front to back: children nearest first, and stack
    /// entries farther than the closest hit so far skipped.
    #[inline(always)]
    pub fn intersect(&self, prims: &[Prim], ray: &Ray) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        match self.isa {
            // SAFETY: `isa` names only instruction sets detected on this processor.
            Isa::Avx512 => return unsafe { self.intersect_avx512(prims, &ray.into()) },
            Isa::Avx => return unsafe { self.intersect_avx(prims, &ray.into()) },
            Isa::Base => {}
        }
        self.intersect_base(prims, &ray.into())
    }

    /// Some primitive in (0, ray.tmax), if there is one: children in any order, and the
    /// first hit found ends it (not the nearest).
    #[inline(always)]
    pub fn any_hit(&self, prims: &[Prim], ray: &Ray) -> Option<u32> {
        #[cfg(target_arch = "x86_64")]
        match self.isa {
            // SAFETY: `isa` names only instruction sets detected on this processor.
            Isa::Avx512 => return unsafe { self.any_hit_avx512(prims, &ray.into()) },
            Isa::Avx => return unsafe { self.any_hit_avx(prims, &ray.into()) },
            Isa::Base => {}
        }
        self.any_hit_base(prims, &ray.into())
    }

    /// The closest hit along `closest` and some hit along `any`, the two traversals
    /// interleaved: what [`intersect`](Self::intersect) and [`any_hit`](Self::any_hit)
    /// return, in less time than the two calls.
    #[inline(always)]
    pub fn intersect_and_any(
        &self,
        prims: &[Prim],
        closest: &Ray,
        any: &Ray,
    ) -> (Option<Hit>, Option<u32>) {
        let (c, a): (&TraceRay, &TraceRay) = (&closest.into(), &any.into());
        #[cfg(target_arch = "x86_64")]
        match self.isa {
            // SAFETY: `isa` names only instruction sets detected on this processor.
            Isa::Avx512 => return unsafe { self.pair_avx512(prims, c, a) },
            Isa::Avx => return unsafe { self.pair_avx(prims, c, a) },
            Isa::Base => {}
        }
        self.pair_base(prims, c, a)
    }

    #[inline(never)]
    fn pair_base(&self, prims: &[Prim], c: &TraceRay, a: &TraceRay) -> (Option<Hit>, Option<u32>) {
        self.pair_on_stack::<F4>(prims, c, a)
    }

    /// # Safety
    /// The processor must support AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn pair_avx(
        &self,
        prims: &[Prim],
        c: &TraceRay,
        a: &TraceRay,
    ) -> (Option<Hit>, Option<u32>) {
        self.pair_on_stack::<F8>(prims, c, a)
    }

    /// # Safety
    /// The processor must support AVX-512F and AVX-512VL.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    unsafe fn pair_avx512(
        &self,
        prims: &[Prim],
        c: &TraceRay,
        a: &TraceRay,
    ) -> (Option<Hit>, Option<u32>) {
        self.pair_on_stack::<F8>(prims, c, a)
    }

    /// The kernels compiled for the baseline target (SSE2 on x86_64). Out of line, so
    /// the dispatch above stays small enough to inline into callers.
    #[inline(never)]
    fn intersect_base(&self, prims: &[Prim], ray: &TraceRay) -> Option<Hit> {
        self.closest_on_stack::<F4>(prims, ray)
    }

    #[inline(never)]
    fn any_hit_base(&self, prims: &[Prim], ray: &TraceRay) -> Option<u32> {
        self.any_on_stack::<F4>(prims, ray)
    }

    /// The kernels compiled with AVX: the same four-lane slab tests with fewer register
    /// copies, and pack tests eight lanes at a time.
    ///
    /// # Safety
    /// The processor must support AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn intersect_avx(&self, prims: &[Prim], ray: &TraceRay) -> Option<Hit> {
        self.closest_on_stack::<F8>(prims, ray)
    }

    /// # Safety
    /// The processor must support AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn any_hit_avx(&self, prims: &[Prim], ray: &TraceRay) -> Option<u32> {
        self.any_on_stack::<F8>(prims, ray)
    }

    /// The kernels compiled for AVX-512VL: still four lanes, but with 32 vector
    /// registers.
    ///
    /// # Safety
    /// The processor must support AVX-512F and AVX-512VL.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    unsafe fn intersect_avx512(&self, prims: &[Prim], ray: &TraceRay) -> Option<Hit> {
        self.closest_on_stack::<F8>(prims, ray)
    }

    /// # Safety
    /// The processor must support AVX-512F and AVX-512VL.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    unsafe fn any_hit_avx512(&self, prims: &[Prim], ray: &TraceRay) -> Option<u32> {
        self.any_on_stack::<F8>(prims, ray)
    }

    /// Makes traversal take the heap stack meant for very deep trees.
    #[cfg(test)]
    pub fn force_heap_stack(&mut self) {
        self.stack_len = self.stack_len.max(STACK + 1);
    }

    #[cfg(test)]
    pub fn sphere_packs_empty(&self) -> bool {
        self.spheres.is_empty()
    }

    /// Levels of inner nodes, from the bound the builder set on the walk's stack.
    #[cfg(test)]
    pub fn depth(&self) -> usize {
        self.stack_len.saturating_sub(1) / 3
    }

    #[cfg(test)]
    pub fn is_flat(&self) -> bool {
        self.flat_len > 0
    }

    /// Leaf references of each kind: (triangle packs, sphere packs, runs tested one
    /// primitive at a time).
    #[cfg(test)]
    pub fn leaf_kinds(&self) -> (usize, usize, usize) {
        let leaves = self.nodes.iter().flat_map(|n| n.child);
        let leaves: Vec<u32> = leaves.filter(|&c| c & LEAF != 0 && c != EMPTY).collect();
        let of = |kind: u32| {
            leaves
                .iter()
                .filter(|&&c| c & (PRIMS | SPHERES) == kind)
                .count()
        };
        (of(0), of(SPHERES), of(PRIMS))
    }

    /// Chooses the baseline kernels even where AVX exists.
    #[cfg(test)]
    pub fn disable_avx(&mut self) {
        self.isa = Isa::Base;
    }

    /// Chooses the AVX kernels where AVX-512 exists too (processors without it, such
    /// as many CI runners, take that path).
    #[cfg(test)]
    pub fn disable_avx512(&mut self) {
        self.isa = self.isa.min(Isa::Avx);
    }

    /// A tree over nothing: every ray misses.
    pub fn empty() -> Bvh4 {
        Bvh4 {
            nodes: Vec::new(),
            tris: Vec::new(),
            spheres: Vec::new(),
            root: EMPTY,
            stack_len: 0,
            flat: [EMPTY; 4],
            flat_len: 0,
            isa: Isa::detect(),
        }
    }

    /// Bytes held by nodes and triangle packs.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node4>()
            + self.tris.len() * std::mem::size_of::<Tri8>()
            + self.spheres.len() * std::mem::size_of::<Sphere8>()
    }

    /// Flattens a binary tree over `prims` (its leaves index them through
    /// `primitive_indices`, each primitive once; see [`build`]). Returns the tree and
    /// the order the primitives must be stored in for it: `order[i]` is the index in
    /// `prims` of the primitive the tree's leaves and hits call `i`.
    pub fn from_bvh2(bvh: &Bvh2, prims: &[Prim]) -> (Bvh4, Vec<u32>) {
        build::from_bvh2(bvh, prims)
    }
}
