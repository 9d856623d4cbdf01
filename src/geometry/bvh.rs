//! The scene BVH: a binary tree built by obvhs (PLOC with reinsertion optimisation;
//! Meister and Bittner 2018), flattened into our own four-wide tree and traversed
//! with SIMD slab and triangle tests (see `bvh4`). Closest-hit and any-hit (shadow)
//! queries over triangles, spheres and disks.
//!
//! PLOC takes quadratic time on copies of one primitive and other inputs whose
//! merge costs tie (see `rounds`); those get a top-down tree instead (`top_down`).

use super::bvh4::Bvh4;
use super::primitive::{surface_point, Prim, PrimHit, PrimMeta};
use super::{Interaction, Ray};
use crate::math::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::bvh2::Bvh2;
use obvhs::BvhBuildParams;
use rounds::{ploc_rounds, Limits};
use std::time::{Duration, Instant};

mod rounds;
mod top_down;

// `Hit` lives beside `Ray` in `geometry`, where `bvh4` takes it without depending on
// this module; the old path stays.
pub use super::Hit;

/// The slower presets build trees that trace measurably faster; their build cost only
/// shows on large meshes.
fn build_params(prims: usize) -> BvhBuildParams {
    let mut p = if prims < 200_000 {
        BvhBuildParams::very_slow_build()
    } else {
        BvhBuildParams::medium_build()
    };
    // One primitive per binary leaf: our flattening forms the leaves, with the costs
    // of our kernels (see bvh4/build.rs).
    p.max_prims_per_leaf = 1;
    p
}

/// Natural geometry takes a few dozen rounds and searches 3 to 6 boxes per primitive
/// (meshes, clouds of triangles, 4k to 1M of them); a build beyond these bounds would
/// run long and make a deep tree, so it is left to `top_down`.
const PLOC_LIMITS: Limits = Limits {
    rounds: 256,
    searched_per_box: 16,
};

/// Which builder made the binary tree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Builder {
    /// obvhs's PLOC, after this many merge rounds.
    Ploc { rounds: usize },
    /// The top-down builder, for an input PLOC would take too long on.
    TopDown,
}

/// The binary tree, from obvhs where it builds in bounded time, else from `top_down`.
fn build_binary(aabbs: &[Aabb]) -> (Bvh2, Builder) {
    let params = build_params(aabbs.len());
    match ploc_rounds(aabbs, &params, PLOC_LIMITS) {
        Some(r) => {
            let bvh = build_bvh2(aabbs, params, &mut Duration::default());
            (bvh, Builder::Ploc { rounds: r.rounds })
        }
        None => (top_down::build(aabbs), Builder::TopDown),
    }
}

pub struct Accel {
    tree: Bvh4,
    /// Primitives in the tree's leaf order, so that leaves are runs of them.
    prims: Vec<Prim>,
    meta: Vec<PrimMeta>,
    /// `Prim::flat_normal` of each primitive, in the same order.
    normals: Vec<Vec3A>,
    pub build_time: Duration,
    pub builder: Builder,
    pub bounds: Aabb,
}

impl Accel {
    /// Most primitives one tree holds.
    pub const MAX_PRIMITIVES: usize = super::bvh4::MAX_PRIMITIVES;

    pub fn build(prims: Vec<Prim>, meta: Vec<PrimMeta>) -> Self {
        let start = Instant::now();
        if prims.is_empty() {
            return Accel {
                tree: Bvh4::empty(),
                prims,
                meta,
                normals: Vec::new(),
                build_time: start.elapsed(),
                builder: Builder::TopDown,
                bounds: Aabb::empty(),
            };
        }
        let aabbs: Vec<Aabb> = prims.iter().map(Prim::aabb).collect();
        let (bvh2, builder) = build_binary(&aabbs);
        let (tree, order) = Bvh4::from_bvh2(&bvh2, &prims);
        let prims: Vec<Prim> = order.iter().map(|&i| prims[i as usize]).collect();
        Accel {
            tree,
            normals: prims.iter().map(Prim::flat_normal).collect(),
            prims,
            meta: order.iter().map(|&i| meta[i as usize]).collect(),
            build_time: start.elapsed(),
            builder,
            bounds: *bvh2.nodes[0].aabb(),
        }
    }

    /// Bytes held by nodes, leaves and primitives.
    pub fn memory_bytes(&self) -> usize {
        self.tree.memory_bytes()
            + self.prims.len() * std::mem::size_of::<Prim>()
            + self.meta.len() * std::mem::size_of::<PrimMeta>()
            + self.normals.len() * std::mem::size_of::<Vec3A>()
    }

    pub fn prim_count(&self) -> usize {
        self.prims.len()
    }

    /// Closest intersection along the ray, if any.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.tree.intersect(&self.prims, ray)
    }

    /// True when anything blocks the ray before `ray.tmax`.
    #[inline(always)]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.tree.any_hit(&self.prims, ray).is_some()
    }

    /// The closest hit along `ray` and whether anything blocks `shadow`, found together
    /// (see [`Bvh4::intersect_and_any`]).
    #[inline]
    pub fn intersect_and_occluded(&self, ray: &Ray, shadow: &Ray) -> (Option<Hit>, bool) {
        let (hit, blocker) = self.tree.intersect_and_any(&self.prims, ray, shadow);
        (hit, blocker.is_some())
    }

    /// Some primitive before `ray.tmax` (the first found, not the nearest), if any.
    #[inline]
    pub fn any_hit(&self, ray: &Ray) -> Option<u32> {
        self.tree.any_hit(&self.prims, ray)
    }

    pub fn meta(&self, prim: u32) -> PrimMeta {
        self.meta[prim as usize]
    }

    pub fn prim(&self, prim: u32) -> &Prim {
        &self.prims[prim as usize]
    }

    /// Geometry of a hit, before the scene applies per-shape normal flips and
    /// shading normals.
    #[inline]
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> Interaction {
        let prim = &self.prims[hit.prim as usize];
        let ph = PrimHit {
            t: hit.t,
            uv: hit.uv,
        };
        let (p, p_err, ng) = surface_point(prim, self.normals[hit.prim as usize], ray, &ph);
        let meta = self.meta[hit.prim as usize];
        Interaction {
            p,
            p_err,
            ng,
            ns: ng,
            uv: hit.uv,
            shape: meta.shape,
            local: meta.local,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Rng, Vec3, Vec3A};

    #[test]
    fn closest_hit_and_occlusion_over_mixed_primitives() {
        let prims = vec![
            Prim::Sphere {
                c: Vec3A::new(0.0, 0.0, -5.0),
                r: 1.0,
            },
            Prim::Tri {
                p0: Vec3A::new(-1.0, -1.0, -2.0),
                e1: Vec3A::new(2.0, 0.0, 0.0),
                e2: Vec3A::new(0.0, 2.0, 0.0),
            },
        ];
        let meta = vec![
            PrimMeta { shape: 7, local: 0 },
            PrimMeta { shape: 9, local: 0 },
        ];
        let accel = Accel::build(prims, meta);
        let ray = Ray::new(Vec3::new(-0.5, -0.5, 0.0), Vec3::new(0.0, 0.0, -1.0));
        let hit = accel.intersect(&ray).unwrap();
        assert!((hit.t - 2.0).abs() < 1e-5);
        assert_eq!(accel.meta(hit.prim).shape, 9);
        let ray = Ray::new(Vec3::new(0.6, 0.6, 0.0), Vec3::new(0.0, 0.0, -1.0));
        let hit = accel.intersect(&ray).unwrap();
        assert_eq!(accel.meta(hit.prim).shape, 7);
        let mut short = ray;
        short.tmax = 3.0;
        assert!(!accel.occluded(&short));
        short.tmax = 4.5;
        assert!(accel.occluded(&short));
    }
    fn assert_same_hit(a: Option<Hit>, b: Option<Hit>, ray: &Ray) {
        let key =
            |h: Option<Hit>| h.map(|h| (h.t.to_bits(), h.prim, h.uv.to_array().map(f32::to_bits)));
        assert_eq!(key(a), key(b), "ray {ray:?}");
    }

    /// Closest hit and occlusion by testing every primitive, as the reference.
    fn brute_force(prims: &[Prim], ray: &Ray) -> Option<(f32, Vec<usize>)> {
        let (o, d) = (Vec3A::from(ray.o), Vec3A::from(ray.d));
        let hits: Vec<(f32, usize)> = prims
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.intersect(o, d, ray.tmax).map(|h| (h.t, i)))
            .collect();
        let t = hits.iter().map(|h| h.0).min_by(f32::total_cmp)?;
        // Every primitive at exactly that distance (ties, e.g. on shared edges).
        Some((t, hits.iter().filter(|h| h.0 == t).map(|h| h.1).collect()))
    }

    /// The BVH's closest hit must be bit-identical to the primitive's own test (the
    /// SIMD pack test repeats the scalar one's operations), and occlusion must
    /// agree for limits just below, at and beyond that hit.
    fn check(accel: &Accel, prims: &[Prim], ray: &Ray) {
        let brute = brute_force(prims, ray);
        let got = accel.intersect(ray);
        match (&brute, got) {
            (None, None) => {}
            (Some((t, ids)), Some(h)) => {
                assert_eq!(h.t.to_bits(), t.to_bits(), "ray {ray:?}");
                let i = accel.meta(h.prim).shape as usize;
                assert!(ids.contains(&i), "ray {ray:?}: prim {i}, expected {ids:?}");
                let own = prims[i]
                    .intersect(ray.o.into(), ray.d.into(), ray.tmax)
                    .unwrap();
                assert_eq!(h.uv, own.uv, "ray {ray:?}");
            }
            (b, g) => panic!("ray {ray:?}: brute force {b:?} vs bvh {g:?}"),
        }
        let mut limits = vec![ray.tmax, 5.0, 1e-3];
        if let Some((t, _)) = brute {
            limits.extend([t, t * 0.999, t * 1.001, t.next_up()]);
        }
        for tmax in limits {
            let short = Ray { tmax, ..*ray };
            let expect = prims
                .iter()
                .any(|p| p.intersect(ray.o.into(), ray.d.into(), tmax).is_some());
            assert_eq!(accel.occluded(&short), expect, "ray {short:?}");
            // Traced together, either way round, the two queries answer as apart.
            let (hit, occluded) = accel.intersect_and_occluded(ray, &short);
            assert_same_hit(hit, got, ray);
            assert_eq!(occluded, expect, "ray {short:?} paired");
            let (hit, occluded) = accel.intersect_and_occluded(&short, ray);
            assert_same_hit(hit, accel.intersect(&short), &short);
            assert_eq!(occluded, accel.occluded(ray), "ray {ray:?} paired");
            // A limit of zero, below or NaN makes an any-hit ray that meets nothing
            // (pt pairs such a ray with rays that have no shadow ray to go with).
            for tmax in [-1.0, 0.0, f32::NAN] {
                let none = Ray { tmax, ..short };
                let (hit, occluded) = accel.intersect_and_occluded(ray, &none);
                assert_same_hit(hit, got, ray);
                assert!(!occluded && !accel.occluded(&none), "ray {none:?}");
            }
            // The primitive any-hit reports is one the ray really meets.
            if let Some(i) = accel.any_hit(&short) {
                let own = &prims[accel.meta(i).shape as usize];
                assert!(own.intersect(ray.o.into(), ray.d.into(), tmax).is_some());
            }
        }
    }

    fn build(prims: &[Prim]) -> Accel {
        let meta = (0..prims.len() as u32)
            .map(|i| PrimMeta { shape: i, local: 0 })
            .collect();
        Accel::build(prims.to_vec(), meta)
    }

    /// The same tree traversed every way it can be: with AVX-512 and AVX encodings
    /// where the processor has them, with SSE only, and with the heap stack of deep
    /// trees. The tests give every variant the same rays.
    fn variants(prims: &[Prim]) -> Vec<Accel> {
        let mut sse = build(prims);
        sse.tree.disable_avx();
        let mut avx = build(prims);
        avx.tree.disable_avx512();
        let mut heap = build(prims);
        heap.tree.force_heap_stack();
        vec![build(prims), avx, sse, heap]
    }

    fn random_dir(rng: &mut Rng) -> Vec3 {
        crate::math::warp::square_to_uniform_sphere(rng.next_2d())
    }

    /// Directions along the axes, with both signs of zero in the other components.
    fn axis_dirs() -> Vec<Vec3> {
        let mut dirs = Vec::new();
        for axis in 0..3 {
            for s in [1.0f32, -1.0] {
                for z in [0.0f32, -0.0] {
                    let mut d = Vec3::splat(z);
                    d[axis] = s;
                    dirs.push(d);
                }
            }
        }
        dirs
    }

    /// A point on the primitive's surface.
    fn surface(p: &Prim, rng: &mut Rng) -> Vec3 {
        use crate::math::warp::{square_to_disk, square_to_triangle};
        match *p {
            Prim::Tri { p0, e1, e2 } => {
                let u = square_to_triangle(rng.next_2d());
                (p0 + e1 * u.x + e2 * u.y).into()
            }
            Prim::Quad { p0, e1, e2 } => {
                let u = rng.next_2d();
                (p0 + e1 * u.x + e2 * u.y).into()
            }
            Prim::Sphere { c, r } => (c + Vec3A::from(random_dir(rng)) * r).into(),
            Prim::Disk { c, u: a, v: b } => {
                let u = square_to_disk(rng.next_2d());
                (c + a * u.x + b * u.y).into()
            }
        }
    }

    /// Random rays, rays along the axes from points on the boxes' slab planes (where
    /// 0 * inf = NaN appears), and rays leaving primitives' surfaces.
    fn check_many(accel: &Accel, prims: &[Prim], rng: &mut Rng, n: usize) {
        let b = accel.bounds;
        let (lo, hi) = (Vec3::from(b.min), Vec3::from(b.max));
        let ext = (hi - lo).max(Vec3::splat(1e-3));
        let dirs = axis_dirs();
        for k in 0..n {
            let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let o = lo - 0.25 * ext + u * 1.5 * ext;
            check(accel, prims, &Ray::new(o, random_dir(rng)));
            // Along an axis, with the other coordinates taken from a primitive's
            // bounds, so the ray grazes slab planes exactly.
            let p = &prims[rng.next_u32() as usize % prims.len()];
            let pb = p.aabb();
            let pick = |i: usize, rng: &mut Rng| match rng.next_u32() % 3 {
                0 => pb.min[i],
                1 => pb.max[i],
                _ => o[i],
            };
            let mut q = Vec3::new(pick(0, rng), pick(1, rng), pick(2, rng));
            let d = dirs[k % dirs.len()];
            let axis = (k % dirs.len()) / 4;
            q[axis] = o[axis];
            check(accel, prims, &Ray::new(q, d));
            // From the surface of a primitive, both ways.
            let s = surface(p, rng);
            let d = random_dir(rng);
            check(accel, prims, &Ray::new(s, d));
            check(accel, prims, &Ray::new(s, -d));
        }
    }

    fn random_prims(rng: &mut Rng, n: usize, size: f32, spheres: bool) -> Vec<Prim> {
        (0..n)
            .map(|i| {
                let c = Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 20.0 - 10.0;
                let e = |r: &mut Rng| {
                    (Vec3A::new(r.next_f32(), r.next_f32(), r.next_f32()) - 0.5) * size
                };
                match i % 6 {
                    0 if spheres => Prim::Sphere {
                        c,
                        r: size * (0.05 + 0.3 * rng.next_f32()),
                    },
                    3 if spheres => Prim::Disk {
                        c,
                        u: e(rng),
                        v: e(rng),
                    },
                    1 | 4 => Prim::Quad {
                        p0: c,
                        e1: e(rng),
                        e2: e(rng),
                    },
                    _ => Prim::Tri {
                        p0: c,
                        e1: e(rng),
                        e2: e(rng),
                    },
                }
            })
            .collect()
    }

    /// The BVH must agree with testing every primitive, on a cloud of random spheres,
    /// disks and triangles large enough to make a deep tree.
    #[test]
    fn agrees_with_brute_force() {
        let mut rng = Rng::new(11, 0, 0);
        let prims = random_prims(&mut rng, 3000, 1.0, true);
        for accel in variants(&prims) {
            check_many(&accel, &prims, &mut rng.clone(), 1000);
        }
    }

    /// Spheres alone (their leaves become sphere packs), large and overlapping, small
    /// and far apart, and two on one centre.
    #[test]
    fn agrees_with_brute_force_on_spheres() {
        let mut rng = Rng::new(12, 0, 0);
        let mut prims: Vec<Prim> = (0..400)
            .map(|i| {
                let c = Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 20.0 - 10.0;
                let r = if i % 3 == 0 { 2.0 } else { 0.05 } * (0.5 + rng.next_f32());
                Prim::Sphere { c, r }
            })
            .collect();
        prims.push(Prim::Sphere {
            c: Vec3A::ZERO,
            r: 1.0,
        });
        prims.push(Prim::Sphere {
            c: Vec3A::ZERO,
            r: 0.5,
        });
        let accel = build(&prims);
        assert!(!accel.tree.sphere_packs_empty(), "no sphere packs built");
        for accel in variants(&prims) {
            check_many(&accel, &prims, &mut rng.clone(), 1000);
        }
    }

    /// Axis-aligned rectangles sharing edges, like a room: every slab plane is shared
    /// by many boxes, and axis rays run along them. Built from triangle pairs and from
    /// parallelograms.
    #[test]
    fn agrees_with_brute_force_on_axis_aligned_walls() {
        for merged in [false, true] {
            walls(merged);
        }
    }

    fn walls(merged: bool) {
        let rng = Rng::new(12, 0, 0);
        let mut prims = Vec::new();
        for i in -4..4 {
            for j in -4..4 {
                let (x, y) = (i as f32 * 0.5, j as f32 * 0.5);
                let quad = |p0: Vec3A, a: Vec3A, b: Vec3A| {
                    if merged {
                        return vec![Prim::Quad { p0, e1: a, e2: b }];
                    }
                    vec![
                        Prim::Tri { p0, e1: a, e2: b },
                        Prim::Tri {
                            p0: p0 + a + b,
                            e1: -a,
                            e2: -b,
                        },
                    ]
                };
                let (ex, ey, ez) = (Vec3A::X * 0.5, Vec3A::Y * 0.5, Vec3A::Z * 0.5);
                prims.extend(quad(Vec3A::new(x, y, -2.0), ex, ey));
                prims.extend(quad(Vec3A::new(x, -2.0, y), ez, ex));
                prims.extend(quad(Vec3A::new(-2.0, x, y), ey, ez));
            }
        }
        prims.push(Prim::Sphere {
            c: Vec3A::ZERO,
            r: 0.5,
        });
        for accel in variants(&prims) {
            let mut rng = rng.clone();
            check_many(&accel, &prims, &mut rng, 1000);
            // Aimed at vertices and edge midpoints, where the slab test decides by an
            // ulp whether the box holding the hit is entered (hence Ize's widening).
            for _ in 0..3000 {
                let (Prim::Tri { p0, e1, e2 } | Prim::Quad { p0, e1, e2 }) =
                    prims[rng.next_u32() as usize % (prims.len() - 1)]
                else {
                    unreachable!()
                };
                let target = match rng.next_u32() % 4 {
                    0 => p0,
                    1 => p0 + e1,
                    2 => p0 + 0.5 * e2,
                    _ => p0 + 0.5 * (e1 + e2),
                };
                let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 3.0;
                let d = Vec3::from(target) - o;
                check(&accel, &prims, &Ray::new(o, d.normalize()));
                check(&accel, &prims, &Ray::new(o, d));
            }
        }
    }

    /// A room like SmallVCM's: five walls and two spheres on the floor. The binary
    /// builder splits the floor (a flat box) from the other walls, but in one pack it
    /// costs nothing more, so the leaves of the root join: one pack of walls, one of
    /// spheres, and nothing tested alone. Every ray enters the walls' box, so the
    /// tree is flat: walks test both packs without a slab test.
    #[test]
    fn walls_of_a_room_share_one_pack() {
        let (x, y, z) = (Vec3A::X * 2.0, Vec3A::Y * 2.0, Vec3A::Z * 2.0);
        let o = Vec3A::splat(-1.0);
        let quad = |p0, e1, e2| Prim::Quad { p0, e1, e2 };
        let prims = vec![
            quad(o, x, y),
            quad(o + z, y, x),
            quad(o, z, x),
            quad(o, y, z),
            quad(o + x, z, y),
            Prim::Sphere {
                c: Vec3A::new(-0.5, 0.0, -0.5),
                r: 0.5,
            },
            Prim::Sphere {
                c: Vec3A::new(0.5, 0.0, -0.5),
                r: 0.5,
            },
        ];
        let accel = build(&prims);
        assert_eq!(accel.tree.leaf_kinds(), (1, 1, 0));
        assert!(accel.tree.is_flat());
        for accel in variants(&prims) {
            check_many(&accel, &prims, &mut Rng::new(14, 0, 0), 500);
        }
    }

    #[test]
    fn single_primitive_and_empty_scenes() {
        let mut rng = Rng::new(13, 0, 0);
        for prims in [
            random_prims(&mut rng, 1, 1.0, false),
            vec![Prim::Sphere {
                c: Vec3A::new(1.0, 2.0, 3.0),
                r: 0.5,
            }],
            vec![Prim::Disk {
                c: Vec3A::ZERO,
                u: Vec3A::X,
                v: Vec3A::Y,
            }],
        ] {
            let accel = build(&prims);
            assert_eq!(accel.prim_count(), 1);
            check_many(&accel, &prims, &mut rng, 300);
        }
        let empty = build(&[]);
        assert_eq!(empty.prim_count(), 0);
        for _ in 0..100 {
            let ray = Ray::new(Vec3::ZERO, random_dir(&mut rng));
            assert!(empty.intersect(&ray).is_none());
            assert!(!empty.occluded(&ray));
        }
    }

    /// Sets on which PLOC's merge costs tie or chain: copies of one triangle and of one
    /// sphere, zero-area triangles on one line (the scene drops those, the BVH must not
    /// rely on it), triangles turned about one centre, spheres growing about one centre
    /// and along a line.
    fn coincident_sets(n: usize) -> Vec<(&'static str, Vec<Prim>)> {
        let tri = |p0: Vec3A, p1: Vec3A, p2: Vec3A| Prim::Tri {
            p0,
            e1: p1 - p0,
            e2: p2 - p0,
        };
        let f = |i: usize| i as f32 / n as f32;
        let turned = |i: usize| {
            let (s, c) = (f(i) * std::f32::consts::TAU).sin_cos();
            let (u, v) = (Vec3A::new(c, s, 0.0), Vec3A::new(-s, c, 0.0));
            tri(u, -0.5 * u + 0.87 * v, -0.5 * u - 0.87 * v)
        };
        let sphere = |c, r| Prim::Sphere { c, r };
        vec![
            (
                "copies of a triangle",
                vec![tri(Vec3A::ZERO, Vec3A::X, Vec3A::Y); n],
            ),
            ("copies of a sphere", vec![sphere(Vec3A::ONE, 0.5); n]),
            (
                "segments on a line",
                (0..n)
                    .map(|i| tri(Vec3A::ZERO, Vec3A::X * (1.0 + f(i)), Vec3A::X))
                    .collect(),
            ),
            ("turned about a centre", (0..n).map(turned).collect()),
            (
                "concentric spheres",
                (0..n).map(|i| sphere(Vec3A::ZERO, 1.0 + f(i))).collect(),
            ),
            (
                "spheres growing along a line",
                (0..n)
                    .map(|i| sphere(Vec3A::X * f(i), 1.0 + f(i)))
                    .collect(),
            ),
        ]
    }

    /// On these (but the turned triangles, which take a few hundred rounds), PLOC
    /// merged one pair per round: as many rounds as primitives, a quadratic build (32k
    /// copies of a triangle took 40 s) and a binary tree as deep as it is wide (a
    /// four-wide one hundreds deep here). The tree must be logarithmically deep.
    #[test]
    fn coincident_primitives_build_a_shallow_tree() {
        for (name, prims) in coincident_sets(2048) {
            let depth = build(&prims).tree.depth();
            assert!(depth <= 12, "{name}: four-wide depth {depth}");
        }
    }

    /// Hits on copies and coincident primitives are still the closest, and any of
    /// the primitives at that distance.
    #[test]
    fn agrees_with_brute_force_on_coincident_primitives() {
        let mut rng = Rng::new(15, 0, 0);
        for (_, prims) in coincident_sets(300) {
            for accel in variants(&prims) {
                check_many(&accel, &prims, &mut rng, 150);
            }
        }
    }

    /// Normal geometry keeps obvhs's tree.
    #[test]
    fn random_primitives_are_built_by_ploc() {
        let prims = random_prims(&mut Rng::new(16, 0, 0), 3000, 1.0, true);
        assert!(matches!(build(&prims).builder, Builder::Ploc { .. }));
    }

    /// 100k tiny triangles: a deep tree whose leaves are far smaller than the scene.
    #[test]
    fn agrees_with_brute_force_on_many_tiny_triangles() {
        let mut rng = Rng::new(14, 0, 0);
        let prims = random_prims(&mut rng, 100_000, 0.05, false);
        let accel = build(&prims);
        // Aim at triangles so that rays hit something.
        for _ in 0..300 {
            let p = &prims[rng.next_u32() as usize % prims.len()];
            let target = surface(p, &mut rng);
            let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 30.0 - 15.0;
            check(&accel, &prims, &Ray::new(o, (target - o).normalize()));
        }
        check_many(&accel, &prims, &mut rng, 100);
    }
}
