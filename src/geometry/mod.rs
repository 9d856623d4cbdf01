//! Geometry: primitives (triangles, analytic spheres and disks), the BVH over all of
//! them, ray offsets, the surface interaction a hit resolves to, and texture
//! coordinates.

pub mod bvh;
mod bvh4;
mod lanes;
pub mod offset;
pub mod primitive;
pub mod uv;

pub use bvh::Accel;
pub use offset::{offset_ray_origin, spawn_ray, spawn_ray_to};
pub use primitive::{Prim, PrimMeta};
pub use uv::TexCoords;

use crate::math::{Vec2, Vec3};

/// A ray; `d` need not be unit length for shadow rays (then `tmax` is parametric).
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub tmax: f32,
}

impl Ray {
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray {
            o,
            d,
            tmax: f32::INFINITY,
        }
    }

    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// A closest hit, as the BVH reports it: distance, primitive (index into
/// [`Accel::prim`]) and its surface parameters.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub uv: Vec2,
}

/// Where a ray met a surface, resolved from a [`Hit`].
#[derive(Clone, Copy, Debug)]
pub struct Interaction {
    pub p: Vec3,
    /// Conservative absolute error bound of `p`, per axis, for ray offsets.
    pub p_err: Vec3,
    /// Geometric normal, unit length, on the shape's front side.
    pub ng: Vec3,
    /// Shading normal (interpolated vertex normals), on the same side as `ng`.
    pub ns: Vec3,
    pub uv: Vec2,
    /// Index of the shape in the compiled scene.
    pub shape: u32,
    /// Triangle index within the shape's mesh (0 for analytic shapes).
    pub local: u32,
}
