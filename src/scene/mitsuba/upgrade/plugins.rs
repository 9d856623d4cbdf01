//! 0.x plugins and parameters whose Mitsuba 3 form differs, in that form: films
//! (`ldrfilm`, `tiledhdrfilm`, `high_quality_edges`), the sensor's
//! `shutter_open_time`, a bitmap's wrap modes, EWA filter and gamma, a homogeneous
//! medium's `sigma_a`/`sigma_s` and its Skin1 defaults, a heterogeneous medium's
//! `density`, a grid's placement, and options of 0.x plugins that only changed speed
//! or noise (`sampling_weight`, `cache`, `method`, ...), which are dropped.

use super::super::node::Node;
use super::super::params::xyz;
use super::forms::{colour_value, join};
use super::{child, element, rename_child, take, take_float};
use crate::scene::error::Result;
use glam::DVec3;

/// Element `n` (its parameter names already snake_case) in its Mitsuba 3 form.
pub fn plugin(n: &mut Node, warnings: &mut Vec<String>) -> Result<()> {
    match (n.tag.as_str(), n.kind()) {
        ("film", "ldrfilm") => ldr_film(n, warnings)?,
        ("film", "hdrfilm" | "tiledhdrfilm") => hdr_film(n),
        ("sensor", _) => shutter(n)?,
        ("emitter", _) => drop(n, &["sampling_weight", "cache"]),
        ("shape", "obj" | "ply" | "serialized") => mesh(n, warnings)?,
        ("texture", "bitmap") => bitmap(n, warnings)?,
        ("medium", "homogeneous") => {
            // How distances are sampled: the same medium, other noise.
            drop(
                n,
                &["strategy", "sampling_density", "medium_sampling_weight"],
            );
            homogeneous(n)?;
        }
        ("medium", "heterogeneous") => {
            // Woodcock tracking or ray marching: the same medium either way.
            drop(n, &["method", "step_size"]);
            rename_child(n, "density", "sigma_t");
        }
        ("volume", "gridvolume") => {
            drop(n, &["send_data"]);
            grid_placement(n, warnings)?;
        }
        _ => {}
    }
    Ok(())
}

/// Drops parameters that change only the speed, the noise or the output files.
fn drop(n: &mut Node, names: &[&str]) {
    n.children
        .retain(|c| !c.attr("name").is_some_and(|k| names.contains(&k)));
}

/// Takes the `<string>` parameter `name` out of `n`.
fn take_string(n: &mut Node, name: &str) -> Result<Option<(Node, String)>> {
    let Some(c) = take(n, name) else {
        return Ok(None);
    };
    if c.tag != "string" {
        return Err(c.err(format!("\"{name}\" must be a <string>")));
    }
    let v = (c.attr("value").map(str::to_string)).ok_or_else(|| c.err("needs a value"))?;
    Ok(Some((c, v)))
}

fn hdr_film(n: &mut Node) {
    n.set_attr("type", "hdrfilm");
    rename_child(n, "high_quality_edges", "sample_border");
    drop(n, &["attach_log", "channel_names"]);
}

/// `ldrfilm` is `hdrfilm` with a tone mapping on the way to its 8-bit file; caustic
/// writes a linear EXR and an sRGB PNG after an exposure, which is `ldrfilm`'s default.
fn ldr_film(n: &mut Node, warnings: &mut Vec<String>) -> Result<()> {
    hdr_film(n);
    let mut changed = Vec::new();
    if let Some((_, m)) = take_string(n, "tonemap_method")?.filter(|(_, m)| m != "gamma") {
        changed.push(format!("tonemap_method {m}"));
    }
    for (name, default) in [("gamma", -1.0), ("exposure", 0.0)] {
        if let Some((_, v)) = take_float(n, name)?.filter(|(_, v)| *v != default) {
            changed.push(format!("{name} {v}"));
        }
    }
    drop(n, &["key", "burn"]);
    if !changed.is_empty() {
        warnings.push(n.warning(format!(
            "the ldrfilm's {} is not applied: caustic writes a linear EXR and an \
             sRGB-encoded PNG (the rendered image is the same)",
            changed.join(", ")
        )));
    }
    Ok(())
}

/// 0.x gave the shutter as an opening time and a duration, Mitsuba 3 as two times.
fn shutter(n: &mut Node) -> Result<()> {
    let Some((c, time)) = take_float(n, "shutter_open_time")? else {
        return Ok(());
    };
    let open = child(n, "shutter_open")
        .and_then(|i| n.children[i].attr("value"))
        .and_then(|v| v.trim().parse::<f64>().ok())
        .unwrap_or(0.0);
    let close = [
        ("name", "shutter_close".into()),
        ("value", (open + time).to_string()),
    ];
    n.children.push(element("float", &close, &c.loc));
    Ok(())
}

/// 0.x rebuilt a mesh's normals at creases sharper than `max_smooth_angle`.
fn mesh(n: &mut Node, warnings: &mut Vec<String>) -> Result<()> {
    drop(n, &["collapse"]);
    if let Some((c, angle)) = take_float(n, "max_smooth_angle")? {
        warnings.push(c.warning(format!(
            "Mitsuba 0.x discarded the mesh's normals and rebuilt them, smooth except at \
             creases sharper than {angle} degrees; caustic shades with the file's normals \
             (or flat, where it has none)"
        )));
    }
    Ok(())
}

/// A 0.x bitmap's per-axis wrap modes, EWA filtering and gamma.
fn bitmap(n: &mut Node, warnings: &mut Vec<String>) -> Result<()> {
    wrap_modes(n)?;
    let filter = take_string(n, "filter_type")?;
    let kind = filter.as_ref().map_or("ewa", |(_, f)| f.as_str());
    if kind == "ewa" || kind == "trilinear" {
        let at = filter.as_ref().map_or(&*n, |(c, _)| c);
        warnings.push(at.warning(format!(
            "Mitsuba 0.x filtered this texture ({kind}, its default being ewa) over each \
             pixel's footprint; Mitsuba 3 and caustic interpolate it bilinearly: a \
             sharper texture where it is small on screen"
        )));
    } else if let Some((c, _)) = filter {
        // `nearest`, or no 0.x filter either (which the texture's converter refuses).
        n.children.push(c);
    }
    drop(n, &["max_anisotropy", "cache"]);
    let Some((c, gamma)) = take_float(n, "gamma")? else {
        return Ok(());
    };
    // 0: from the file, -1: sRGB (both Mitsuba 3's reading of 8-bit images); 1: linear.
    if gamma == 1.0 {
        let raw = [("name", "raw".into()), ("value", "true".into())];
        n.children.push(element("boolean", &raw, &c.loc));
    } else if gamma != 0.0 && gamma != -1.0 {
        warnings.push(c.warning(format!(
            "gamma {gamma}: decoded with the sRGB curve instead, as Mitsuba 3 decodes \
             8-bit images"
        )));
    }
    Ok(())
}

/// `wrap_mode_u` and `wrap_mode_v` (each defaulting to `wrap_mode`) as one
/// `wrap_mode`: Mitsuba 3 has no per-axis modes, nor 0.x's `zero` and `one`.
fn wrap_modes(n: &mut Node) -> Result<()> {
    let both = take_string(n, "wrap_mode")?;
    let (u, v) = (
        take_string(n, "wrap_mode_u")?,
        take_string(n, "wrap_mode_v")?,
    );
    let u = u.as_ref().or(both.as_ref());
    let v = v.as_ref().or(both.as_ref());
    for (c, mode) in [u, v].into_iter().flatten() {
        if matches!(mode.as_str(), "zero" | "black" | "one" | "white") {
            return Err(c.err(format!(
                "wrap mode \"{mode}\" (a constant outside the image) has no Mitsuba 3 form: \
                 use repeat, mirror or clamp"
            )));
        }
    }
    let [mu, mv] = [u, v].map(|m| m.map_or("repeat", |(_, s)| s.as_str()));
    if mu != mv {
        return Err(n.err(format!(
            "wrap mode {mu} in u and {mv} in v: Mitsuba 3 and caustic take one wrap_mode \
             for both"
        )));
    }
    if let Some((c, m)) = u.or(v) {
        let attrs = [("name", "wrap_mode".into()), ("value", m.clone())];
        n.children.push(element("string", &attrs, &c.loc));
    }
    Ok(())
}

/// Mitsuba 0.x's default medium, the measured Skin1 preset (Jensen et al. 2001, in
/// 1/mm, times 100 as 0.x scales it): what a 0.x homogeneous medium takes for the
/// coefficients it does not give.
const SKIN1_SIGMA_S: [f64; 3] = [74.0, 88.0, 101.0];
const SKIN1_SIGMA_A: [f64; 3] = [3.2, 17.0, 48.0];

/// 0.x's `sigma_a` and `sigma_s` as Mitsuba 3's `sigma_t` and `albedo`, with 0.x's
/// defaults for what is missing.
fn homogeneous(n: &mut Node) -> Result<()> {
    if let Some(i) = child(n, "material") {
        return Err(n.children[i].err(
            "measured material presets are not supported: give sigma_a and sigma_s (or \
             sigma_t and albedo)",
        ));
    }
    let colour = |c: Option<Node>| c.map(|c| colour_value(&c)).transpose();
    let sigma_a = colour(take(n, "sigma_a"))?;
    let sigma_s = colour(take(n, "sigma_s"))?;
    let has = |n: &Node, k| child(n, k).is_some();
    let (sigma_t, albedo) = match (sigma_a, sigma_s) {
        (None, None) => {
            let skin = skin1();
            (
                (!has(n, "sigma_t")).then_some(skin.0),
                (!has(n, "albedo")).then_some(skin.1),
            )
        }
        _ if has(n, "sigma_t") || has(n, "albedo") => {
            return Err(n.err(
                "give sigma_a and sigma_s, or sigma_t and albedo, not a mix (as Mitsuba 0.x \
                 requires)",
            ))
        }
        (a, s) => {
            let (t, albedo) = coefficients(a.unwrap_or(SKIN1_SIGMA_A), s.unwrap_or(SKIN1_SIGMA_S));
            (Some(t), Some(albedo))
        }
    };
    let loc = n.loc.clone();
    for (name, v) in [("sigma_t", sigma_t), ("albedo", albedo)] {
        if let Some(v) = v {
            let attrs = [("name", name.into()), ("value", join(v))];
            n.children.push(element("rgb", &attrs, &loc));
        }
    }
    Ok(())
}

fn skin1() -> ([f64; 3], [f64; 3]) {
    coefficients(SKIN1_SIGMA_A, SKIN1_SIGMA_S)
}

/// sigma_t = sigma_a + sigma_s and albedo = sigma_s / sigma_t (0 where sigma_t is).
fn coefficients(a: [f64; 3], s: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let t = [0, 1, 2].map(|i| a[i] + s[i]);
    let albedo = [0, 1, 2].map(|i| if t[i] > 0.0 { s[i] / t[i] } else { 0.0 });
    (t, albedo)
}

/// A 0.x grid lies on the box stored in its file, or on `min`..`max` when both are
/// given, before its `to_world`; Mitsuba 3 puts a grid on the unit cube unless
/// `use_grid_bbox`. (A 0.x scene's heterogeneous medium names its grid `density`,
/// which Mitsuba 3 does not read, so only the 0.x placement can be what it meant.)
fn grid_placement(n: &mut Node, warnings: &mut Vec<String>) -> Result<()> {
    let point = |n: &Node, name: &str| {
        (n.children.iter()).position(|c| c.tag == "point" && c.attr("name") == Some(name))
    };
    if let (Some(lo), Some(hi)) = (point(n, "min"), point(n, "max")) {
        let (min, max) = (xyz(&n.children[lo], 0.0)?, xyz(&n.children[hi], 0.0)?);
        let loc = n.children[lo].loc.clone();
        let xyz_element = |tag: &str, v: DVec3| {
            let attrs = [("x", v.x), ("y", v.y), ("z", v.z)].map(|(k, x)| (k, x.to_string()));
            element(tag, &attrs, &loc)
        };
        // Applied first: the unit cube onto min..max, then the grid's to_world.
        let box_parts = [
            xyz_element("scale", max - min),
            xyz_element("translate", min),
        ];
        n.children
            .retain(|c| !(c.tag == "point" && matches!(c.attr("name"), Some("min" | "max"))));
        match (n.children.iter_mut())
            .find(|c| c.tag == "transform" && c.attr("name") == Some("to_world"))
        {
            Some(t) => {
                t.children.splice(0..0, box_parts);
            }
            None => {
                let mut t = element("transform", &[("name", "to_world".into())], &loc);
                t.children.extend(box_parts);
                n.children.push(t);
            }
        }
    } else if !n
        .children
        .iter()
        .any(|c| c.attr("name") == Some("use_grid_bbox"))
    {
        let attrs = [("name", "use_grid_bbox".into()), ("value", "true".into())];
        let flag = element("boolean", &attrs, &n.loc);
        n.children.push(flag);
    }
    warnings.push(n.warning(
        "Mitsuba 0.x put a grid's values on the corners of its box, Mitsuba 3 and caustic \
         at the centres of its cells: the density is shifted by up to half a voxel",
    ));
    Ok(())
}
