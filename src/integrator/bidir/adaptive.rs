//! `selection: adaptive`: efficiency-aware choice of each pixel's merge estimators
//! (Grittmann, Yazici, Georgiev and Slusallek 2022, "Efficiency-aware multiple
//! importance sampling for bidirectional rendering algorithms").
//!
//! Pilot iterations (0, 3, 15, 63, ...: 4^j - 1) render with every estimator and,
//! beside the image, each candidate's estimate of every pixel ([`super::selection`]'s
//! candidates, weighted as radius layers are: from the same subpaths and their
//! parts). Their squares are the candidates' second moments, and the merges each
//! estimator evaluated per pixel their cost beyond the rays every candidate traces.
//! After 4^j iterations each pixel takes the candidate with the least product of
//! second moment and cost over a 7 x 7 neighbourhood (the moments of a few iterations
//! are too noisy per pixel). The paper estimates the moments by reweighting the
//! current technique's samples; here each candidate's estimate is computed outright,
//! so the moments include the correlations between techniques of one path.
//!
//! The choice for iteration i depends only on the pilots before i, which are pure
//! functions of the seed: a job resumed at i, or a pool worker given iterations from
//! i on, renders the pilots it has not seen (into a film it throws away) and so makes
//! the same choices, bit for bit, for any thread count and any split of the work.

use super::Bidir;
use crate::film::Film;
use crate::integrator::paths::partial::Merge;
use crate::integrator::paths::parts::{Candidate, ALL};
use crate::integrator::RenderStats;
use crate::math::{Rgb, Vec2};
use crate::scene::Scene;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;

/// Merges cost this many traced rays each: a surface or point x point merge, a photon
/// point along a query beam, a photon beam crossing one. Measured all-in: the render
/// time an estimator adds over its merges, in units of `bpt`'s time per ray
/// (`caustic render ... --spp 4 --threads 1`, merge_depth all): surface 1.1-3.2
/// (fog-cornell, gbs_p), point x point 1.2-2.6, point x beam 2.9-3.3, beam x beam
/// 4.2-9.4, most of it in the camera's beam queries (callgrind: `beams::gather` 60-87%),
/// which a pixel that drops the estimator saves. The first guesses were 20-50 times
/// lower ([0.05, 0.05, 0.1, 0.2]). At 60 s on one core, four seeds, these give
/// fog-cornell a median RMSE of 8.8e-3 against 1.0e-2, and dense-cornell 1.68e-2
/// against 1.60e-2 (`deploy/scripts/bench-upbp.sh`, scenes/media/bench-upbp-39): fewer
/// merges kept, faster iterations. A query that finds nothing costs time that no merge
/// count sees, so neither set is the exact marginal cost of a merge.
const MERGE_COST: [f32; Merge::COUNT] = [1.5, 1.5, 3.0, 5.0];

/// The neighbourhood of a pixel whose moments and costs its choice reads: (2 R + 1)^2.
const R: usize = 3;

/// Whether iteration `i` is a pilot: i = 4^j - 1.
pub(super) fn is_pilot(i: u64) -> bool {
    let n = i + 1;
    n.is_power_of_two() && n.trailing_zeros().is_multiple_of(2)
}

/// The pilots before iteration `i`, in order.
pub(super) fn pilots_before(i: u64) -> impl Iterator<Item = u64> {
    (0..32u32)
        .map(|j| (1u64 << (2 * j)) - 1)
        .take_while(move |&p| p < i)
}

/// What one pilot iteration measured, per pixel (row-major): each candidate's value
/// (the mean of its three channels), the merges of each estimator, and the rays per
/// pixel of the whole iteration (light paths included).
pub(super) struct Pilot {
    pub candidates: Vec<Candidate>,
    pub values: Vec<f32>,
    pub merges: Vec<u32>,
    pub rays_per_pixel: f64,
}

impl Pilot {
    /// The camera pass's part: candidate `c`'s value in slot `k + c` of each pixel's
    /// `side` (three f32 bit patterns per slot, `k + n` slots a pixel), and the
    /// merge counts `merges`.
    pub fn new(
        side: &[AtomicU32],
        (k, candidates): (usize, Vec<Candidate>),
        merges: &[AtomicU32],
    ) -> Pilot {
        let n = candidates.len();
        let mut values = Vec::new();
        if n > 0 {
            for slots in side.chunks_exact(3 * (k + n)) {
                let mean = |c: usize| {
                    let v =
                        |j: usize| f32::from_bits(slots[3 * (k + c) + j].load(Ordering::Relaxed));
                    (v(0) + v(1) + v(2)) / 3.0
                };
                values.extend((0..n).map(mean));
            }
        }
        Pilot {
            candidates,
            values,
            merges: merges.iter().map(|m| m.load(Ordering::Relaxed)).collect(),
            rays_per_pixel: 0.0,
        }
    }

    /// A light-tracing splat `v` of candidate `c` at film position `p`, in the pixel
    /// that holds it.
    pub fn add_splat(&mut self, scene: &Scene, p: Vec2, v: Rgb, c: usize) {
        let (w, h) = (scene.width() as usize, scene.height() as usize);
        let n = self.candidates.len();
        let (x, y) = (
            (p.x.max(0.0) as usize).min(w - 1),
            (p.y.max(0.0) as usize).min(h - 1),
        );
        if let Some(slot) = self.values.get_mut((y * w + x) * n + c) {
            *slot += (v.x + v.y + v.z) / 3.0;
        }
    }
}

impl Bidir {
    /// An iteration of `selection: adaptive`: the pilots before it summed first (any
    /// this integrator has not seen rendered into a film that is thrown away), then
    /// either a pilot or an iteration under the choice of the pilots before it.
    pub(super) fn iterate_adaptive(
        &self,
        state: &Mutex<State>,
        scene: &Scene,
        (seed, iteration): (u64, u64),
        film: &mut Film,
    ) -> RenderStats {
        let mut st = state.lock().unwrap_or_else(|e| e.into_inner());
        st.for_seed(seed);
        let size = (scene.width() as usize, scene.height() as usize);
        let before: Vec<u64> = pilots_before(iteration).collect();
        for &p in before.iter().skip(st.pilots) {
            let mut scratch = Film::new(scene.width(), scene.height());
            let (_, pilot) = self.render(scene, (seed, p), &mut scratch, &[], true);
            st.add(&pilot.expect("a pilot measures"), size);
        }
        if is_pilot(iteration) {
            let (stats, pilot) = self.render(scene, (seed, iteration), film, &[], true);
            if st.pilots == before.len() {
                st.add(&pilot.expect("a pilot measures"), size);
            }
            return stats;
        }
        // Iteration 0 is a pilot: every other has at least one before it.
        let choice = st.choices[before.len() - 1].clone();
        drop(st);
        self.render(scene, (seed, iteration), film, &choice, false)
            .0
    }
}

/// The pilots' sums so far and the choices they made.
#[derive(Default)]
pub(super) struct State {
    seed: u64,
    /// Pilots summed (the first `pilots` of [`pilots_before`]'s sequence).
    pub pilots: usize,
    /// Per pixel and candidate, the sum of squared values.
    m2: Vec<f64>,
    /// Per pixel and estimator, the sum of merges.
    merges: Vec<f64>,
    rays: f64,
    /// The choice after each number of pilots: `choices[j]` from the first j + 1.
    pub choices: Vec<Vec<u8>>,
}

impl State {
    /// Starts over for `seed` unless it is the seed summed so far.
    pub fn for_seed(&mut self, seed: u64) {
        if self.seed != seed || self.pilots == 0 {
            *self = State {
                seed,
                ..State::default()
            };
        }
    }

    /// Adds the next pilot and chooses again.
    pub fn add(&mut self, p: &Pilot, (w, h): (usize, usize)) {
        let candidates = &p.candidates;
        let n = candidates.len();
        let pixels = w * h;
        self.m2.resize(pixels * n, 0.0);
        self.merges.resize(pixels * Merge::COUNT, 0.0);
        for (m, &v) in self.m2.iter_mut().zip(&p.values) {
            *m += (v as f64) * (v as f64);
        }
        for (m, &c) in self.merges.iter_mut().zip(&p.merges) {
            *m += c as f64;
        }
        self.rays += p.rays_per_pixel;
        self.pilots += 1;
        let choice = self.choose(candidates, (w, h));
        let mut counts = vec![0usize; n];
        for &c in &choice {
            counts[c as usize] += 1;
        }
        tracing::debug!(
            pilots = self.pilots,
            ?counts,
            "selection: pixels per candidate"
        );
        self.choices.push(choice);
    }

    /// Per pixel, the candidate with the least second moment times cost over its
    /// neighbourhood; ties (a black neighbourhood) go to the cheapest, then to the
    /// first (every estimator).
    fn choose(&self, candidates: &[Candidate], (w, h): (usize, usize)) -> Vec<u8> {
        let n = candidates.len();
        let m2 = box_filter(&self.m2, n, (w, h));
        // Merges per pixel, averaged over the neighbourhood (the moments are compared
        // across candidates only, so their sums serve).
        let merges = box_filter(&self.merges, Merge::COUNT, (w, h));
        let area = box_filter(&vec![1.0; w * h], 1, (w, h));
        let pilots = self.pilots as f64;
        (0..w * h)
            .map(|p| {
                let cost = |c: &Candidate| {
                    let kept = ALL.iter().filter(|&&k| c.keeps(k));
                    let merge: f64 = kept
                        .map(|&k| {
                            merges[p * Merge::COUNT + k as usize] / area[p]
                                * MERGE_COST[k as usize] as f64
                        })
                        .sum();
                    (self.rays + merge) / pilots
                };
                let scores = candidates.iter().enumerate().map(|(i, c)| {
                    let cost = cost(c);
                    (m2[p * n + i] / pilots * cost, cost)
                });
                // min_by keeps the first of equals.
                let best = scores
                    .enumerate()
                    .min_by(|(_, a), (_, b)| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
                best.map_or(0, |(i, _)| i) as u8
            })
            .collect()
    }
}

/// `values` (per pixel, `n` each) summed over each pixel's (2 R + 1)^2 neighbourhood,
/// clipped at the image's edges; separable, so O(pixels n R).
fn box_filter(values: &[f64], n: usize, (w, h): (usize, usize)) -> Vec<f64> {
    let mut rows = vec![0.0; values.len()];
    for y in 0..h {
        for x in 0..w {
            let (lo, hi) = (x.saturating_sub(R), (x + R).min(w - 1));
            for i in 0..n {
                rows[(y * w + x) * n + i] = (lo..=hi).map(|u| values[(y * w + u) * n + i]).sum();
            }
        }
    }
    let mut out = vec![0.0; values.len()];
    for y in 0..h {
        let (lo, hi) = (y.saturating_sub(R), (y + R).min(h - 1));
        for x in 0..w {
            for i in 0..n {
                out[(y * w + x) * n + i] = (lo..=hi).map(|v| rows[(v * w + x) * n + i]).sum();
            }
        }
    }
    out
}

#[cfg(test)]
mod tests;
