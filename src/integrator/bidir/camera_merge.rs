//! Merging at a camera vertex: the surface photons within the radius, and in media the
//! light vertices of the same medium (point x point 3D), each weighted by the MIS and,
//! with radius layers, under every layer's.

use super::merge::{MergeSet, MergeVertex};
use super::radius_layers::{light_q, RadiusSums};
use super::selection::{rule, Rule};
use super::{Pass, Workspace};
use crate::integrator::paths::correlation::{merge_fixes, CameraSide, Chain, Link};
use crate::integrator::paths::partial::{Merge, Mis, Partial, Site};
use crate::integrator::paths::parts::{Candidate, MEDIA};
use crate::integrator::paths::vertex::MediumPoint;
use crate::integrator::paths::walk::{Surface, Walk, MIN_COS};
use crate::integrator::RenderStats;
use crate::material::Mode;
use crate::math::{Rgb, Vec3};
use std::sync::atomic::AtomicU32;

/// Merging with every stored light vertex within the radius ([TR] eqs. 38-39), with
/// the constant kernel 1 / (pi r^2) and the 1 / N of the light paths.
#[inline(always)]
pub(super) fn merge<const RADII: bool>(
    pass: &Pass,
    ws: &Workspace,
    (walk, cand, side): (&Walk, Option<&Candidate>, Option<CameraSide>),
    (it, surface): (&crate::geometry::Interaction, &Surface),
    stats: &mut RenderStats,
    slots: &[AtomicU32],
) -> Rgb {
    if !pass.uses(Merge::Surface) {
        return Rgb::ZERO;
    }
    let k = Merge::Surface;
    let at = (walk.q, &walk.parts);
    let Some(rule) = rule(pass, cand, at, k, &[k]) else {
        return Rgb::ZERO;
    };
    let qc = rule.camera(pass, walk.q, &walk.parts);
    // The camera side's acceptance product, the same for every light vertex.
    let sided = side.map(|s| (s, s.chain(None, 0.0).total(&s.fp)));
    let mut sum = Rgb::ZERO;
    let mut merges = 0u64;
    let cut = pass.mis.cuts(walk.medium_seen);
    let set = &ws.surface;
    let mut radii = RadiusSums::<RADII>::new(pass, walk, Merge::Surface);
    let r2 = pass.radii[Merge::Surface as usize].powi(2);
    set.grid.query_sorted_in(
        it.p,
        &set.merge,
        #[inline(always)]
        |y, d2| {
            if y.len + walk.len > pass.s.max_depth {
                return;
            }
            let Some(e) = surface.eval(y.wo, Mode::Radiance) else {
                return;
            };
            if e.cos < MIN_COS {
                return;
            }
            let (dir, rev) = (e.pdf_dir * surface.cont, e.pdf_rev * y.cont);
            // The photon's flux already holds the cosine at its surface: f without it.
            let c = y.throughput * e.f;
            let weighted = |mis: &Mis, yq, q, rho: f64| {
                let eta = mis.eta(Merge::Surface, 1.0, 0.0, 1.0) * rho;
                mis.weight_merge(yq, q, (eta, eta), dir, rev)
            };
            let weight = |mis: &Mis, yq, q| weighted(mis, yq, q, 1.0);
            radii.add(set, y, d2, cut, |mis, yq, q| {
                c * (weight(mis, yq, q) / e.cos)
            });
            if d2 > r2 {
                return; // within a radius layer's radius only
            }
            let w = match sided {
                None => point_weight(pass, (rule, k), (set, y, cut), (walk.q, qc), weight),
                Some(s) => {
                    let links = ws.links_of(set, y);
                    correlated_weight(pass, s, links, (dir, rev), (y.q, walk.q), weighted)
                }
            };
            merges += 1;
            sum += c * (w / e.cos);
        },
    );
    stats.merges += merges;
    radii.record(walk.throughput, slots);
    sum * pass.norms[Merge::Surface as usize]
}

/// Merging at a medium vertex x with the stored light vertices of the same medium
/// within the medium radius (point x point 3D): the kernel 1 / (4/3 pi r^3), the
/// phase function at x, and 1 / N; throughput included. The camera's throughput holds
/// the flight's sigma_s(x) T / pdf and each light vertex's its own sigma_s: the merged
/// path has one scattering event, so the camera's sigma_s(x) is divided out (as
/// `vpm`'s point estimate does).
#[inline(always)]
pub(super) fn merge_medium<const RADII: bool>(
    pass: &Pass,
    ws: &Workspace,
    (walk, cand, side): (&Walk, Option<&Candidate>, Option<CameraSide>),
    (x, m): (Vec3, &MediumPoint),
    stats: &mut RenderStats,
    slots: &[AtomicU32],
) -> Rgb {
    let Some(medium) = walk.medium.filter(|_| pass.uses(Merge::Point3d)) else {
        return Rgb::ZERO;
    };
    if pass.mis.cuts(walk.medium_seen) {
        return Rgb::ZERO;
    }
    let k = Merge::Point3d;
    let Some(rule) = rule(pass, cand, (walk.q, &walk.parts), k, &MEDIA) else {
        return Rgb::ZERO;
    };
    let qc = rule.camera(pass, walk.q, &walk.parts);
    // The camera side's acceptance product, the same for every light vertex.
    let sided = side.map(|s| (s, s.chain(None, 0.0).total(&s.fp)));
    let sigma_s = pass.scene.media[medium as usize].sigma_s_at(x);
    let beta = Rgb::select(
        sigma_s.cmpgt(Rgb::ZERO),
        walk.throughput / sigma_s,
        Rgb::ZERO,
    );
    if beta == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let mut sum = Rgb::ZERO;
    let mut merges = 0u64;
    let set = &ws.medium;
    let mut radii = RadiusSums::<RADII>::new(pass, walk, Merge::Point3d);
    let r2 = pass.radii[Merge::Point3d as usize].powi(2);
    // A merge in a medium is on the camera side of the light's earlier vertices.
    let cut = pass.mis.first_medium;
    set.grid.query_sorted_in(
        x,
        &set.merge,
        #[inline(always)]
        |y, d2| {
            if y.medium != medium || y.len + walk.len > pass.s.max_depth {
                return;
            }
            let ph = m.phase.eval(-m.wo, y.wo);
            if ph <= 0.0 {
                return;
            }
            let (dir, rev) = (ph * m.cont, ph * y.cont);
            let sin = pass.mis.sine(m.wo, y.wo);
            let weighted = |mis: &Mis, yq, q, rho: f64| {
                let own = mis.eta(Merge::Point3d, m.sigma, sin, walk.tr) * rho;
                let all = mis.merges(Site::Medium, m.sigma, sin, None, walk.tr) * rho;
                mis.weight_merge(yq, q, (own, all), dir, rev)
            };
            let weight = |mis: &Mis, yq, q| weighted(mis, yq, q, 1.0);
            radii.add(set, y, d2, cut, |mis, yq, q| {
                y.throughput * (ph * weight(mis, yq, q))
            });
            if d2 > r2 {
                return; // within a radius layer's radius only
            }
            let w = match sided {
                None => point_weight(pass, (rule, k), (set, y, cut), (walk.q, qc), weight),
                Some(s) => {
                    let links = ws.links_of(set, y);
                    correlated_weight(pass, s, links, (dir, rev), (y.q, walk.q), weighted)
                }
            };
            merges += 1;
            sum += y.throughput * (ph * w);
        },
    );
    stats.merges += merges;
    radii.record(beta, slots);
    beta * sum * pass.norms[Merge::Point3d as usize]
}

/// The correlation-aware weight of a merge at the camera's last vertex with the light
/// vertex whose subpath's links end in `links`, from `weighted(mis, light, camera,
/// rho)`; `camera_dir`, `camera_rev` and the partial weights `(yq, q)` as
/// [`Mis::weight_merge`] takes them.
#[inline(always)]
fn correlated_weight(
    pass: &Pass,
    (side, ct): (CameraSide, f64),
    links: &[Link],
    (camera_dir, camera_rev): (f32, f32),
    (yq, q): (Partial, Partial),
    weighted: impl Fn(&Mis, Partial, Partial, f64) -> f32,
) -> f32 {
    let (lc, cc) = (
        Chain::light(links, camera_dir),
        side.chain(None, camera_rev),
    );
    let mis = &pass.mis;
    let (fl, fc) = merge_fixes(mis, &side.fp, lc, (cc, ct));
    weighted(mis, fl.apply(yq), fc.apply(q), fc.rho)
}

/// A merge's weight at a camera vertex with light vertex `y` of `set` (its partial
/// weights cut if `cut`): the job's, or the pixel's `rule` for estimator `k`, from
/// `weight(mis, light, camera)`; `q` is the camera side's partial weights, as the job
/// and as the rule has them.
#[inline(always)]
fn point_weight(
    pass: &Pass,
    (rule, k): (Rule, Merge),
    (set, y, cut): (&MergeSet, &MergeVertex, bool),
    (q, qc): (Partial, Partial),
    weight: impl Fn(&Mis, Partial, Partial) -> f32,
) -> f32 {
    let yq = if cut { pass.mis.cut(y.q, y.vol()) } else { y.q };
    let sides = |scale: &_| {
        let light = light_q(pass, (y.q, y.vol(), set.parts_of(y)), cut, scale);
        (light, qc)
    };
    rule.weight(k, (yq, q), sides, weight, &pass.mis)
}
