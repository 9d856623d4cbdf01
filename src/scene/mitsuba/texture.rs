//! `<texture>` plugins (`bitmap`, `checkerboard`, and 0.x's `scale`) as scene-format
//! textures, for any parameter a converter reads with [`Params::param`] or
//! [`Params::scalar`], which live here so that `params` need not know textures.
//! Imports `params` and `node`.

use super::node::Node;
use super::params::{Params, Xf};
use super::Ctx;
use crate::material::texture::{Filter, Wrap};
use crate::scene::error::Result;
use crate::scene::format::{Param, Scalar, TextureDesc};

/// `p` as Mitsuba 3 reads it where one number is wanted (an opacity, a weight, a
/// roughness): through the textures' `eval_1`, which for `checkerboard` picks
/// `color0` where its colour lookup picks `color1` and the other way round
/// (src/textures/checkerboard.cpp, Mitsuba 3.9: `eval` tests `mask.x() == mask.y()`,
/// `eval_1` tests `!=`). Swapping the two keeps the image Mitsuba's.
pub fn scalar(p: Param) -> Param {
    let Param::Texture(t) = p else { return p };
    Param::Texture(Box::new(match *t {
        TextureDesc::Checkerboard {
            color0,
            color1,
            to_uv,
        } => TextureDesc::Checkerboard {
            color0: scalar(color1),
            color1: scalar(color0),
            to_uv,
        },
        TextureDesc::Scale { texture, scale } => TextureDesc::Scale {
            texture: scalar(texture),
            scale,
        },
        bitmap @ TextureDesc::Bitmap { .. } => bitmap,
    }))
}

impl<'a> Params<'a> {
    /// A colour: `<rgb>`, a `<spectrum>` with one value, or a `<float>` (grey).
    /// A colour or a texture (nested, or a reference in slot `name`).
    pub fn param(&self, name: &str, ctx: &mut Ctx<'a>) -> Result<Option<Param>> {
        if let Some(n) = self.texture_node(name) {
            return texture(n, ctx).map(Some);
        }
        Ok(self.color(name)?.map(Param::Value))
    }

    /// A scalar: a `<float>` or a texture (nested, or a reference in slot `name`).
    pub fn scalar(&self, name: &str, ctx: &mut Ctx<'a>) -> Result<Option<Scalar>> {
        if let Some(n) = self.texture_node(name) {
            // Mitsuba reads one number through `eval_1` (see `scalar`).
            return texture(n, ctx).map(|t| Some(Scalar(scalar(t))));
        }
        Ok(self.float(name)?.map(|v| Scalar::value(v as f32)))
    }
}

/// The texture of element `n`.
pub fn texture<'a>(n: &'a Node, ctx: &mut Ctx<'a>) -> Result<Param> {
    let p = Params::new(n, ctx)?;
    let t = match n.kind() {
        "bitmap" => bitmap(n, &p, ctx)?,
        "checkerboard" => TextureDesc::Checkerboard {
            color0: p.param("color0", ctx)?.unwrap_or(Param::grey(0.4)),
            color1: p.param("color1", ctx)?.unwrap_or(Param::grey(0.2)),
            to_uv: to_uv(&p)?,
        },
        // Mitsuba 0.x: a nested texture times a factor.
        "scale" => {
            let inner = p
                .object(&["texture"], None)?
                .ok_or_else(|| n.err("needs a nested <texture>"))?;
            TextureDesc::Scale {
                texture: texture(inner, ctx)?,
                scale: p
                    .param("scale", ctx)?
                    .filter(|s| !s.is_texture())
                    .unwrap_or(Param::grey(1.0)),
            }
        }
        other => {
            return Err(n.err(format!(
                "unknown or unsupported texture plugin \"{other}\": caustic imports bitmap, \
                 checkerboard and scale"
            )))
        }
    };
    p.finish(&format!("the {} texture", n.kind()))?;
    Ok(Param::Texture(Box::new(t)))
}

fn bitmap<'a>(n: &'a Node, p: &Params<'a>, ctx: &mut Ctx<'a>) -> Result<TextureDesc> {
    let (fnode, name) = p
        .string("filename")?
        .ok_or_else(|| n.err("needs a filename"))?;
    let filename = ctx.file_ref(fnode, name)?;
    let filter = match p.string("filter_type")? {
        None => Filter::Bilinear,
        Some((_, "bilinear")) => Filter::Bilinear,
        Some((_, "nearest")) => Filter::Nearest,
        Some((m, other)) => {
            return Err(m.err(format!(
                "unknown filter_type \"{other}\" (bilinear or nearest)"
            )))
        }
    };
    let wrap = match p.string("wrap_mode")? {
        None => Wrap::Repeat,
        Some((_, "repeat")) => Wrap::Repeat,
        Some((_, "mirror")) => Wrap::Mirror,
        Some((_, "clamp")) => Wrap::Clamp,
        Some((m, other)) => {
            return Err(m.err(format!(
                "unknown wrap_mode \"{other}\" (repeat, mirror or clamp)"
            )))
        }
    };
    // Mitsuba stores the image as it is (no effect on the values caustic reads).
    p.ignore(&["format", "accel"]);
    Ok(TextureDesc::Bitmap {
        filename,
        raw: p.boolean("raw")?.unwrap_or(false),
        filter,
        wrap,
        to_uv: to_uv(p)?,
    })
}

/// Mitsuba applies the 4x4 `to_uv` to (u, v, 0, 1): its x and y rows, without z.
fn to_uv(p: &Params) -> Result<Option<[[f32; 3]; 2]>> {
    Ok(p.transform("to_uv")?.map(|Xf { m, .. }| {
        let row = |r: glam::DVec4| [r.x as f32, r.y as f32, r.w as f32];
        [row(m.row(0)), row(m.row(1))]
    }))
}
