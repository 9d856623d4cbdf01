//! Mitsuba 0.x files brought to Mitsuba 3's form before anything reads them. Each
//! file is upgraded by its own version (a file without one is a 0.x file: Mitsuba 3
//! and 2 require it), element by element after its children, so an included Mitsuba 3
//! file is left as it is.
//!
//! First what Mitsuba 3's own parser does for a file whose version is below 2.0
//! (`upgrade_from_v1`): camelCase parameter names become snake_case (`toWorld` ->
//! `to_world`, `intIOR` -> `int_ior`), a diffuse BSDF's `diffuse_reflectance` becomes
//! `reflectance`, and a texture's `uoffset`, `voffset`, `uscale`, `vscale` become a
//! `to_uv` transform. Mitsuba 3 stops there, so most 0.x files still fail in it; here
//! module `forms` also rewrites the 0.x values it no longer reads (`<lookAt>`,
//! `<srgb>`, `#rrggbb`, `intent`) and module `plugins` the 0.x plugins and parameters
//! whose Mitsuba 3 form differs (films, bitmaps, media, grids, emitters), so that the
//! converters only ever see Mitsuba 3 names. What has no Mitsuba 3 form is an error at
//! its element; what changes the image is a warning. Integrators and samplers are
//! left to module `integrator`, which maps every one, 0.x or not.

mod forms;
mod plugins;

use super::node::{Loc, Node};
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
/// What changes the image (an order of operations Mitsuba 3 defines differently, a
/// filter it lacks) adds a line to `warnings`.
pub fn node(n: &mut Node, warnings: &mut Vec<String>) -> Result<()> {
    forms::element(n)?;
    if n.tag != "default" {
        if let Some(name) = n.attr("name") {
            let name = snake_case(name);
            n.set_attr("name", &name);
        }
    }
    if (n.tag.as_str(), n.kind()) == ("bsdf", "diffuse") {
        rename_child(n, "diffuse_reflectance", "reflectance");
    }
    plugins::plugin(n, warnings)?;
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

/// The index of `n`'s parameter named `name`.
fn child(n: &Node, name: &str) -> Option<usize> {
    n.children.iter().position(|c| c.attr("name") == Some(name))
}

/// Takes `n`'s parameter named `name` out of it.
fn take(n: &mut Node, name: &str) -> Option<Node> {
    child(n, name).map(|i| n.children.remove(i))
}

fn rename_child(n: &mut Node, from: &str, to: &str) {
    if let Some(i) = child(n, from) {
        n.children[i].set_attr("name", to);
    }
}

/// Takes the `<float>` (or `<integer>`) parameter named `name` out of `n`, with its
/// value.
fn take_float(n: &mut Node, name: &str) -> Result<Option<(Node, f64)>> {
    let Some(c) = take(n, name) else {
        return Ok(None);
    };
    if c.tag != "float" && c.tag != "integer" {
        return Err(c.err(format!("\"{name}\" must be a <float>")));
    }
    let v = c.attr("value").unwrap_or("");
    let x: f64 = (v.trim().parse().ok())
        .filter(|x: &f64| x.is_finite())
        .ok_or_else(|| c.err(format!("\"{v}\" is not a number")))?;
    Ok(Some((c, x)))
}

/// A new element `<tag k="v" ...>` at `loc`.
fn element(tag: &str, attrs: &[(&str, String)], loc: &Loc) -> Node {
    Node {
        tag: tag.into(),
        attrs: (attrs.iter())
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect(),
        children: Vec::new(),
        loc: loc.clone(),
    }
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
    let xy = |tag: &str, v: [f64; 2]| {
        element(
            tag,
            &[("x", v[0].to_string()), ("y", v[1].to_string())],
            &loc,
        )
    };
    let mut transform = element("transform", &[("name", "to_uv".into())], &loc);
    if offset != [0.0; 2] {
        transform.children.push(xy("translate", offset));
    }
    if scale != [1.0; 2] {
        transform.children.push(xy("scale", scale));
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

#[cfg(test)]
mod tests;
