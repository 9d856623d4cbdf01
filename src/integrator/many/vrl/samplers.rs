//! The five ways of drawing the pair of points (u on the ray light, t on the camera
//! segment) of the VRL thesis (Oppitz 2018; Novák et al. 2012, sec. 4): a density for
//! u, then a density for t given the light point y(u). The joint density is their
//! product, p(u, t) = p(u) p(t | u), and `Sampler::pdf` rebuilds exactly the densities
//! `Sampler::sample` drew from (same pair, same guarded distances, same rounding of u),
//! so an estimate f / p is unbiased whatever the geometry.

use super::advanced::{Advanced, Phases, MAX_NODES};
use super::distance::{Distance, EquiAngular, Exponential, Uniform};
use super::marginal::Marginal;
use super::pair::{v64, Pair};
use serde::{Deserialize, Deserializer, Serialize};

/// How the pair of points is drawn (`sampler` in the settings, tagged by `type`).
///
/// | type | light ray | camera ray |
/// |---|---|---|
/// | `uniform` | uniform | uniform |
/// | `exponential` | transmittance (truncated) | transmittance (truncated) |
/// | `uniform_equiangular` | uniform | equi-angular about y(u) |
/// | `joint_simple` | asinh marginal of 1/w^2 | equi-angular about y(u) |
/// | `joint_advanced` | asinh marginal of 1/w^2 | piecewise-linear fit of the phase product, `nodes` (default 10, 2..=64) |
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Sampler {
    Uniform,
    Exponential,
    UniformEquiangular,
    JointSimple,
    JointAdvanced {
        #[serde(default = "default_nodes", deserialize_with = "nodes_in_range")]
        nodes: u32,
    },
}

fn default_nodes() -> u32 {
    10
}

fn nodes_in_range<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    let n = u32::deserialize(d)?;
    if (2..=MAX_NODES as u32).contains(&n) {
        Ok(n)
    } else {
        Err(serde::de::Error::custom(format!(
            "nodes must be in 2..={MAX_NODES}, got {n}"
        )))
    }
}

/// What the samplers need of the media: the extinction each exponential density uses
/// (a majorant or a mean sigma_t in a heterogeneous medium: the estimate divides by
/// the density used, so any positive value is unbiased) and the phase functions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairMedia {
    pub sigma_light: f32,
    pub sigma_cam: f32,
    pub phases: Phases,
}

/// A drawn pair of points with its joint density (per unit u per unit t).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairSample {
    pub u: f32,
    pub t: f32,
    pub pdf: f32,
}

/// A density on one of the two segments. Lives on the stack for one sample, so the
/// large fit table is not boxed (that would allocate per sample).
#[allow(clippy::large_enum_variant)]
pub(super) enum Dist {
    Uniform(Uniform),
    Exponential(Exponential),
    EquiAngular(EquiAngular),
    Marginal(Marginal),
    Advanced(Advanced),
}

impl Dist {
    pub(super) fn sample(&self, xi: f64) -> (f64, f64) {
        match self {
            Dist::Uniform(d) => d.sample(xi),
            Dist::Exponential(d) => d.sample(xi),
            Dist::EquiAngular(d) => d.sample(xi),
            Dist::Marginal(d) => d.sample(xi),
            Dist::Advanced(d) => d.sample(xi),
        }
    }

    pub(super) fn pdf(&self, x: f64) -> f64 {
        match self {
            Dist::Uniform(d) => d.pdf(x),
            Dist::Exponential(d) => d.pdf(x),
            Dist::EquiAngular(d) => d.pdf(x),
            Dist::Marginal(d) => d.pdf(x),
            Dist::Advanced(d) => d.pdf(x),
        }
    }
}

/// Equi-angular sampling of the camera segment about the light point y(u), with the
/// pair's guarded distance, and the unit direction from the camera line to y.
pub fn equiangular_about(pair: &Pair, u: f64) -> (EquiAngular, [f64; 3]) {
    let (delta, h, n) = pair.camera_foot(pair.light.at64(u));
    let ea = EquiAngular::new(delta, h.max(pair.h_min), pair.cam.tmax as f64);
    (ea, n)
}

impl Sampler {
    /// The density of u.
    pub(super) fn light_density(&self, pair: &Pair, media: &PairMedia) -> Dist {
        let len = pair.light.tmax as f64;
        match self {
            Sampler::Uniform | Sampler::UniformEquiangular => Dist::Uniform(Uniform { len }),
            Sampler::Exponential => Dist::Exponential(Exponential {
                sigma: media.sigma_light as f64,
                len,
            }),
            Sampler::JointSimple | Sampler::JointAdvanced { .. } => {
                Dist::Marginal(Marginal::new(pair))
            }
        }
    }

    /// The density of t given u.
    pub(super) fn camera_density(&self, pair: &Pair, media: &PairMedia, u: f64) -> Dist {
        let len = pair.cam.tmax as f64;
        match *self {
            Sampler::Uniform => Dist::Uniform(Uniform { len }),
            Sampler::Exponential => Dist::Exponential(Exponential {
                sigma: media.sigma_cam as f64,
                len,
            }),
            Sampler::UniformEquiangular | Sampler::JointSimple => {
                Dist::EquiAngular(equiangular_about(pair, u).0)
            }
            Sampler::JointAdvanced { nodes } => {
                let (ea, n) = equiangular_about(pair, u);
                let (dl, dc) = (v64(pair.light.d), v64(pair.cam.d));
                let nodes = (nodes as usize).clamp(2, MAX_NODES);
                Dist::Advanced(Advanced::new(ea, dl, dc, n, &media.phases, nodes))
            }
        }
    }

    /// Draws (u, t) from two uniform numbers: xi[0] for the light ray, xi[1] for the
    /// camera ray. Always a point of both segments with a positive, finite density
    /// (`Pair::new` is where degenerate geometry is refused).
    pub fn sample(&self, pair: &Pair, media: &PairMedia, xi: [f32; 2]) -> PairSample {
        let light = self.light_density(pair, media);
        // u is rounded to f32 before t is drawn about y(u), so the conditional density
        // is the one `pdf` rebuilds from the returned u.
        let u = light.sample(xi[0] as f64).0 as f32;
        let cam = self.camera_density(pair, media, u as f64);
        let t = cam.sample(xi[1] as f64).0 as f32;
        let pdf = light.pdf(u as f64) * cam.pdf(t as f64);
        PairSample {
            u,
            t,
            pdf: pdf as f32,
        }
    }

    /// The joint density of (u, t) under `sample`: 0 outside the two segments.
    pub fn pdf(&self, pair: &Pair, media: &PairMedia, u: f32, t: f32) -> f32 {
        let pu = self.light_density(pair, media).pdf(u as f64);
        if pu == 0.0 {
            return 0.0;
        }
        (pu * self.camera_density(pair, media, u as f64).pdf(t as f64)) as f32
    }
}
