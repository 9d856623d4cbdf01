//! Texture coordinates of surface points, as Mitsuba 3 gives them: interpolated
//! vertex (u, v) on meshes (OBJ `vt`, PLY `u v`, inline `uvs`; rectangles and cubes
//! with Mitsuba's own), and the analytic parametrisations of spheres and disks.
//!
//! Only shapes whose material reads a texture carry them, so a scene without textures
//! compiles to exactly the primitives it did before. Here, below `light` and `scene`,
//! because textured area lights read them too; imports only `math` and the hit record.

use super::Interaction;
use crate::math::{Mat3, Vec2, Vec3, INV_2PI, INV_PI};

/// How a shape's hits map to (u, v).
#[derive(Clone, Debug)]
pub enum TexCoords {
    /// Per primitive (indexed by the hit's `local`): the affine map `[o, a, b]` with
    /// uv = o + s a + t b, (s, t) being a triangle's barycentrics (b1, b2) or a
    /// parallelogram's edge coordinates.
    Mesh(Vec<[Vec2; 3]>),
    /// u = phi / 2 pi, counter-clockwise from the object's +x about +z; v = theta /
    /// pi from +z. `to_object` turns world directions into the object's frame.
    Sphere { center: Vec3, to_object: Mat3 },
    /// (r, phi / 2 pi) in the disk's own coordinates; `swapped` when a mirroring
    /// transform exchanged the disk's axes to keep its front side.
    Disk { swapped: bool },
}

impl TexCoords {
    #[inline(always)]
    pub fn uv(&self, it: &Interaction) -> Vec2 {
        self.uv_on(it.local, it.uv, it.p)
    }

    /// The (u, v) of point `p` on primitive `local` of the shape, at primitive
    /// coordinates `st` (a hit's `Interaction::uv`: barycentrics, edge or disk
    /// coordinates; unused on spheres): for points that are not hits, such as the
    /// points light sampling picks on an emitter. Inlined: called, it took `p` by
    /// reference, which pointed into the caller's hit and kept that in memory.
    #[inline(always)]
    pub fn uv_on(&self, local: u32, st: Vec2, p: Vec3) -> Vec2 {
        match self {
            TexCoords::Mesh(maps) => {
                let [o, a, b] = maps[local as usize];
                o + a * st.x + b * st.y
            }
            TexCoords::Sphere { center, to_object } => sphere_uv(*to_object * (p - *center)),
            TexCoords::Disk { swapped } => {
                let (x, y) = if *swapped { (st.y, st.x) } else { (st.x, st.y) };
                Vec2::new((x * x + y * y).sqrt(), angle_fraction(y, x))
            }
        }
    }
}

/// Mitsuba's sphere coordinates of a direction from the centre, object frame.
fn sphere_uv(d: Vec3) -> Vec2 {
    let len = d.length();
    let cos_theta = if len > 0.0 {
        (d.z / len).clamp(-1.0, 1.0)
    } else {
        1.0
    };
    Vec2::new(angle_fraction(d.y, d.x), cos_theta.acos() * INV_PI)
}

/// atan2(y, x) as a fraction of a turn in [0, 1).
fn angle_fraction(y: f32, x: f32) -> f32 {
    let phi = y.atan2(x);
    let phi = if phi < 0.0 {
        phi + 2.0 * std::f32::consts::PI
    } else {
        phi
    };
    (phi * INV_2PI).min(1.0 - f32::EPSILON / 2.0)
}

/// The affine map of one primitive from the (u, v) of its corners, in the order the
/// primitive is parametrised (p0, then the ends of e1 and e2).
pub fn corner_map([o, a, b]: [Vec2; 3]) -> [Vec2; 3] {
    [o, a - o, b - o]
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A hit at `p` with primitive coordinates `uv` on a +z-facing surface.
    pub(crate) fn at(p: Vec3, uv: Vec2) -> Interaction {
        Interaction {
            p,
            p_err: Vec3::ZERO,
            ng: Vec3::Z,
            ns: Vec3::Z,
            uv,
            shape: 0,
            local: 0,
        }
    }

    fn close(a: Vec2, b: Vec2) -> bool {
        (a - b).abs().max_element() < 1e-6
    }

    /// Values read from Mitsuba 3.9 (`ray_intersect` on its `sphere` and `disk`).
    #[test]
    fn spheres_and_disks_match_mitsuba() {
        let s = TexCoords::Sphere {
            center: Vec3::ZERO,
            to_object: Mat3::IDENTITY,
        };
        for (p, uv) in [
            (Vec3::X, Vec2::new(0.0, 0.5)),
            (Vec3::Y, Vec2::new(0.25, 0.5)),
            (-Vec3::X, Vec2::new(0.5, 0.5)),
            (-Vec3::Y, Vec2::new(0.75, 0.5)),
            (Vec3::Z, Vec2::new(0.0, 0.0)),
            (Vec3::new(0.0, 0.0, -1.0), Vec2::new(0.0, 1.0)),
        ] {
            assert!(close(s.uv(&at(p, Vec2::ZERO)), uv), "{p}");
        }
        // Turned 90 degrees about z: world -x is the object's +y.
        let turned = TexCoords::Sphere {
            center: Vec3::new(5.0, 0.0, 0.0),
            to_object: Mat3::from_rotation_z(90f32.to_radians()).transpose(),
        };
        let uv = turned.uv(&at(Vec3::new(4.0, 0.0, 0.0), Vec2::ZERO));
        assert!(close(uv, Vec2::new(0.25, 0.5)), "{uv}");
        let d = TexCoords::Disk { swapped: false };
        for (xy, uv) in [
            (Vec2::new(0.5, 0.0), Vec2::new(0.5, 0.0)),
            (Vec2::new(0.0, 0.5), Vec2::new(0.5, 0.25)),
            (Vec2::new(-0.5, 0.0), Vec2::new(0.5, 0.5)),
            (Vec2::new(0.0, -0.5), Vec2::new(0.5, 0.75)),
            (Vec2::new(0.25, 0.0), Vec2::new(0.25, 0.0)),
        ] {
            assert!(close(d.uv(&at(Vec3::ZERO, xy)), uv), "{xy}");
        }
        let swapped = TexCoords::Disk { swapped: true };
        let uv = swapped.uv(&at(Vec3::ZERO, Vec2::new(0.0, 0.5)));
        assert!(close(uv, Vec2::new(0.5, 0.0)), "{uv}");
    }

    #[test]
    fn mesh_maps_interpolate_corners() {
        let corners = [
            Vec2::new(0.1, 0.8),
            Vec2::new(0.9, 0.8),
            Vec2::new(0.9, 0.3),
        ];
        let m = TexCoords::Mesh(vec![corner_map(corners)]);
        for (bary, uv) in [
            (Vec2::ZERO, corners[0]),
            (Vec2::X, corners[1]),
            (Vec2::Y, corners[2]),
            (Vec2::new(0.25, 0.25), Vec2::new(0.5, 0.675)),
        ] {
            assert!(close(m.uv(&at(Vec3::ZERO, bary)), uv), "{bary}");
        }
    }
}
