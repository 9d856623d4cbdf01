//! Top-level `<emitter>` plugins as caustic lights.

use super::node::Node;
use super::params::{f3, rotation, Params, Part, Xf};
use super::Ctx;
use crate::scene::error::Result;
use crate::scene::format::LightDesc;
use glam::DVec3;

pub fn emitter<'a>(n: &'a Node, ctx: &mut Ctx<'a>) -> Result<LightDesc> {
    let p = Params::new(n, ctx)?;
    let light = match n.kind() {
        "point" => {
            let position = placed(&p, "position", |xf| xf.point(DVec3::ZERO), DVec3::ZERO)?;
            LightDesc::Point {
                position: f3(position),
                intensity: p.color("intensity")?.unwrap_or([1.0; 3]),
            }
        }
        "spot" => {
            let xf = p.transform("to_world")?.unwrap_or_else(Xf::identity);
            let (position, target) = match xf.parts.as_slice() {
                [Part::LookAt { origin, target, .. }] => (*origin, *target),
                _ => (xf.point(DVec3::ZERO), xf.point(DVec3::Z)),
            };
            let cutoff = p.float("cutoff_angle")?.unwrap_or(20.0) as f32;
            LightDesc::Spot {
                position: f3(position),
                target: f3(target),
                intensity: p.color("intensity")?.unwrap_or([1.0; 3]),
                cutoff_angle: cutoff,
                beam_width: p.float("beam_width")?.map(|v| v as f32),
            }
        }
        "directional" => {
            let direction = placed(&p, "direction", |xf| xf.vector(DVec3::Z), DVec3::Z)?;
            LightDesc::Directional {
                direction: f3(direction),
                irradiance: p.color("irradiance")?.unwrap_or([1.0; 3]),
            }
        }
        "constant" => LightDesc::Constant {
            radiance: p.color("radiance")?.unwrap_or([1.0; 3]),
        },
        "envmap" => {
            let (fnode, name) = p
                .string("filename")?
                .ok_or_else(|| n.err("needs a filename"))?;
            if !name.to_ascii_lowercase().ends_with(".exr") {
                return Err(fnode.err(format!(
                    "\"{name}\": caustic reads environment maps from EXR files; convert it"
                )));
            }
            let filename = ctx.file_ref(fnode, name)?;
            // Mitsuba's map is caustic's turned half a turn about +y (Mitsuba's u = 0
            // looks along -z, caustic's along +z): to_world * rotate_y(180).
            let xf = p.transform("to_world")?.unwrap_or_else(Xf::identity);
            let m = xf.m * rotation(DVec3::Y, 180.0);
            let transform = Xf {
                m,
                parts: vec![Part::Matrix],
            }
            .matrix_desc();
            ctx.warn(
                n,
                "caustic looks environment maps up by nearest texel (Mitsuba interpolates \
                 bilinearly): a slightly blockier background",
            );
            LightDesc::Envmap {
                filename,
                scale: p.float("scale")?.unwrap_or(1.0) as f32,
                transform: Some(transform),
            }
        }
        "area" => {
            return Err(
                n.err("an area emitter belongs inside a <shape>; move it into the shape it lights")
            )
        }
        other => {
            return Err(n.err(format!(
                "unknown or unsupported emitter plugin \"{other}\": caustic imports area, \
                 point, spot, directional, constant and envmap"
            )))
        }
    };
    p.finish(&format!("the {} light", n.kind()))?;
    Ok(light)
}

/// A position or direction given as parameter `key`, or taken from `to_world` by
/// `from_xf`, or `default`.
fn placed(p: &Params, key: &str, from_xf: impl Fn(&Xf) -> DVec3, default: DVec3) -> Result<DVec3> {
    match (p.point(key)?, p.transform("to_world")?) {
        (Some(v), None) => Ok(v),
        (None, Some(xf)) => Ok(from_xf(&xf)),
        (None, None) => Ok(default),
        (Some(_), Some(_)) => Err(p.node.err(format!("give {key} or to_world, not both"))),
    }
}
