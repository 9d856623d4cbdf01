//! `<sensor>`, with its `<film>` and `<rfilter>` (its `<sampler>`: module `integrator`).

use super::node::Node;
use super::params::{f3, Params, Part};
use super::{integrator, media, Ctx};
use crate::scene::error::Result;
use crate::scene::format::{CameraDesc, FilmDesc, Filter, FilterDesc, FovAxis, LookAt};
use glam::DVec3;

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
    let (fov, axis) = field_of_view(n, &p)?;
    let (w, h) = (film.width as f64, film.height as f64);
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
    let spp = integrator::sampler(&p, ctx)?;
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

/// `fov` (degrees) and its `fov_axis`; or, as Mitsuba (0.x and 3) reads a sensor
/// without a fov, `focal_length` (`50mm` by default) on a 36 x 24 mm film: a fov
/// across the diagonal of 2 atan(sqrt(36^2 + 24^2) / (2 f)).
fn field_of_view<'a>(n: &'a Node, p: &Params<'a>) -> Result<(f64, Option<(&'a Node, &'a str)>)> {
    let focal = p.string("focal_length")?;
    match (p.float("fov")?, focal) {
        (Some(_), Some((f, _))) => Err(f.err("give a fov or a focal_length, not both")),
        (Some(fov), None) => Ok((fov, p.string("fov_axis")?)),
        (None, focal) => {
            let text = focal.map_or("50mm", |(_, s)| s).trim();
            let mm = (text.strip_suffix("mm").unwrap_or(text).trim().parse().ok())
                .filter(|f: &f64| f.is_finite() && *f > 0.0)
                .ok_or_else(|| {
                    focal.map_or(n, |(f, _)| f).err(format!(
                        "focal_length \"{text}\" is not a length in millimetres such as 50mm"
                    ))
                })?;
            // Mitsuba ignores the axis then.
            p.ignore(&["fov_axis"]);
            let diagonal = (36.0f64 * 36.0 + 24.0 * 24.0).sqrt();
            let fov = 2.0 * (diagonal / (2.0 * mm)).atan().to_degrees();
            Ok((fov, Some((n, "diagonal"))))
        }
    }
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
