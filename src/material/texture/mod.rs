//! Textures: values that vary over a surface with its (u, v) coordinates, as Mitsuba
//! 3 defines them (`bitmap`, `checkerboard`) plus Mitsuba 0.x's `scale`. A material
//! parameter that may vary is a [`Texture`]; a constant is the common case and costs
//! one `match` arm.
//!
//! Scalar parameters (roughness, blend weights, opacity) read a texture's luminance,
//! as Mitsuba's `eval_1` does for RGB data.

mod bitmap;
mod decode;
mod texels;

pub use bitmap::{Bitmap, Filter, Wrap};
pub use decode::{decode, decode_within, TextureError};
pub use texels::Texels;

use crate::math::{luminance, Rgb, Vec2};

/// An affine map of (u, v): Mitsuba's `to_uv` (a 3x3 matrix on (u, v, 1)); `rows` are
/// the first two rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    pub rows: [[f32; 3]; 2],
}

impl UvTransform {
    pub const IDENTITY: UvTransform = UvTransform {
        rows: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
    };

    pub fn scale(s: Vec2) -> UvTransform {
        UvTransform {
            rows: [[s.x, 0.0, 0.0], [0.0, s.y, 0.0]],
        }
    }

    #[inline]
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let [a, b] = self.rows;
        Vec2::new(
            a[0] * uv.x + a[1] * uv.y + a[2],
            b[0] * uv.x + b[1] * uv.y + b[2],
        )
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Constant(Rgb),
    Bitmap(Bitmap),
    /// `color0` where the fractional parts of u and v are on the same side of 1/2,
    /// else `color1` (Mitsuba's `checkerboard`).
    Checkerboard {
        color0: Box<Texture>,
        color1: Box<Texture>,
        to_uv: UvTransform,
    },
    /// `inner` times `scale` (Mitsuba 0.x's `scale`).
    Scale {
        inner: Box<Texture>,
        scale: Rgb,
    },
}

impl Texture {
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Rgb {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(b) => b.eval(uv),
            Texture::Checkerboard {
                color0,
                color1,
                to_uv,
            } => {
                let p = to_uv.apply(uv);
                let high = |x: f32| x - x.floor() > 0.5;
                if high(p.x) == high(p.y) {
                    color0.eval(uv)
                } else {
                    color1.eval(uv)
                }
            }
            Texture::Scale { inner, scale } => inner.eval(uv) * *scale,
        }
    }

    /// A scalar parameter: the value's luminance (a grey value itself).
    #[inline]
    pub fn eval_scalar(&self, uv: Vec2) -> f32 {
        luminance(self.eval(uv))
    }

    /// The gradient in (u, v) of the scalar value (the luminance), for bump maps: a
    /// bilinear bitmap's analytic one (Mitsuba's `eval_1_grad`), zero for constants
    /// and within checks (Mitsuba has none for a checkerboard).
    pub fn grad(&self, uv: Vec2) -> Vec2 {
        let [du, dv] = self.grad_rgb(uv);
        Vec2::new(luminance(du), luminance(dv))
    }

    fn grad_rgb(&self, uv: Vec2) -> [Rgb; 2] {
        match self {
            Texture::Constant(_) | Texture::Checkerboard { .. } => [Rgb::ZERO; 2],
            Texture::Bitmap(b) => b.grad(uv),
            Texture::Scale { inner, scale } => inner.grad_rgb(uv).map(|g| g * *scale),
        }
    }

    /// The value when it does not vary over the surface.
    pub fn constant(&self) -> Option<Rgb> {
        match self {
            Texture::Constant(c) => Some(*c),
            Texture::Scale { inner, scale } => inner.constant().map(|c| c * *scale),
            Texture::Bitmap(_) | Texture::Checkerboard { .. } => None,
        }
    }

    /// Whether every value is finite and not negative, as an emitter's radiance
    /// must be (constants and scales are checked with the scene file; images here).
    pub fn is_valid_radiance(&self) -> bool {
        match self {
            Texture::Constant(_) => true,
            Texture::Bitmap(b) => b.texels.is_valid_radiance(),
            Texture::Checkerboard { color0, color1, .. } => {
                color0.is_valid_radiance() && color1.is_valid_radiance()
            }
            Texture::Scale { inner, .. } => inner.is_valid_radiance(),
        }
    }

    /// Largest value any channel takes anywhere (for energy checks and bounds).
    pub fn max_value(&self) -> f32 {
        match self {
            Texture::Constant(c) => c.max_element(),
            Texture::Bitmap(b) => b.texels.max_value(),
            Texture::Checkerboard { color0, color1, .. } => {
                color0.max_value().max(color1.max_value())
            }
            Texture::Scale { inner, scale } => inner.max_value() * scale.max_element().max(0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mitsuba 3.9's default checkerboard (0.4 and 0.2) at three points.
    #[test]
    fn checkerboard_matches_mitsuba() {
        let c = Texture::Checkerboard {
            color0: Box::new(Texture::Constant(Rgb::splat(0.4))),
            color1: Box::new(Texture::Constant(Rgb::splat(0.2))),
            to_uv: UvTransform::IDENTITY,
        };
        assert_eq!(c.eval(Vec2::new(0.25, 0.25)), Rgb::splat(0.4));
        assert_eq!(c.eval(Vec2::new(0.75, 0.25)), Rgb::splat(0.2));
        assert_eq!(c.eval(Vec2::new(0.25, 0.75)), Rgb::splat(0.2));
        assert_eq!(c.eval(Vec2::new(0.75, 0.75)), Rgb::splat(0.4));
        assert_eq!(c.eval(Vec2::new(-0.25, 0.25)), Rgb::splat(0.2));
        assert_eq!(c.constant(), None);
        assert_eq!(c.max_value(), 0.4);
    }

    #[test]
    fn scale_and_scalar_reads() {
        let s = Texture::Scale {
            inner: Box::new(Texture::Constant(Rgb::new(0.5, 1.0, 2.0))),
            scale: Rgb::splat(2.0),
        };
        assert_eq!(s.eval(Vec2::ZERO), Rgb::new(1.0, 2.0, 4.0));
        assert_eq!(s.constant(), Some(Rgb::new(1.0, 2.0, 4.0)));
        let grey = Texture::Constant(Rgb::splat(0.3));
        assert!((grey.eval_scalar(Vec2::ZERO) - 0.3).abs() < 1e-6);
    }

    #[test]
    fn to_uv_is_affine() {
        let t = UvTransform {
            rows: [[2.0, 0.0, 0.5], [0.0, 3.0, -1.0]],
        };
        assert_eq!(t.apply(Vec2::new(1.0, 1.0)), Vec2::new(2.5, 2.0));
        assert_eq!(
            UvTransform::IDENTITY.apply(Vec2::new(0.3, 0.7)),
            Vec2::new(0.3, 0.7)
        );
    }
}
