//! A binary BVH for segment queries ("which items lie within r of this segment?"):
//! points, as the beam radiance estimate asks, and segments (photon beams), as the
//! beam x beam estimate does. Items are sorted along a Morton curve of their centres
//! (keys hold the item's index, so the order never depends on threads), split where the
//! Morton codes change their highest differing bit (the LBVH split, an octree-like
//! hierarchy), leaves of a few items. Every item has the same radius in a query, so
//! nodes store the items' own bounds and the ray is tested against them grown by r. A
//! BVH bounds a segment query by the items near the segment and fixes the order in
//! which they are reported. obvhs could build over item boxes, but its PLOC builder
//! divides the work by `rayon::current_num_threads()`, so its tree (and with it the
//! summation order, and the image bits) would not obviously be thread-count
//! independent; a Morton sort with unique keys is, and building it costs one parallel
//! sort.

use crate::integrator::memory::{array, refilled};
use crate::math::Vec3;
use rayon::prelude::*;

/// What the BVH stores: anything with a box.
pub trait Bounded: Copy + Send + Sync {
    /// The smallest and largest corner.
    fn bounds(&self) -> (Vec3, Vec3);
}

/// A point item: its box is the point.
pub trait Point: Copy + Send + Sync {
    fn position(&self) -> Vec3;
}

impl<T: Point> Bounded for T {
    #[inline(always)]
    fn bounds(&self) -> (Vec3, Vec3) {
        (self.position(), self.position())
    }
}

/// The BVH over points of the beam radiance estimate.
pub type PointBvh<T> = Lbvh<T>;

/// Photons per leaf: a few point tests cost less than more box tests. Measured on 84k
/// uniform photons in a cube of side 2 (rays of length 3, r = 0.04): 7.8 us per ray
/// with 8, 7.5 with 16, 9.3 with 4, and 21.7 for index-middle splits with 4.
const LEAF: usize = 8;

/// A binary BVH in Morton order (module notes). `keys` keeps the sorted (code,
/// index) pairs of the last build for the splits. Node 0 is the root; an inner node's
/// first child follows it, `index` names the second.
pub struct Lbvh<T> {
    nodes: Vec<BvhNode>,
    keys: Vec<u64>,
    scratch: Vec<T>,
}

#[derive(Clone, Copy, Debug)]
struct BvhNode {
    lo: Vec3,
    hi: Vec3,
    /// Leaf: the first item; inner: the second child.
    index: u32,
    /// Items in a leaf; 0 for inner nodes.
    count: u32,
}

impl<T> Default for Lbvh<T> {
    fn default() -> Self {
        Lbvh {
            nodes: Vec::new(),
            keys: Vec::new(),
            scratch: Vec::new(),
        }
    }
}

/// The centre of an item's box.
#[inline(always)]
fn centre<T: Bounded>(item: &T) -> Vec3 {
    let (lo, hi) = item.bounds();
    (lo + hi) * 0.5
}

impl<T: Bounded> Lbvh<T> {
    /// Reorders `photons` (the items) along a Morton curve of their centres and builds
    /// the tree over them.
    pub fn build(&mut self, photons: &mut Vec<T>) {
        assert!(
            photons.len() < u32::MAX as usize,
            "too many items for the BVH"
        );
        self.nodes.clear();
        self.keys.clear();
        if photons.is_empty() {
            return;
        }
        let (lo, hi) = photons.par_iter().map(|p| (centre(p), centre(p))).reduce(
            || (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        );
        let scale = Vec3::splat(1023.0) / (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
        self.keys
            .par_extend(photons.par_iter().enumerate().map(|(i, p)| {
                let c = ((centre(p) - lo) * scale).clamp(Vec3::ZERO, Vec3::splat(1023.0));
                (morton3(c.x as u32, c.y as u32, c.z as u32) as u64) << 32 | i as u64
            }));
        // Keys are unique (they hold the index): the sorted order is the same for any
        // number of threads.
        self.keys.par_sort_unstable();
        self.scratch.clear();
        self.scratch
            .par_extend(self.keys.par_iter().map(|k| photons[*k as u32 as usize]));
        std::mem::swap(photons, &mut self.scratch);
        self.node(photons, 0, photons.len());
    }

    /// Appends the subtree over `photons[a..b]`; returns its root's index.
    fn node(&mut self, photons: &[T], a: usize, b: usize) -> u32 {
        let at = self.nodes.len();
        if b - a <= LEAF {
            let (lo, hi) = photons[a..b].iter().fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), p| {
                    let (l, h) = p.bounds();
                    (lo.min(l), hi.max(h))
                },
            );
            self.nodes.push(BvhNode {
                lo,
                hi,
                index: a as u32,
                count: (b - a) as u32,
            });
            return at as u32;
        }
        self.nodes.push(BvhNode {
            lo: Vec3::ZERO,
            hi: Vec3::ZERO,
            index: 0,
            count: 0,
        });
        let mid = self.split(a, b);
        let left = self.node(photons, a, mid) as usize;
        let right = self.node(photons, mid, b);
        let (l, r) = (self.nodes[left], self.nodes[right as usize]);
        self.nodes[at] = BvhNode {
            lo: l.lo.min(r.lo),
            hi: l.hi.max(r.hi),
            index: right,
            count: 0,
        };
        at as u32
    }

    /// Where `[a, b)` divides: at the first photon whose Morton code has the highest bit
    /// in which the range's first and last codes differ, i.e. the spatial middle of the
    /// range's octree cell (Karras 2012, "Maximizing parallelism in the construction of
    /// BVHs, octrees, and k-d trees"), which keeps node boxes tight where an index
    /// middle would straddle jumps of the curve; the index middle when every code is
    /// equal.
    fn split(&self, a: usize, b: usize) -> usize {
        let code = |k: u64| (k >> 32) as u32;
        let (first, last) = (code(self.keys[a]), code(self.keys[b - 1]));
        if first == last {
            return a + (b - a) / 2;
        }
        // The codes in [a, b) share every bit above `bit`, so it is 0 then 1 along it.
        let bit = 31 - (first ^ last).leading_zeros();
        a + self.keys[a..b].partition_point(|&k| code(k) >> bit & 1 == 0)
    }

    /// Calls `f(item)` for every item whose box, grown by `r`, the segment o + t d, t
    /// in [0, tmax] (unit d), meets; in a fixed order. The caller tests the item.
    #[inline]
    pub fn visit(&self, items: &[T], o: Vec3, d: Vec3, tmax: f32, r: f32, mut f: impl FnMut(&T)) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = d.recip();
        let grow = Vec3::splat(r);
        // Depth is at most 30 Morton levels plus log2(n) middle splits of equal codes.
        let mut stack = [0u32; 96];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let at = stack[top] as usize;
            let n = self.nodes[at];
            if !slab_hit(n.lo - grow, n.hi + grow, o, inv, tmax) {
                continue;
            }
            if n.count == 0 {
                stack[top] = n.index;
                stack[top + 1] = at as u32 + 1;
                top += 2;
                continue;
            }
            let start = n.index as usize;
            items[start..start + n.count as usize]
                .iter()
                .for_each(&mut f);
        }
    }

    /// Bytes a BVH rebuilt every iteration over about `n` items holds: their keys,
    /// the items' second buffer (`build` reorders into it) and the nodes, about 0.36
    /// per item for uniform, clustered and planar points (measured, 10^3 to 3 x 10^5
    /// items; 0.4 counted), each buffer as it is refilled.
    pub fn bytes_for(n: f64) -> f64 {
        array::<u64>(refilled(n, 0.0))
            + array::<T>(refilled(n, 0.0))
            + array::<BvhNode>(refilled(0.4 * n, 0.0))
    }

    pub fn bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<BvhNode>()
            + self.keys.capacity() * 8
            + self.scratch.capacity() * std::mem::size_of::<T>()
    }
}

impl<T: Point> Lbvh<T> {
    /// Calls `f(photon, t)` for every photon within `r` of the segment o + t d, t in
    /// [0, tmax) (unit d), t being its projection on the ray; in a fixed order.
    #[inline]
    pub fn query(
        &self,
        photons: &[T],
        o: Vec3,
        d: Vec3,
        tmax: f32,
        r: f32,
        mut f: impl FnMut(&T, f32),
    ) {
        self.query_d2(photons, o, d, tmax, r, |ph, t, _| f(ph, t));
    }

    /// [`Lbvh::query`], telling `f` each photon's squared distance from the segment
    /// too (so a caller can sort the photons into narrower radii).
    #[inline]
    pub fn query_d2(
        &self,
        photons: &[T],
        o: Vec3,
        d: Vec3,
        tmax: f32,
        r: f32,
        mut f: impl FnMut(&T, f32, f32),
    ) {
        let r2 = r * r;
        self.visit(photons, o, d, tmax, r, |ph| {
            let v = ph.position() - o;
            let t = v.dot(d);
            let d2 = (v - d * t).length_squared();
            if (0.0..tmax).contains(&t) && d2 <= r2 {
                f(ph, t, d2);
            }
        });
    }

    /// The items' original indices in the order [`Lbvh::build`] left them.
    pub fn order(&self) -> impl Iterator<Item = usize> + '_ {
        self.keys.iter().map(|k| *k as u32 as usize)
    }
}

/// Whether the segment t in [0, tmax] of o + t d (inv = 1 / d) meets the box. NaN from
/// 0 * inf (a ray in a slab's plane) is ignored by min/max, which only widens the
/// interval: the test stays conservative.
#[inline]
fn slab_hit(lo: Vec3, hi: Vec3, o: Vec3, inv: Vec3, tmax: f32) -> bool {
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    let near = a.min(b).max_element().max(0.0);
    let far = a.max(b).min_element().min(tmax);
    near <= far
}

/// Interleaves the low 10 bits of x, y and z (x in the lowest position).
#[inline]
fn morton3(x: u32, y: u32, z: u32) -> u32 {
    spread(x) | spread(y) << 1 | spread(z) << 2
}

/// Puts two zero bits between each of the low 10 bits of v.
#[inline]
fn spread(v: u32) -> u32 {
    let mut v = v & 0x3ff;
    v = (v | v << 16) & 0x030000ff;
    v = (v | v << 8) & 0x0300f00f;
    v = (v | v << 4) & 0x030c30c3;
    (v | v << 2) & 0x09249249
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    /// A point and its name (what a query reports).
    #[derive(Clone, Copy, Debug)]
    struct Named {
        p: Vec3,
        depth: u32,
    }

    impl Point for Named {
        fn position(&self) -> Vec3 {
            self.p
        }
    }

    fn photon_at(p: Vec3, i: u32) -> Named {
        Named { p, depth: i }
    }

    #[test]
    fn beam_query_finds_exactly_the_photons_near_the_segment() {
        let mut rng = Rng::new(3, 1, 4);
        let mut photons: Vec<Named> = (0..4000)
            .map(|i| {
                let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32() * 0.2);
                photon_at(p * 2.0 - 1.0, i)
            })
            .collect();
        let original = photons.clone();
        let mut bvh = Lbvh::default();
        bvh.build(&mut photons);
        for q in 0..300 {
            let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 3.0 - 1.5;
            let d = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
            // Axis-parallel rays exercise the slab test's 0 * inf case.
            let d = if q % 7 == 0 { Vec3::X } else { d.normalize() };
            let tmax = if q % 5 == 0 {
                f32::INFINITY
            } else {
                2.0 * rng.next_f32()
            };
            let r = 0.02 + 0.2 * rng.next_f32();
            let mut found = Vec::new();
            bvh.query(&photons, o, d, tmax, r, |ph, _| found.push(ph.depth));
            let mut expect: Vec<u32> = original
                .iter()
                .filter(|ph| {
                    let v = ph.p - o;
                    let t = v.dot(d);
                    (0.0..tmax).contains(&t) && (v - d * t).length_squared() <= r * r
                })
                .map(|ph| ph.depth)
                .collect();
            found.sort_unstable();
            expect.sort_unstable();
            assert_eq!(found, expect, "query {q}");
        }
    }

    #[test]
    fn bvh_of_nothing_or_one_photon() {
        let mut bvh = Lbvh::default();
        let mut none = Vec::new();
        bvh.build(&mut none);
        let mut n = 0;
        bvh.query(&none, Vec3::ZERO, Vec3::X, 1.0, 1.0, |_, _| n += 1);
        assert_eq!(n, 0);
        let mut one = vec![photon_at(Vec3::new(0.5, 0.1, 0.0), 0)];
        bvh.build(&mut one);
        bvh.query(&one, Vec3::ZERO, Vec3::X, 1.0, 0.2, |_, t| {
            assert!((t - 0.5).abs() < 1e-6);
            n += 1;
        });
        assert_eq!(n, 1);
    }

    #[test]
    fn bvh_splits_ranges_of_equal_morton_codes() {
        // 1000 photons on one point (one Morton code) among a few others.
        let mut photons: Vec<Named> = (0..1000)
            .map(|i| photon_at(Vec3::splat(0.25), i))
            .chain((0..50).map(|i| photon_at(Vec3::new(i as f32 * 0.02, 0.0, 0.0), 1000 + i)))
            .collect();
        let mut bvh = Lbvh::default();
        bvh.build(&mut photons);
        let mut found = Vec::new();
        let d = Vec3::new(1.0, 1.0, 1.0).normalize();
        bvh.query(&photons, Vec3::ZERO, d, 1.0, 0.01, |ph, _| {
            found.push(ph.depth)
        });
        // The 1000 coincident photons and the one at the origin, each once.
        found.sort_unstable();
        assert_eq!(found, (0..=1000).collect::<Vec<u32>>());
    }
}
