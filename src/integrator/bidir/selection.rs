//! Per-pixel merge estimators (efficiency-aware selection, Grittmann, Yazici,
//! Georgiev and Slusallek 2022): a pixel whose [`Candidate`] drops an estimator weighs
//! its camera subpath's techniques as if that estimator were off, and skips its
//! queries wherever a kept technique covers every path they could find. The light
//! subpaths are traced once under the job's MIS; their [`Parts`] carry them to each
//! pixel's weights ([`crate::integrator::paths::parts`]).

use super::Pass;
use crate::integrator::paths::partial::{Merge, Mis, Partial};
use crate::integrator::paths::parts::{dropped_weight, Candidate, Parts, Scale, ALL};
use crate::integrator::paths::walk::Walk;

/// How the main image weighs merges by one estimator at one camera vertex or query.
#[derive(Clone, Copy)]
pub(super) enum Rule<'p> {
    /// The job's own weights.
    Job,
    /// Under the candidate, which keeps the estimator.
    Kept(&'p Candidate),
    /// The candidate drops it, but the camera side alone does not rule out paths
    /// only this merge finds (see [`dropped_weight`]).
    Dropped(&'p Candidate),
}

/// The MIS and camera partial weights under which the main image weighs techniques
/// at `walk`: the pixel's candidate's, or the job's.
#[inline(always)]
pub(super) fn camera_main<'p>(
    pass: &'p Pass,
    cand: Option<&'p Candidate>,
    walk: &Walk,
) -> (&'p Mis, Partial) {
    match cand {
        Some(c) => (&c.mis, pass.mis.rescale(walk.q, &walk.parts, &c.scale)),
        None => (&pass.mis, walk.q),
    }
}

/// The rule for merges by `k` where the camera side's partial weights are `q` with
/// `parts`, at a vertex where the estimators `site` may sit; None where the pixel's
/// candidate drops `k` and [`camera_rules_out`] such merges, which are then not
/// queried.
#[inline(always)]
pub(super) fn rule<'p>(
    pass: &Pass,
    cand: Option<&'p Candidate>,
    (q, parts): (Partial, &Parts),
    k: Merge,
    site: &[Merge],
) -> Option<Rule<'p>> {
    let Some(c) = cand else {
        return Some(Rule::Job);
    };
    if c.keeps(k) {
        return Some(Rule::Kept(c));
    }
    let qc = pass.mis.rescale(q, parts, &c.scale);
    let covering = |j: &Merge| *j != Merge::BeamBeam1d && pass.uses(*j) && c.keeps(*j);
    let kept_here = site.iter().any(covering);
    (!camera_rules_out(c, qc, kept_here)).then_some(Rule::Dropped(c))
}

/// Whether a kept technique has density on every path that a merge by a dropped
/// estimator at this camera vertex could find, whatever the light vertex: the camera
/// side connects to it or to an earlier vertex (`qc`, its partial weights under `c`),
/// or a kept estimator merges here (`kept_here`: surface, point x point or point x
/// beam, whose Mis(eta) is never 0 where they sit; beam x beam's is below its least
/// sine). Then every such merge weighs 0 ([`dropped_weight`]).
#[inline(always)]
pub(super) fn camera_rules_out(c: &Candidate, qc: Partial, kept_here: bool) -> bool {
    kept_here || qc.dvcm * c.mis.vc > 0.0 || qc.dvm > 0.0
}

impl Rule<'_> {
    /// The camera side's partial weights `q` (with `parts`) as this rule weighs them.
    #[inline(always)]
    pub fn camera(&self, pass: &Pass, q: Partial, parts: &Parts) -> Partial {
        match *self {
            Rule::Job => q,
            Rule::Kept(c) | Rule::Dropped(c) => pass.mis.rescale(q, parts, &c.scale),
        }
    }

    /// A merge's weight by estimator `k`: `weight(mis, light, camera)` under a MIS and
    /// both sides' partial weights, `job` the job's (light, camera) and `sides(scale)`
    /// theirs under other factors.
    #[inline(always)]
    pub fn weight(
        &self,
        k: Merge,
        job: (Partial, Partial),
        sides: impl FnOnce(&Scale) -> (Partial, Partial),
        weight: impl Fn(&Mis, Partial, Partial) -> f32,
        job_mis: &Mis,
    ) -> f32 {
        match *self {
            Rule::Job => weight(job_mis, job.0, job.1),
            Rule::Kept(c) => {
                let (ql, qc) = sides(&c.scale);
                weight(&c.mis, ql, qc)
            }
            Rule::Dropped(c) => {
                let (ql, qc) = sides(&c.scale);
                let restored = weight(&c.restored[k as usize], ql, qc);
                dropped_weight(restored, || weight(job_mis, job.0, job.1))
            }
        }
    }
}

/// A pass's candidates: the first keeps every estimator it uses; then none; then, in
/// media, the surface alone and the surface with each media estimator.
pub(super) fn candidates(pass: &crate::integrator::paths::Pass) -> Vec<Candidate> {
    let used = ALL.map(|k| pass.uses(k));
    let mut sets = vec![used, [false; Merge::COUNT]];
    let media: Vec<Merge> = ALL[1..]
        .iter()
        .copied()
        .filter(|&k| used[k as usize])
        .collect();
    if !media.is_empty() {
        let surface = used[Merge::Surface as usize];
        let mut only = [false; Merge::COUNT];
        only[Merge::Surface as usize] = surface;
        sets.push(only);
        if media.len() > 1 {
            for k in media {
                let mut with = only;
                with[k as usize] = true;
                sets.push(with);
            }
        }
    }
    let mut out: Vec<[bool; Merge::COUNT]> = Vec::new();
    for s in sets {
        if !out.contains(&s) {
            out.push(s);
        }
    }
    out.iter().map(|&s| Candidate::new(&pass.mis, s)).collect()
}

#[cfg(test)]
pub(super) mod tests;
