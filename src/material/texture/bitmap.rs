//! Mitsuba 3's `bitmap` texture: an image looked up at the surface's (u, v), after
//! the `to_uv` transform, with `nearest` or `bilinear` filtering and `repeat`,
//! `mirror` or `clamp` wrapping. (u, v) = (0, 0) is the image's top-left corner and v
//! grows downwards (row 0 is the top row), as in Mitsuba; OBJ files flip their v on
//! load to match.

use super::texels::Texels;
use super::UvTransform;
use crate::math::{Rgb, Vec2};
use std::sync::Arc;

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Filter {
    Nearest,
    Bilinear,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Wrap {
    Repeat,
    Mirror,
    Clamp,
}

#[derive(Clone, Debug)]
pub struct Bitmap {
    pub texels: Arc<Texels>,
    pub filter: Filter,
    pub wrap: Wrap,
    pub to_uv: UvTransform,
}

impl PartialEq for Bitmap {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.texels, &other.texels)
            && (self.filter, self.wrap, self.to_uv) == (other.filter, other.wrap, other.to_uv)
    }
}

impl Bitmap {
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Rgb {
        let uv = self.to_uv.apply(uv);
        // A NaN would survive the filter's weights; no texel is also an answer.
        let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
        let t = &*self.texels;
        let size = Vec2::new(t.width() as f32, t.height() as f32);
        match self.filter {
            Filter::Nearest => {
                let p = (uv * size).floor();
                self.texel(p.x as i64, p.y as i64)
            }
            Filter::Bilinear => {
                // Texel centres sit at half-integers.
                let p = uv * size - Vec2::splat(0.5);
                let p0 = p.floor();
                let f = p - p0;
                let (x, y) = (p0.x as i64, p0.y as i64);
                let top = self.texel(x, y) * (1.0 - f.x) + self.texel(x + 1, y) * f.x;
                let bottom = self.texel(x, y + 1) * (1.0 - f.x) + self.texel(x + 1, y + 1) * f.x;
                top * (1.0 - f.y) + bottom * f.y
            }
        }
    }

    /// d/du and d/dv of the value, per channel: the derivative of the bilinear
    /// interpolant within the texel square holding `uv` (zero under nearest
    /// filtering), through `to_uv` as Mitsuba's `eval_1_grad` takes it (the transposed
    /// matrix times the texel-space gradient, then times the resolution).
    pub fn grad(&self, uv: Vec2) -> [Rgb; 2] {
        let p = self.to_uv.apply(uv);
        if self.filter == Filter::Nearest || !p.is_finite() {
            return [Rgb::ZERO; 2];
        }
        let t = &*self.texels;
        let size = Vec2::new(t.width() as f32, t.height() as f32);
        let q = p * size - Vec2::splat(0.5);
        let q0 = q.floor();
        let f = q - q0;
        let (x, y) = (q0.x as i64, q0.y as i64);
        let (f00, f10) = (self.texel(x, y), self.texel(x + 1, y));
        let (f01, f11) = (self.texel(x, y + 1), self.texel(x + 1, y + 1));
        let dx = (f10 - f00) * (1.0 - f.y) + (f11 - f01) * f.y;
        let dy = (f01 - f00) * (1.0 - f.x) + (f11 - f10) * f.x;
        let [a, b] = self.to_uv.rows;
        [
            (dx * a[0] + dy * b[0]) * size.x,
            (dx * a[1] + dy * b[1]) * size.y,
        ]
    }

    /// The texel at integer coordinates, wrapped into the image.
    #[inline]
    fn texel(&self, x: i64, y: i64) -> Rgb {
        let t = &*self.texels;
        let x = wrap(x, t.width(), self.wrap);
        let y = wrap(y, t.height(), self.wrap);
        t.get(x, y)
    }
}

/// `i` (any integer; huge or saturated values from NaN or infinite coordinates
/// included) folded into 0..n by the wrap mode.
#[inline]
fn wrap(i: i64, n: u32, mode: Wrap) -> u32 {
    let n = i64::from(n);
    let k = match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Mirror => {
            let k = i.rem_euclid(2 * n);
            if k >= n {
                2 * n - 1 - k
            } else {
                k
            }
        }
    };
    k as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Red, green on the top row; blue, white below (as Mitsuba's own check).
    fn quad(filter: Filter, wrap: Wrap) -> Bitmap {
        let data = vec![
            1.0, 0.0, 0.0, 0.0, 1.0, 0.0, //
            0.0, 0.0, 1.0, 1.0, 1.0, 1.0,
        ];
        Bitmap {
            texels: Arc::new(Texels::from_floats(2, 2, 3, data)),
            filter,
            wrap,
            to_uv: UvTransform::IDENTITY,
        }
    }

    const RED: Rgb = Rgb::new(1.0, 0.0, 0.0);
    const GREEN: Rgb = Rgb::new(0.0, 1.0, 0.0);
    const BLUE: Rgb = Rgb::new(0.0, 0.0, 1.0);

    /// Values read from Mitsuba 3.9's `bitmap` plugin (scalar_rgb) on this image.
    #[test]
    fn lookups_match_mitsuba() {
        let n = quad(Filter::Nearest, Wrap::Repeat);
        let at = |b: &Bitmap, u: f32, v: f32| b.eval(Vec2::new(u, v));
        assert_eq!(at(&n, 0.25, 0.25), RED);
        assert_eq!(at(&n, 0.75, 0.25), GREEN);
        assert_eq!(at(&n, 0.25, 0.75), BLUE);
        assert_eq!(at(&n, 0.5, 0.5), Rgb::ONE);
        assert_eq!(at(&n, 1.1, 0.25), RED);
        let b = quad(Filter::Bilinear, Wrap::Repeat);
        assert_eq!(at(&b, 0.25, 0.25), RED);
        assert_eq!(at(&b, 0.5, 0.5), Rgb::splat(0.5));
        assert_eq!(at(&b, 0.0, 0.0), Rgb::splat(0.5));
        let v = at(&b, 1.1, 0.25);
        assert!(
            (v - Rgb::new(0.7, 0.3, 0.0)).abs().max_element() < 1e-6,
            "{v}"
        );
        assert_eq!(at(&quad(Filter::Nearest, Wrap::Mirror), 1.25, 0.25), GREEN);
        assert_eq!(at(&quad(Filter::Nearest, Wrap::Clamp), 1.25, 0.25), GREEN);
        let mut scaled = quad(Filter::Nearest, Wrap::Repeat);
        scaled.to_uv = UvTransform::scale(Vec2::new(2.0, 1.0));
        assert_eq!(at(&scaled, 0.3, 0.25), GREEN);
    }

    /// The gradient is the bilinear interpolant's derivative: central differences
    /// inside one texel square agree with it.
    #[test]
    fn gradients_are_the_interpolants_derivatives() {
        let b = Bitmap {
            to_uv: UvTransform {
                rows: [[2.0, 0.5, 0.1], [-0.3, 1.5, 0.0]],
            },
            ..quad(Filter::Bilinear, Wrap::Repeat)
        };
        let uv = Vec2::new(0.37, 0.61);
        let h = 1e-3;
        let [du, dv] = b.grad(uv);
        let fd_u = (b.eval(uv + Vec2::X * h) - b.eval(uv - Vec2::X * h)) / (2.0 * h);
        let fd_v = (b.eval(uv + Vec2::Y * h) - b.eval(uv - Vec2::Y * h)) / (2.0 * h);
        assert!((du - fd_u).abs().max_element() < 1e-2, "{du} {fd_u}");
        assert!((dv - fd_v).abs().max_element() < 1e-2, "{dv} {fd_v}");
        assert_eq!(quad(Filter::Nearest, Wrap::Repeat).grad(uv), [Rgb::ZERO; 2]);
    }

    #[test]
    fn wrapping_folds_every_integer_into_the_image() {
        for mode in [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp] {
            for i in [-7, -1, 0, 3, 4, 9, i64::MIN / 2, i64::MAX / 2] {
                assert!(wrap(i, 4, mode) < 4, "{mode:?} {i}");
            }
        }
        assert_eq!(
            (-2..6)
                .map(|i| wrap(i, 3, Wrap::Mirror))
                .collect::<Vec<_>>(),
            [1, 0, 0, 1, 2, 2, 1, 0]
        );
        // NaN coordinates saturate to 0 on the cast and still land in the image.
        let n = quad(Filter::Bilinear, Wrap::Clamp);
        assert!(n.eval(Vec2::new(f32::NAN, f32::INFINITY)).is_finite());
    }
}
