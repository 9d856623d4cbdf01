//! Next-event estimation: one light picked by the scene's light sampler, one point on
//! it, and the shadow ray that decides whether it is seen, from a surface vertex or a
//! scattering point in a medium. The tracers differ only in what they do with the
//! link: the path tracers weight it by MIS against their own scattering (keeping the
//! shadow ray for later, as `pt` does, or tracing it through media at once), the photon
//! methods take it alone. Random numbers: one for the light, two for the point.

use crate::geometry::offset::SHADOW_EPSILON;
use crate::geometry::{spawn_ray, spawn_ray_to, Interaction, Ray};
use crate::integrator::RenderStats;
use crate::light::LightSample;
use crate::material::{Material, Mode};
use crate::math::{Frame, Rgb, Rng, Vec3};
use crate::medium::Phase;
use crate::scene::Scene;

/// Where next-event estimation starts.
#[derive(Clone, Copy)]
pub enum Origin<'a> {
    /// A non-delta surface vertex; `wo` points back along the path, in `frame`.
    Surface {
        it: &'a Interaction,
        frame: &'a Frame,
        wo: Vec3,
        m: &'a Material,
    },
    /// A scattering point in a medium, reached travelling along `d`.
    Medium { p: Vec3, d: Vec3, phase: &'a Phase },
}

impl Origin<'_> {
    #[inline(always)]
    pub fn p(&self) -> Vec3 {
        match self {
            Origin::Surface { it, .. } => it.p,
            Origin::Medium { p, .. } => *p,
        }
    }
}

/// A light sample seen from an [`Origin`], its shadow ray not yet traced.
#[derive(Clone, Copy, Debug)]
pub struct LightLink {
    /// The light's index in the scene.
    pub light: usize,
    /// From the origin (offset off its surface) to the light point, or towards a light
    /// at infinity.
    pub ray: Ray,
    /// Unit direction towards the light.
    pub wi: Vec3,
    /// The BSDF (cosine included) or phase function towards the light.
    pub f: Rgb,
    /// The light's radiance (or intensity / d^2) along `wi`.
    pub li: Rgb,
    /// Selection probability times the light's solid-angle density of `wi` (1 for
    /// delta lights).
    pub pdf_light: f32,
    /// The origin's own solid-angle density of scattering into `wi` (no roulette).
    pub pdf_scatter: f32,
    /// The light is a delta light: no scattering sample can find it.
    pub delta: bool,
}

/// The first move of every next-event estimator, shared with the bidirectional
/// camera walk: a light by the scene's light sampler and a point on it seen from `p`.
/// Returns the light's index, its selection probability and the sample; None when
/// the scene has no light or the sample has no density.
#[inline(always)]
pub fn pick_light(scene: &Scene, p: Vec3, rng: &mut Rng) -> Option<(usize, f32, LightSample)> {
    if scene.lights.is_empty() {
        return None;
    }
    let (light, sel_pdf, _) = scene.light_sampler.sample(rng.next_f32());
    let ls = scene.lights[light].sample_li(p, rng.next_2d())?;
    (ls.pdf > 0.0 && sel_pdf > 0.0).then_some((light, sel_pdf, ls))
}

/// Samples a light from `at` (None when the scene has no light, the sample has no
/// density, arrives through the geometric surface, or the origin does not scatter
/// towards it). Counts the shadow ray it returns in `stats`.
#[inline(always)]
pub fn sample_light(
    scene: &Scene,
    at: &Origin,
    rng: &mut Rng,
    stats: &mut RenderStats,
) -> Option<LightLink> {
    let (light, sel_pdf, ls) = pick_light(scene, at.p(), rng)?;
    let (f, pdf_scatter, ray) = match *at {
        Origin::Surface { it, frame, wo, m } => {
            let wi = frame.to_local(ls.wi());
            // Light arriving from behind the geometric surface would leak through it.
            if (ls.wi().dot(it.ng) > 0.0) != (wi.z > 0.0) {
                return None;
            }
            let (f, pdf, _) = m.eval_pdfs(wo, wi, Mode::Radiance);
            if f == Rgb::ZERO {
                return None;
            }
            let ray = if ls.dist.is_finite() {
                spawn_ray_to(it.p, it.p_err, it.ng, ls.p(), Vec3::ZERO, Vec3::ZERO)
            } else {
                spawn_ray(it.p, it.p_err, it.ng, ls.wi())
            };
            (f, pdf, ray)
        }
        Origin::Medium { p, d, phase } => {
            let ph = phase.eval(d, ls.wi());
            if ph == 0.0 {
                return None;
            }
            // A medium point has no surface to leave: no offset at the start.
            let ray = if ls.dist.is_finite() {
                Ray {
                    o: p,
                    d: ls.p() - p,
                    tmax: 1.0 - SHADOW_EPSILON,
                }
            } else {
                Ray::new(p, ls.wi())
            };
            (Rgb::splat(ph), ph, ray)
        }
    };
    stats.shadow_rays += 1;
    Some(LightLink {
        light,
        ray,
        wi: ls.wi(),
        f,
        li: ls.li(),
        pdf_light: sel_pdf * ls.pdf,
        pdf_scatter,
        delta: ls.delta,
    })
}

impl LightLink {
    /// f Li / p_light: the unweighted estimate (light sampling alone).
    #[inline(always)]
    pub fn unweighted(&self) -> Rgb {
        self.f * self.li / self.pdf_light
    }
}

/// [`sample_light`] through media: the link and the transmittance along its shadow ray
/// through media and `null` boundaries (0 when something opaque blocks it), the move
/// that `volpath` and [`direct_unweighted`] share. `medium` is the one the path
/// travels in at the origin. The shadow ray's tracking rays count in `stats`.
#[inline(always)]
pub fn sample_light_through(
    scene: &Scene,
    at: &Origin,
    medium: Option<u32>,
    rng: &mut Rng,
    stats: &mut RenderStats,
) -> Option<(LightLink, Rgb)> {
    let link = sample_light(scene, at, rng, stats)?;
    let start = match at {
        Origin::Surface { it, .. } => scene.medium_after(it, link.wi, medium),
        Origin::Medium { .. } => medium,
    };
    let tr = scene.transmittance(&link.ray, start, rng, &mut stats.shadow_rays);
    Some((link, tr))
}

/// Light sampling alone from `at`, through media and null boundaries (`medium`: the
/// one the path travels in there): f T Li / p_light, counted as a connection. For the
/// photon methods, whose camera paths count emitters only after specular events, so
/// that no scattering sample competes.
#[inline(always)]
pub fn direct_unweighted(
    scene: &Scene,
    at: &Origin,
    medium: Option<u32>,
    rng: &mut Rng,
    stats: &mut RenderStats,
) -> Rgb {
    let Some((link, tr)) = sample_light_through(scene, at, medium, rng, stats) else {
        return Rgb::ZERO;
    };
    stats.connections += 1;
    link.f * tr * link.li / link.pdf_light
}
