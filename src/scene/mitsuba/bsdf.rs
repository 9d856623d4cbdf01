//! `<bsdf>` plugins as caustic materials.

use super::node::Node;
use super::params::Params;
use super::Ctx;
use crate::scene::error::Result;
use crate::scene::format::{DistributionDesc, MaterialDesc, Param, Scalar, V3};

/// Conductors Mitsuba names, as RGB (eta, k): the values of Mitsuba's spectral data
/// reduced to linear sRGB that Tungsten and Mitsuba 0.6's RGB mode tabulate.
pub const CONDUCTORS: &[(&str, V3, V3)] = &[
    (
        "Au",
        [0.143119, 0.374957, 1.44248],
        [3.98316, 2.38572, 1.60322],
    ),
    (
        "Ag",
        [0.155265, 0.116723, 0.138342],
        [4.82835, 3.12225, 2.14696],
    ),
    (
        "Cu",
        [0.200438, 0.924033, 1.10221],
        [3.91295, 2.45285, 2.14219],
    ),
    (
        "Al",
        [1.65746, 0.880369, 0.521229],
        [9.22387, 6.26952, 4.837],
    ),
    ("Cr", [4.36968, 2.9167, 1.6547], [5.20643, 4.23136, 3.75469]),
];

/// Mitsuba's named indices of refraction.
const IORS: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.00004),
    ("hydrogen", 1.00013),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.333),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.47),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.575),
    ("diamond", 2.419),
];

/// The name of the material for `<bsdf>` element `n` (converted once).
pub fn material<'a>(n: &'a Node, ctx: &mut Ctx<'a>) -> Result<String> {
    if let Some(name) = ctx.name_of(n) {
        return Ok(name);
    }
    let desc = bsdf(n, ctx, 0)?;
    let name = ctx.name_for(n, "bsdf");
    ctx.materials.insert(name.clone(), desc);
    Ok(name)
}

/// Mitsuba's BSDF for shapes that name none: diffuse, reflectance 0.5, except on an
/// area emitter, whose surface absorbs (reflectance 0; Mitsuba 3's
/// src/render/shape.cpp, the constructor's default BSDF, and 0.x's `Shape::configure`).
pub fn default_material(ctx: &mut Ctx, emitter: bool) -> String {
    let (name, grey) = if emitter {
        ("mitsuba-default-emitter", 0.0)
    } else {
        ("mitsuba-default", 0.5)
    };
    ctx.materials
        .entry(name.to_string())
        .or_insert(MaterialDesc::Diffuse {
            reflectance: Param::grey(grey),
            two_sided: false,
        });
    name.to_string()
}

/// How deep BSDFs may nest (wrappers and mixtures): deeper is a BSDF that refers to
/// itself, which would otherwise recurse until the stack overflows.
const MAX_NESTING: u32 = 16;

/// The BSDF of element `n`, `depth` levels inside others.
fn bsdf<'a>(n: &'a Node, ctx: &mut Ctx<'a>, depth: u32) -> Result<MaterialDesc> {
    if n.tag != "bsdf" {
        return Err(n.err("is not a <bsdf>"));
    }
    if depth > MAX_NESTING {
        return Err(n.err(format!(
            "BSDFs nested more than {MAX_NESTING} deep (or one that refers to itself)"
        )));
    }
    let p = Params::new(n, ctx)?;
    let desc = match n.kind() {
        "diffuse" => MaterialDesc::Diffuse {
            reflectance: p.param("reflectance", ctx)?.unwrap_or(Param::grey(0.5)),
            two_sided: false,
        },
        "twosided" => {
            let inner = p
                .object(&["bsdf"], None)?
                .ok_or_else(|| n.err("needs a nested <bsdf>"))?;
            // Also what keeps a twosided that refers to itself, directly or through
            // others, from recursing until the stack overflows: only twosided nests.
            if inner.kind() == "twosided" {
                return Err(inner.err(
                    "a twosided inside a twosided (or one that refers to itself); remove \
                     the inner wrapper",
                ));
            }
            let mut desc = bsdf(inner, ctx, depth + 1)?;
            if !make_two_sided(scattering_mut(&mut desc)) {
                return Err(inner.err(
                    "twosided applies to reflecting BSDFs only (diffuse, conductor, \
                     roughconductor, plastic, roughplastic, and blends and mixtures of them); \
                     remove the twosided wrapper",
                ));
            }
            desc
        }
        "mask" => mask(n, &p, ctx, depth)?,
        "normalmap" | "bumpmap" => perturbed(n, &p, ctx, depth)?,
        "blendbsdf" => blend(n, &p, ctx, depth)?,
        "mixturebsdf" => mixture(n, &p, ctx, depth)?,
        "dielectric" => {
            let (specular_reflectance, specular_transmittance) = specular_factors(&p, ctx)?;
            MaterialDesc::Dielectric {
                int_ior: ior(&p, "int_ior", 1.5046)?,
                ext_ior: ior(&p, "ext_ior", 1.000277)?,
                specular_reflectance,
                specular_transmittance,
            }
        }
        "roughdielectric" => {
            let (distribution, alpha, alpha_u, alpha_v) = roughness(n, &p, ctx)?;
            let (specular_reflectance, specular_transmittance) = specular_factors(&p, ctx)?;
            MaterialDesc::RoughDielectric {
                distribution,
                alpha,
                alpha_u,
                alpha_v,
                int_ior: ior(&p, "int_ior", 1.5046)?,
                ext_ior: ior(&p, "ext_ior", 1.000277)?,
                specular_reflectance,
                specular_transmittance,
            }
        }
        "conductor" | "roughconductor" => conductor(n, &p, ctx)?,
        "plastic" | "roughplastic" => plastic(n, &p, ctx)?,
        "null" => MaterialDesc::Null {},
        "thindielectric" => MaterialDesc::ThinDielectric {
            int_ior: ior(&p, "int_ior", 1.5046)?,
            ext_ior: ior(&p, "ext_ior", 1.000277)?,
            specular_reflectance: p.color("specular_reflectance")?.unwrap_or([1.0; 3]),
            specular_transmittance: p.color("specular_transmittance")?.unwrap_or([1.0; 3]),
        },
        other => match super::stand_in::stand_in(n, &p, ctx)? {
            Some(desc) => desc,
            None => {
                return Err(n.err(format!(
                    "unknown or unsupported BSDF plugin \"{other}\": caustic imports diffuse, \
                 dielectric, roughdielectric, thindielectric, conductor, roughconductor, \
                 plastic, roughplastic, twosided, mask, normalmap, bumpmap, blendbsdf, mixturebsdf, null (and stands in \
                 for principled,                  pplastic, hair and measured)"
                )))
            }
        },
    };
    p.finish(&format!("the {} BSDF", n.kind()))?;
    Ok(desc)
}

/// A cut-out: the nested BSDF with an opacity (Mitsuba's default 0.5).
fn mask<'a>(n: &'a Node, p: &Params<'a>, ctx: &mut Ctx<'a>, depth: u32) -> Result<MaterialDesc> {
    let inner = p
        .object(&["bsdf"], None)?
        .ok_or_else(|| n.err("needs a nested <bsdf>"))?;
    // Masks do not nest (not even through a twosided), which also keeps a mask that
    // refers to itself from recursing until the stack overflows.
    if let Some(m) = through_twosided(inner, ctx)?.filter(|m| m.kind() == "mask") {
        return Err(m.err("a mask inside a mask (or one that refers to itself); remove one"));
    }
    Ok(MaterialDesc::Mask {
        opacity: super::texture::scalar(p.param("opacity", ctx)?.unwrap_or(Param::grey(0.5))),
        material: Box::new(bsdf(inner, ctx, depth + 1)?),
    })
}

/// The BSDF a nested `inner` wraps: inside a twosided, its nested one.
fn through_twosided<'a>(inner: &'a Node, ctx: &Ctx<'a>) -> Result<Option<&'a Node>> {
    match inner.kind() {
        "twosided" => Params::new(inner, ctx)?.object(&["bsdf"], None),
        _ => Ok(Some(inner)),
    }
}

/// Makes a reflecting material two-sided (a blend or mixture: each of its parts);
/// false for one that transmits or holds a part that does.
fn make_two_sided(desc: &mut MaterialDesc) -> bool {
    match desc {
        MaterialDesc::Diffuse { two_sided, .. }
        | MaterialDesc::Phong { two_sided, .. }
        | MaterialDesc::Mirror { two_sided, .. }
        | MaterialDesc::Conductor { two_sided, .. }
        | MaterialDesc::RoughConductor { two_sided, .. }
        | MaterialDesc::Plastic { two_sided, .. }
        | MaterialDesc::RoughPlastic { two_sided, .. } => {
            *two_sided = true;
            true
        }
        MaterialDesc::Mixture { materials, .. } | MaterialDesc::Blend { materials, .. } => {
            materials.iter_mut().all(make_two_sided)
        }
        _ => false,
    }
}

/// The material that scatters inside masks and normal maps.
fn scattering_mut(desc: &mut MaterialDesc) -> &mut MaterialDesc {
    match desc {
        MaterialDesc::Mask { material, .. }
        | MaterialDesc::NormalMap { material, .. }
        | MaterialDesc::BumpMap { material, .. } => scattering_mut(material),
        other => other,
    }
}

/// A normal map (its texture in slot `normalmap`) or bump map (any nested texture,
/// with `scale`) over the nested BSDF, with Mitsuba's options and defaults.
fn perturbed<'a>(
    n: &'a Node,
    p: &Params<'a>,
    ctx: &mut Ctx<'a>,
    depth: u32,
) -> Result<MaterialDesc> {
    let inner = p
        .object(&["bsdf"], None)?
        .ok_or_else(|| n.err("needs a nested <bsdf>"))?;
    // Only a scattering BSDF goes inside (a mask goes outside), which also keeps a
    // map that refers to itself from recursing until the stack overflows.
    let through = through_twosided(inner, ctx)?;
    if let Some(m) = through.filter(|m| matches!(m.kind(), "mask" | "normalmap" | "bumpmap")) {
        return Err(m.err(format!(
            "a {} inside a {} (or one that refers to itself): caustic takes masks outside \
             normal and bump maps, and one map per material",
            m.kind(),
            n.kind()
        )));
    }
    let material = Box::new(bsdf(inner, ctx, depth + 1)?);
    let flip_invalid_normals = p.boolean("flip_invalid_normals")?.unwrap_or(true);
    let use_shadowing_function = p.boolean("use_shadowing_function")?.unwrap_or(true);
    if n.kind() == "normalmap" {
        return Ok(MaterialDesc::NormalMap {
            normalmap: p
                .param("normalmap", ctx)?
                .ok_or_else(|| n.err("needs a \"normalmap\" texture"))?,
            material,
            flip_invalid_normals,
            use_shadowing_function,
        });
    }
    let texture = p
        .object(&["texture"], None)?
        .ok_or_else(|| n.err("needs a nested <texture>"))?;
    Ok(MaterialDesc::BumpMap {
        texture: super::texture::texture(texture, ctx)?,
        scale: p.float("scale")?.map_or(1.0, |s| s as f32),
        material,
        flip_invalid_normals,
        use_shadowing_function,
    })
}

/// Mitsuba 3's `blendbsdf`: `weight` (default 0.5, a float or texture) between two
/// nested BSDFs, in document order (what Mitsuba 3.9 does, whatever their names).
fn blend<'a>(n: &'a Node, p: &Params<'a>, ctx: &mut Ctx<'a>, depth: u32) -> Result<MaterialDesc> {
    let weight = p.scalar("weight", ctx)?.unwrap_or(Scalar::value(0.5));
    let inner = p.objects("bsdf");
    if inner.len() != 2 {
        return Err(n.err(format!("needs two nested <bsdf>s, not {}", inner.len())));
    }
    Ok(MaterialDesc::Blend {
        weight,
        materials: components(&inner, ctx, depth)?,
    })
}

/// Mitsuba 0.x's `mixturebsdf`: a comma-separated `weights` string, one weight per
/// nested BSDF. (`ensureEnergyConservation`, true by default, divides weights that
/// sum past 1 by their sum; the scene format always does.)
fn mixture<'a>(n: &'a Node, p: &Params<'a>, ctx: &mut Ctx<'a>, depth: u32) -> Result<MaterialDesc> {
    let (wnode, text) = p
        .string("weights")?
        .ok_or_else(|| n.err("needs a \"weights\" string"))?;
    let weights = (text.split([' ', ',', ';']).filter(|w| !w.is_empty()))
        .map(|w| match w.parse::<f32>() {
            Ok(x) if x >= 0.0 && x.is_finite() => Ok(x),
            _ => Err(wnode.err(format!("weight \"{w}\" is not a number >= 0"))),
        })
        .collect::<Result<Vec<f32>>>()?;
    if p.boolean("ensure_energy_conservation")? == Some(false) && weights.iter().sum::<f32>() > 1.0
    {
        return Err(n.err(
            "weights summing past 1 without energy conservation would create energy; caustic \
             divides them by their sum",
        ));
    }
    let inner = p.objects("bsdf");
    if inner.len() != weights.len() || inner.is_empty() {
        return Err(wnode.err(format!(
            "{} weights for {} nested <bsdf>s: give one weight per BSDF",
            weights.len(),
            inner.len()
        )));
    }
    Ok(MaterialDesc::Mixture {
        weights,
        materials: components(&inner, ctx, depth)?,
    })
}

/// The nested BSDFs of a blend or mixture (masks and null have nothing to weigh).
fn components<'a>(inner: &[&'a Node], ctx: &mut Ctx<'a>, depth: u32) -> Result<Vec<MaterialDesc>> {
    let mut out = Vec::with_capacity(inner.len());
    for c in inner {
        let m = bsdf(c, ctx, depth + 1)?;
        if matches!(
            m,
            MaterialDesc::Mask { .. }
                | MaterialDesc::Null {}
                | MaterialDesc::NormalMap { .. }
                | MaterialDesc::BumpMap { .. }
        ) {
            return Err(c.err(
                "a mask, null, normalmap or bumpmap inside a blend or mixture: mix scattering \
                 BSDFs only (put a mask or map outside the blend)",
            ));
        }
        out.push(m);
    }
    Ok(out)
}

/// A dielectric's `specular_reflectance` and `specular_transmittance` (default 1).
fn specular_factors<'a>(p: &Params<'a>, ctx: &mut Ctx<'a>) -> Result<(Param, Param)> {
    let factor = |name, ctx: &mut Ctx<'a>| -> Result<Param> {
        Ok(p.param(name, ctx)?.unwrap_or(Param::grey(1.0)))
    };
    Ok((
        factor("specular_reflectance", ctx)?,
        factor("specular_transmittance", ctx)?,
    ))
}

/// An index of refraction: a number or one of Mitsuba's names.
fn ior(p: &Params, key: &str, default: f32) -> Result<f32> {
    if let Some((n, s)) = p.string(key).ok().flatten() {
        return IORS
            .iter()
            .find(|(name, _)| *name == s)
            .map(|(_, v)| *v)
            .ok_or_else(|| n.err(format!("unknown index of refraction \"{s}\"")));
    }
    Ok(p.float(key)?.map_or(default, |v| v as f32))
}

/// A conductor: `conductor` (smooth; material "none" is a mirror) or `roughconductor`
/// (material "none" is Mitsuba's eta 0, k 1: Fresnel 1 at every angle).
fn conductor<'a>(n: &'a Node, p: &Params<'a>, ctx: &mut Ctx<'a>) -> Result<MaterialDesc> {
    let rough = n.kind() == "roughconductor";
    let specular_reflectance = p
        .param("specular_reflectance", ctx)?
        .unwrap_or(Param::grey(1.0));
    let named = p.string("material")?;
    let (eta, k) = match (p.color("eta")?, p.color("k")?, named) {
        (Some(eta), Some(k), None) => (eta, k),
        (None, None, Some((m, name))) if name != "none" => CONDUCTORS
            .iter()
            .find(|(c, _, _)| *c == name)
            .map(|(_, eta, k)| (*eta, *k))
            .ok_or_else(|| {
                let known: Vec<&str> = CONDUCTORS.iter().map(|c| c.0).collect();
                m.err(format!(
                    "conductor \"{name}\" has no RGB values in caustic (known: {}, none); \
                     give eta and k as <rgb>",
                    known.join(", ")
                ))
            })?,
        (None, None, _) if !rough => {
            // Mitsuba's "none": a perfect mirror.
            p.ignore(&["sample_visible"]);
            return Ok(MaterialDesc::Mirror {
                reflectance: specular_reflectance,
                two_sided: false,
            });
        }
        (None, None, _) => ([0.0; 3], [1.0; 3]),
        _ => return Err(n.err("give either eta and k, or material, not both or one")),
    };
    if !rough {
        p.ignore(&["sample_visible"]);
        return Ok(MaterialDesc::Conductor {
            eta,
            k,
            roughness: 0.0,
            specular_reflectance,
            two_sided: false,
        });
    }
    let (distribution, alpha, alpha_u, alpha_v) = roughness(n, p, ctx)?;
    Ok(MaterialDesc::RoughConductor {
        distribution,
        alpha,
        alpha_u,
        alpha_v,
        eta,
        k,
        specular_reflectance,
        two_sided: false,
    })
}

/// A rough BSDF's `distribution` and `alpha` or `alpha_u` / `alpha_v`, as given (the
/// scene format has Mitsuba's defaults). `sample_visible` is read and not needed:
/// caustic always samples visible normals, which changes the noise, not the image.
type Roughness = (
    DistributionDesc,
    Option<Scalar>,
    Option<Scalar>,
    Option<Scalar>,
);

fn roughness<'a>(n: &'a Node, p: &Params<'a>, ctx: &mut Ctx<'a>) -> Result<Roughness> {
    p.ignore(&["sample_visible"]);
    let distribution = match p.string("distribution")? {
        None => DistributionDesc::Beckmann,
        Some((_, "beckmann")) => DistributionDesc::Beckmann,
        Some((_, "ggx")) => DistributionDesc::Ggx,
        Some((d, other)) => {
            return Err(d.err(format!(
                "unknown distribution \"{other}\" (ggx or beckmann)"
            )))
        }
    };
    let alpha = p.scalar("alpha", ctx)?;
    let alpha_u = p.scalar("alpha_u", ctx)?;
    let alpha_v = p.scalar("alpha_v", ctx)?;
    match (&alpha, &alpha_u, &alpha_v) {
        (Some(_), None, None) | (None, Some(_), Some(_)) | (None, None, None) => {
            Ok((distribution, alpha, alpha_u, alpha_v))
        }
        _ => Err(n.err("give alpha, or both alpha_u and alpha_v")),
    }
}

/// `plastic` or `roughplastic` (isotropic only, as in Mitsuba 3).
fn plastic<'a>(n: &'a Node, p: &Params<'a>, ctx: &mut Ctx<'a>) -> Result<MaterialDesc> {
    let diffuse_reflectance = p
        .param("diffuse_reflectance", ctx)?
        .unwrap_or(Param::grey(0.5));
    let specular_reflectance = p.color("specular_reflectance")?.unwrap_or([1.0; 3]);
    let int_ior = ior(p, "int_ior", 1.49)?;
    let ext_ior = ior(p, "ext_ior", 1.000277)?;
    let nonlinear = p.boolean("nonlinear")?.unwrap_or(false);
    if n.kind() == "plastic" {
        return Ok(MaterialDesc::Plastic {
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            nonlinear,
            two_sided: false,
        });
    }
    let (distribution, alpha, alpha_u, alpha_v) = roughness(n, p, ctx)?;
    if alpha_u.is_some() || alpha_v.is_some() {
        return Err(n.err(
            "roughplastic is isotropic (as in Mitsuba 3): give alpha, not alpha_u and alpha_v",
        ));
    }
    let alpha = match alpha {
        None => crate::scene::format::DEFAULT_ALPHA,
        Some(a) => a.constant().ok_or_else(|| {
            n.err("roughplastic's alpha is a number in Mitsuba 3, not a texture; give a <float>")
        })?,
    };
    Ok(MaterialDesc::RoughPlastic {
        distribution,
        alpha,
        diffuse_reflectance,
        specular_reflectance,
        int_ior,
        ext_ior,
        nonlinear,
        two_sided: false,
    })
}
