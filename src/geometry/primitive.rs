//! Primitives as one closed enum, intersected inside the BVH loop by `match`.

use super::Ray;
use crate::math::{gamma, safe_sqrt, Vec2, Vec3, Vec3A};
use obvhs::aabb::Aabb;

#[derive(Clone, Copy, Debug)]
pub enum Prim {
    /// Vertex p0 and edges e1 = p1 - p0, e2 = p2 - p0.
    Tri {
        p0: Vec3A,
        e1: Vec3A,
        e2: Vec3A,
    },
    /// Parallelogram p0 + u e1 + v e2 with u, v in [0, 1]: two triangles of a mesh
    /// merged (see `scene::shapes`), tested for the cost of one.
    Quad {
        p0: Vec3A,
        e1: Vec3A,
        e2: Vec3A,
    },
    Sphere {
        c: Vec3A,
        r: f32,
    },
    /// Points c + x u + y v with x^2 + y^2 <= 1 (any affine image of the unit disk).
    Disk {
        c: Vec3A,
        u: Vec3A,
        v: Vec3A,
    },
}

/// Which shape (and which triangle of it) a primitive came from.
#[derive(Clone, Copy, Debug, Default)]
pub struct PrimMeta {
    pub shape: u32,
    pub local: u32,
}

/// Result of a primitive test: distance and two surface parameters (barycentrics for
/// triangles, edge coordinates for parallelograms, disk coordinates for disks, unused
/// for spheres).
#[derive(Clone, Copy, Debug)]
pub struct PrimHit {
    pub t: f32,
    pub uv: Vec2,
}

impl Prim {
    pub fn aabb(&self) -> Aabb {
        match *self {
            Prim::Tri { p0, e1, e2 } => {
                let mut b = Aabb::from_point(p0);
                b.extend(p0 + e1);
                b.extend(p0 + e2);
                b
            }
            Prim::Quad { p0, e1, e2 } => {
                let mut b = Aabb::from_point(p0);
                b.extend(p0 + e1);
                b.extend(p0 + e2);
                b.extend(p0 + e1 + e2);
                b
            }
            Prim::Sphere { c, r } => Aabb::new(c - Vec3A::splat(r), c + Vec3A::splat(r)),
            Prim::Disk { c, u, v } => {
                // Half-extent per axis of an ellipse: sqrt(u_i^2 + v_i^2).
                let e = (u * u + v * v).sqrt();
                Aabb::new(c - e, c + e)
            }
        }
    }

    /// Closest intersection with t in (0, ray.tmax).
    #[inline(always)]
    pub fn intersect(&self, o: Vec3A, d: Vec3A, tmax: f32) -> Option<PrimHit> {
        match *self {
            Prim::Tri { p0, e1, e2 } => moeller_trumbore::<false>(p0, e1, e2, o, d, tmax),
            Prim::Quad { p0, e1, e2 } => moeller_trumbore::<true>(p0, e1, e2, o, d, tmax),
            Prim::Sphere { c, r } => intersect_sphere(c, r, o, d, tmax),
            Prim::Disk { c, u, v } => intersect_disk(c, u, v, o, d, tmax),
        }
    }

    /// The unit normal of a flat primitive (counter-clockwise triangles, u x v for
    /// disks); zero for spheres, whose normal depends on the hit point.
    pub fn flat_normal(&self) -> Vec3A {
        match *self {
            Prim::Tri { e1, e2, .. } | Prim::Quad { e1, e2, .. } => e1.cross(e2).normalize(),
            Prim::Sphere { .. } => Vec3A::ZERO,
            Prim::Disk { u, v, .. } => u.cross(v).normalize(),
        }
    }

    pub fn area(&self) -> f32 {
        match *self {
            Prim::Tri { e1, e2, .. } => 0.5 * e1.cross(e2).length(),
            Prim::Quad { e1, e2, .. } => e1.cross(e2).length(),
            Prim::Sphere { r, .. } => 4.0 * crate::math::PI * r * r,
            Prim::Disk { u, v, .. } => crate::math::PI * u.cross(v).length(),
        }
    }
}

/// Moeller-Trumbore with precomputed edges; u, v are the barycentrics of p1 and p2,
/// or for a parallelogram (`QUAD`) the coordinates along e1 and e2, where the only
/// change is the acceptance test: v <= 1 instead of u + v <= 1.
#[inline(always)]
fn moeller_trumbore<const QUAD: bool>(
    p0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
    o: Vec3A,
    d: Vec3A,
    tmax: f32,
) -> Option<PrimHit> {
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let tv = o - p0;
    let u = tv.dot(pv) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qv = tv.cross(e1);
    let v = d.dot(qv) * inv;
    if v < 0.0 || (if QUAD { v } else { u + v }) > 1.0 {
        return None;
    }
    let t = e2.dot(qv) * inv;
    if t > 0.0 && t < tmax {
        Some(PrimHit {
            t,
            uv: Vec2::new(u, v),
        })
    } else {
        None
    }
}

/// Ray-sphere with the numerically careful discriminant of Haines et al., "Precision
/// Improvements for Ray/Sphere Intersection" (Ray Tracing Gems, 2019).
#[inline(always)]
fn intersect_sphere(c: Vec3A, r: f32, o: Vec3A, d: Vec3A, tmax: f32) -> Option<PrimHit> {
    let f = o - c;
    let a = d.length_squared();
    let b = -f.dot(d);
    // |f - (f.d / a) d|^2 is the squared distance from the centre to the line.
    let l = f + (b / a) * d;
    let disc = a * (r * r - l.length_squared());
    if disc < 0.0 {
        return None;
    }
    let s = safe_sqrt(disc);
    let q = if b >= 0.0 { b + s } else { b - s };
    let (mut t0, mut t1) = (q / a, (f.length_squared() - r * r) / q);
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    let t = if t0 > 0.0 { t0 } else { t1 };
    if t > 0.0 && t < tmax && t.is_finite() {
        Some(PrimHit { t, uv: Vec2::ZERO })
    } else {
        None
    }
}

#[inline(always)]
fn intersect_disk(c: Vec3A, u: Vec3A, v: Vec3A, o: Vec3A, d: Vec3A, tmax: f32) -> Option<PrimHit> {
    let n = u.cross(v);
    let denom = n.dot(d);
    if denom == 0.0 {
        return None;
    }
    let t = n.dot(c - o) / denom;
    if !(t > 0.0 && t < tmax) {
        return None;
    }
    let q = o + d * t - c;
    // Coordinates in the (u, v) basis via the dual basis: x = (q x v).n / |n|^2.
    let nn = n.length_squared();
    let x = q.cross(v).dot(n) / nn;
    let y = u.cross(q).dot(n) / nn;
    if x * x + y * y > 1.0 {
        return None;
    }
    Some(PrimHit {
        t,
        uv: Vec2::new(x, y),
    })
}

/// Hit point, its error bound and the geometric normal (unflipped: counter-clockwise
/// triangles, outward spheres, u x v for disks). `flat` is the primitive's
/// [`Prim::flat_normal`], computed once per primitive rather than once per hit.
#[inline]
pub fn surface_point(prim: &Prim, flat: Vec3A, ray: &Ray, hit: &PrimHit) -> (Vec3, Vec3, Vec3) {
    match *prim {
        Prim::Tri { p0, e1, e2 } => {
            let (b1, b2) = (hit.uv.x, hit.uv.y);
            let b0 = 1.0 - b1 - b2;
            let (p1, p2) = (p0 + e1, p0 + e2);
            let p = p0 * b0 + p1 * b1 + p2 * b2;
            let err = gamma(8) * ((p0 * b0).abs() + (p1 * b1).abs() + (p2 * b2).abs());
            (p.into(), err.into(), flat.into())
        }
        Prim::Quad { p0, e1, e2 } => {
            let (a, b) = (e1 * hit.uv.x, e2 * hit.uv.y);
            let p = p0 + a + b;
            let err = gamma(8) * (p0.abs() + a.abs() + b.abs());
            (p.into(), err.into(), flat.into())
        }
        Prim::Sphere { c, r } => {
            let p = Vec3A::from(ray.at(hit.t));
            let dir = (p - c).normalize();
            let p = c + dir * r;
            let err = gamma(6) * ((p - c).abs() + c.abs());
            (p.into(), err.into(), dir.into())
        }
        Prim::Disk { c, u, v } => {
            let p = c + u * hit.uv.x + v * hit.uv.y;
            let err = gamma(6) * (c.abs() + (u * hit.uv.x).abs() + (v * hit.uv.y).abs());
            (p.into(), err.into(), flat.into())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn a(x: f32, y: f32, z: f32) -> Vec3A {
        Vec3A::new(x, y, z)
    }

    #[test]
    fn triangle_hit_and_barycentrics() {
        let t = Prim::Tri {
            p0: a(0.0, 0.0, 0.0),
            e1: a(1.0, 0.0, 0.0),
            e2: a(0.0, 1.0, 0.0),
        };
        let h = t
            .intersect(a(0.25, 0.5, 1.0), a(0.0, 0.0, -1.0), f32::INFINITY)
            .unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!((h.uv - Vec2::new(0.25, 0.5)).length() < 1e-6);
        assert!(t
            .intersect(a(0.8, 0.8, 1.0), a(0.0, 0.0, -1.0), f32::INFINITY)
            .is_none());
        assert!(t
            .intersect(a(0.2, 0.2, 1.0), a(0.0, 0.0, -1.0), 0.5)
            .is_none());
    }

    #[test]
    fn parallelogram_covers_both_triangles_and_nothing_else() {
        let (p0, e1, e2) = (a(1.0, 0.0, 0.0), a(1.0, 0.5, 0.0), a(0.25, 1.0, 0.0));
        let q = Prim::Quad { p0, e1, e2 };
        let halves = [
            Prim::Tri { p0, e1, e2 },
            Prim::Tri {
                p0: p0 + e1 + e2,
                e1: -e1,
                e2: -e2,
            },
        ];
        let dir = a(0.0, 0.0, -1.0);
        let mut hits = 0;
        for i in 0..40 {
            for j in 0..40 {
                let o = a(0.5 + i as f32 * 0.06, -0.5 + j as f32 * 0.06, 2.0);
                let got = q.intersect(o, dir, f32::INFINITY);
                let tri = halves.iter().any(|t| t.intersect(o, dir, 1e30).is_some());
                assert_eq!(got.is_some(), tri, "origin {o}");
                if let Some(h) = got {
                    hits += 1;
                    assert!((h.t - 2.0).abs() < 1e-6);
                    let on = p0 + e1 * h.uv.x + e2 * h.uv.y;
                    assert!((on - a(o.x, o.y, 0.0)).length() < 1e-5);
                }
            }
        }
        assert!(hits > 100, "{hits} hits");
        assert!((q.area() - halves[0].area() * 2.0).abs() < 1e-6);
    }

    #[test]
    fn sphere_from_outside_inside_and_far_away() {
        let s = Prim::Sphere {
            c: a(0.0, 0.0, 0.0),
            r: 1.0,
        };
        let h = s.intersect(a(0.0, 0.0, 5.0), a(0.0, 0.0, -1.0), f32::INFINITY);
        assert!((h.unwrap().t - 4.0).abs() < 1e-5);
        let h = s.intersect(a(0.0, 0.0, 0.0), a(0.0, 1.0, 0.0), f32::INFINITY);
        assert!((h.unwrap().t - 1.0).abs() < 1e-6);
        // A tiny sphere far from the origin: the careful discriminant still hits.
        let s = Prim::Sphere {
            c: a(0.0, 0.0, 0.0),
            r: 1e-3,
        };
        let h = s.intersect(a(0.0, 0.0, 1e4), a(0.0, 0.0, -1.0), f32::INFINITY);
        assert!((h.unwrap().t - (1e4 - 1e-3)).abs() < 1e-2);
    }

    #[test]
    fn disk_hit_inside_only() {
        let d = Prim::Disk {
            c: a(0.0, 0.0, 0.0),
            u: a(2.0, 0.0, 0.0),
            v: a(0.0, 1.0, 0.0),
        };
        let dir = a(0.0, 0.0, -1.0);
        assert!(d.intersect(a(1.9, 0.0, 1.0), dir, f32::INFINITY).is_some());
        assert!(d.intersect(a(0.0, 1.1, 1.0), dir, f32::INFINITY).is_none());
        assert!((d.area() - 2.0 * crate::math::PI).abs() < 1e-5);
    }
}
