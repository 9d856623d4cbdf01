//! Range queries over light vertices for vertex merging and photon mapping: a hashed
//! uniform grid with cells of twice the radius, so a query visits at most 2 x 2 x 2
//! cells (the cell of the point and its nearest neighbour on each axis; on average
//! 6.9 of them, as corners beyond the radius are skipped).
//!
//! Built each iteration: slots are computed in parallel, then a counting sort groups
//! the points by slot, in index order within each slot, so the order (and with it
//! every sum over a query) never depends on the thread count. Buffers keep their
//! capacity between builds.

use super::huge;
use crate::integrator::memory::array;
use crate::math::Vec3;
use rayon::prelude::*;

#[derive(Default)]
pub struct HashGrid {
    origin: Vec3,
    inv_cell: f32,
    radius2: f32,
    /// `starts[h]..starts[h + 1]` indexes `entries` for table slot h.
    starts: Vec<u32>,
    /// Vertex indices grouped by table slot.
    entries: Vec<u32>,
    /// The points in `entries` order, so that a query reads each slot's candidates
    /// from one contiguous run of memory (the query is bound by these loads).
    sorted: Vec<Vec3>,
    /// Each point's table slot.
    slots: Vec<u32>,
    /// The next free position of each slot during the counting sort.
    cursor: Vec<u32>,
    /// Each point's position in storage order (the inverse of `entries`).
    rank: Vec<u32>,
}

impl HashGrid {
    /// Indexes `points` for queries of radius `radius`.
    pub fn build(&mut self, points: &[Vec3], radius: f32) {
        let n = points.len();
        assert!(n < u32::MAX as usize, "too many points for the hash grid");
        self.radius2 = radius * radius;
        self.inv_cell = 1.0 / (2.0 * radius);
        self.origin = points
            .par_iter()
            .copied()
            .reduce(|| Vec3::splat(f32::INFINITY), Vec3::min);
        let table = Self::table_size(n) as u64;
        let (origin, inv) = (self.origin, self.inv_cell);
        self.slots.clear();
        huge::reserve(&mut self.slots, n);
        self.slots.par_extend(
            points
                .par_iter()
                .map(|p| (hash(cell_of(*p, origin, inv)) & (table - 1)) as u32),
        );
        self.starts.clear();
        self.starts.resize(table as usize + 1, 0);
        for &s in &self.slots {
            self.starts[s as usize + 1] += 1;
        }
        for h in 1..self.starts.len() {
            self.starts[h] += self.starts[h - 1];
        }
        // Counting sort, stable: indices enter each slot's run in increasing order.
        self.cursor.clear();
        self.cursor
            .extend_from_slice(&self.starts[..table as usize]);
        self.entries.clear();
        huge::reserve(&mut self.entries, n);
        self.entries.resize(n, 0);
        self.rank.clear();
        huge::reserve(&mut self.rank, n);
        for (i, &s) in self.slots.iter().enumerate() {
            let at = &mut self.cursor[s as usize];
            self.entries[*at as usize] = i as u32;
            self.rank.push(*at);
            *at += 1;
        }
        self.sorted.clear();
        huge::reserve(&mut self.sorted, n);
        self.sorted
            .par_extend(self.entries.par_iter().map(|&i| points[i as usize]));
    }

    pub fn radius2(&self) -> f32 {
        self.radius2
    }

    /// Calls `f(&data[index], distance^2)` for every point within the radius of `p`
    /// (`data` in the caller's original order), in a fixed order, prefetching each
    /// point's data as soon as the scan finds it. Hash collisions could visit a point
    /// twice only if two visited cells shared a slot, which [`HashGrid::runs`] prevents.
    ///
    /// Queries and their closures are forced inline: left out of line they were
    /// compiled for baseline x86-64, without the callers' AVX2, and their `floor`
    /// became a libm call.
    #[inline(always)]
    pub fn query_in<'d, T>(&self, p: Vec3, data: &'d [T], mut f: impl FnMut(&'d T, f32)) {
        let entries = &self.entries;
        self.batches(
            p,
            #[inline(always)]
            |k| prefetch(&data[entries[k as usize] as usize]),
            #[inline(always)]
            |hits| {
                for &(k, d2) in hits {
                    f(&data[entries[k as usize] as usize], d2);
                }
            },
        );
    }

    /// The storage position of each point, in the original order: data laid out so,
    /// `sorted[rank[i]] = data[i]`, is read in runs by [`HashGrid::query_sorted_in`].
    pub fn rank(&self) -> &[u32] {
        &self.rank
    }

    /// Like [`HashGrid::query_in`] for data laid out in storage order (see
    /// [`HashGrid::rank`]): a query then reads it in runs too.
    #[inline(always)]
    pub fn query_sorted_in<'d, T>(&self, p: Vec3, data: &'d [T], mut f: impl FnMut(&'d T, f32)) {
        debug_assert_eq!(data.len(), self.sorted.len());
        self.batches(
            p,
            #[inline(always)]
            |k| prefetch(&data[k as usize]),
            #[inline(always)]
            |hits| {
                for &(k, d2) in hits {
                    f(&data[k as usize], d2);
                }
            },
        );
    }

    /// The points within the radius of `p` as (storage index, distance^2), in batches;
    /// `found` is told of each point as the scan finds it (to prefetch its data).
    ///
    /// A query is bound by cache misses: the slot bounds, each slot's run of
    /// positions, and the caller's data for every hit. Each stage issues its loads
    /// before anything waits on them, so the misses overlap instead of following one
    /// another.
    #[inline(always)]
    fn batches(&self, p: Vec3, found: impl Fn(u32), mut f: impl FnMut(&[(u32, f32)])) {
        if self.entries.is_empty() {
            return;
        }
        let (runs, n) = self.runs(p);
        let mut hits = [(0u32, 0f32); BATCH];
        let mut m = 0;
        for &(a, b) in &runs[..n] {
            for k in a..b {
                let d2 = (self.sorted[k as usize] - p).length_squared();
                if d2 <= self.radius2 {
                    found(k);
                    hits[m] = (k, d2);
                    m += 1;
                    if m == BATCH {
                        f(&hits);
                        m = 0;
                    }
                }
            }
        }
        if m > 0 {
            f(&hits[..m]);
        }
    }

    /// The storage ranges of the distinct slots of the cells a sphere of the radius
    /// around `p` can reach: with cells of 2r, the cell of `p` and its neighbours
    /// towards the nearer face on each axis, less those farther than r from `p`.
    #[inline(always)]
    fn runs(&self, p: Vec3) -> ([(u32, u32); 8], usize) {
        let table = (self.starts.len() - 1) as u64;
        let g = (p - self.origin) * self.inv_cell;
        let c = g.floor();
        let frac = g - c;
        let base = [c.x as i32, c.y as i32, c.z as i32];
        let step = [frac.x, frac.y, frac.z].map(|f| if f < 0.5 { -1 } else { 1 });
        // Squared distance (in cells) to the neighbour's face on each axis.
        let gap = [frac.x, frac.y, frac.z].map(|f| {
            let d = f.min(1.0 - f);
            d * d
        });
        let mut slots = [0u64; 8];
        let mut n = 0;
        for k in 0..8 {
            let mut reach = 0.0;
            let mut cell = base;
            for axis in 0..3 {
                if k & (1 << axis) != 0 {
                    reach += gap[axis];
                    cell[axis] += step[axis];
                }
            }
            // r is a quarter of a cell squared; the margin covers rounding in `frac`.
            if reach > 0.25 * (1.0 + 1e-3) {
                continue;
            }
            let slot = hash(cell) & (table - 1);
            if !slots[..n].contains(&slot) {
                slots[n] = slot;
                n += 1;
            }
        }
        let mut runs = [(0u32, 0u32); 8];
        for (run, &slot) in runs.iter_mut().zip(&slots[..n]) {
            *run = (self.starts[slot as usize], self.starts[slot as usize + 1]);
        }
        for &(a, b) in &runs[..n] {
            if a < b {
                prefetch(&self.sorted[a as usize]);
            }
        }
        (runs, n)
    }

    /// Bytes a grid over `n` points holds once built (what [`HashGrid::bytes`] then
    /// reports): the table, and per point its slot, entry, rank and sorted copy.
    pub fn bytes_for(n: f64) -> f64 {
        let table = Self::table_size(n as usize) as f64;
        let per_point = 3 * std::mem::size_of::<u32>() + std::mem::size_of::<Vec3>();
        array::<u32>(2.0 * table + 1.0) + (huge::reserved(n as usize) * per_point) as f64
    }

    /// Slots of the table for `n` points.
    fn table_size(n: usize) -> usize {
        (n.max(4) / 4).next_power_of_two()
    }

    /// Bytes held by the grid's buffers.
    pub fn bytes(&self) -> usize {
        self.starts.capacity() * 4
            + self.entries.capacity() * 4
            + self.slots.capacity() * 4
            + self.cursor.capacity() * 4
            + self.rank.capacity() * 4
            + self.sorted.capacity() * 12
    }
}

#[inline]
fn cell_of(p: Vec3, origin: Vec3, inv_cell: f32) -> [i32; 3] {
    let g = ((p - origin) * inv_cell).floor();
    [g.x as i32, g.y as i32, g.z as i32]
}

/// Hits handed to a query's caller at a time.
const BATCH: usize = 16;

/// Asks for the cache line holding `r` without waiting for it.
#[inline(always)]
fn prefetch<T>(r: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is only a hint; it never faults, even on a bad address.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>((r as *const T).cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = r;
}

/// Teschner et al. 2003's spatial hash.
#[inline(always)]
fn hash(c: [i32; 3]) -> u64 {
    let h = (c[0] as u32).wrapping_mul(73_856_093)
        ^ (c[1] as u32).wrapping_mul(19_349_663)
        ^ (c[2] as u32).wrapping_mul(83_492_791);
    h as u64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    #[test]
    fn finds_exactly_the_points_within_the_radius() {
        let mut rng = Rng::new(7, 0, 0);
        let pts: Vec<Vec3> = (0..5000)
            .map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32() * 0.1) * 3.0 - 1.0)
            .collect();
        let ids: Vec<usize> = (0..pts.len()).collect();
        let mut grid = HashGrid::default();
        for r in [0.01f32, 0.07, 0.4] {
            grid.build(&pts, r);
            for q in 0..200 {
                let p = pts[q * 7] + Vec3::new(0.01, -0.02, 0.005);
                let mut found = Vec::new();
                grid.query_in(p, &ids, |&i, _| found.push(i));
                let mut expect: Vec<usize> = (0..pts.len())
                    .filter(|&i| (pts[i] - p).length_squared() <= r * r)
                    .collect();
                found.sort_unstable();
                expect.sort_unstable();
                assert_eq!(found, expect, "radius {r}, query {q}");
            }
        }
    }

    /// Queries anywhere in the cloud (so at every position within a cell, where the
    /// corner cells are skipped or not), through both entry points; the larger
    /// radius finds more than a batch of points per query.
    #[test]
    fn every_entry_point_finds_the_same_points_anywhere() {
        let mut rng = Rng::new(11, 0, 0);
        let pts: Vec<Vec3> = (0..20000)
            .map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()))
            .collect();
        let ids: Vec<usize> = (0..pts.len()).collect();
        let mut grid = HashGrid::default();
        let mut most = 0;
        for r in [0.03f32, 0.1] {
            grid.build(&pts, r);
            // The ids laid out in storage order; rank must be a permutation.
            let mut sorted = vec![usize::MAX; pts.len()];
            for (i, &at) in grid.rank().iter().enumerate() {
                assert_eq!(sorted[at as usize], usize::MAX, "rank {at} given twice");
                sorted[at as usize] = i;
            }
            for q in 0..1000 {
                let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let mut expect: Vec<usize> = (0..pts.len())
                    .filter(|&i| (pts[i] - p).length_squared() <= r * r)
                    .collect();
                let (mut a, mut c) = (Vec::new(), Vec::new());
                grid.query_in(p, &ids, |&i, d2| {
                    assert_eq!(d2, (pts[i] - p).length_squared());
                    a.push(i)
                });
                grid.query_sorted_in(p, &sorted, |&i, _| c.push(i));
                assert_eq!(
                    a, c,
                    "r {r}, query {q}: query_sorted_in visits in the same order"
                );
                a.sort_unstable();
                expect.sort_unstable();
                assert_eq!(a, expect, "r {r}, query {q}");
                most = most.max(a.len());
            }
        }
        assert!(most > 3 * BATCH, "at most {most} hits per query");
    }

    #[test]
    fn empty_grid_finds_nothing() {
        let mut grid = HashGrid::default();
        grid.build(&[], 0.1);
        let mut n = 0;
        grid.query_in(Vec3::ZERO, &[0u8; 0], |_, _| n += 1);
        assert_eq!(n, 0);
    }
}
