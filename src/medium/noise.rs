//! Fractal Perlin noise for procedural media (Perlin 2002, "Improving noise": quintic
//! fade, twelve edge gradients), summed over octaves (fractional Brownian motion).
//!
//! Density in the local unit cube: with v the octave sum divided by the sum of the
//! octave amplitudes (so |v| <= ~1), n = (1 + v) / 2 and
//! density = clamp((n - threshold) / (1 - threshold), 0, 1).

use crate::math::{Rng, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct FbmParams {
    pub octaves: u32,
    pub lacunarity: f32,
    pub gain: f32,
    /// Cycles of the first octave across the unit cube.
    pub frequency: f32,
    pub seed: u64,
    pub threshold: f32,
}

#[derive(Clone, Debug)]
pub struct Fbm {
    p: FbmParams,
    perm: Box<[u8; 512]>,
    norm: f32,
    /// Bound on |grad n| in local units, for the majorant margin.
    lipschitz: f32,
}

const GRADIENTS: [[f32; 3]; 12] = [
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [1.0, -1.0, 0.0],
    [-1.0, -1.0, 0.0],
    [1.0, 0.0, 1.0],
    [-1.0, 0.0, 1.0],
    [1.0, 0.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, 1.0, 1.0],
    [0.0, -1.0, 1.0],
    [0.0, 1.0, -1.0],
    [0.0, -1.0, -1.0],
];

/// Bound on |grad| of one octave of unit frequency. The quintic fade has slope at most
/// 15/8, each of the eight corner terms is a gradient (norm sqrt 2) dotted with an
/// offset of norm <= sqrt 3; a crude product bound over the interpolation keeps this
/// safely above the true maximum (about 2.2 measured by finite differences).
const OCTAVE_LIPSCHITZ: f32 = 6.0;

impl Fbm {
    pub fn new(p: FbmParams) -> Self {
        let mut perm = Box::new([0u8; 512]);
        let mut base: Vec<u8> = (0..=255).collect();
        let mut rng = Rng::new(p.seed, 0x5eed, 0x9e37);
        for i in (1..256).rev() {
            let j = (rng.next_u32() as usize) % (i + 1);
            base.swap(i, j);
        }
        for i in 0..512 {
            perm[i] = base[i & 255];
        }
        let mut norm = 0.0;
        let mut lip = 0.0;
        let (mut amp, mut freq) = (1.0f32, p.frequency);
        for _ in 0..p.octaves {
            norm += amp;
            lip += amp * freq * OCTAVE_LIPSCHITZ;
            amp *= p.gain;
            freq *= p.lacunarity;
        }
        // d density / d n = 1 / (1 - threshold); n = (1 + v) / 2.
        let lipschitz = 0.5 * lip / norm / (1.0 - p.threshold);
        Fbm {
            p,
            perm,
            norm,
            lipschitz,
        }
    }

    fn perlin(&self, q: Vec3) -> f32 {
        let fl = q.floor();
        let f = q - fl;
        let i = [fl.x as i64 & 255, fl.y as i64 & 255, fl.z as i64 & 255].map(|v| v as usize);
        let fade = |t: f32| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
        let (u, v, w) = (fade(f.x), fade(f.y), fade(f.z));
        let hash = |x: usize, y: usize, z: usize| {
            let p = &self.perm;
            p[p[p[x] as usize + y] as usize + z] as usize % 12
        };
        let grad = |h: usize, x: f32, y: f32, z: f32| {
            let g = GRADIENTS[h];
            g[0] * x + g[1] * y + g[2] * z
        };
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let corner = |dx: usize, dy: usize, dz: usize| {
            grad(
                hash(i[0] + dx, i[1] + dy, i[2] + dz),
                f.x - dx as f32,
                f.y - dy as f32,
                f.z - dz as f32,
            )
        };
        lerp(
            lerp(
                lerp(corner(0, 0, 0), corner(1, 0, 0), u),
                lerp(corner(0, 1, 0), corner(1, 1, 0), u),
                v,
            ),
            lerp(
                lerp(corner(0, 0, 1), corner(1, 0, 1), u),
                lerp(corner(0, 1, 1), corner(1, 1, 1), u),
                v,
            ),
            w,
        )
    }

    /// The normalised octave sum v(p).
    pub fn value(&self, p: Vec3) -> f32 {
        let (mut amp, mut freq, mut sum) = (1.0f32, self.p.frequency, 0.0f32);
        for o in 0..self.p.octaves {
            // Each octave is shifted so that lattice points of different octaves do
            // not coincide (all Perlin noise is zero at integer points).
            let shift = Vec3::splat(17.31 * o as f32 + 0.37);
            sum += amp * self.perlin(p * freq + shift);
            amp *= self.p.gain;
            freq *= self.p.lacunarity;
        }
        sum / self.norm
    }

    #[inline]
    pub fn density(&self, p: Vec3) -> f32 {
        let n = 0.5 * (1.0 + self.value(p));
        ((n - self.p.threshold) / (1.0 - self.p.threshold)).clamp(0.0, 1.0)
    }

    /// An upper bound of the density over the box: the largest of a lattice of samples
    /// plus the Lipschitz bound times the farthest any point is from the lattice.
    pub fn bound_over(&self, lo: Vec3, hi: Vec3) -> f32 {
        const K: usize = 6;
        let step = (hi - lo) / K as f32;
        let mut m = 0.0f32;
        for z in 0..=K {
            for y in 0..=K {
                for x in 0..=K {
                    let p = lo + step * Vec3::new(x as f32, y as f32, z as f32);
                    m = m.max(self.density(p));
                }
            }
        }
        (m + self.lipschitz * 0.5 * step.length()).min(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fbm(seed: u64) -> Fbm {
        Fbm::new(FbmParams {
            octaves: 4,
            lacunarity: 2.0,
            gain: 0.5,
            frequency: 3.0,
            seed,
            threshold: 0.3,
        })
    }

    #[test]
    fn octave_gradient_bound_holds() {
        let f = fbm(1);
        let mut rng = Rng::new(9, 9, 9);
        let h = 1e-3;
        let mut worst = 0.0f32;
        for _ in 0..50_000 {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 40.0;
            let g = Vec3::new(
                f.perlin(p + Vec3::X * h) - f.perlin(p - Vec3::X * h),
                f.perlin(p + Vec3::Y * h) - f.perlin(p - Vec3::Y * h),
                f.perlin(p + Vec3::Z * h) - f.perlin(p - Vec3::Z * h),
            ) / (2.0 * h);
            worst = worst.max(g.length());
        }
        assert!(worst < OCTAVE_LIPSCHITZ, "gradient {worst}");
        assert!(worst > 1.0, "suspiciously flat noise: {worst}");
    }

    #[test]
    fn bounds_hold_and_seeds_differ() {
        let f = fbm(7);
        let mut rng = Rng::new(1, 2, 3);
        for _ in 0..200 {
            let lo = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.9;
            let hi = lo + Vec3::splat(0.0625);
            let b = f.bound_over(lo, hi);
            for _ in 0..50 {
                let t = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let p = lo + (hi - lo) * t;
                assert!(f.density(p) <= b + 1e-6);
            }
        }
        let g = fbm(8);
        let p = Vec3::new(0.31, 0.52, 0.77);
        assert_ne!(f.value(p), g.value(p));
        assert!(f.value(p).abs() <= 1.0);
    }
}
