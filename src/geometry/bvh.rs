//! One obvhs compressed wide BVH (CWBVH) over every primitive of the scene, with
//! closest-hit and any-hit (shadow) queries.

use super::primitive::{surface_point, Prim, PrimHit, PrimMeta};
use super::{Interaction, Ray};
use crate::math::{Vec2, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::{builder::build_cwbvh, CwBvh};
use obvhs::BvhBuildParams;
use std::time::{Duration, Instant};

/// A closest hit: distance, primitive (in BVH order) and its surface parameters.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub uv: Vec2,
}

/// The slower presets build trees that trace measurably faster (callgrind: 7% fewer
/// instructions on the Cornell box); their build cost only shows on large meshes.
fn build_params(prims: usize) -> BvhBuildParams {
    if prims < 200_000 {
        BvhBuildParams::very_slow_build()
    } else {
        BvhBuildParams::medium_build()
    }
}

pub struct Accel {
    bvh: Option<CwBvh>,
    /// Primitives reordered to the BVH's leaf order, so leaves index them directly.
    prims: Vec<Prim>,
    meta: Vec<PrimMeta>,
    pub build_time: Duration,
    pub bounds: Aabb,
}

impl Accel {
    pub fn build(prims: Vec<Prim>, meta: Vec<PrimMeta>) -> Self {
        let start = Instant::now();
        if prims.is_empty() {
            return Accel {
                bvh: None,
                prims,
                meta,
                build_time: start.elapsed(),
                bounds: Aabb::empty(),
            };
        }
        let aabbs: Vec<Aabb> = prims.iter().map(Prim::aabb).collect();
        let bvh = build_cwbvh(&aabbs, build_params(prims.len()), &mut Duration::default());
        let order = &bvh.primitive_indices;
        let prims: Vec<Prim> = order.iter().map(|&i| prims[i as usize]).collect();
        let meta: Vec<PrimMeta> = order.iter().map(|&i| meta[i as usize]).collect();
        Accel {
            bounds: bvh.total_aabb,
            bvh: Some(bvh),
            prims,
            meta,
            build_time: start.elapsed(),
        }
    }

    /// Bytes held by nodes and primitives.
    pub fn memory_bytes(&self) -> usize {
        let nodes = self.bvh.as_ref().map_or(0, |b| {
            b.nodes.len() * std::mem::size_of_val(&b.nodes[0]) + b.primitive_indices.len() * 4
        });
        nodes
            + self.prims.len() * std::mem::size_of::<Prim>()
            + self.meta.len() * std::mem::size_of::<PrimMeta>()
    }

    pub fn prim_count(&self) -> usize {
        self.prims.len()
    }

    #[inline]
    fn obvhs_ray(ray: &Ray) -> obvhs::ray::Ray {
        obvhs::ray::Ray::new(ray.o.into(), ray.d.into(), 0.0, ray.tmax)
    }

    /// Closest intersection along the ray, if any.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let mut best = Hit {
            t: ray.tmax,
            prim: u32::MAX,
            uv: Vec2::ZERO,
        };
        let mut rh = obvhs::ray::RayHit::none();
        let (o, d) = (Vec3A::from(ray.o), Vec3A::from(ray.d));
        bvh.ray_traverse(Self::obvhs_ray(ray), &mut rh, |r, id| {
            match self.prims[id].intersect(o, d, r.tmax) {
                Some(PrimHit { t, uv }) => {
                    best = Hit {
                        t,
                        prim: id as u32,
                        uv,
                    };
                    t
                }
                None => f32::INFINITY,
            }
        });
        (best.prim != u32::MAX).then_some(best)
    }

    /// True when anything blocks the ray before `ray.tmax`.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        let (o, d) = (Vec3A::from(ray.o), Vec3A::from(ray.d));
        !bvh.ray_traverse_miss(Self::obvhs_ray(ray), |r, id| {
            self.prims[id]
                .intersect(o, d, r.tmax)
                .map_or(f32::INFINITY, |h| h.t)
        })
    }

    pub fn meta(&self, prim: u32) -> PrimMeta {
        self.meta[prim as usize]
    }

    pub fn prim(&self, prim: u32) -> &Prim {
        &self.prims[prim as usize]
    }

    /// Geometry of a hit, before the scene applies per-shape normal flips and
    /// shading normals.
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> Interaction {
        let prim = &self.prims[hit.prim as usize];
        let ph = PrimHit {
            t: hit.t,
            uv: hit.uv,
        };
        let (p, p_err, ng) = surface_point(prim, ray, &ph);
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
    use crate::math::{Rng, Vec3};

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
    /// The BVH must agree with testing every primitive, on a cloud of random spheres
    /// and triangles large enough to make a deep tree.
    #[test]
    fn agrees_with_brute_force() {
        let mut rng = Rng::new(11, 0, 0);
        let mut prims = Vec::new();
        for i in 0..3000 {
            let c = Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 20.0 - 10.0;
            if i % 3 == 0 {
                prims.push(Prim::Sphere {
                    c,
                    r: 0.05 + 0.3 * rng.next_f32(),
                });
            } else {
                let e = |r: &mut Rng| Vec3A::new(r.next_f32(), r.next_f32(), r.next_f32()) - 0.5;
                prims.push(Prim::Tri {
                    p0: c,
                    e1: e(&mut rng),
                    e2: e(&mut rng),
                });
            }
        }
        let meta = (0..prims.len() as u32)
            .map(|i| PrimMeta { shape: i, local: 0 })
            .collect();
        let accel = Accel::build(prims.clone(), meta);
        for _ in 0..2000 {
            let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 30.0 - 15.0;
            let d = crate::math::warp::square_to_uniform_sphere(rng.next_2d());
            let ray = Ray::new(o, d);
            let brute = prims
                .iter()
                .enumerate()
                .filter_map(|(i, p)| {
                    p.intersect(o.into(), d.into(), f32::INFINITY)
                        .map(|h| (h.t, i))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let got = accel.intersect(&ray);
            match (brute, got) {
                (None, None) => {}
                (Some((t, i)), Some(h)) => {
                    assert!((t - h.t).abs() <= 1e-5 * t.max(1.0));
                    assert_eq!(accel.meta(h.prim).shape as usize, i);
                }
                (b, g) => panic!("brute force {b:?} vs bvh {g:?}"),
            }
            let mut short = ray;
            short.tmax = 5.0;
            assert_eq!(accel.occluded(&short), brute.is_some_and(|(t, _)| t < 5.0));
        }
    }
}
