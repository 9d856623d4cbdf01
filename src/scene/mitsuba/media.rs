//! `<medium>` plugins (homogeneous, heterogeneous with grid and constant volumes) and
//! their `<phase>` functions.

use super::node::Node;
use super::params::{Params, Xf};
use super::Ctx;
use crate::scene::error::Result;
use crate::scene::format::{MediumDesc, PhaseDesc, TransformDesc, V3};

/// The name of the medium for `<medium>` element `n` (converted once).
pub fn medium<'a>(n: &'a Node, ctx: &mut Ctx<'a>) -> Result<String> {
    if n.tag != "medium" {
        return Err(n.err("is not a <medium>"));
    }
    if let Some(name) = ctx.name_of(n) {
        return Ok(name);
    }
    let desc = convert(n, ctx)?;
    let name = ctx.name_for(n, "medium");
    ctx.media.insert(name.clone(), desc);
    Ok(name)
}

/// A volume parameter: a constant, or a grid file placed by its transform (`None`:
/// the bounds stored in the file).
enum Volume<'a> {
    Const(V3),
    Grid {
        node: &'a Node,
        file: String,
        transform: Option<TransformDesc>,
    },
}

fn convert<'a>(n: &'a Node, ctx: &mut Ctx<'a>) -> Result<MediumDesc> {
    let p = Params::new(n, ctx)?;
    let kind = n.kind();
    if kind != "homogeneous" && kind != "heterogeneous" {
        return Err(n.err(format!(
            "unknown medium plugin \"{kind}\": caustic imports homogeneous and heterogeneous"
        )));
    }
    let sigma_t = volume(&p, "sigma_t", ctx)?.unwrap_or(Volume::Const([1.0; 3]));
    let albedo = volume(&p, "albedo", ctx)?.unwrap_or(Volume::Const([0.75; 3]));
    let scale = p.float("scale")?.unwrap_or(1.0) as f32;
    let phase = match p.object(&["phase"], None)? {
        Some(ph) => phase(ph, ctx)?,
        None => PhaseDesc::Isotropic,
    };
    // Whether lights are sampled in media changes the noise, not the image.
    p.ignore(&["sample_emitters"]);
    p.finish(&format!("the {kind} medium"))?;
    Ok(match (sigma_t, albedo) {
        (Volume::Const(sigma_t), Volume::Const(albedo)) => MediumDesc::Homogeneous {
            sigma_a: None,
            sigma_s: None,
            sigma_t: Some(sigma_t),
            albedo: Some(albedo),
            scale,
            phase,
        },
        (
            Volume::Grid {
                file, transform, ..
            },
            albedo,
        ) => {
            let (albedo, albedo_file) = match albedo {
                Volume::Const(a) => (a, None),
                Volume::Grid {
                    node,
                    file: a_file,
                    transform: a_transform,
                } => {
                    if a_transform != transform {
                        return Err(node.err(
                            "the albedo grid must be placed like the sigma_t grid (the same \
                             to_world and use_grid_bbox)",
                        ));
                    }
                    ([1.0; 3], Some(a_file))
                }
            };
            MediumDesc::Grid {
                file,
                grid: None,
                sigma_t: [1.0; 3],
                albedo,
                albedo_file,
                scale,
                bounds: None,
                transform,
                phase,
            }
        }
        (Volume::Const(_), Volume::Grid { node, .. }) => {
            return Err(node.err(
                "an albedo grid with a constant sigma_t is not supported: give sigma_t as a \
                 gridvolume (a grid of ones)",
            ))
        }
    })
}

/// A float, colour, `constvolume` or `gridvolume` parameter.
fn volume<'a>(p: &Params<'a>, name: &str, ctx: &mut Ctx<'a>) -> Result<Option<Volume<'a>>> {
    if let Some(c) = p.color(name)? {
        return Ok(Some(Volume::Const(c)));
    }
    let Some(v) = p.object(&["volume"], Some(name))? else {
        return Ok(None);
    };
    let vp = Params::new(v, ctx)?;
    let out = match v.kind() {
        "constvolume" => Volume::Const(vp.color("value")?.ok_or_else(|| v.err("needs a value"))?),
        "gridvolume" => {
            let (fnode, fname) = vp
                .string("filename")?
                .ok_or_else(|| v.err("needs a filename"))?;
            if !fname.to_ascii_lowercase().ends_with(".vol") {
                return Err(fnode.err(format!("\"{fname}\": gridvolume reads Mitsuba .vol files")));
            }
            let file = ctx.file_ref(fnode, fname)?;
            let xf = vp.transform("to_world")?;
            let use_bbox = vp.boolean("use_grid_bbox")?.unwrap_or(false);
            let transform = match (use_bbox, xf) {
                (true, None) => None,
                (true, Some(_)) => {
                    return Err(v.err("use_grid_bbox with a to_world is not supported; give one"))
                }
                (false, xf) => Some(xf.unwrap_or_else(Xf::identity).matrix_desc()),
            };
            if let Some((f, filter)) = vp.string("filter_type")? {
                if filter != "trilinear" {
                    return Err(f.err(format!(
                        "filter_type \"{filter}\": caustic interpolates grids trilinearly only"
                    )));
                }
            }
            // Caching and accelerator hints change nothing in the image.
            vp.ignore(&["cache", "accel", "raw"]);
            Volume::Grid {
                node: v,
                file,
                transform,
            }
        }
        other => {
            return Err(v.err(format!(
                "unknown volume plugin \"{other}\": caustic imports gridvolume and constvolume"
            )))
        }
    };
    vp.finish(&format!("the {} volume", v.kind()))?;
    Ok(Some(out))
}

fn phase<'a>(n: &'a Node, ctx: &mut Ctx<'a>) -> Result<PhaseDesc> {
    let p = Params::new(n, ctx)?;
    let out = match n.kind() {
        "isotropic" => PhaseDesc::Isotropic,
        "hg" => PhaseDesc::HenyeyGreenstein {
            g: p.float("g")?.unwrap_or(0.8) as f32,
        },
        other => {
            return Err(n.err(format!(
                "unknown phase plugin \"{other}\": caustic imports isotropic and hg"
            )))
        }
    };
    p.finish(&format!("the {} phase function", n.kind()))?;
    Ok(out)
}
