//! Chi-square goodness of fit of every sampler's samples against its own density:
//! the 1D densities, and the joint samplers on every kind of pair, the advanced one
//! at every tested asymmetry. Bins are equal-probability under the sampler (edges at
//! its quantiles), so a peaked density still spreads over many cells; expected counts
//! come from quadrature of `pdf` over each cell, so a sampler that disagrees with its
//! density moves the expected counts away from the observed ones.

use super::chi2;
use super::densities::cases;
use super::joint::{mass, media};
use super::quadrature::integrate;
use super::{pair, rng, GS, SAMPLERS};
use crate::integrator::many::vrl::{Pair, PairMedia, Sampler};

/// Sorted edges without repeats, covering [0, len].
fn edges(mut e: Vec<f64>, len: f64) -> Vec<f64> {
    e.push(0.0);
    e.push(len);
    e.sort_by(f64::total_cmp);
    e.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * len);
    e
}

fn bin(edges: &[f64], x: f64) -> usize {
    edges.partition_point(|&e| e <= x).clamp(1, edges.len() - 1) - 1
}

#[test]
fn one_dimensional_densities_fit_their_samples() {
    let (n, bins) = (40_000, 40);
    let mut ps = vec![];
    for (k, c) in cases().into_iter().enumerate() {
        let e = edges(
            (1..bins)
                .map(|i| c.dist.sample(i as f64 / bins as f64).0)
                .collect(),
            c.len,
        );
        let mut obs = vec![0.0; e.len() - 1];
        let mut r = rng(2, k as u64);
        for _ in 0..n {
            obs[bin(&e, c.dist.sample(r.next_f32() as f64).0)] += 1.0;
        }
        let exp: Vec<f64> = e
            .windows(2)
            .map(|w| n as f64 * integrate(|t| c.dist.pdf(t), w[0], w[1], &c.splits, 1e-8))
            .collect();
        ps.push(chi2::check(&c.name, &obs, &exp));
    }
    eprintln!("1D p-values in [{:.4}, {:.4}]", min(&ps), max(&ps));
}

fn min(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(0.0, f64::max)
}

/// The chi-square p-value of a joint sampler on a pair (fails below the threshold).
fn joint_fit(name: &str, s: &Sampler, p: &Pair, m: &PairMedia, seed: u64) -> f64 {
    let (n, bins) = (60_000, 12);
    let q = |i: usize| i as f32 / bins as f32;
    // u edges at the light density's quantiles; t edges at the camera density's about
    // the median light point and the uniform ones, so both the peak and the tails of
    // the conditional are resolved wherever y(u) lies.
    let eu = edges(
        (1..bins)
            .map(|i| s.sample(p, m, [q(i), 0.5]).u as f64)
            .collect(),
        p.light.tmax as f64,
    );
    let mut et: Vec<f64> = (1..bins)
        .map(|i| s.sample(p, m, [0.5, q(i)]).t as f64)
        .collect();
    et.extend((1..4).map(|i| p.cam.tmax as f64 * i as f64 / 4.0));
    let et = edges(et, p.cam.tmax as f64);
    let cols = et.len() - 1;
    let mut obs = vec![0.0; (eu.len() - 1) * cols];
    let mut r = rng(3, seed);
    for _ in 0..n {
        let x = s.sample(p, m, [r.next_f32(), r.next_f32()]);
        obs[bin(&eu, x.u as f64) * cols + bin(&et, x.t as f64)] += 1.0;
    }
    let mut exp = vec![];
    for wu in eu.windows(2) {
        for wt in et.windows(2) {
            exp.push(n as f64 * mass(s, p, m, (wu[0], wu[1]), (wt[0], wt[1]), 1e-4));
        }
    }
    chi2::check(name, &obs, &exp)
}

#[test]
fn joint_samplers_fit_their_samples() {
    let mut ps = vec![];
    let general = pair("general");
    for (k, s) in SAMPLERS.iter().enumerate() {
        ps.push(joint_fit(
            &format!("{s:?} general"),
            s,
            &general,
            &media(0.5),
            k as u64,
        ));
    }
    let adv = Sampler::JointAdvanced { nodes: 10 };
    for (k, g) in GS.into_iter().enumerate() {
        ps.push(joint_fit(
            &format!("advanced g={g} general"),
            &adv,
            &general,
            &media(g),
            10 + k as u64,
        ));
    }
    let hard = [
        "close",
        "nearly_parallel",
        "parallel",
        "nearly_intersecting",
        "intersecting",
    ];
    for (k, name) in hard.into_iter().enumerate() {
        let p = pair(name);
        for (j, s) in [Sampler::UniformEquiangular, Sampler::JointSimple, adv]
            .iter()
            .enumerate()
        {
            ps.push(joint_fit(
                &format!("{s:?} {name}"),
                s,
                &p,
                &media(0.5),
                20 + 3 * k as u64 + j as u64,
            ));
        }
        for (j, g) in [-0.95, 0.95].into_iter().enumerate() {
            ps.push(joint_fit(
                &format!("advanced g={g} {name}"),
                &adv,
                &p,
                &media(g),
                40 + 2 * k as u64 + j as u64,
            ));
        }
    }
    eprintln!("joint p-values in [{:.4}, {:.4}]", min(&ps), max(&ps));
}
