//! A binary tree built top down, for the inputs on which PLOC would take quadratic
//! time (see `rounds`): copies of one primitive, primitives on one line or around one
//! centre. Each node splits its primitives by the surface area heuristic over a few
//! bins of their centres, or at the median centre along the widest axis where the
//! centres do not spread (copies) or the tree is already deep. So every level costs a
//! pass over its primitives and the tree is at most `SAH_LEVELS` plus log2(n) deep:
//! O(n log n) whatever the input. The result has one primitive per leaf, like the
//! trees obvhs builds for us, and the same layout (children in adjacent slots, after
//! their parent).

use obvhs::aabb::Aabb;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::{Bvh2, DEFAULT_MAX_STACK_DEPTH};

const BINS: usize = 16;
/// Below this depth a node splits by the surface area heuristic, which may cut one
/// primitive off at a time; deeper, at the median, which halves.
const SAH_LEVELS: usize = 32;

pub fn build(aabbs: &[Aabb]) -> Bvh2 {
    let n = aabbs.len();
    let mut bvh = Bvh2 {
        nodes: Vec::with_capacity((2 * n).saturating_sub(1)),
        primitive_indices: (0..n as u32).collect(),
        ..Bvh2::default()
    };
    if n == 0 {
        return bvh;
    }
    let centres: Vec<[f32; 3]> = aabbs.iter().map(|b| b.center().to_array()).collect();
    bvh.nodes.push(Bvh2Node::default());
    // (node, first primitive, end, depth)
    let mut work = vec![(0usize, 0usize, n, 0usize)];
    let mut depth = 0;
    while let Some((node, start, end, d)) = work.pop() {
        depth = depth.max(d);
        let ids = &mut bvh.primitive_indices[start..end];
        let bounds = ids
            .iter()
            .fold(Aabb::empty(), |b, &i| b.union(&aabbs[i as usize]));
        if ids.len() == 1 {
            bvh.nodes[node] = Bvh2Node::new(bounds, 1, start as u32);
            continue;
        }
        let mid = start + split(ids, &centres, aabbs, d);
        let left = bvh.nodes.len();
        bvh.nodes[node] = Bvh2Node::new(bounds, 0, left as u32);
        bvh.nodes.extend([Bvh2Node::default(); 2]);
        work.push((left + 1, mid, end, d + 1));
        work.push((left, start, mid, d + 1));
    }
    bvh.max_depth = DEFAULT_MAX_STACK_DEPTH.max(depth + 1);
    bvh.children_are_ordered_after_parents = true;
    bvh
}

/// Reorders `ids` into two nonempty parts and returns the length of the first.
fn split(ids: &mut [u32], centres: &[[f32; 3]], aabbs: &[Aabb], depth: usize) -> usize {
    let (lo, hi) = centre_bounds(ids, centres);
    let axis = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .unwrap_or(0);
    let extent = hi[axis] - lo[axis];
    if depth < SAH_LEVELS && extent > 0.0 && extent.is_finite() {
        let bin = |i: u32| {
            let t = (centres[i as usize][axis] - lo[axis]) / extent * BINS as f32;
            (t as usize).min(BINS - 1)
        };
        let plane = sah_plane(ids, aabbs, &bin);
        let first = partition(ids, |i| bin(i) < plane);
        if first > 0 && first < ids.len() {
            return first;
        }
    }
    let mid = ids.len() / 2;
    ids.select_nth_unstable_by(mid, |&a, &b| {
        centres[a as usize][axis].total_cmp(&centres[b as usize][axis])
    });
    mid
}

fn centre_bounds(ids: &[u32], centres: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for &i in ids {
        for a in 0..3 {
            lo[a] = lo[a].min(centres[i as usize][a]);
            hi[a] = hi[a].max(centres[i as usize][a]);
        }
    }
    (lo, hi)
}

/// The bin boundary (1..BINS) that minimises the summed area times count of the two
/// sides; of equal costs (boxes of no area, such as segments on one line), the one
/// that halves best.
fn sah_plane(ids: &[u32], aabbs: &[Aabb], bin: &impl Fn(u32) -> usize) -> usize {
    let mut boxes = [Aabb::empty(); BINS];
    let mut counts = [0u32; BINS];
    for &i in ids {
        let b = bin(i);
        boxes[b] = boxes[b].union(&aabbs[i as usize]);
        counts[b] += 1;
    }
    // Area times count, and count, of bins 0..k for each k.
    let mut below = [(0.0f32, 0u32); BINS];
    let (mut acc, mut count) = (Aabb::empty(), 0);
    for k in 1..BINS {
        acc = acc.union(&boxes[k - 1]);
        count += counts[k - 1];
        below[k] = (acc.half_area() * count as f32, count);
    }
    let (mut acc, mut count) = (Aabb::empty(), 0);
    let mut best = (f32::INFINITY, u32::MAX, BINS / 2);
    for k in (1..BINS).rev() {
        acc = acc.union(&boxes[k]);
        count += counts[k];
        let cost = below[k].0 + acc.half_area() * count as f32;
        let imbalance = below[k].1.abs_diff(count);
        if cost < best.0 || (cost == best.0 && imbalance < best.1) {
            best = (cost, imbalance, k);
        }
    }
    best.2
}

/// Moves the ids for which `left` holds to the front; returns how many there are.
fn partition(ids: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut first = 0;
    for k in 0..ids.len() {
        if left(ids[k]) {
            ids.swap(first, k);
            first += 1;
        }
    }
    first
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3A;

    fn boxes(n: usize, f: impl Fn(usize) -> (Vec3A, f32)) -> Vec<Aabb> {
        (0..n)
            .map(|i| {
                let (c, r) = f(i);
                Aabb::new(c - Vec3A::splat(r), c + Vec3A::splat(r))
            })
            .collect()
    }

    /// Every primitive in exactly one leaf of its own, every node's box holding its
    /// children's, and the depth within the stated bound.
    fn check(aabbs: &[Aabb]) -> usize {
        let bvh = build(aabbs);
        let n = aabbs.len();
        assert_eq!(bvh.nodes.len(), 2 * n - 1);
        let mut seen = vec![false; n];
        let mut stack = vec![(0usize, 1usize)];
        let mut depth = 0;
        while let Some((i, d)) = stack.pop() {
            depth = depth.max(d);
            let node = &bvh.nodes[i];
            if node.is_leaf() {
                assert_eq!(node.prim_count, 1);
                let p = bvh.primitive_indices[node.first_index as usize] as usize;
                assert!(!seen[p], "primitive {p} twice");
                seen[p] = true;
                assert_eq!(*node.aabb(), aabbs[p]);
                continue;
            }
            let l = node.first_index as usize;
            assert_eq!(l % 2, 1, "left children sit in odd slots");
            for c in [l, l + 1] {
                assert!(c > i);
                let b = bvh.nodes[c].aabb();
                assert_eq!(node.aabb().union(b), *node.aabb());
                stack.push((c, d + 1));
            }
        }
        assert!(seen.iter().all(|&s| s));
        let log = (n as f64).log2().ceil() as usize;
        assert!(depth <= SAH_LEVELS + log + 1, "depth {depth}");
        depth
    }

    #[test]
    fn copies_make_a_balanced_tree() {
        let depth = check(&boxes(1000, |_| (Vec3A::ONE, 0.5)));
        assert_eq!(depth, 11);
        check(&boxes(1, |_| (Vec3A::ONE, 0.5)));
        check(&boxes(2, |_| (Vec3A::ONE, 0.5)));
    }

    /// Centres spread so that each bin split by area cuts off only the last: the
    /// median takes over below `SAH_LEVELS`.
    #[test]
    fn doubling_spacing_stays_within_the_depth_bound() {
        check(&boxes(120, |i| (Vec3A::X * 1.2f32.powi(i as i32), 0.1)));
    }

    #[test]
    fn spread_boxes() {
        check(&boxes(3000, |i| {
            let h = (i as u32).wrapping_mul(2654435761) as f32 / u32::MAX as f32;
            (Vec3A::new(h, (i % 17) as f32, (i % 5) as f32), 0.01 + h)
        }));
    }
}
