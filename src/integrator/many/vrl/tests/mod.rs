//! Tests of the ray-light samplers and estimators. Fixtures here: a light segment on
//! the x axis against camera segments in every configuration the samplers must
//! survive, homogeneous media, and deterministic random streams.

mod beam;
mod chi2;
mod degenerate;
mod densities;
mod estimates;
mod fit;
mod joint;
mod quadrature;
mod settings;
mod variance;

use super::{Grey, Pair, Phases, Sampler, Segment};
use crate::math::{Rng, Vec3};
use crate::medium::Phase;

/// Every sampler, the advanced one with its default node count.
pub const SAMPLERS: [Sampler; 5] = [
    Sampler::Uniform,
    Sampler::Exponential,
    Sampler::UniformEquiangular,
    Sampler::JointSimple,
    Sampler::JointAdvanced { nodes: 10 },
];

/// The asymmetries the advanced sampler is tested at.
pub const GS: [f32; 5] = [-0.95, -0.5, 0.0, 0.5, 0.95];

/// The ray light: y(u) = (u, 0, 0), u in [0, 2].
pub fn light() -> Segment {
    Segment::new(Vec3::ZERO, Vec3::X, 2.0)
}

fn cam(o: [f32; 3], d: [f32; 3], tmax: f32) -> Segment {
    Segment::new(Vec3::from(o), Vec3::from(d).normalize(), tmax)
}

/// The camera segments, by name: skew at 0.3, skew at 0.02 (the close pair), nearly
/// and exactly parallel, nearly (1e-4) and exactly intersecting.
pub fn cameras() -> Vec<(&'static str, Segment)> {
    vec![
        ("general", cam([1.2, -1.0, 0.3], [-0.3, 1.0, 0.05], 2.5)),
        ("close", close_camera()),
        (
            "nearly_parallel",
            cam([-0.5, 0.3, 0.1], [1.0, 1e-4, 0.0], 3.0),
        ),
        ("parallel", cam([-0.5, 0.3, 0.1], [1.0, 0.0, 0.0], 3.0)),
        (
            "nearly_intersecting",
            cam([1.0, -1.0, 1e-4], [0.0, 1.0, 0.0], 2.0),
        ),
        ("intersecting", cam([1.0, -1.0, 0.0], [0.0, 1.0, 0.0], 2.0)),
    ]
}

/// Passes 0.02 from the light segment, at an angle, within both segments.
pub fn close_camera() -> Segment {
    cam([0.8, -1.0, 0.02], [0.2, 1.0, 0.0], 2.0)
}

pub fn pair_with(cam: Segment) -> Pair {
    Pair::new(light(), cam).expect("fixture segments have length")
}

/// The pair of a named camera.
pub fn pair(name: &str) -> Pair {
    let (_, c) = cameras().into_iter().find(|(n, _)| *n == name).unwrap();
    pair_with(c)
}

pub fn hg(g: f32) -> Phase {
    if g == 0.0 {
        Phase::Isotropic
    } else {
        Phase::HenyeyGreenstein { g }
    }
}

pub fn medium(g: f32) -> Grey {
    Grey {
        sigma_s: 0.8,
        sigma_t: 1.0,
        phase: hg(g),
    }
}

pub fn phases(g: f32) -> Phases {
    Phases {
        light: hg(g),
        cam: hg(g),
    }
}

/// A deterministic stream per test and case.
pub fn rng(test: u64, case: u64) -> Rng {
    Rng::new(0x7672_6c20, test, case)
}

/// Where the joint densities peak on the light segment (closest approach) ...
pub fn u_splits(p: &Pair) -> [f64; 1] {
    [p.u0]
}

/// ... and on the camera segment given u (the foot of the perpendicular from y(u)).
pub fn t_splits(p: &Pair) -> impl Fn(f64) -> [f64; 1] + '_ {
    move |u| [p.camera_foot(p.light.at64(u)).0]
}
