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
//!   too (see [`RayLanes::slab`]), with Ize's widening of the exit distance; hit
//!   distances are the primitives' own, bit for bit.
//! - The stack lives on the machine stack, its bound taken from the tree's depth.
//! - x86_64 needs nothing beyond SSE2; where the processor has AVX the same kernels
//!   run compiled with its three-operand encodings (fewer register copies) and with
//!   eight-lane pack tests, and where
//!   it has AVX-512VL, compiled again for its 32 vector registers (the ray's nine
//!   broadcast lanes and the node's planes then stay in registers instead of being
//!   spilled and reloaded on every node). The kernel is chosen once, when the tree is
//!   built. Other targets use the portable lanes.

#[cfg(target_arch = "x86_64")]
use super::lanes::F8;
use super::lanes::{Lanes, F4};
use super::primitive::Prim;
use super::{Hit, Ray};
use crate::math::{Vec2, Vec3A};
use obvhs::bvh2::Bvh2;
use std::mem::MaybeUninit;

mod build;
mod pack;

use pack::{Pack, PackRay, Sphere8, Tri8};

// A child reference is one u32: an inner node index (top bit clear), or a leaf: a run
// of triangle packs, (with SPHERES set) of sphere packs, or (with PRIMS set) of
// primitives tested one at a time. The run's length sits above SPHERES, its first
// index below.
const LEAF: u32 = 1 << 31;
const PRIMS: u32 = 1 << 30;
const COUNT_SHIFT: u32 = 27;
const SPHERES: u32 = 1 << 26;
const INDEX_MASK: u32 = SPHERES - 1;
/// Most packs or primitives one leaf reference can hold.
const MAX_RUN: usize = 7;
/// An unused slot: its box is empty, so no ray reaches it, and should a NaN ray get
/// through the slab test anyway it is a run of no primitives.
const EMPTY: u32 = LEAF | PRIMS;

/// Widening of the slab test's exit distance, 1 + 2 gamma(3), which makes it
/// conservative under rounding (Ize, "Robust BVH Ray Traversal", JCGT 2013).
const ROBUST: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Entries an on-stack traversal stack holds; deeper trees use a heap stack.
const STACK: usize = 192;

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

/// A ray as the kernels take it: origin and direction in four lanes each, so the
/// caller writes them with one vector store apiece and the kernel reads them back
/// with one load. Handed a [`Ray`] (three scalars per vector, written by scalar
/// stores), the kernel's wider loads missed store forwarding and waited for the
/// stores to retire (perf, Cornell box `pt`).
struct TraceRay {
    o: Vec3A,
    d: Vec3A,
    tmax: f32,
}

impl From<&Ray> for TraceRay {
    #[inline(always)]
    fn from(r: &Ray) -> Self {
        TraceRay {
            o: r.o.into(),
            d: r.d.into(),
            tmax: r.tmax,
        }
    }
}

/// Per-ray values shared by every slab and triangle test.
struct RayLanes {
    o: [F4; 3],
    inv: [F4; 3],
    /// Per axis, 1 when the direction is negative (then the near plane is `hi`).
    neg: [usize; 3],
    o3: Vec3A,
    d3: Vec3A,
}

impl RayLanes {
    #[inline(always)]
    fn new(ray: &TraceRay) -> Self {
        let (o3, d3) = (ray.o, ray.d);
        // 1 / +-0 = +-inf is intended: the slab test below copes with it.
        let d = F4::from_vec3a(d3);
        let inv = F4::splat(1.0) / d;
        // The signs of d and 1 / d agree (-0 gives -inf); taking them from d keeps the
        // division off the path to the first node's loads.
        let neg = d.sign_bits();
        RayLanes {
            o: F4::from_vec3a(o3).broadcast3(),
            inv: inv.broadcast3(),
            neg: [
                neg as usize & 1,
                neg as usize >> 1 & 1,
                neg as usize >> 2 & 1,
            ],
            o3,
            d3,
        }
    }

    /// Bit mask of the children whose box the ray enters before `tmax`, and their
    /// entry distances.
    ///
    /// Robust for axis-parallel rays: a zero direction component gives 1 / 0 = inf,
    /// and 0 * inf = NaN when the origin lies on that slab's plane. `max` and `min`
    /// return their second operand on NaN, and the last operation of each chain has a
    /// second operand that is never NaN (`max(tnz, 0)`, `min(tfz, tmax)`), so a NaN
    /// only drops its slab from the test: the box is kept, never lost. Boxes are
    /// entered only through their near planes (chosen by the direction's signs), which
    /// is what makes empty slots (lo = +inf, hi = -inf) miss. The exit distance, and
    /// with it `tmax`, is widened by 1 + 2 gamma(3) against rounding (Ize 2013).
    #[inline(always)]
    fn slab(&self, n: &Node4, tmax: F4) -> (u32, F4) {
        let [x, y, z] = &n.planes;
        // `& 1` lets the compiler drop the bounds checks.
        let [nx, ny, nz] = self.neg.map(|s| s & 1);
        let tnx = (x[nx] - self.o[0]) * self.inv[0];
        let tfx = (x[nx ^ 1] - self.o[0]) * self.inv[0];
        let tny = (y[ny] - self.o[1]) * self.inv[1];
        let tfy = (y[ny ^ 1] - self.o[1]) * self.inv[1];
        let tnz = (z[nz] - self.o[2]) * self.inv[2];
        let tfz = (z[nz ^ 1] - self.o[2]) * self.inv[2];
        let tn = tnx.max(tny).max(tnz.max(F4::splat(0.0)));
        let tf = tfx.min(tfy).min(tfz.min(tmax)) * F4::splat(ROBUST);
        (tn.le(tf).bits(), tn)
    }
}

/// Binds `$buf` to traversal stack storage for `$tree`: on the machine stack, or on
/// the heap when the tree is too deep for that. (A macro rather than a function
/// taking the kernel as a closure, which measured 3% more instructions.)
macro_rules! stack_buffer {
    ($tree:expr, $buf:ident) => {
        let mut items = [MaybeUninit::<Entry>::uninit(); STACK];
        let mut heap;
        let $buf: &mut [_] = if $tree.stack_len > STACK {
            heap = heap_stack($tree.stack_len);
            &mut heap
        } else {
            &mut items
        };
    };
}

#[derive(Clone, Copy)]
struct Entry {
    child: u32,
    t: f32,
}

/// A traversal stack; `Bvh4::stack_len` bounds how deep it gets.
struct Stack<'a> {
    items: &'a mut [MaybeUninit<Entry>],
    len: usize,
}

impl<'a> Stack<'a> {
    #[inline(always)]
    fn new(items: &'a mut [MaybeUninit<Entry>]) -> Self {
        Stack { items, len: 0 }
    }

    #[inline(always)]
    fn push(&mut self, child: u32, t: f32) {
        self.items[self.len] = MaybeUninit::new(Entry { child, t });
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<Entry> {
        self.len = self.len.checked_sub(1)?;
        // SAFETY: every slot below `len` was written by `push`.
        Some(unsafe { self.items[self.len].assume_init() })
    }

    #[inline(always)]
    fn get(&self, i: usize) -> Entry {
        debug_assert!(i < self.len);
        // SAFETY: callers only read below `len`, and those slots were pushed.
        unsafe { self.items[i].assume_init() }
    }

    #[inline(always)]
    fn set(&mut self, i: usize, e: Entry) {
        self.items[i] = MaybeUninit::new(e);
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

    #[inline(always)]
    fn pair_on_stack<L: Lanes>(
        &self,
        prims: &[Prim],
        c: &TraceRay,
        a: &TraceRay,
    ) -> (Option<Hit>, Option<u32>) {
        stack_buffer!(self, buf_c);
        stack_buffer!(self, buf_a);
        self.closest_and_any::<L>(prims, c, a, Stack::new(buf_c), Stack::new(buf_a))
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

    // The stack: uninitialised on the machine stack (zeroing it per ray shows in
    // profiles), or on the heap for trees too deep for that (never seen in practice).
    // One copy of each kernel serves both, so the heap case runs with the same
    // instruction set as the rest (an out-of-line copy would lose the AVX features).

    #[inline(always)]
    fn closest_on_stack<L: Lanes>(&self, prims: &[Prim], ray: &TraceRay) -> Option<Hit> {
        stack_buffer!(self, buf);
        self.closest::<L>(prims, ray, Stack::new(buf))
    }

    #[inline(always)]
    fn any_on_stack<L: Lanes>(&self, prims: &[Prim], ray: &TraceRay) -> Option<u32> {
        stack_buffer!(self, buf);
        self.any::<L>(prims, ray, Stack::new(buf))
    }

    #[inline(always)]
    fn closest<L: Lanes>(&self, prims: &[Prim], ray: &TraceRay, stack: Stack) -> Option<Hit> {
        let mut w = Closest::<L>::new(self, ray, stack);
        while !w.step(self, prims) {}
        w.hit()
    }

    #[inline(always)]
    fn any<L: Lanes>(&self, prims: &[Prim], ray: &TraceRay, stack: Stack) -> Option<u32> {
        let mut w = Any::<L>::new(self, ray, stack);
        loop {
            if w.cur & LEAF == 0 {
                let n = &self.nodes[w.cur as usize];
                let (mask, _) = w.r.slab(n, w.tmax4);
                if mask != 0 {
                    w.cur = w.descend(n, mask);
                    continue;
                }
            } else if let Some(i) = w.leaf(self, prims) {
                return Some(i);
            }
            w.cur = w.stack.pop()?.child;
        }
    }

    /// Both walks in one loop, a step of each in turn: their dependency chains are
    /// independent, so the processor overlaps them (one walk alone leaves most of the
    /// core idle waiting on its loads and compares). Results are those of the
    /// separate kernels, bit for bit.
    #[inline(always)]
    fn closest_and_any<L: Lanes>(
        &self,
        prims: &[Prim],
        closest: &TraceRay,
        any: &TraceRay,
        sc: Stack,
        sa: Stack,
    ) -> (Option<Hit>, Option<u32>) {
        let mut c = Closest::<L>::new(self, closest, sc);
        if any.tmax.is_nan() || any.tmax <= 0.0 {
            // Nothing lies in (0, tmax) (and a NaN limit meets nothing either): the
            // closest-hit walk alone, in this kernel.
            while !c.step(self, prims) {}
            return (c.hit(), None);
        }
        let mut a = Any::<L>::new(self, any, sa);
        let (mut c_done, mut a_code) = (false, GOING);
        while !c_done && a_code == GOING {
            c_done = c.step(self, prims);
            a_code = a.step(self, prims);
        }
        while !c_done {
            c_done = c.step(self, prims);
        }
        while a_code == GOING {
            a_code = a.step(self, prims);
        }
        (c.hit(), any_result(a_code))
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

/// A closest-hit traversal in progress: front to back, children nearest first, stack
/// entries farther than the closest hit so far skipped.
struct Closest<'s, L> {
    r: RayLanes,
    pr: PackRay<L>,
    tmax: f32,
    /// The closest hit so far, in locals rather than an Option the compiler keeps in
    /// memory; `prim == u32::MAX` until something is hit.
    prim: u32,
    uv: Vec2,
    /// The reference to visit next.
    cur: u32,
    stack: Stack<'s>,
}

impl<'s, L: Lanes> Closest<'s, L> {
    #[inline(always)]
    fn new(tree: &Bvh4, ray: &TraceRay, mut stack: Stack<'s>) -> Self {
        let r = RayLanes::new(ray);
        let pr = PackRay::<L>::new(r.o3, r.d3);
        Closest {
            r,
            pr,
            tmax: ray.tmax,
            prim: u32::MAX,
            uv: Vec2::ZERO,
            cur: first_ref(tree, &mut stack),
            stack,
        }
    }

    #[inline(always)]
    fn hit(&self) -> Option<Hit> {
        (self.prim != u32::MAX).then_some(Hit {
            t: self.tmax,
            prim: self.prim,
            uv: self.uv,
        })
    }

    /// Tests the leaf `cur`, keeping its hit if nearer.
    #[inline(always)]
    fn leaf(&mut self, tree: &Bvh4, prims: &[Prim]) {
        let (first, count) = run(self.cur);
        if self.cur & PRIMS != 0 {
            if let Some(h) = run_closest(prims, first, count, self.r.o3, self.r.d3, self.tmax) {
                (self.tmax, self.prim, self.uv) = (h.t, h.prim, h.uv);
            }
        } else if self.cur & SPHERES != 0 {
            self.packs(&tree.spheres[first..first + count]);
        } else {
            self.packs(&tree.tris[first..first + count]);
        }
    }

    #[inline(always)]
    fn packs<P: Pack>(&mut self, packs: &[P]) {
        for pack in packs {
            if let Some((lane, t, uv)) = self.pr.nearest(pack, self.tmax) {
                (self.tmax, self.prim, self.uv) = (t, pack.prim(lane), uv);
            }
        }
    }

    /// The next stack entry still nearer than the closest hit; entry distances carry
    /// the slab test's widening so rounding never culls a box that holds the hit.
    #[inline(always)]
    fn next(&mut self) -> Option<u32> {
        let cull = self.tmax * ROBUST;
        loop {
            let e = self.stack.pop()?;
            if e.t <= cull {
                return Some(e.child);
            }
        }
    }

    /// Visits `cur` and chooses the next reference; true when nothing is left.
    #[inline(always)]
    fn step(&mut self, tree: &Bvh4, prims: &[Prim]) -> bool {
        if self.cur & LEAF == 0 {
            let n = &tree.nodes[self.cur as usize];
            let (mask, tn) = self.r.slab(n, F4::splat(self.tmax));
            if mask != 0 {
                self.cur = descend(&mut self.stack, n, mask, tn.to_array());
                return false;
            }
        } else {
            self.leaf(tree, prims);
        }
        match self.next() {
            Some(c) => {
                self.cur = c;
                false
            }
            None => true,
        }
    }
}

/// Where a walk starts: the root, or in a flat tree its first leaf, with the others
/// stacked at distance 0 so that no closest hit culls them.
#[inline(always)]
fn first_ref(tree: &Bvh4, stack: &mut Stack) -> u32 {
    if tree.flat_len == 0 {
        return tree.root;
    }
    let leaves = &tree.flat[..tree.flat_len];
    for &c in leaves[1..].iter().rev() {
        stack.push(c, 0.0);
    }
    leaves[0]
}

/// A leaf reference's run: (first index, length).
#[inline(always)]
fn run(leaf: u32) -> (usize, usize) {
    let first = (leaf & INDEX_MASK) as usize;
    let count = ((leaf & !(LEAF | PRIMS)) >> COUNT_SHIFT) as usize;
    (first, count)
}

/// The nearest child of `n` in `mask`, the others stacked farthest first.
#[inline(always)]
fn descend(stack: &mut Stack, n: &Node4, mask: u32, tn: [f32; 4]) -> u32 {
    let i0 = mask.trailing_zeros() as usize;
    let rest = mask & (mask - 1);
    if rest == 0 {
        return n.child[i0];
    }
    let i1 = rest.trailing_zeros() as usize;
    let rest = rest & (rest - 1);
    if rest == 0 {
        let (near, far) = if tn[i1] < tn[i0] { (i1, i0) } else { (i0, i1) };
        stack.push(n.child[far], tn[far]);
        return n.child[near];
    }
    // Three or four: push them all, sort those entries farthest first (insertion
    // sort), and continue with the nearest.
    let base = stack.len;
    let mut m = mask;
    while m != 0 {
        let i = m.trailing_zeros() as usize;
        m &= m - 1;
        stack.push(n.child[i], tn[i]);
    }
    for i in base + 1..stack.len {
        let e = stack.get(i);
        let mut j = i;
        while j > base && stack.get(j - 1).t < e.t {
            stack.set(j, stack.get(j - 1));
            j -= 1;
        }
        stack.set(j, e);
    }
    stack.pop().map_or(EMPTY, |e| e.child)
}

/// An any-hit traversal in progress: children in slot order, ended by the first hit.
struct Any<'s, L> {
    r: RayLanes,
    pr: PackRay<L>,
    tmax: f32,
    tmax4: F4,
    cur: u32,
    stack: Stack<'s>,
}

impl<'s, L: Lanes> Any<'s, L> {
    #[inline(always)]
    fn new(tree: &Bvh4, ray: &TraceRay, mut stack: Stack<'s>) -> Self {
        let r = RayLanes::new(ray);
        let pr = PackRay::<L>::new(r.o3, r.d3);
        Any {
            r,
            pr,
            tmax: ray.tmax,
            tmax4: F4::splat(ray.tmax),
            cur: first_ref(tree, &mut stack),
            stack,
        }
    }

    /// The first child of `n` in `mask`; the others are stacked.
    #[inline(always)]
    fn descend(&mut self, n: &Node4, mask: u32) -> u32 {
        let mut m = mask & (mask - 1);
        while m != 0 {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            self.stack.push(n.child[i], 0.0);
        }
        n.child[mask.trailing_zeros() as usize]
    }

    /// Some primitive of the leaf `cur` that the ray hits.
    #[inline(always)]
    fn leaf(&self, tree: &Bvh4, prims: &[Prim]) -> Option<u32> {
        let (first, count) = run(self.cur);
        if self.cur & PRIMS != 0 {
            run_any(prims, first, count, self.r.o3, self.r.d3, self.tmax)
        } else if self.cur & SPHERES != 0 {
            self.packs(&tree.spheres[first..first + count])
        } else {
            self.packs(&tree.tris[first..first + count])
        }
    }

    #[inline(always)]
    fn packs<P: Pack>(&self, packs: &[P]) -> Option<u32> {
        // A loop, not `find_map`: its closure could be compiled out of line, without
        // the kernel's AVX features.
        for pack in packs {
            if let Some(lane) = self.pr.any(pack, self.tmax) {
                return Some(pack.prim(lane));
            }
        }
        None
    }

    /// Visits `cur` and chooses the next reference: [`GOING`], or the end of the walk
    /// (the primitive hit, or [`MISSED`]). A code rather than an `Option` held in the
    /// walk, which the compiler kept in memory.
    #[inline(always)]
    fn step(&mut self, tree: &Bvh4, prims: &[Prim]) -> u32 {
        if self.cur & LEAF == 0 {
            let n = &tree.nodes[self.cur as usize];
            let (mask, _) = self.r.slab(n, self.tmax4);
            if mask != 0 {
                self.cur = self.descend(n, mask);
                return GOING;
            }
        } else if let Some(i) = self.leaf(tree, prims) {
            return i;
        }
        match self.stack.pop() {
            Some(e) => {
                self.cur = e.child;
                GOING
            }
            None => MISSED,
        }
    }
}

/// What [`Any::step`] returns while the walk goes on; any other value ends it: a
/// primitive hit, or [`MISSED`].
const GOING: u32 = u32::MAX - 1;
const MISSED: u32 = u32::MAX;

/// A finished any-hit walk's result.
#[inline(always)]
fn any_result(code: u32) -> Option<u32> {
    (code != MISSED).then_some(code)
}

#[cold]
#[inline(never)]
fn heap_stack(len: usize) -> Vec<MaybeUninit<Entry>> {
    vec![MaybeUninit::uninit(); len]
}

/// A leaf tested one primitive at a time (spheres, disks, mixed leaves, and leaves of
/// one triangle, where a pack would waste three lanes). Out of line, so that its code
/// does not take registers from the loop around the SIMD tests.
#[inline(never)]
fn run_closest(
    prims: &[Prim],
    first: usize,
    count: usize,
    o: Vec3A,
    d: Vec3A,
    mut tmax: f32,
) -> Option<Hit> {
    let mut best = None;
    for (i, p) in prims[first..first + count].iter().enumerate() {
        if let Some(h) = p.intersect(o, d, tmax) {
            tmax = h.t;
            best = Some(Hit {
                t: h.t,
                prim: (first + i) as u32,
                uv: h.uv,
            });
        }
    }
    best
}

#[inline(never)]
fn run_any(
    prims: &[Prim],
    first: usize,
    count: usize,
    o: Vec3A,
    d: Vec3A,
    tmax: f32,
) -> Option<u32> {
    (first..first + count)
        .find(|&i| prims[i].intersect(o, d, tmax).is_some())
        .map(|i| i as u32)
}
