//! Stand-ins for Mitsuba 3 BSDFs that caustic does not implement: `principled` and
//! `principledthin` (Disney's BSDF), `pplastic` (polarized plastic), `hair` and
//! `measured` (tabulated RGL BRDFs). A scene that holds one still imports: the BSDF
//! becomes the nearest material caustic has, with a warning that says which and what
//! it leaves out, instead of the whole scene being refused.

use super::node::Node;
use super::params::Params;
use super::Ctx;
use crate::scene::error::Result;
use crate::scene::format::{DistributionDesc, MaterialDesc, Param, Scalar};

/// The stand-in for `<bsdf>` element `n`, or None when its plugin has none. Every
/// parameter of the element counts as read; those the stand-in ignores are listed in
/// the warning.
pub fn stand_in<'a>(
    n: &'a Node,
    p: &Params<'a>,
    ctx: &mut Ctx<'a>,
) -> Result<Option<MaterialDesc>> {
    let (desc, what) = match n.kind() {
        "principled" | "principledthin" => principled(p, ctx)?,
        "pplastic" => pplastic(p, ctx)?,
        "hair" | "measured" => (
            MaterialDesc::Diffuse {
                reflectance: Param::grey(0.5),
                two_sided: true,
            },
            "a two-sided grey diffuse (reflectance 0.5)".to_string(),
        ),
        _ => return Ok(None),
    };
    let ignored = p.take_unread();
    let ignored = match ignored.is_empty() {
        true => String::new(),
        false => format!("; ignored: {}", ignored.join(", ")),
    };
    ctx.warn(
        n,
        format!(
            "caustic has no {} BSDF: rendered as {what}, which changes the image{ignored}",
            n.kind()
        ),
    );
    Ok(Some(desc))
}

/// A number parameter; a texture there is read as its default (and so named in the
/// warning).
fn scalar(p: &Params, name: &str, default: f32) -> Result<f32> {
    if p.has_texture(name) {
        return Ok(default);
    }
    Ok(p.float(name)?.map_or(default, |v| v as f32))
}

/// Disney's BSDF as its dominant lobe: a transmissive one (`spec_trans` at least 0.5)
/// as a rough glass of its `eta` tinted by `base_color`, a metallic one (`metallic` at
/// least 0.5) as a rough mirror tinted by `base_color`, any other as a rough plastic with base
/// `base_color`; GGX of alpha = roughness^2 in each (the principled BSDF's own
/// mapping; Burley 2012).
fn principled<'a>(p: &Params<'a>, ctx: &mut Ctx<'a>) -> Result<(MaterialDesc, String)> {
    let base = p.param("base_color", ctx)?;
    let roughness = scalar(p, "roughness", 0.5)?.clamp(0.0, 1.0);
    let alpha = (roughness * roughness).max(1e-3);
    let metallic = scalar(p, "metallic", 0.0)?;
    let spec_trans = scalar(p, "spec_trans", 0.0)?;
    let eta = scalar(p, "eta", 1.5)?;
    if spec_trans >= 0.5 {
        let desc = MaterialDesc::RoughDielectric {
            distribution: DistributionDesc::Ggx,
            alpha: Some(Scalar::value(alpha)),
            alpha_u: None,
            alpha_v: None,
            int_ior: eta,
            ext_ior: 1.0,
            specular_reflectance: Param::grey(1.0),
            specular_transmittance: base.unwrap_or(Param::grey(1.0)),
        };
        return Ok((
            desc,
            format!("roughdielectric (GGX, alpha {alpha}, eta {eta})"),
        ));
    }
    if metallic >= 0.5 {
        let desc = MaterialDesc::RoughConductor {
            distribution: DistributionDesc::Ggx,
            alpha: Some(Scalar::value(alpha)),
            alpha_u: None,
            alpha_v: None,
            eta: [0.0; 3],
            k: [1.0; 3],
            specular_reflectance: base.unwrap_or(Param::grey(0.5)),
            two_sided: false,
        };
        return Ok((desc, format!("roughconductor (GGX, alpha {alpha})")));
    }
    let desc = MaterialDesc::RoughPlastic {
        distribution: DistributionDesc::Ggx,
        alpha,
        diffuse_reflectance: base.unwrap_or(Param::grey(0.5)),
        specular_reflectance: [1.0; 3],
        int_ior: eta,
        ext_ior: 1.0,
        nonlinear: false,
        two_sided: false,
    };
    Ok((
        desc,
        format!("roughplastic (GGX, alpha {alpha}, eta {eta})"),
    ))
}

/// Polarized plastic without polarization: `roughplastic` with its parameters (GGX,
/// as `pplastic` is).
fn pplastic<'a>(p: &Params<'a>, ctx: &mut Ctx<'a>) -> Result<(MaterialDesc, String)> {
    let alpha = scalar(p, "alpha", 0.1)?;
    let desc = MaterialDesc::RoughPlastic {
        distribution: DistributionDesc::Ggx,
        alpha,
        diffuse_reflectance: p
            .param("diffuse_reflectance", ctx)?
            .unwrap_or(Param::grey(0.5)),
        specular_reflectance: p.color("specular_reflectance")?.unwrap_or([1.0; 3]),
        int_ior: scalar(p, "int_ior", 1.49)?,
        ext_ior: scalar(p, "ext_ior", 1.000277)?,
        nonlinear: false,
        two_sided: false,
    };
    Ok((
        desc,
        format!("roughplastic (GGX, alpha {alpha}), unpolarized"),
    ))
}
