//! Mitsuba 0.x files brought to Mitsuba 3's form before anything reads them, as
//! Mitsuba 3's own loader does for a file whose `version` is below 2.0: camelCase
//! parameter names become snake_case (`toWorld` -> `to_world`, `intIOR` ->
//! `int_ior`), a diffuse BSDF's `diffuse_reflectance` becomes `reflectance`, and a
//! texture's `uoffset`, `voffset`, `uscale`, `vscale` become a `to_uv` transform.
//!
//! Mitsuba 3 stops there; so that a 0.x scene loads, this also rewrites the 0.x forms
//! Mitsuba 3 no longer reads into the ones it does: `<lookAt>`, `<srgb>`, `#rrggbb`
//! colours, the `intent` of a colour, a heterogeneous medium's `density` (now
//! `sigma_t`) and a grid's placement (0.x put it on the box stored in its file, or on
//! `min`..`max`). What has no Mitsuba 3 form (`<blackbody>`, `<animation>`) is an error
//! at its element. Each file is upgraded by its own version, element by element after
//! its children, so an included Mitsuba 3 file is left as it is.

use super::params::xyz;
use super::xml::Node;
use crate::scene::error::Result;

/// Whether a scene file of `version` (`0.6.0`, or `0.6`) predates Mitsuba 2, whose
/// files Mitsuba 3 upgrades; `None` if it is not a version number.
pub fn is_legacy(version: &str) -> Option<bool> {
    let parts: Vec<&str> = version.trim().split('.').collect();
    let numbers: Option<Vec<u32>> = parts.iter().map(|p| p.parse().ok()).collect();
    match numbers?.as_slice() {
        [major, ..] if parts.len() <= 3 => Some(*major < 2),
        _ => None,
    }
}

/// Element `n` of a 0.x file, its children already upgraded, in Mitsuba 3's form.
/// Changes that change the image (an order of operations Mitsuba 3 defines
/// differently) add a line to `warnings`.
pub fn node(n: &mut Node, warnings: &mut Vec<String>) -> Result<()> {
    match n.tag.as_str() {
        "lookAt" => n.tag = "lookat".into(),
        "srgb" => {
            let linear = colour_value(n)?.map(|c| crate::film::srgb_eotf(c as f32));
            n.tag = "rgb".into();
            n.set_attr("value", &linear.map(|c| c.to_string()).join(", "));
        }
        "rgb" if n.attr("value").is_some_and(|v| v.trim().starts_with('#')) => {
            let c = colour_value(n)?;
            n.set_attr("value", &c.map(|c| c.to_string()).join(", "));
        }
        "blackbody" => {
            return Err(n.err(
                "black-body spectra are not supported (caustic renders RGB): give the \
                 colour as <rgb>",
            ))
        }
        "animation" => {
            return Err(n.err(
                "animated transforms are not supported: give one <transform> (the pose \
                 at the shutter time you want)",
            ))
        }
        _ => {}
    }
    // In an RGB renderer a colour means the same whichever intent it names.
    n.attrs.retain(|(k, _)| k != "intent");
    if n.tag != "default" {
        if let Some(name) = n.attr("name") {
            let name = snake_case(name);
            n.set_attr("name", &name);
        }
    }
    match (n.tag.as_str(), n.kind()) {
        ("bsdf", "diffuse") => rename_child(n, "diffuse_reflectance", "reflectance"),
        ("medium", "heterogeneous") => rename_child(n, "density", "sigma_t"),
        ("volume", "gridvolume") => grid_placement(n, warnings)?,
        _ => {}
    }
    uv_transform(n, warnings)
}

/// `camelCase` as `camel_case`; a run of capitals after a small letter is one word
/// (`intIOR` -> `int_ior`), as Mitsuba 3 converts names.
pub fn snake_case(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if i > 0 && chars[i - 1].is_ascii_lowercase() && c.is_ascii_uppercase() {
            out.push('_');
            while i < chars.len() && chars[i].is_ascii_uppercase() {
                out.push(chars[i].to_ascii_lowercase());
                i += 1;
            }
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

/// The three numbers of a 0.x colour: `#rrggbb` (each byte / 255), one value, or
/// three.
fn colour_value(n: &Node) -> Result<[f64; 3]> {
    let v = n
        .attr("value")
        .ok_or_else(|| n.err("needs a value attribute"))?
        .trim();
    if let Some(hex) = v.strip_prefix('#') {
        let bytes = u32::from_str_radix(hex, 16)
            .ok()
            .filter(|_| hex.len() == 6)
            .ok_or_else(|| n.err(format!("\"{v}\" is not a colour of the form #rrggbb")))?;
        return Ok([16, 8, 0].map(|shift| f64::from((bytes >> shift) & 0xff) / 255.0));
    }
    let numbers: Vec<f64> = v
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| {
            t.parse()
                .map_err(|_| n.err(format!("\"{t}\" is not a number")))
        })
        .collect::<Result<_>>()?;
    match numbers.as_slice() {
        [x] => Ok([*x; 3]),
        [r, g, b] => Ok([*r, *g, *b]),
        _ => Err(n.err(format!("\"{v}\" is not one value or three (r, g, b)"))),
    }
}

fn rename_child(n: &mut Node, from: &str, to: &str) {
    for c in &mut n.children {
        if c.attr("name") == Some(from) {
            c.set_attr("name", to);
        }
    }
}

/// Takes the `<float>` child named `name` out of `n`, with its value.
fn take_float(n: &mut Node, name: &str) -> Result<Option<(Node, f64)>> {
    let Some(i) =
        (n.children.iter()).position(|c| c.tag == "float" && c.attr("name") == Some(name))
    else {
        return Ok(None);
    };
    let c = n.children.remove(i);
    let v = c.attr("value").unwrap_or("");
    let x: f64 = (v.trim().parse().ok())
        .filter(|x: &f64| x.is_finite())
        .ok_or_else(|| c.err(format!("\"{v}\" is not a number")))?;
    Ok(Some((c, x)))
}

/// `uoffset`, `voffset`, `uscale`, `vscale` as Mitsuba 3's upgrade writes them: a
/// `to_uv` transform that translates, then scales, so uv' = (uv + offset) * scale.
/// Mitsuba 0.x computed uv * scale + offset: the two differ when both are given.
fn uv_transform(n: &mut Node, warnings: &mut Vec<String>) -> Result<()> {
    let mut taken = Vec::new();
    for name in ["uoffset", "voffset", "uscale", "vscale"] {
        taken.push(take_float(n, name)?);
    }
    let Some(first) = taken.iter().flatten().next() else {
        return Ok(());
    };
    let loc = first.0.loc.clone();
    let value = |i: usize, default: f64| taken[i].as_ref().map_or(default, |(_, x)| *x);
    let (offset, scale) = (
        [value(0, 0.0), value(1, 0.0)],
        [value(2, 1.0), value(3, 1.0)],
    );
    let element = |tag: &str, xy: [f64; 2]| Node {
        tag: tag.into(),
        attrs: vec![
            ("x".into(), xy[0].to_string()),
            ("y".into(), xy[1].to_string()),
        ],
        children: Vec::new(),
        loc: loc.clone(),
    };
    let mut transform = Node {
        tag: "transform".into(),
        attrs: vec![("name".into(), "to_uv".into())],
        children: Vec::new(),
        loc: loc.clone(),
    };
    if offset != [0.0; 2] {
        transform.children.push(element("translate", offset));
    }
    if scale != [1.0; 2] {
        transform.children.push(element("scale", scale));
    }
    if offset != [0.0; 2] && scale != [1.0; 2] {
        warnings.push(n.warning(
            "uoffset/voffset with uscale/vscale: Mitsuba 0.x scaled the texture coordinates \
             before offsetting them (uv * scale + offset); caustic follows Mitsuba 3's \
             upgrade, which offsets first ((uv + offset) * scale), so the texture sits \
             elsewhere than in Mitsuba 0.x",
        ));
    }
    n.children.push(transform);
    Ok(())
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
        let element = |tag: &str, v: glam::DVec3| Node {
            tag: tag.into(),
            attrs: [("x", v.x), ("y", v.y), ("z", v.z)]
                .map(|(k, x)| (k.to_string(), x.to_string()))
                .to_vec(),
            children: Vec::new(),
            loc: loc.clone(),
        };
        // Applied first: the unit cube onto min..max, then the grid's to_world.
        let box_parts = [element("scale", max - min), element("translate", min)];
        n.children
            .retain(|c| !(c.tag == "point" && matches!(c.attr("name"), Some("min" | "max"))));
        match (n.children.iter_mut())
            .find(|c| c.tag == "transform" && c.attr("name") == Some("to_world"))
        {
            Some(t) => {
                t.children.splice(0..0, box_parts);
            }
            None => n.children.push(Node {
                tag: "transform".into(),
                attrs: vec![("name".into(), "to_world".into())],
                children: Vec::from(box_parts),
                loc,
            }),
        }
    } else if !n
        .children
        .iter()
        .any(|c| c.attr("name") == Some("use_grid_bbox"))
    {
        n.children.push(Node {
            tag: "boolean".into(),
            attrs: vec![
                ("name".into(), "use_grid_bbox".into()),
                ("value".into(), "true".into()),
            ],
            children: Vec::new(),
            loc: n.loc.clone(),
        });
    }
    warnings.push(n.warning(
        "Mitsuba 0.x put a grid's values on the corners of its box, Mitsuba 3 and caustic \
         at the centres of its cells: the density is shifted by up to half a voxel",
    ));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_become_snake_case_as_mitsuba_3_converts_them() {
        let cases = [
            ("toWorld", "to_world"),
            ("maxDepth", "max_depth"),
            ("intIOR", "int_ior"),
            ("specularReflectance", "specular_reflectance"),
            ("alphaU", "alpha_u"),
            ("aBcD", "a_bc_d"),
            ("useGridBBox", "use_grid_bbox"),
            ("already_snake", "already_snake"),
            ("B", "B"),
            ("color0", "color0"),
        ];
        for (camel, snake) in cases {
            assert_eq!(snake_case(camel), snake, "{camel}");
        }
    }

    #[test]
    fn versions_below_2_are_legacy() {
        assert_eq!(is_legacy("0.6.0"), Some(true));
        assert_eq!(is_legacy("0.5"), Some(true));
        assert_eq!(is_legacy("3.0.0"), Some(false));
        assert_eq!(is_legacy("2.1.0"), Some(false));
        assert_eq!(is_legacy("three"), None);
        assert_eq!(is_legacy("0.6.0.1"), None);
    }
}
