//! Multiple importance sampling between unidirectional strategies (Veach 1997, ch. 9):
//! the heuristics, and the weights of emission found by a sampled direction against
//! next-event estimation of the same light. Shared by the path tracers and by the
//! camera paths of the photon methods.

use crate::geometry::Interaction;
use crate::math::{balance_heuristic, power_heuristic, Rgb, Vec3};
use crate::scene::Scene;
use serde::{Deserialize, Serialize};

/// How MIS weighs two strategies (the bidirectional core uses it for its partial sums
/// too: `Power` squares density ratios, `Balance` takes them as they are).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Heuristic {
    #[default]
    Power,
    Balance,
}

impl Heuristic {
    /// The MIS weight of a strategy with density `a` against one with density `b`.
    #[inline(always)]
    pub fn weight(self, a: f32, b: f32) -> f32 {
        match self {
            Heuristic::Power => power_heuristic(a, b),
            Heuristic::Balance => balance_heuristic(a, b),
        }
    }
}

/// Emission at surface `it` reached along `d` by a sampled direction of density
/// `pdf` from `prev_p`, weighted against next-event estimation of the same light
/// (weight 1 after a delta event, which light sampling cannot produce).
#[inline(always)]
pub fn emitted(
    scene: &Scene,
    it: &Interaction,
    d: Vec3,
    prev_p: Vec3,
    specular: bool,
    pdf: f32,
    h: Heuristic,
) -> Rgb {
    let Some((li, area)) = scene.area_light(it) else {
        return Rgb::ZERO;
    };
    let le = area.le(it, -d);
    if le == Rgb::ZERO || specular {
        return le;
    }
    let pdf_l = scene.light_sampler.pmf(li) * area.pdf_li(prev_p, it.p, it.ng);
    le * h.weight(pdf, pdf_l)
}

/// Environment light along an escaping direction, weighted like [`emitted`].
#[inline(always)]
pub fn escaped(scene: &Scene, d: Vec3, specular: bool, pdf: f32, h: Heuristic) -> Rgb {
    if scene.env_lights.is_empty() {
        return Rgb::ZERO;
    }
    let le = scene.env_radiance(d);
    if specular {
        le
    } else {
        le * h.weight(pdf, scene.env_pdf(d))
    }
}
