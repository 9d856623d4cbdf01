//! A light tree: picks one of many virtual lights (points or segments) for a gather
//! query (a point or a segment) with a probability that follows the light's likely
//! contribution, in O(depth) and with the exact probability, so a many-light estimator
//! can divide by it.
//!
//! The tree is a BVH of up to 8 children per node over the lights in Morton order of
//! their midpoints (63-bit codes). A node's children are the ranges left after
//! splitting, up to 8 times, the range with the largest Morton cell at its LBVH split
//! (Karras 2012, as in `lbvh`): an octree cell's occupied octants. One light per
//! leaf. A node keeps the bounding sphere of its box and its total power; siblings
//! are stored as arrays (structure of arrays) in tree units (scene centre, scene
//! radius), so the 8 importances of a node are one pass of vector instructions.
//! Sampling walks down from the root, choosing a child with probability proportional
//! to its importance (below), so a light's probability is the product of the choices
//! on its path; `pmf` climbs from the light's leaf through parent links and multiplies
//! the same numbers from the root down. One uniform number suffices: as in pbrt-v4's
//! `BVHLightSampler`, but instead of rescaling u at each level (a division, rounding
//! that grows on the way down, and u creeping up to 1) the interval [lo, hi) holding u
//! is narrowed, and a child of weight 0 owns an empty interval.
//!
//! Importance of a node (centre c, radius r, power P) for a query segment o + d t,
//! t in [0, T] (a point when T = 0):
//!
//! ```text
//! h^2 = max(|c - o - d t*|^2, (NEAR r)^2, near^2),  t* = clamp((c - o) . d, 0, T)
//! I   = P / D,  D = h max(h, T / pi)   (= h^2 for a point)
//! ```
//!
//! h is the distance from the node's centre to the query (closed form; with T = inf the
//! clamp keeps every term finite), at least a quarter of the node's radius so that
//! enclosing clusters do not swallow the probability, and at least `near` (the caller's
//! clamping distance, `set_min_distance`, else 1e-4 of the scene's radius) so point
//! lights at the query stay finite. It is an estimate, not a bound: the lower bound
//! max(|c - x| - r, 0) was tried first and measured far worse, since it makes large
//! far clusters look as near as their nearest corner and flattens the choice towards
//! power. In the development runs (binary version of this tree, 2000 lights, a
//! transport-like integrand; variance of picking by power over variance of the tree,
//! point / segment / unbounded queries) the lower bound gained 1.0 / 0.8 / 1.0 x on 20
//! clusters and 2.4 / 1.4 / 1.1 x on one cloud, the centre distance 9.7 / 2.9 / 3.0 x
//! and 45 / 39 / 8.7 x. The floor did best at 0.25 r of {0, 0.1, 0.25, 0.5, 1} (1,
//! pbrt's half diagonal, lost 3-10 x).
//!
//! D is the falloff of integrated transport: a point light at distance h from a query
//! point contributes ~ 1 / h^2, but along a query segment of length T
//! int dt / (h^2 + t^2) ~ min(pi / h, T / h^2) = pi / (h max(h, T / pi)): 1 / h near a
//! long segment, 1 / h^2 far from a short one. With 1 / h^2 alone the variance for
//! finite segment queries was 1.03-1.2 x higher; for unbounded ones it was mixed (from
//! 3.3 x higher to 0.75 x), and the physical form was kept.
//!
//! The importance is only an estimate (no visibility, no cosines, a long segment light
//! is a sphere), so the sampler is a defensive mixture (Hesterberg 1995): a share
//! DEFENSIVE of u picks by power alone on the same tree, and both strategies' products
//! are computed along the one path, so pmf = (1 - a) p_importance + a power / total.
//! Every light with power > 0 has at least a times its power share, whatever the
//! geometry, and the variance is at most 1 / a times that of picking by power.
//!
//! Tried and dropped: cutting long segments into pieces (a light's probability the sum
//! over its pieces) cut the variance by ~1.1 x for points and unbounded queries and
//! not for segments, for 2-3 x the time; binary nodes (before the vector layout) took
//! 1.5 x the time of 8-wide ones and had 1.3-1.45 x the variance.
//!
//! Weights are f32 (tree units keep them in range), sums and products f64, all in a
//! fixed order, so `sample` and `pmf` agree bit for bit; the tree (a parallel sort of
//! unique keys, then a serial recursion) does not depend on the number of threads. The
//! one uniform number is an f32: probabilities far below its resolution (2^-24) are
//! honoured by `pmf`, but `sample` resolves them only as finely as the caller's u.

use crate::integrator::memory::{array, refilled};
use crate::math::Vec3;
use rayon::prelude::*;

/// A virtual light for selection: a segment from `a` to `b` (a point light when
/// a == b) with a non-negative power (any scalar importance; 0 = never picked). Lights
/// whose power or ends are not finite are never picked either.
#[derive(Clone, Copy, Debug)]
pub struct Emitter {
    pub a: Vec3,
    pub b: Vec3,
    pub power: f32,
}

impl Emitter {
    pub fn point(p: Vec3, power: f32) -> Self {
        Emitter { a: p, b: p, power }
    }
}

/// What a gather asks about: the segment o + d t, t in [0, tmax] (unit d; tmax may be
/// f32::INFINITY), or a point when tmax == 0.
#[derive(Clone, Copy, Debug)]
pub struct Query {
    pub o: Vec3,
    pub d: Vec3,
    pub tmax: f32,
}

impl Query {
    pub fn point(p: Vec3) -> Self {
        Query {
            o: p,
            d: Vec3::ZERO,
            tmax: 0.0,
        }
    }
}

/// The share of samples that ignore geometry and follow power (module notes).
const DEFENSIVE: f64 = 0.1;
/// A node's distance is taken as at least this fraction of its radius.
const NEAR: f32 = 0.25;
/// `near` when the caller sets none, and its least value: fractions of the scene's
/// radius (the unit of the tree's coordinates).
const NEAR_OF_SCENE: f32 = 1e-4;
const NEAR_MIN: f32 = 1e-10;
/// T / pi at most, in scene radii: an unbounded segment's falloff stays finite, and a
/// segment a million times the scene's size looks unbounded from inside it.
const FAR: f32 = 1e6;
/// Children per node, at most.
const WIDTH: usize = 8;
/// Marks a leaf's `child` (then the light's index).
const LEAF: u32 = 1 << 31;
/// An inner node's `child`: (children - 1) << COUNT | their group.
const COUNT: u32 = 28;
const GROUP: u32 = (1 << COUNT) - 1;
/// No node: the root's parent, or the leaf of a light that cannot be picked.
const NONE: u32 = u32::MAX;
/// The largest f64 below 1.
const ONE_BELOW: f64 = 1.0 - f64::EPSILON / 2.0;
/// Deeper than any tree: 63 Morton levels, then 31 index halvings of equal codes.
const MAX_DEPTH: usize = 128;

/// The children of one node, side by side as arrays so that their importances are
/// computed together (vector instructions). Unused slots have power 0 (weight 0).
/// Coordinates are relative to the scene's centre, in units of its radius. Node
/// `8 g + j` is slot j of group g; group 0 holds the root's children.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
struct Group {
    x: [f32; WIDTH],
    y: [f32; WIDTH],
    z: [f32; WIDTH],
    /// The radius of the bounding sphere of the node's box.
    radius: [f32; WIDTH],
    /// Relative to the strongest light.
    power: [f32; WIDTH],
    /// Leaf: LEAF | the light; inner: its children (COUNT, GROUP).
    child: [u32; WIDTH],
}

/// The light tree (module notes). Buffers are kept between builds.
#[derive(Default)]
pub struct LightTree {
    groups: Vec<Group>,
    /// The root's children (the used slots of group 0).
    roots: usize,
    /// The node each group hangs from (NONE for group 0).
    parents: Vec<u32>,
    /// Each light's leaf, or NONE.
    leaf_of: Vec<u32>,
    /// (Morton code of the midpoint, light), sorted.
    keys: Vec<(u64, u32)>,
    /// The scene's centre and 1 / its radius: the tree's coordinates.
    center: Vec3,
    inv_radius: f32,
    /// The caller's clamping distance (0: none).
    min_distance: f32,
    /// The square of the distance floor in use, in tree units.
    near2: f32,
}

/// A query in tree units, in the form the importance needs.
struct Prepared {
    o: Vec3,
    d: Vec3,
    tmax: f32,
    /// T / pi, at most FAR.
    spread: f32,
}

/// The weights of one group's slots: importance (f32, from one vector pass) and the
/// reciprocals of both strategies' sums.
struct Weights {
    geo: [f32; WIDTH],
    inv_geo: f64,
    inv_pow: f64,
}

fn selectable(e: &Emitter) -> bool {
    e.power > 0.0 && e.power.is_finite() && e.a.is_finite() && e.b.is_finite()
}

impl LightTree {
    /// Distances below `d` count as `d` (the clamp of the caller's estimator, so the
    /// tree does not chase lights whose contribution the estimator bounds anyway).
    /// Takes effect at the next build; 0 (the default) means 1e-4 of the scene radius.
    pub fn set_min_distance(&mut self, d: f32) {
        self.min_distance = if d > 0.0 && d.is_finite() { d } else { 0.0 };
    }

    /// Rebuilds over `items` (buffers reused between builds). Deterministic: the tree
    /// and every probability depend only on `items` (and the minimum distance).
    pub fn build(&mut self, items: &[Emitter]) {
        assert!(items.len() < LEAF as usize, "too many lights for the tree");
        self.groups.clear();
        self.parents.clear();
        self.leaf_of.clear();
        self.leaf_of.resize(items.len(), NONE);
        let (lo, hi, strongest) = items
            .par_iter()
            .filter(|e| selectable(e))
            .map(|e| (e.a.min(e.b), e.a.max(e.b), e.power))
            .reduce(
                || {
                    (
                        Vec3::splat(f32::INFINITY),
                        Vec3::splat(f32::NEG_INFINITY),
                        0.0,
                    )
                },
                |a, b| (a.0.min(b.0), a.1.max(b.1), a.2.max(b.2)),
            );
        let top = ((1u32 << 21) - 1) as f32;
        let scale = Vec3::splat(top) / (hi - lo).max(Vec3::splat(1e-30));
        self.keys.clear();
        self.keys.par_extend(
            items
                .par_iter()
                .enumerate()
                .filter(|(_, e)| selectable(e))
                .map(|(i, e)| {
                    let m = e.a * 0.5 + e.b * 0.5;
                    let c = ((m - lo) * scale).clamp(Vec3::ZERO, Vec3::splat(top));
                    (morton3(c.x as u64, c.y as u64, c.z as u64), i as u32)
                }),
        );
        if self.keys.is_empty() {
            self.roots = 0;
            return;
        }
        // Keys are unique (they hold the index): the order is the same on any pool.
        self.keys.par_sort_unstable();
        self.center = lo * 0.5 + hi * 0.5;
        let radius = ((hi - lo) * 0.5).length();
        self.inv_radius = if radius > 0.0 && radius.is_finite() {
            1.0 / radius
        } else {
            1.0
        };
        let near = if self.min_distance > 0.0 {
            self.min_distance * self.inv_radius
        } else {
            NEAR_OF_SCENE
        };
        let near = near.clamp(NEAR_MIN, 1.0 / NEAR_MIN);
        self.near2 = near * near;
        let (child, ..) = self.children(items, 1.0 / strongest as f64, NONE, 0, self.keys.len(), 0);
        self.roots = (child >> COUNT) as usize + 1;
    }

    /// Appends the group of children of node `parent` (NONE: the root) over
    /// `keys[a..b]`: up to WIDTH ranges, made by splitting the range of the largest
    /// Morton cell until there are WIDTH (an octree cell's eight octants when its codes
    /// differ in all three axes), then fills their subtrees. Returns the parent's
    /// `child` field, the box (world units) and the power of the whole.
    fn children(
        &mut self,
        items: &[Emitter],
        unit: f64,
        parent: u32,
        a: usize,
        b: usize,
        depth: usize,
    ) -> (u32, Vec3, Vec3, f64) {
        assert!(depth < MAX_DEPTH, "light tree too deep");
        let mut ranges = [(a, b); WIDTH];
        let mut count = 1;
        while count < WIDTH {
            // The largest cell: the highest differing bit; equal codes (-1) last, and
            // single lights never. Ties go to the first, so the tree is fixed.
            let mut best = None;
            let mut best_bit = -2;
            for (j, &(x, y)) in ranges[..count].iter().enumerate() {
                if y - x < 2 {
                    continue;
                }
                let bit = 63 - (self.keys[x].0 ^ self.keys[y - 1].0).leading_zeros() as i32;
                if bit > best_bit {
                    (best, best_bit) = (Some(j), bit);
                }
            }
            let Some(j) = best else { break };
            let (x, y) = ranges[j];
            let mid = self.split(x, y);
            ranges.copy_within(j + 1..count, j + 2);
            ranges[j] = (x, mid);
            ranges[j + 1] = (mid, y);
            count += 1;
        }
        let g = self.groups.len();
        assert!(g < GROUP as usize, "too many lights for the tree");
        self.groups.push(Group::default());
        self.parents.push(parent);
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let mut total = 0.0;
        for (j, &(x, y)) in ranges[..count].iter().enumerate() {
            let node = (WIDTH * g + j) as u32;
            let (child, l, h, power) = if y - x == 1 {
                let i = self.keys[x].1;
                let e = items[i as usize];
                self.leaf_of[i as usize] = node;
                // A light far weaker than the strongest keeps a positive power.
                let power = (e.power as f64 * unit).max(f32::MIN_POSITIVE as f64);
                (LEAF | i, e.a.min(e.b), e.a.max(e.b), power)
            } else {
                self.children(items, unit, node, x, y, depth + 1)
            };
            let c = ((l * 0.5 + h * 0.5) - self.center) * self.inv_radius;
            let slot = &mut self.groups[g];
            (slot.x[j], slot.y[j], slot.z[j]) = (c.x, c.y, c.z);
            slot.radius[j] = ((h - l) * 0.5).length() * self.inv_radius;
            slot.power[j] = power as f32;
            slot.child[j] = child;
            (lo, hi) = (lo.min(l), hi.max(h));
            total += power;
        }
        ((count as u32 - 1) << COUNT | g as u32, lo, hi, total)
    }

    /// Where `[a, b)` divides: at the highest bit in which the first and last Morton
    /// codes differ (Karras 2012, as in `lbvh`); the index middle for equal codes.
    fn split(&self, a: usize, b: usize) -> usize {
        let (first, last) = (self.keys[a].0, self.keys[b - 1].0);
        if first == last {
            return a + (b - a) / 2;
        }
        let bit = 63 - (first ^ last).leading_zeros();
        a + self.keys[a..b].partition_point(|k| k.0 >> bit & 1 == 0)
    }

    /// Lights that can be picked (power > 0).
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Picks one light for the query from one uniform number u in [0, 1): (its index
    /// into the `items` given to `build`, the probability of having picked it). None
    /// when nothing can be picked.
    pub fn sample(&self, q: &Query, u: f32) -> Option<(usize, f32)> {
        if self.roots == 0 {
            return None;
        }
        let q = self.prepare(q);
        // u = 1 would lie past the last child; NaN and negatives count as 0.
        let u = if u > 0.0 {
            (u as f64).min(ONE_BELOW)
        } else {
            0.0
        };
        // Instead of rescaling u at each node (a division, and rounding that grows on
        // the way down), narrow the interval [lo, hi) that holds it: [DEFENSIVE, 1)
        // picks by importance, [0, DEFENSIVE) by power.
        let geometric = u >= DEFENSIVE;
        let (mut lo, mut hi) = if geometric {
            (DEFENSIVE, 1.0)
        } else {
            (0.0, DEFENSIVE)
        };
        let (mut p_geo, mut p_pow) = (1.0f64, 1.0f64);
        let (mut g, mut count) = (0, self.roots);
        loop {
            let group = &self.groups[g];
            let w = self.weights(&q, group);
            let scale = (hi - lo) * if geometric { w.inv_geo } else { w.inv_pow };
            // Slot k owns [lo + C_k s, lo + C_(k+1) s) (C: partial sums), the last up
            // to hi; lo <= u < hi throughout, so a slot of weight 0 has an empty
            // interval and is never taken (but the last, by rounding: then its weight
            // 0 goes into the product and the other strategy's probability remains).
            let (mut k, mut cum, mut below) = (count - 1, 0.0, lo);
            for j in 0..count - 1 {
                cum += if geometric { w.geo[j] } else { group.power[j] } as f64;
                let split = lo + cum * scale;
                if u < split {
                    (k, hi) = (j, split);
                    break;
                }
                below = split;
            }
            lo = below;
            let (geo, pow) = w.of(group, k);
            p_geo *= geo;
            p_pow *= pow;
            let child = group.child[k];
            if child & LEAF != 0 {
                return Some(((child & !LEAF) as usize, mix(p_geo, p_pow)));
            }
            (g, count) = ((child & GROUP) as usize, (child >> COUNT) as usize + 1);
        }
    }

    /// The probability that `sample` picks `index` for this query (exactly what
    /// `sample` returns with it); 0 for lights that cannot be picked.
    pub fn pmf(&self, q: &Query, index: usize) -> f32 {
        let Some(&leaf) = self.leaf_of.get(index) else {
            return 0.0;
        };
        if leaf == NONE {
            return 0.0;
        }
        let q = self.prepare(q);
        let mut path = [0u32; MAX_DEPTH];
        let (mut top, mut at) = (MAX_DEPTH, leaf);
        while at != NONE {
            top -= 1;
            path[top] = at;
            at = self.parents[at as usize / WIDTH];
        }
        // From the root down, as `sample` multiplies.
        let (mut p_geo, mut p_pow) = (1.0f64, 1.0f64);
        for &node in &path[top..] {
            let group = &self.groups[node as usize / WIDTH];
            let (geo, pow) = self.weights(&q, group).of(group, node as usize % WIDTH);
            p_geo *= geo;
            p_pow *= pow;
        }
        mix(p_geo, p_pow)
    }

    /// The query in tree units. NaN or negative lengths make points.
    fn prepare(&self, q: &Query) -> Prepared {
        let tmax = if q.tmax > 0.0 {
            q.tmax * self.inv_radius
        } else {
            0.0
        };
        Prepared {
            o: (q.o - self.center) * self.inv_radius,
            d: if tmax > 0.0 { q.d } else { Vec3::ZERO },
            tmax,
            spread: (tmax * std::f32::consts::FRAC_1_PI).min(FAR),
        }
    }

    /// The importance P / D of every slot (module notes), D = h max(h, T / pi), h^2
    /// for a point query (no square root). One pass over the arrays, written so that
    /// it compiles to vector instructions. Weights that overflow or are NaN (non-unit
    /// d) fall back to power.
    #[inline]
    fn weights(&self, q: &Prepared, group: &Group) -> Weights {
        let mut geo: [f32; WIDTH] = std::array::from_fn(|j| {
            let (vx, vy, vz) = (group.x[j] - q.o.x, group.y[j] - q.o.y, group.z[j] - q.o.z);
            // max / min rather than clamp: NaN becomes 0, and no assertion.
            let t = (vx * q.d.x + vy * q.d.y + vz * q.d.z).max(0.0).min(q.tmax);
            let (wx, wy, wz) = (vx - q.d.x * t, vy - q.d.y * t, vz - q.d.z * t);
            let floor = NEAR * group.radius[j];
            (wx * wx + wy * wy + wz * wz)
                .max(floor * floor)
                .max(self.near2)
        });
        if q.spread > 0.0 {
            for h2 in &mut geo {
                let h = h2.sqrt();
                *h2 = h * h.max(q.spread);
            }
        }
        for (w, p) in geo.iter_mut().zip(&group.power) {
            *w = p / *w;
        }
        let (mut geo_sum, mut pow_sum) = (0.0f64, 0.0f64);
        for (w, p) in geo.iter().zip(&group.power) {
            geo_sum += *w as f64;
            pow_sum += *p as f64;
        }
        let inv_pow = 1.0 / pow_sum;
        if geo_sum > 0.0 && geo_sum.is_finite() {
            Weights {
                geo,
                inv_geo: 1.0 / geo_sum,
                inv_pow,
            }
        } else {
            Weights {
                geo: group.power,
                inv_geo: inv_pow,
                inv_pow,
            }
        }
    }

    /// Bytes a tree rebuilt every iteration over about `n` lights holds: per light its
    /// key and leaf, and the groups, 0.24 to 0.36 per light for uniform, clustered and
    /// planar points (measured, 10^3 to 3 x 10^5 lights; 0.4 counted), each with its
    /// parent; each buffer as it is refilled.
    pub fn bytes_for(n: f64) -> f64 {
        let (lights, groups) = (refilled(n, 0.0), refilled(0.4 * n, 0.0));
        array::<(u64, u32)>(lights)
            + array::<u32>(lights)
            + array::<Group>(groups)
            + array::<u32>(groups)
    }

    pub fn bytes(&self) -> usize {
        self.groups.capacity() * std::mem::size_of::<Group>()
            + (self.parents.capacity() + self.leaf_of.capacity()) * 4
            + self.keys.capacity() * std::mem::size_of::<(u64, u32)>()
    }
}

impl Weights {
    /// The probabilities of slot k: by importance and by power.
    #[inline]
    fn of(&self, group: &Group, k: usize) -> (f64, f64) {
        (
            self.geo[k] as f64 * self.inv_geo,
            group.power[k] as f64 * self.inv_pow,
        )
    }
}

/// The defensive mixture of the two strategies' path probabilities, as a positive f32.
#[inline]
fn mix(p_geo: f64, p_pow: f64) -> f32 {
    (((1.0 - DEFENSIVE) * p_geo + DEFENSIVE * p_pow) as f32).max(f32::MIN_POSITIVE)
}

/// Interleaves the low 21 bits of x, y and z (x in the lowest position).
#[inline]
fn morton3(x: u64, y: u64, z: u64) -> u64 {
    spread(x) | spread(y) << 1 | spread(z) << 2
}

/// Puts two zero bits between each of the low 21 bits of v.
#[inline]
fn spread(v: u64) -> u64 {
    let mut v = v & 0x1f_ffff;
    v = (v | v << 32) & 0x001f_0000_0000_ffff;
    v = (v | v << 16) & 0x001f_0000_ff00_00ff;
    v = (v | v << 8) & 0x100f_00f0_0f00_f00f;
    v = (v | v << 4) & 0x10c3_0c30_c30c_30c3;
    (v | v << 2) & 0x1249_2492_4924_9249
}

#[cfg(test)]
mod tests;
