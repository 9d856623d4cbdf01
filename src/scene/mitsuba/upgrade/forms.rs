//! The 0.x forms of values that Mitsuba 3 no longer reads, as the ones it does:
//! `<lookAt>` as `<lookat>`, `<srgb>` as linear `<rgb>`, `#rrggbb` colours as numbers,
//! and no `intent` (in an RGB renderer a colour means the same whichever intent it
//! names). What has no Mitsuba 3 form (`<blackbody>`, `<animation>`, `<subsurface>`,
//! `<alias>`) is an error.

use super::super::node::Node;
use crate::scene::error::Result;

/// Element `n` in its Mitsuba 3 form, or the error that it has none.
pub fn element(n: &mut Node) -> Result<()> {
    match n.tag.as_str() {
        "lookAt" => n.tag = "lookat".into(),
        "srgb" => {
            let linear = colour_value(n)?.map(|c| crate::film::srgb_eotf(c as f32));
            n.tag = "rgb".into();
            n.set_attr("value", &linear.map(|c| c.to_string()).join(", "));
        }
        "rgb" if n.attr("value").is_some_and(|v| v.trim().starts_with('#')) => {
            let c = colour_value(n)?;
            n.set_attr("value", &join(c));
        }
        "blackbody" => {
            return Err(n.err(
                "black-body spectra are not supported (caustic renders RGB): give the \
                 colour as <rgb>",
            ))
        }
        "subsurface" => {
            return Err(n.err(
                "0.x's subsurface integrators (dipole) have no Mitsuba 3 form: give the shape \
                 a dielectric BSDF and a homogeneous interior medium (volpath renders it)",
            ))
        }
        "alias" => {
            return Err(n.err("<alias> has no Mitsuba 3 form: refer to the object by its own id"))
        }
        "animation" => {
            return Err(n.err(
                "animated transforms are not supported: give one <transform> (the pose \
                 at the shutter time you want)",
            ))
        }
        _ => {}
    }
    n.attrs.retain(|(k, _)| k != "intent");
    Ok(())
}

/// Three numbers as a `value` attribute.
pub fn join(c: [f64; 3]) -> String {
    c.map(|x| x.to_string()).join(", ")
}

/// The three numbers of a 0.x colour (`<rgb>`, `<srgb>`, `<spectrum>` or `<float>`):
/// `#rrggbb` (each byte / 255), one value, or three.
pub fn colour_value(n: &Node) -> Result<[f64; 3]> {
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
    if v.contains(':') {
        return Err(n.err(
            "spectra given by wavelength are not supported (caustic renders RGB): give an \
             <rgb> or one value",
        ));
    }
    let numbers: Vec<f64> = v
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| {
            (t.parse().ok())
                .filter(|x: &f64| x.is_finite())
                .ok_or_else(|| n.err(format!("\"{t}\" is not a number")))
        })
        .collect::<Result<_>>()?;
    match numbers.as_slice() {
        [x] => Ok([*x; 3]),
        [r, g, b] => Ok([*r, *g, *b]),
        _ => Err(n.err(format!("\"{v}\" is not one value or three (r, g, b)"))),
    }
}
