//! Area-light radiance that varies over the surface: a texture looked up at the
//! (u, v) of the emitting point, whether a ray hit it or light sampling picked it.
//! Sampling stays uniform by area (the texture weights the samples), so every
//! estimator that was unbiased for constant radiance stays so.

use crate::geometry::{Interaction, Prim, TexCoords};
use crate::material::texture::Texture;
use crate::math::warp::{square_to_disk, square_to_triangle};
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Debug)]
pub(super) struct Emitting {
    pub texture: Texture,
    pub uvs: TexCoords,
}

impl Emitting {
    /// Radiance at a hit on the light's shape (the hit by value, so that the callers'
    /// kernels never take its address: see `Scene::material`).
    #[inline(never)]
    pub fn at_hit(&self, it: Interaction) -> Rgb {
        self.texture.eval(self.uvs.uv(&it))
    }

    /// Radiance at the point `p` that `AreaLight::point_on(i, u)` placed on
    /// primitive `prim` (the light's `i`-th, as the shape's hits number it): the
    /// square sample `u` becomes the primitive coordinates a hit there would carry.
    #[inline(never)]
    pub fn at_sample(&self, prim: &Prim, i: usize, u: Vec2, p: Vec3) -> Rgb {
        let st = match prim {
            Prim::Tri { .. } => square_to_triangle(u),
            Prim::Quad { .. } => u,
            Prim::Disk { .. } => square_to_disk(u),
            Prim::Sphere { .. } => Vec2::ZERO,
        };
        self.texture.eval(self.uvs.uv_on(i as u32, st, p))
    }
}

/// Points of a `side` x `side` grid of cell centres in the unit square, for the
/// deterministic estimate of a texture's mean over the light's surface.
pub(super) fn grid(side: u32) -> impl Iterator<Item = Vec2> {
    let cell = 1.0 / side as f32;
    (0..side * side).map(move |k| {
        Vec2::new(
            ((k % side) as f32 + 0.5) * cell,
            ((k / side) as f32 + 0.5) * cell,
        )
    })
}
