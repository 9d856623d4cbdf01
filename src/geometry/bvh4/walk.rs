//! The walks: closest hit, any hit, and the two interleaved, generic over the lanes
//! of the pack tests so that each instruction set gets its own compilation.

use super::pack::{Pack, PackRay};
use super::ray::{RayLanes, TraceRay, ROBUST};
use super::stack::{heap_stack, stack_buffer, Entry, Stack, STACK};
use super::{Bvh4, Node4, COUNT_SHIFT, EMPTY, INDEX_MASK, LEAF, PRIMS, SPHERES};
use crate::geometry::lanes::{Lanes, F4};
use crate::geometry::primitive::Prim;
use crate::geometry::Hit;
use crate::math::{Vec2, Vec3A};
use std::mem::MaybeUninit;

impl Bvh4 {
    #[inline(always)]
    pub(super) fn pair_on_stack<L: Lanes>(
        &self,
        prims: &[Prim],
        c: &TraceRay,
        a: &TraceRay,
    ) -> (Option<Hit>, Option<u32>) {
        stack_buffer!(self, buf_c);
        stack_buffer!(self, buf_a);
        self.closest_and_any::<L>(prims, c, a, Stack::new(buf_c), Stack::new(buf_a))
    }

    // The stack: uninitialised on the machine stack (zeroing it per ray shows in
    // profiles), or on the heap for trees too deep for that (never seen in practice).
    // One copy of each kernel serves both, so the heap case runs with the same
    // instruction set as the rest (an out-of-line copy would lose the AVX features).

    #[inline(always)]
    pub(super) fn closest_on_stack<L: Lanes>(&self, prims: &[Prim], ray: &TraceRay) -> Option<Hit> {
        stack_buffer!(self, buf);
        self.closest::<L>(prims, ray, Stack::new(buf))
    }

    #[inline(always)]
    pub(super) fn any_on_stack<L: Lanes>(&self, prims: &[Prim], ray: &TraceRay) -> Option<u32> {
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
