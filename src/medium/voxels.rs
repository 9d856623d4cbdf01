//! Density fields of heterogeneous media, in the medium's local unit cube [0, 1]^3:
//! voxel grids (trilinear between voxel centres, clamped at the edges) and fractal
//! Perlin noise. Each also bounds itself over boxes, for the majorant grid.

use super::grid_io::DenseGrid;
use super::noise::Fbm;
use crate::math::Vec3;
use rayon::prelude::*;

/// A scalar grid with values at voxel centres (x fastest).
#[derive(Clone, Debug)]
pub struct VoxelGrid {
    dims: [usize; 3],
    data: Vec<f32>,
}

impl VoxelGrid {
    pub fn new(g: &DenseGrid) -> Self {
        VoxelGrid {
            dims: g.dims,
            data: g.data.clone(),
        }
    }

    #[inline]
    fn at(&self, x: usize, y: usize, z: usize) -> f32 {
        self.data[x + self.dims[0] * (y + self.dims[1] * z)]
    }

    /// Trilinear interpolation between voxel centres; clamped outside them.
    #[inline]
    pub fn eval(&self, p: Vec3) -> f32 {
        let mut i = [0usize; 3];
        let mut j = [0usize; 3];
        let mut f = [0f32; 3];
        for a in 0..3 {
            let n = self.dims[a];
            let c = (p[a] * n as f32 - 0.5).clamp(0.0, (n - 1) as f32);
            let lo = (c as usize).min(n - 1);
            i[a] = lo;
            j[a] = (lo + 1).min(n - 1);
            f[a] = c - lo as f32;
        }
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let x00 = lerp(self.at(i[0], i[1], i[2]), self.at(j[0], i[1], i[2]), f[0]);
        let x10 = lerp(self.at(i[0], j[1], i[2]), self.at(j[0], j[1], i[2]), f[0]);
        let x01 = lerp(self.at(i[0], i[1], j[2]), self.at(j[0], i[1], j[2]), f[0]);
        let x11 = lerp(self.at(i[0], j[1], j[2]), self.at(j[0], j[1], j[2]), f[0]);
        lerp(lerp(x00, x10, f[1]), lerp(x01, x11, f[1]), f[2])
    }

    /// The largest value `eval` takes in the box [lo, hi]: trilinear interpolation
    /// stays within its eight corner values, so the maximum over the voxels whose
    /// centres' cells overlap the box bounds it exactly.
    pub fn max_over(&self, lo: Vec3, hi: Vec3) -> f32 {
        let range = |a: usize| {
            let n = self.dims[a];
            let first = ((lo[a] * n as f32 - 0.5).floor().max(0.0) as usize).min(n - 1);
            let last = ((hi[a] * n as f32 - 0.5).floor() as isize + 1).clamp(0, n as isize - 1);
            first..=last as usize
        };
        let mut m = 0.0f32;
        for z in range(2) {
            for y in range(1) {
                for x in range(0) {
                    m = m.max(self.at(x, y, z));
                }
            }
        }
        m
    }

    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }
}

/// Where density comes from.
#[derive(Clone, Debug)]
pub enum DensityField {
    Grid(VoxelGrid),
    Noise(Fbm),
}

impl DensityField {
    #[inline]
    pub fn eval(&self, p: Vec3) -> f32 {
        match self {
            DensityField::Grid(g) => g.eval(p),
            DensityField::Noise(n) => n.density(p),
        }
    }

    /// Majorant-grid resolution: about four voxels per cell for grids (pbrt-v4 uses a
    /// fixed 16^3), 32^3 for noise.
    fn majorant_res(&self) -> [usize; 3] {
        match self {
            DensityField::Grid(g) => g.dims.map(|n| n.div_ceil(4).clamp(1, 64)),
            DensityField::Noise(_) => [32; 3],
        }
    }
}

/// Per-cell upper bounds of the density over the unit cube, walked by a 3D DDA so that
/// free-flight sampling takes long steps through thin regions and skips empty ones.
#[derive(Clone, Debug)]
pub struct MajorantGrid {
    pub res: [usize; 3],
    pub max: Vec<f32>,
}

impl MajorantGrid {
    pub fn build(field: &DensityField) -> Self {
        let res = field.majorant_res();
        let max = match field {
            DensityField::Grid(g) => grid_cell_bounds(g, res),
            DensityField::Noise(f) => f.cell_bounds(res[0], 4),
        };
        MajorantGrid { res, max }
    }

    #[inline]
    pub fn get(&self, c: [usize; 3]) -> f32 {
        self.max[c[0] + self.res[0] * (c[1] + self.res[1] * c[2])]
    }

    pub fn global_max(&self) -> f32 {
        self.max.iter().copied().fold(0.0, f32::max)
    }

    /// The mean of the cell bounds: an upper bound of the mean density over the cube.
    pub fn mean(&self) -> f32 {
        let sum: f64 = self.max.iter().map(|&m| m as f64).sum();
        (sum / self.max.len().max(1) as f64) as f32
    }
}

/// Exact per-cell maxima of a voxel grid (see [`VoxelGrid::max_over`]).
fn grid_cell_bounds(g: &VoxelGrid, res: [usize; 3]) -> Vec<f32> {
    (0..res[0] * res[1] * res[2])
        .into_par_iter()
        .map(|i| {
            let c = [i % res[0], (i / res[0]) % res[1], i / (res[0] * res[1])];
            let lo = Vec3::from_array(std::array::from_fn(|a| c[a] as f32 / res[a] as f32));
            let hi = Vec3::from_array(std::array::from_fn(|a| (c[a] + 1) as f32 / res[a] as f32));
            g.max_over(lo, hi)
        })
        .collect()
}

/// Segments (t0, t1, majorant) of a local-space ray o + t d through the majorant
/// cells, in order (Amanatides and Woo 1987).
pub struct MajorantWalk<'a> {
    grid: &'a MajorantGrid,
    cell: [isize; 3],
    step: [isize; 3],
    next_t: [f32; 3],
    delta_t: [f32; 3],
    t: f32,
    t_end: f32,
}

impl<'a> MajorantWalk<'a> {
    /// The walk over t in [t0, t1], which must lie inside the unit cube.
    pub fn new(grid: &'a MajorantGrid, o: Vec3, d: Vec3, t0: f32, t1: f32) -> Self {
        let p = o + d * t0;
        let mut w = MajorantWalk {
            grid,
            cell: [0; 3],
            step: [0; 3],
            next_t: [f32::INFINITY; 3],
            delta_t: [f32::INFINITY; 3],
            t: t0,
            t_end: t1,
        };
        for a in 0..3 {
            let n = grid.res[a] as f32;
            let c = ((p[a] * n) as isize).clamp(0, grid.res[a] as isize - 1);
            w.cell[a] = c;
            if d[a] > 0.0 {
                w.step[a] = 1;
                w.next_t[a] = t0 + ((c + 1) as f32 / n - p[a]) / d[a];
                w.delta_t[a] = 1.0 / (n * d[a]);
            } else if d[a] < 0.0 {
                w.step[a] = -1;
                w.next_t[a] = t0 + (c as f32 / n - p[a]) / d[a];
                w.delta_t[a] = -1.0 / (n * d[a]);
            }
        }
        w
    }
}

impl Iterator for MajorantWalk<'_> {
    type Item = (f32, f32, f32);

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        if self.t >= self.t_end {
            return None;
        }
        let a = if self.next_t[0] < self.next_t[1] {
            if self.next_t[0] < self.next_t[2] {
                0
            } else {
                2
            }
        } else if self.next_t[1] < self.next_t[2] {
            1
        } else {
            2
        };
        let t1 = self.next_t[a].min(self.t_end);
        let c = self.cell.map(|c| c as usize);
        let seg = (self.t, t1, self.grid.get(c));
        self.t = t1;
        self.cell[a] += self.step[a];
        self.next_t[a] += self.delta_t[a];
        if self.cell[a] < 0 || self.cell[a] >= self.grid.res[a] as isize {
            self.t_end = self.t;
        }
        Some(seg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(dims: [usize; 3], f: impl Fn(usize, usize, usize) -> f32) -> VoxelGrid {
        let mut data = Vec::new();
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    data.push(f(x, y, z));
                }
            }
        }
        VoxelGrid { dims, data }
    }

    #[test]
    fn trilinear_hits_voxel_centres_and_clamps() {
        let g = grid([4, 3, 2], |x, y, z| (x + 10 * y + 100 * z) as f32);
        let centre = |x: usize, y: usize, z: usize| {
            Vec3::new(
                (x as f32 + 0.5) / 4.0,
                (y as f32 + 0.5) / 3.0,
                (z as f32 + 0.5) / 2.0,
            )
        };
        assert!((g.eval(centre(2, 1, 1)) - 112.0).abs() < 1e-4);
        // Half way between two centres along x: the mean.
        let p = (centre(1, 0, 0) + centre(2, 0, 0)) * 0.5;
        assert!((g.eval(p) - 1.5).abs() < 1e-4);
        // Outside the outer centres the value is clamped.
        assert!((g.eval(Vec3::new(0.0, 0.0, 0.0)) - 0.0).abs() < 1e-6);
        assert!((g.eval(Vec3::new(1.0, 1.0, 1.0)) - 123.0).abs() < 1e-4);
    }

    #[test]
    fn majorants_bound_the_field() {
        let g = grid([9, 7, 5], |x, y, z| ((x * 7 + y * 13 + z * 29) % 11) as f32);
        let field = DensityField::Grid(g.clone());
        let m = MajorantGrid::build(&field);
        let mut rng = crate::math::Rng::new(4, 5, 6);
        for _ in 0..20_000 {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let c = std::array::from_fn(|a| ((p[a] * m.res[a] as f32) as usize).min(m.res[a] - 1));
            assert!(g.eval(p) <= m.get(c) + 1e-5, "{p}");
        }
    }

    #[test]
    fn walk_covers_the_segment_in_order() {
        let g = grid([16, 16, 16], |x, _, _| x as f32);
        let m = MajorantGrid::build(&DensityField::Grid(g));
        let o = Vec3::new(0.01, 0.3, 0.97);
        let d = Vec3::new(0.9, 0.2, -0.8);
        let (t0, t1) = (0.05, 1.1);
        let mut t = t0;
        let mut n = 0;
        for (a, b, maj) in MajorantWalk::new(&m, o, d, t0, t1) {
            assert!((a - t).abs() < 1e-5 && b >= a, "{a} {b} after {t}");
            // The cell's majorant bounds the field at the segment's middle.
            let mid = o + d * (0.5 * (a + b));
            assert!(mid.x * 16.0 - 0.5 <= maj + 1.0 + 1e-4);
            t = b;
            n += 1;
        }
        assert!((t - t1).abs() < 1e-5, "ended at {t}");
        assert!(n >= 4, "{n} cells");
    }
}
