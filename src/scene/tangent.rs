//! Surface tangents dp/du and dp/dv, as Mitsuba 3 defines them, for the shapes whose
//! material perturbs its normals (normal and bump maps read their maps in the frame
//! dp/du spans, and bump maps take their slopes in (u, v) units).
//!
//! Meshes: per triangle from positions and (u, v) (Mitsuba's `Mesh`), the barycentric
//! edges where the mesh has no (u, v), an arbitrary basis of the normal where the
//! (u, v) are degenerate. Rectangles and cubes are meshes with Mitsuba's own (u, v),
//! which gives its analytic dp/du (to_world (2, 0, 0) on a rectangle). Spheres and
//! disks: Mitsuba's analytic derivatives of their parametrisations (`uv.rs`).
//!
//! Only shapes whose material needs them carry tangents, so other scenes compile to
//! what they did before and their hits pay one branch.

use crate::geometry::{Interaction, Prim, TexCoords};
use crate::math::{Frame, Mat3, Vec3, PI};

#[derive(Clone, Debug)]
pub enum Tangents {
    /// [dp/du, dp/dv] per primitive (indexed by the hit's `local`).
    Mesh(Vec<[Vec3; 2]>),
    /// `to_object` turns world directions into the sphere's frame (a rotation).
    Sphere {
        center: Vec3,
        radius: f32,
        to_object: Mat3,
    },
    /// The images of the disk's x and y axes, and whether the primitive swapped them
    /// (`TexCoords::Disk`).
    Disk { x: Vec3, y: Vec3, swapped: bool },
}

impl Tangents {
    /// The tangents of a shape built as `prims` with texture coordinates `uvs`.
    pub fn new(prims: &[Prim], uvs: &TexCoords) -> Tangents {
        match (uvs, prims.first()) {
            (TexCoords::Mesh(maps), _) => Tangents::Mesh(
                prims
                    .iter()
                    .zip(maps)
                    .map(|(p, map)| mesh_tangents(p, *map))
                    .collect(),
            ),
            (TexCoords::Sphere { center, to_object }, Some(Prim::Sphere { r, .. })) => {
                Tangents::Sphere {
                    center: *center,
                    radius: *r,
                    to_object: *to_object,
                }
            }
            (TexCoords::Disk { swapped }, Some(Prim::Disk { u, v, .. })) => {
                let (u, v) = (Vec3::from(*u), Vec3::from(*v));
                let (x, y) = if *swapped { (v, u) } else { (u, v) };
                Tangents::Disk {
                    x,
                    y,
                    swapped: *swapped,
                }
            }
            (t, p) => unreachable!("texture coordinates {t:?} on {p:?}"),
        }
    }

    /// (dp/du, dp/dv) at a hit.
    #[inline]
    pub fn at(&self, it: &Interaction) -> (Vec3, Vec3) {
        match self {
            Tangents::Mesh(t) => {
                let [du, dv] = t[it.local as usize];
                (du, dv)
            }
            Tangents::Sphere {
                center,
                radius,
                to_object,
            } => sphere_tangents(*to_object, *radius, (it.p - *center) / *radius),
            Tangents::Disk { x, y, swapped } => {
                let (a, b) = if *swapped {
                    (it.uv.y, it.uv.x)
                } else {
                    (it.uv.x, it.uv.y)
                };
                let r = (a * a + b * b).sqrt();
                // At the centre phi is undefined; any direction serves.
                let (c, s) = if r > 0.0 { (a / r, b / r) } else { (1.0, 0.0) };
                (*x * c + *y * s, (*y * c - *x * s) * (2.0 * PI * r))
            }
        }
    }
}

/// dp/du and dp/dv of a triangle or parallelogram p0 + s e1 + t e2 whose (u, v) are
/// o + s a + t b: [e1 e2] [a b]^-1 (Mitsuba's `Mesh::compute_surface_interaction`).
fn mesh_tangents(p: &Prim, [_, a, b]: [crate::math::Vec2; 3]) -> [Vec3; 2] {
    let (e1, e2) = match p {
        Prim::Tri { e1, e2, .. } | Prim::Quad { e1, e2, .. } => (Vec3::from(*e1), Vec3::from(*e2)),
        other => unreachable!("mesh texture coordinates on {other:?}"),
    };
    let det = a.x * b.y - a.y * b.x;
    if det == 0.0 || !det.is_finite() {
        // Degenerate (u, v): an arbitrary basis of the normal, as Mitsuba does.
        let f = Frame::from_normal(e1.cross(e2).normalize());
        return [f.s, f.t];
    }
    let inv = 1.0 / det;
    [(e1 * b.y - e2 * a.y) * inv, (e2 * a.x - e1 * b.x) * inv]
}

/// Mitsuba's sphere: u = phi / 2 pi, v = theta / pi; `local` is the unit direction
/// from the centre in the world frame.
fn sphere_tangents(to_object: Mat3, radius: f32, world_dir: Vec3) -> (Vec3, Vec3) {
    let l = to_object * world_dir;
    let to_world = to_object.transpose();
    let rd = (l.x * l.x + l.y * l.y).sqrt();
    let dv = if rd > 0.0 {
        Vec3::new(l.z * l.x / rd, l.z * l.y / rd, -rd)
    } else {
        Vec3::X
    };
    (
        to_world * Vec3::new(-l.y, l.x, 0.0) * (2.0 * PI * radius),
        to_world * dv * (PI * radius),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::uv::tests::at;
    use crate::math::{Vec2, Vec3A};

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).abs().max_element() < 1e-5
    }

    /// dp/du and dp/dv are the derivatives of the (u, v) -> p map that `uv.rs`
    /// inverts: stepping (u, v) by the tangents' duals moves p along them.
    #[test]
    fn mesh_tangents_invert_the_uv_map() {
        let prim = Prim::Tri {
            p0: Vec3A::ZERO,
            e1: Vec3A::new(2.0, 0.0, 0.0),
            e2: Vec3A::new(0.0, 3.0, 1.0),
        };
        let corners = [
            Vec2::new(0.1, 0.2),
            Vec2::new(0.5, 0.3),
            Vec2::new(0.2, 0.9),
        ];
        let map = crate::geometry::uv::corner_map(corners);
        let t = Tangents::new(&[prim], &TexCoords::Mesh(vec![map]));
        let (du, dv) = t.at(&at(Vec3::ZERO, Vec2::ZERO));
        // p1 - p0 = du (u1 - u0) + dv (v1 - v0), and likewise for p2.
        let d1 = corners[1] - corners[0];
        let d2 = corners[2] - corners[0];
        assert!(close(du * d1.x + dv * d1.y, Vec3::new(2.0, 0.0, 0.0)));
        assert!(close(du * d2.x + dv * d2.y, Vec3::new(0.0, 3.0, 1.0)));
        // Degenerate (u, v): an orthonormal basis of the normal.
        let flat = [corners[0]; 3];
        let t = Tangents::new(
            &[prim],
            &TexCoords::Mesh(vec![crate::geometry::uv::corner_map(flat)]),
        );
        let (du, dv) = t.at(&at(Vec3::ZERO, Vec2::ZERO));
        let n = Vec3::new(0.0, -1.0, 3.0).normalize();
        assert!(du.dot(n).abs() < 1e-6 && dv.dot(n).abs() < 1e-6);
        assert!((du.cross(dv).dot(n) - 1.0).abs() < 1e-5);
    }

    /// Values read from Mitsuba 3.9 (`dp_du`, `dp_dv` of `ray_intersect` on a sphere
    /// of radius 2 and a disk scaled by 3 along x).
    #[test]
    fn spheres_and_disks_match_mitsuba() {
        let s = Tangents::Sphere {
            center: Vec3::ZERO,
            radius: 2.0,
            to_object: Mat3::IDENTITY,
        };
        let p = Vec3::new(1.0, 1.0, 2.0f32.sqrt());
        let (du, dv) = s.at(&at(p, Vec2::ZERO));
        assert!(close(du, Vec3::new(-1.0, 1.0, 0.0) * 2.0 * PI), "{du}");
        let h = 0.5f32.sqrt();
        assert!(close(dv, Vec3::new(h * h, h * h, -h) * 2.0 * PI), "{dv}");
        let d = Tangents::Disk {
            x: Vec3::X * 3.0,
            y: Vec3::Y,
            swapped: false,
        };
        let (du, dv) = d.at(&at(Vec3::ZERO, Vec2::new(0.0, 0.5)));
        assert!(close(du, Vec3::Y), "{du}");
        assert!(close(dv, Vec3::new(-3.0, 0.0, 0.0) * PI), "{dv}");
    }
}
