//! How much work obvhs's PLOC builder would do on a set of boxes, found by playing its
//! merge rounds on the boxes alone, before it is asked to build.
//!
//! PLOC (Meister and Bittner 2018) sorts the boxes along a Morton curve and then, round
//! after round, merges every pair of neighbours that choose each other as the cheapest
//! partner within a window. On natural geometry each round merges a good fraction of
//! what is left, so a build takes a few dozen rounds. Where partners tie (copies of one
//! primitive, boxes that are lines, boxes nested inside each other in curve order), the
//! choices form chains instead of pairs, a round merges one pair, and the build takes as
//! many rounds as there are boxes: quadratic work, and a tree as deep as it is wide,
//! which then makes obvhs's reinsertion pass quadratic too. The crate offers no way to
//! stop a build, so the rounds are played here first, with a limit.
//!
//! The play follows the builder's rules so that its count is the builder's: the same
//! Morton codes (the crate's own encoders), the same sort (rayon's unstable sort orders
//! equal codes the same way for the same input), partners scored by the crate's own box
//! arithmetic, ties going to the rightmost candidate, and the first rounds choosing
//! between the two adjacent neighbours only. A test checks the count against the
//! builder's.

use obvhs::aabb::Aabb;
use obvhs::ploc::morton::{morton_encode_u128_unorm, morton_encode_u64_unorm};
use obvhs::ploc::{PlocSearchDistance, SortPrecision};
use obvhs::BvhBuildParams;
use rayon::prelude::*;

/// Below this many boxes a round's search runs on one thread.
const PARALLEL_MIN: usize = 4096;

/// The merge rounds of a build that stayed within the limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rounds {
    /// Rounds until one box was left.
    pub rounds: usize,
    /// Boxes searched over all rounds: the build's work is this times the window.
    pub searched: u64,
}

/// Bounds on a build's rounds. A round costs a pass over what is left, and a tree from
/// `rounds` rounds is at most that deep; obvhs's reinsertion pass walks such paths.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    pub rounds: usize,
    /// Boxes searched over all rounds, as a multiple of the box count.
    pub searched_per_box: u64,
}

/// Plays the rounds; `None` when they would exceed `limits` (the play stops there).
pub fn ploc_rounds(aabbs: &[Aabb], params: &BvhBuildParams, limits: Limits) -> Option<Rounds> {
    let radius = search_radius(params.ploc_search_distance);
    let mut boxes = morton_order(aabbs, params.sort_precision);
    let max_searched = limits.searched_per_box.saturating_mul(aabbs.len() as u64);
    let mut done = Rounds {
        rounds: 0,
        searched: 0,
    };
    let mut offsets = Vec::new();
    while boxes.len() > 1 {
        done.searched += boxes.len() as u64;
        if done.rounds >= limits.rounds || done.searched > max_searched {
            return None;
        }
        if radius == 1 || done.rounds < params.search_depth_threshold {
            adjacent_partners(&boxes, &mut offsets);
        } else {
            window_partners(&boxes, radius, &mut offsets);
        }
        boxes = merge_mutual(&boxes, &offsets);
        done.rounds += 1;
    }
    Some(done)
}

fn search_radius(d: PlocSearchDistance) -> usize {
    match d {
        PlocSearchDistance::Minimum => 1,
        PlocSearchDistance::VeryLow => 2,
        PlocSearchDistance::Low => 6,
        PlocSearchDistance::Medium => 14,
        PlocSearchDistance::High => 24,
        PlocSearchDistance::VeryHigh => 32,
    }
}

/// The boxes in the builder's order: Morton codes of their centres, scaled to the
/// bounds of all of them.
fn morton_order(aabbs: &[Aabb], precision: SortPrecision) -> Vec<Aabb> {
    let mut total = Aabb::empty();
    for b in aabbs {
        total.extend(b.min);
        total.extend(b.max);
    }
    let scale = 1.0 / total.diagonal().as_dvec3();
    let offset = -total.min.as_dvec3() * scale;
    let unit = |b: &Aabb| b.center().as_dvec3() * scale + offset;
    let mut keys: Vec<(u128, u32)> = aabbs
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let code = match precision {
                SortPrecision::U128 => morton_encode_u128_unorm(unit(b)),
                SortPrecision::U64 => morton_encode_u64_unorm(unit(b)) as u128,
            };
            (code, i as u32)
        })
        .collect();
    keys.par_sort_unstable_by_key(|k| k.0);
    keys.iter().map(|&(_, i)| aabbs[i as usize]).collect()
}

/// The cost PLOC gives a pair: the half area of their union.
fn cost(a: &Aabb, b: &Aabb) -> f32 {
    a.union(b).half_area()
}

/// The first rounds' choice: each box points to whichever adjacent neighbour makes the
/// cheaper pair, the left one only when strictly cheaper.
fn adjacent_partners(boxes: &[Aabb], out: &mut Vec<i8>) {
    out.clear();
    let mut left = f32::INFINITY;
    for pair in boxes.windows(2) {
        let right = cost(&pair[0], &pair[1]);
        out.push(if left < right { -1 } else { 1 });
        left = right;
    }
    out.push(-1);
}

/// Each box points to its cheapest partner within `radius` on either side; of equal
/// costs the rightmost wins.
fn window_partners(boxes: &[Aabb], radius: usize, out: &mut Vec<i8>) {
    let best = |i: usize| {
        let window = i.saturating_sub(radius)..(i + radius + 1).min(boxes.len());
        let mut best = (f32::INFINITY, i);
        for j in window.filter(|&j| j != i) {
            let c = cost(&boxes[i], &boxes[j]);
            if c <= best.0 {
                best = (c, j);
            }
        }
        (best.1 as isize - i as isize) as i8
    };
    out.clear();
    if boxes.len() < PARALLEL_MIN {
        out.extend((0..boxes.len()).map(best));
    } else {
        (0..boxes.len())
            .into_par_iter()
            .map(best)
            .collect_into_vec(out);
    }
}

/// The next round's boxes: pairs that chose each other become their union, in the
/// place of the pair's second box; the rest stay in order.
fn merge_mutual(boxes: &[Aabb], offsets: &[i8]) -> Vec<Aabb> {
    let mut next = Vec::with_capacity(boxes.len());
    for (i, b) in boxes.iter().enumerate() {
        let j = (i as isize + offsets[i] as isize) as usize;
        // A box that chose itself (a NaN cost) is kept, as by no partner.
        let mutual = j != i && (j as isize + offsets[j] as isize) as usize == i;
        if !mutual {
            next.push(*b);
        } else if j < i {
            next.push(b.union(&boxes[j]));
        }
    }
    next
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3A;
    use obvhs::ploc::PlocBuilder;

    const UNLIMITED: Limits = Limits {
        rounds: usize::MAX,
        searched_per_box: u64::MAX,
    };

    /// Boxes of one size with centres `c(i)`.
    fn boxes(n: usize, c: impl Fn(usize) -> Vec3A) -> Vec<Aabb> {
        (0..n)
            .map(|i| Aabb::new(c(i), c(i) + Vec3A::new(1.0, 1.0, 0.0)))
            .collect()
    }

    /// obvhs's rounds, which it reports as its tree's stack depth when past 96.
    fn obvhs_rounds(aabbs: &[Aabb], p: &BvhBuildParams) -> usize {
        let ids = (0..aabbs.len() as u32).collect();
        let d = p.ploc_search_distance;
        let bvh = PlocBuilder::with_capacity(aabbs.len()).build(
            d,
            aabbs,
            ids,
            p.sort_precision,
            p.search_depth_threshold,
        );
        bvh.max_depth - 1
    }

    /// The play must count the builder's rounds exactly, for both presets we use, on
    /// inputs that take more than 96 rounds (obvhs reports its rounds as its tree's
    /// stack depth only past that): copies, and copies shifted by tiny hashed or
    /// growing offsets, whose many near ties make irregular rounds.
    #[test]
    fn counts_the_rounds_obvhs_takes() {
        let hash = |i: usize| (i as u32).wrapping_mul(2654435761) as f32 / u32::MAX as f32;
        let sets = [
            boxes(300, |_| Vec3A::ONE),
            boxes(3000, |i| Vec3A::splat(1.0 + hash(i) * 1e-6)),
            boxes(3000, |i| Vec3A::splat(1.0 + i as f32 * f32::EPSILON)),
        ];
        for p in [
            BvhBuildParams::very_slow_build(),
            BvhBuildParams::medium_build(),
        ] {
            for set in &sets {
                let ours = ploc_rounds(set, &p, UNLIMITED).unwrap().rounds;
                assert!(ours > 96, "{ours} rounds: obvhs would not report them");
                assert_eq!(ours, obvhs_rounds(set, &p), "{p:?}");
            }
        }
    }

    #[test]
    fn copies_take_a_round_per_box_and_stop_at_the_limit() {
        let set = boxes(500, |_| Vec3A::ZERO);
        let p = BvhBuildParams::very_slow_build();
        let r = ploc_rounds(&set, &p, UNLIMITED).unwrap();
        assert_eq!(r.rounds, 499);
        let limits = Limits {
            rounds: 256,
            searched_per_box: 16,
        };
        assert_eq!(ploc_rounds(&set, &p, limits), None);
        let spread = boxes(500, |i| {
            Vec3A::new((i % 10) as f32, (i / 10) as f32, 0.0) * 2.0
        });
        let r = ploc_rounds(&spread, &p, limits).unwrap();
        assert!(r.rounds < 40 && r.searched < 8 * 500, "{r:?}");
    }
}
