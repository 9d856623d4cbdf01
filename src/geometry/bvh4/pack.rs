//! Leaf packs: up to eight triangles or parallelograms tested together by
//! Moeller-Trumbore, or up to eight spheres, in one group of eight lanes under AVX or
//! in two groups of four (SSE2 and portable code). Each test repeats the scalar one in
//! primitive.rs operation for operation, so hits are bit-identical to it.

use crate::geometry::lanes::Lanes;
use crate::math::{Vec2, Vec3A};

/// Primitives per pack.
pub(super) const WIDTH: usize = 8;

/// Vertex and edges by coordinate, and primitive indices. Unused lanes have zero
/// edges, so their determinant is zero and they never hit.
#[repr(C, align(32))]
pub(super) struct Tri8 {
    pub p0: [[f32; WIDTH]; 3],
    pub e1: [[f32; WIDTH]; 3],
    pub e2: [[f32; WIDTH]; 3],
    /// Per lane, the weight of u in the far-edge test v + k u <= 1: 1 for triangles
    /// (u + v <= 1), 0 for parallelograms (v <= 1). v + 1 u is u + v exactly.
    pub k: [f32; WIDTH],
    pub prim: [u32; WIDTH],
}

/// Centres and radii by coordinate, and primitive indices.
#[repr(C, align(32))]
pub(super) struct Sphere8 {
    pub c: [[f32; WIDTH]; 3],
    pub r: [f32; WIDTH],
    pub prim: [u32; WIDTH],
    /// Bit i is set when lane i holds a sphere.
    pub used: u32,
}

/// What the lane-group tests share: triangle packs and sphere packs.
pub(super) trait Pack {
    /// Lanes `at..at + L::N`: the bits of those hit in (0, tmax), and t, u, v (for
    /// spheres u = v = 0, as their scalar test reports).
    fn group<L: Lanes>(&self, ray: &PackRay<L>, at: usize, tmax: L) -> (u32, L, L, L);
    /// The primitive in `lane`, as hits report it.
    fn prim(&self, lane: usize) -> u32;
}

impl Pack for Tri8 {
    #[inline(always)]
    fn group<L: Lanes>(&self, ray: &PackRay<L>, at: usize, tmax: L) -> (u32, L, L, L) {
        ray.tri_group(self, at, tmax)
    }
    #[inline(always)]
    fn prim(&self, lane: usize) -> u32 {
        self.prim[lane]
    }
}

impl Pack for Sphere8 {
    #[inline(always)]
    fn group<L: Lanes>(&self, ray: &PackRay<L>, at: usize, tmax: L) -> (u32, L, L, L) {
        let (m, t) = ray.sphere_group(self, at, tmax);
        let zero = L::splat(0.0);
        (m, t, zero, zero)
    }
    #[inline(always)]
    fn prim(&self, lane: usize) -> u32 {
        self.prim[lane]
    }
}

/// (x + y) + z of the products, as glam's `Vec3A::dot` sums them.
#[inline(always)]
fn dot<L: Lanes>(a: [L; 3], b: [L; 3]) -> L {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The ray's origin and direction broadcast to lanes, once per traversal.
pub(super) struct PackRay<L> {
    o: [L; 3],
    d: [L; 3],
    /// |d|^2, as the scalar sphere test computes it.
    dd: L,
}

impl<L: Lanes> PackRay<L> {
    #[inline(always)]
    pub fn new(o: Vec3A, d: Vec3A) -> Self {
        // No `array::map` here or below: its closures can be left out of line, without
        // the AVX features of the kernels that call them.
        PackRay {
            o: [L::splat(o.x), L::splat(o.y), L::splat(o.z)],
            d: [L::splat(d.x), L::splat(d.y), L::splat(d.z)],
            dd: L::splat(d.length_squared()),
        }
    }

    /// Spheres `at..at + L::N`: the bits of those hit in (0, tmax), and t. The scalar
    /// `intersect_sphere` lane by lane: its dot products sum as glam's, (x + y) + z.
    #[inline(always)]
    fn sphere_group(&self, p: &Sphere8, at: usize, tmax: L) -> (u32, L) {
        let c = [
            L::load(&p.c[0][at..]),
            L::load(&p.c[1][at..]),
            L::load(&p.c[2][at..]),
        ];
        let r = L::load(&p.r[at..]);
        let (o, d, a) = (self.o, self.d, [self.dd; 3]);
        let f = [o[0] - c[0], o[1] - c[1], o[2] - c[2]];
        let zero = L::splat(0.0);
        // Times -1, not 0 - x: the scalar test negates, and -0 must stay -0.
        let b = L::splat(-1.0) * dot(f, d);
        let k = b / a[0];
        let l = [f[0] + k * d[0], f[1] + k * d[1], f[2] + k * d[2]];
        let rr = r * r;
        let disc = a[0] * (rr - dot(l, l));
        // Every sphere's line missed: skip the square root and both divisions on the
        // way to the same empty result.
        let used = p.used >> at;
        let on_line = disc.nlt(zero);
        if L::bits(on_line) & used == 0 {
            return (0, zero);
        }
        let s = disc.max(zero).sqrt();
        let q = L::select(b.ge(zero), b + s, b - s);
        let t0 = q / a[0];
        let t1 = (dot(f, f) - rr) / q;
        let swap = t0.gt(t1);
        let (lo, hi) = (L::select(swap, t1, t0), L::select(swap, t0, t1));
        let t = L::select(lo.gt(zero), lo, hi);
        let m = on_line & t.gt(zero) & t.lt(tmax) & t.lt(L::splat(f32::INFINITY));
        (L::bits(m) & used, t)
    }

    /// Triangles `at..at + L::N`: the bits of those hit in (0, tmax), and t, u, v.
    #[inline(always)]
    fn tri_group(&self, p: &Tri8, at: usize, tmax: L) -> (u32, L, L, L) {
        #[inline(always)]
        fn ld<L: Lanes>(a: &[[f32; WIDTH]; 3], at: usize) -> [L; 3] {
            [
                L::load(&a[0][at..]),
                L::load(&a[1][at..]),
                L::load(&a[2][at..]),
            ]
        }
        let [dx, dy, dz] = self.d;
        let [e1x, e1y, e1z] = ld(&p.e1, at);
        let [e2x, e2y, e2z] = ld(&p.e2, at);
        let [p0x, p0y, p0z] = ld(&p.p0, at);
        let pvx = dy * e2z - dz * e2y;
        let pvy = dz * e2x - dx * e2z;
        let pvz = dx * e2y - dy * e2x;
        let det = e1x * pvx + e1y * pvy + e1z * pvz;
        let inv = L::splat(1.0) / det;
        let tvx = self.o[0] - p0x;
        let tvy = self.o[1] - p0y;
        let tvz = self.o[2] - p0z;
        let u = (tvx * pvx + tvy * pvy + tvz * pvz) * inv;
        let qvx = tvy * e1z - tvz * e1y;
        let qvy = tvz * e1x - tvx * e1z;
        let qvz = tvx * e1y - tvy * e1x;
        let v = (dx * qvx + dy * qvy + dz * qvz) * inv;
        let t = (e2x * qvx + e2y * qvy + e2z * qvz) * inv;
        let (zero, one) = (L::splat(0.0), L::splat(1.0));
        let k = L::load(&p.k[at..]);
        // The scalar test's acceptance, NaNs included: u in [0, 1], !(v < 0),
        // !(far-edge > 1), 0 < t < tmax.
        let m = det.ne(zero)
            & u.ge(zero)
            & u.le(one)
            & v.nlt(zero)
            & (v + u * k).ngt(one)
            & t.gt(zero)
            & t.lt(tmax);
        (L::bits(m), t, u, v)
    }

    /// The nearest hit in (0, tmax) as (lane, t, uv); the first lane of equals, as a
    /// scalar loop would.
    #[inline(always)]
    pub fn nearest<P: Pack>(&self, p: &P, tmax: f32) -> Option<(usize, f32, Vec2)> {
        let tm = L::splat(tmax);
        let mut best = None;
        let mut best_t = tmax;
        let mut at = 0;
        while at < WIDTH {
            let (mut m, t, u, v) = p.group(self, at, tm);
            at += L::N;
            if m == 0 {
                continue;
            }
            let mut ts = [0.0f32; WIDTH];
            t.store(&mut ts);
            while m != 0 {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                if ts[i] < best_t {
                    best_t = ts[i];
                    best = Some((at - L::N + i, i, u, v));
                }
            }
        }
        let (lane, i, u, v) = best?;
        let (mut us, mut vs) = ([0.0f32; WIDTH], [0.0f32; WIDTH]);
        u.store(&mut us);
        v.store(&mut vs);
        Some((lane, best_t, Vec2::new(us[i], vs[i])))
    }

    /// Some lane hit in (0, tmax), if any.
    #[inline(always)]
    pub fn any<P: Pack>(&self, p: &P, tmax: f32) -> Option<usize> {
        let tm = L::splat(tmax);
        let mut at = 0;
        while at < WIDTH {
            let m = p.group(self, at, tm).0;
            if m != 0 {
                return Some(at + m.trailing_zeros() as usize);
            }
            at += L::N;
        }
        None
    }
}
