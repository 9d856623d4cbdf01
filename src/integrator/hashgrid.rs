//! Range queries over light vertices for vertex merging and photon mapping: a hashed
//! uniform grid with cells of twice the radius, so a query visits 2 x 2 x 2 cells
//! (the cell of the point and its nearest neighbour on each axis).
//!
//! Built each iteration: keys are computed and sorted in parallel (the key holds the
//! vertex index, so the order, and with it every sum over a query, never depends on
//! the thread count). Buffers keep their capacity between builds.

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
    keys: Vec<u64>,
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
        let table = (n.max(4) / 4).next_power_of_two() as u64;
        let (origin, inv) = (self.origin, self.inv_cell);
        self.keys.clear();
        self.keys
            .par_extend(points.par_iter().enumerate().map(|(i, p)| {
                let c = cell_of(*p, origin, inv);
                (hash(c) & (table - 1)) << 32 | i as u64
            }));
        self.keys.par_sort_unstable();
        self.starts.clear();
        self.starts.resize(table as usize + 1, 0);
        for k in &self.keys {
            self.starts[(k >> 32) as usize + 1] += 1;
        }
        for h in 1..self.starts.len() {
            self.starts[h] += self.starts[h - 1];
        }
        self.entries.clear();
        self.entries.extend(self.keys.iter().map(|k| *k as u32));
        self.sorted.clear();
        self.sorted
            .par_extend(self.entries.par_iter().map(|&i| points[i as usize]));
    }

    pub fn radius2(&self) -> f32 {
        self.radius2
    }

    /// Calls `f(index, distance^2)` for every point within the radius of `p`, in a
    /// fixed order. Hash collisions may visit a point twice only if two of the visited
    /// cells share a slot, which the slot de-duplication below prevents.
    #[inline]
    pub fn query(&self, p: Vec3, mut f: impl FnMut(usize, f32)) {
        self.query_sorted(p, |k, d2| f(self.entries[k] as usize, d2));
    }

    /// The original index of each point, in the grid's storage order.
    pub fn order(&self) -> &[u32] {
        &self.entries
    }

    /// Like [`HashGrid::query`], passing positions in storage order (see
    /// [`HashGrid::order`]): callers that lay their per-point data out in that order
    /// read it contiguously too.
    #[inline]
    pub fn query_sorted(&self, p: Vec3, mut f: impl FnMut(usize, f32)) {
        if self.entries.is_empty() {
            return;
        }
        let table = (self.starts.len() - 1) as u64;
        let g = (p - self.origin) * self.inv_cell;
        let c = g.floor();
        let frac = g - c;
        let base = [c.x as i32, c.y as i32, c.z as i32];
        // The neighbour on each axis is on the side of the nearer cell face.
        let step = [
            if frac.x < 0.5 { -1 } else { 1 },
            if frac.y < 0.5 { -1 } else { 1 },
            if frac.z < 0.5 { -1 } else { 1 },
        ];
        let mut seen = [u64::MAX; 8];
        for k in 0..8 {
            let cell = [
                base[0] + if k & 1 != 0 { step[0] } else { 0 },
                base[1] + if k & 2 != 0 { step[1] } else { 0 },
                base[2] + if k & 4 != 0 { step[2] } else { 0 },
            ];
            let slot = hash(cell) & (table - 1);
            if seen[..k].contains(&slot) {
                continue;
            }
            seen[k] = slot;
            let (a, b) = (
                self.starts[slot as usize] as usize,
                self.starts[slot as usize + 1] as usize,
            );
            for (j, q) in self.sorted[a..b].iter().enumerate() {
                let d2 = (*q - p).length_squared();
                if d2 <= self.radius2 {
                    f(a + j, d2);
                }
            }
        }
    }

    /// Bytes held by the grid's buffers.
    pub fn bytes(&self) -> usize {
        self.starts.capacity() * 4
            + self.entries.capacity() * 4
            + self.keys.capacity() * 8
            + self.sorted.capacity() * 12
    }
}

#[inline]
fn cell_of(p: Vec3, origin: Vec3, inv_cell: f32) -> [i32; 3] {
    let g = ((p - origin) * inv_cell).floor();
    [g.x as i32, g.y as i32, g.z as i32]
}

/// Teschner et al. 2003's spatial hash.
#[inline]
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
        let mut grid = HashGrid::default();
        for r in [0.01f32, 0.07, 0.4] {
            grid.build(&pts, r);
            for q in 0..200 {
                let p = pts[q * 7] + Vec3::new(0.01, -0.02, 0.005);
                let mut found = Vec::new();
                grid.query(p, |i, _| found.push(i));
                let mut expect: Vec<usize> = (0..pts.len())
                    .filter(|&i| (pts[i] - p).length_squared() <= r * r)
                    .collect();
                found.sort_unstable();
                expect.sort_unstable();
                assert_eq!(found, expect, "radius {r}, query {q}");
            }
        }
    }

    #[test]
    fn empty_grid_finds_nothing() {
        let mut grid = HashGrid::default();
        grid.build(&[], 0.1);
        let mut n = 0;
        grid.query(Vec3::ZERO, |_, _| n += 1);
        assert_eq!(n, 0);
    }
}
