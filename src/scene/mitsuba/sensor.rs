//! `<sensor>` (with its `<film>`, `<rfilter>` and `<sampler>`) and `<integrator>`.

use super::params::{f3, Params, Part};
use super::xml::Node;
use super::{media, Ctx};
use crate::scene::error::Result;
use crate::scene::format::{CameraDesc, FilmDesc, Filter, FilterDesc, FovAxis, LookAt};
use glam::DVec3;

/// What Mitsuba's `max_depth` -1 (no limit) becomes.
pub const UNLIMITED_DEPTH: u32 = 1024;

/// The camera, the film and the sample count.
pub fn sensor<'a>(n: &'a Node, ctx: &mut Ctx<'a>) -> Result<(CameraDesc, FilmDesc, Option<u32>)> {
    let p = Params::new(n, ctx)?;
    let kind = match n.kind() {
        "perspective" => "pinhole",
        "thinlens" => "thinlens",
        other => {
            return Err(n.err(format!(
                "unknown sensor plugin \"{other}\": caustic imports perspective and thinlens"
            )))
        }
    };
    let film = film(&p, ctx)?;
    let xf = p.transform("to_world")?;
    let look_at = match &xf {
        None => LookAt {
            origin: [0.0; 3],
            target: [0.0, 0.0, 1.0],
            up: [0.0, 1.0, 0.0],
        },
        Some(xf) => match xf.parts.as_slice() {
            [Part::LookAt { origin, target, up }] => LookAt {
                origin: f3(*origin),
                target: f3(*target),
                up: f3(*up),
            },
            _ => {
                if xf.det() <= 0.0 {
                    return Err(n.err(
                        "to_world mirrors the image (negative determinant): caustic cameras \
                         cannot; remove the mirroring scale (the image comes out mirrored)",
                    ));
                }
                let cols = [DVec3::X, DVec3::Y, DVec3::Z].map(|a| xf.vector(a).length());
                if cols.iter().any(|l| (l - 1.0).abs() > 1e-4) {
                    return Err(n.err(
                        "to_world scales the camera: Mitsuba refuses this too; remove the scale",
                    ));
                }
                let origin = xf.point(DVec3::ZERO);
                LookAt {
                    origin: f3(origin),
                    target: f3(origin + xf.vector(DVec3::Z)),
                    up: f3(xf.vector(DVec3::Y)),
                }
            }
        },
    };
    let fov = p.float("fov")?.ok_or_else(|| {
        n.err(
            "needs a fov (focal_length is not supported): add <float name=\"fov\" value=\"...\"/>",
        )
    })?;
    let (w, h) = (film.width as f64, film.height as f64);
    let axis = p.string("fov_axis")?;
    let (fov, fov_axis) = match axis.map_or("x", |(_, s)| s) {
        "x" => (fov, FovAxis::X),
        "y" => (fov, FovAxis::Y),
        "smaller" if w > h => (fov, FovAxis::Y),
        "smaller" => (fov, FovAxis::X),
        "larger" if h > w => (fov, FovAxis::Y),
        "larger" => (fov, FovAxis::X),
        "diagonal" => {
            let t = (fov.to_radians() / 2.0).tan() * w / (w * w + h * h).sqrt();
            (2.0 * t.atan().to_degrees(), FovAxis::X)
        }
        other => {
            return Err(axis.expect("given").0.err(format!(
                "unknown fov_axis \"{other}\" (x, y, diagonal, smaller or larger)"
            )))
        }
    };
    for key in ["principal_point_offset_x", "principal_point_offset_y"] {
        if p.float(key)?.is_some_and(|v| v != 0.0) {
            return Err(n.err(format!(
                "{key} is not supported (caustic's image is centred)"
            )));
        }
    }
    let clip = [p.float("near_clip")?, p.float("far_clip")?];
    if clip.iter().any(Option::is_some) {
        ctx.warn(
            n,
            "near_clip and far_clip are ignored: caustic cameras do not clip",
        );
    }
    let (aperture_radius, focus_distance) = if kind == "thinlens" {
        let need = |key: &str| {
            p.float(key)?
                .ok_or_else(|| n.err(format!("a thinlens sensor needs a {key}")))
        };
        (
            need("aperture_radius")? as f32,
            Some(need("focus_distance")? as f32),
        )
    } else {
        // A pinhole camera has everything in focus.
        p.ignore(&["focus_distance"]);
        (0.0, None)
    };
    p.ignore(&["shutter_open", "shutter_close"]);
    let spp = sampler(&p, ctx)?;
    let medium = match p.object(&["medium"], None)? {
        Some(m) => Some(media::medium(m, ctx)?),
        None => None,
    };
    p.finish("the camera")?;
    let camera = CameraDesc {
        kind: kind.into(),
        look_at,
        fov: fov as f32,
        fov_axis,
        aperture_radius,
        focus_distance,
        medium,
    };
    Ok((camera, film, spp))
}

/// The film, with Mitsuba's defaults: 768 x 576 and a Gaussian filter.
fn film<'a>(p: &Params<'a>, ctx: &Ctx<'a>) -> Result<FilmDesc> {
    let Some(n) = p.object(&["film"], None)? else {
        return Ok(FilmDesc {
            width: 768,
            height: 576,
            filter: FilterDesc(MITSUBA_DEFAULT_FILTER),
        });
    };
    if n.kind() != "hdrfilm" {
        return Err(n.err(format!(
            "unknown film plugin \"{}\": caustic imports hdrfilm",
            n.kind()
        )));
    }
    let f = Params::new(n, ctx)?;
    let size = |key: &str, default: i64| -> Result<u32> {
        let v = f.int(key)?.unwrap_or(default);
        u32::try_from(v)
            .ok()
            .filter(|v| (1..=16384).contains(v))
            .ok_or_else(|| n.err(format!("{key} {v} is not in 1..=16384")))
    };
    let width = size("width", 768)?;
    let height = size("height", 576)?;
    for key in [
        "crop_offset_x",
        "crop_offset_y",
        "crop_width",
        "crop_height",
    ] {
        if f.int(key)?.is_some() {
            return Err(n.err(format!(
                "{key}: crop windows are not supported; render the whole image and crop it"
            )));
        }
    }
    // Output formats: caustic writes RGB EXR and PNG whatever these say.
    f.ignore(&[
        "pixel_format",
        "component_format",
        "file_format",
        "banner",
        "sample_border",
        "compensate",
    ]);
    let filter = match f.object(&["rfilter"], None)? {
        None => MITSUBA_DEFAULT_FILTER,
        Some(r) => rfilter(r, ctx)?,
    };
    f.finish("the film")?;
    Ok(FilmDesc {
        width,
        height,
        filter: FilterDesc(filter),
    })
}

/// What Mitsuba's films filter with when a scene names no `<rfilter>`.
const MITSUBA_DEFAULT_FILTER: Filter = Filter::Gaussian { stddev: 0.5 };

/// An `<rfilter>` as the filter of the same name and parameters (Mitsuba 0.x's box
/// `radius` too; `catmullrom` is Mitchell's with B = 0, C = 1/2).
fn rfilter<'a>(r: &'a Node, ctx: &Ctx<'a>) -> Result<Filter> {
    let p = Params::new(r, ctx)?;
    let float = |key: &str, default: f32| -> Result<f32> {
        Ok(p.float(key)?.map_or(default, |v| v as f32))
    };
    let filter = match r.kind() {
        "box" => Filter::Box {
            radius: float("radius", 0.5)?,
        },
        "tent" => Filter::Tent {
            radius: float("radius", 1.0)?,
        },
        "gaussian" => Filter::Gaussian {
            stddev: float("stddev", 0.5)?,
        },
        "mitchell" => Filter::Mitchell {
            b: float("B", 1.0 / 3.0)?,
            c: float("C", 1.0 / 3.0)?,
        },
        "catmullrom" => Filter::Mitchell { b: 0.0, c: 0.5 },
        "lanczos" => {
            let lobes = p.int("lobes")?.unwrap_or(3);
            Filter::Lanczos {
                lobes: u32::try_from(lobes)
                    .map_err(|_| r.err(format!("lobes {lobes} must be at least 1")))?,
            }
        }
        other => {
            return Err(r.err(format!(
                "unknown rfilter plugin \"{other}\" (box, tent, gaussian, mitchell, \
                 catmullrom or lanczos)"
            )))
        }
    };
    if let Err(e) = crate::scene::validate::filter(&filter) {
        return Err(r.err(e));
    }
    p.finish("the filter")?;
    Ok(filter)
}

fn sampler<'a>(p: &Params<'a>, ctx: &mut Ctx<'a>) -> Result<Option<u32>> {
    let Some(n) = p.object(&["sampler"], None)? else {
        return Ok(None);
    };
    let s = Params::new(n, ctx)?;
    let count = s.int("sample_count")?.unwrap_or(4);
    let spp = u32::try_from(count)
        .ok()
        .filter(|&c| c >= 1)
        .ok_or_else(|| n.err(format!("sample_count {count} must be at least 1")))?;
    // The random numbers differ anyway: the seed and stratification change the noise,
    // not the expected image.
    s.ignore(&["seed", "jitter", "scramble_seed"]);
    s.finish("the sampler")?;
    match n.kind() {
        "independent" => {}
        "stratified" | "multijitter" | "orthogonal" | "ldsampler" | "sobol" | "pmj02" => ctx.warn(
            n,
            "caustic samples with independent random numbers: the same expected image \
                 with different noise",
        ),
        other => return Err(n.err(format!("unknown sampler plugin \"{other}\""))),
    }
    Ok(Some(spp))
}

/// `{"algorithm": ..., "max_depth": ...}` for the scene's `integrator`.
pub fn integrator<'a>(n: &'a Node, ctx: &mut Ctx<'a>) -> Result<serde_json::Value> {
    let p = Params::new(n, ctx)?;
    let algorithm = match n.kind() {
        "path" => "pt",
        "volpath" | "volpathmis" => "volpath",
        "bdpt" => "bpt",
        "ptracer" => "lt",
        other => {
            return Err(n.err(format!(
                "unknown integrator plugin \"{other}\": caustic imports path, volpath, \
                 volpathmis, bdpt and ptracer (choose another algorithm with --algorithm)"
            )))
        }
    };
    let mut out = serde_json::json!({ "algorithm": algorithm });
    let depth = p.int("max_depth")?.unwrap_or(-1);
    let depth = match depth {
        -1 => {
            ctx.warn(
                n,
                format!("max_depth -1 (no limit) becomes {UNLIMITED_DEPTH}"),
            );
            UNLIMITED_DEPTH
        }
        d if d >= 1 && d <= u32::MAX as i64 => d as u32,
        d => return Err(n.err(format!("max_depth {d} must be -1 or at least 1"))),
    };
    out["max_depth"] = depth.into();
    if let Some(rr) = p.int("rr_depth")? {
        let rr = u32::try_from(rr).map_err(|_| n.err(format!("rr_depth {rr} must be >= 0")))?;
        if algorithm == "pt" || algorithm == "volpath" {
            out["rr_depth"] = rr.into();
        } else {
            ctx.warn(
                n,
                format!(
                    "rr_depth is ignored: caustic's {algorithm} plays Russian roulette on the \
                     albedo at every vertex (the same expected image)"
                ),
            );
        }
    }
    if p.boolean("hide_emitters")? == Some(true) {
        return Err(n.err("hide_emitters is not supported: caustic always shows emitters"));
    }
    p.ignore(&["samples_per_pass", "timeout"]);
    p.finish("the integrator")?;
    Ok(out)
}
