//! A whole path described by its per-vertex densities, and the MIS weights computed
//! from them explicitly, in O(path length) per weight: the definition the O(1)
//! recursion of [`super::partial`] implements (its unit tests check the one against
//! the other), and the place for the weights that the recursion cannot carry.
//!
//! Correlation-aware MIS (Grittmann, Georgiev, Slusallek, EG 2021) is one: merging
//! reuses each light subpath for every pixel, so merges at vertices that many camera
//! subpaths reach through the same light prefix are correlated, and the balance
//! heuristic, which assumes independent samples, over-weights them. The paper scales
//! each merge's density at x_j by
//!
//!   rho_j = cam_j / (cam_j + light_j - cam_j light_j),
//!
//! where cam_j is the probability (under a surrogate acceptance area A) that a camera
//! subpath reaches x_j's neighbourhood through its own vertices, the product over the
//! camera vertices x_{n-1} .. x_j of min(1, p_camera(x_i) A), and light_j the same
//! for the light subpath's vertices x_0 .. x_j. A is a disc of radius d tan(1 deg), d
//! the distance from the camera to the path's first camera vertex (a pixel's
//! footprint grows with it), and at a medium vertex the ball of that radius (its
//! densities are per volume). Merges at the first camera vertex are not correlated
//! this way (rho = 1), and rho is at least 1 / N for N light subpaths (as in the
//! paper's implementation: a merge keeps at least one light subpath's worth of
//! samples). rho depends on both whole subpaths, which is why the recursion cannot
//! carry it: the renderer's O(n) evaluator ([`super::correlation`]) walks both
//! subpaths' stored links, and the MIS unit tests check it against the explicit
//! weights here.
//!
//! Conventions, as in [`super::partial`]: x_0 is on the light (a direction for a light
//! at infinity), x_{n-1} the first camera vertex, x_n the camera; densities are in
//! area measure with the segment's MIS transmittance, and a medium vertex's "cosine"
//! is its sigma_t from both sides.

use super::correlation::{rho, Footprint};
use super::partial::{Merge, Merges, Site, MIN_BEAM_SIN};
use crate::integrator::transport::Heuristic;

/// A path x_0 (light) .. x_n (camera) by its densities and cosines.
#[derive(Clone, Debug)]
pub(crate) struct FullPath {
    /// Vertices x_0 .. x_{n-1}; x_n is the camera.
    pub n: usize,
    /// Squared length of segment (x_i, x_{i+1}).
    pub d2: Vec<f32>,
    /// MIS transmittance of segment (x_i, x_{i+1}).
    pub tr: Vec<f32>,
    /// D at x_i towards x_{i+1} (i < n) and towards x_{i-1} (i > 0): cosines at
    /// surfaces, the same sigma_t both ways at medium vertices.
    pub cf: Vec<f32>,
    pub cb: Vec<f32>,
    /// Solid-angle densities at scattering vertex i of sampling x_{i+1} (light
    /// direction) and x_{i-1} (camera direction).
    pub pl: Vec<f32>,
    pub pc: Vec<f32>,
    pub site: Vec<Site>,
    /// Sine between the two segments at each vertex (beam x beam's density).
    pub sin: Vec<f32>,
    /// Probability of picking the light.
    pub pick: f32,
    /// x_0 is a direction (environment light): positions come from a disk and
    /// light sampling picks a solid angle, with no distance or cosine at x_0.
    pub infinite: bool,
    /// Density of x_0 for light sampling (area, or solid angle at infinity),
    /// emission position (area, or on the disk) and direction.
    pub a_direct: f32,
    pub e_pos: f32,
    pub e_dir: f32,
    /// The camera's density of the first camera ray (solid angle).
    pub camera: f32,
    /// Query beams are long, weighted as such ([`super::partial::Mis::beam_scale`]).
    pub long: bool,
}

/// A technique that samples a path: a connection with `s` light vertices (0: the
/// camera subpath hits the light; 1: light sampling; n: the light subpath reaches
/// the lens), or a merge at vertex j by an estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Technique {
    Connect(usize),
    Merge(usize, Merge),
}

impl FullPath {
    /// Density of x_i sampled from the light side (area measure, or the direction
    /// for x_0 at infinity).
    pub fn fwd(&self, i: usize) -> f32 {
        match (i, self.infinite) {
            (0, false) => self.pick * self.e_pos,
            (0, true) => self.pick * self.e_dir,
            (1, false) => self.e_dir * self.cb[1] * self.tr[0] / self.d2[0],
            (1, true) => self.e_pos * self.cb[1] * self.tr[0],
            _ => self.pl[i - 1] * self.cb[i] * self.tr[i - 1] / self.d2[i - 1],
        }
    }

    /// Density of x_i sampled from the camera side.
    pub fn bwd(&self, i: usize) -> f32 {
        if i == self.n - 1 {
            self.camera * self.cf[i] * self.tr[i] / self.d2[i]
        } else if i == 0 && self.infinite {
            self.pc[1] * self.tr[0]
        } else {
            self.pc[i + 1] * self.cf[i] * self.tr[i] / self.d2[i]
        }
    }

    /// D at vertex i as the MIS takes it (1 at surfaces).
    pub fn sigma(&self, i: usize) -> f32 {
        match self.site[i] {
            Site::Surface => 1.0,
            Site::Medium => self.cf[i],
        }
    }

    /// eta_k(x_j) from its definition ([UPBP], the notes on `Mis`): 0 where the
    /// estimator is not used or cannot sit at x_j. A long query beam covers x_j with
    /// probability 1 rather than the T of the camera-side segment (x_j, x_{j+1}).
    pub fn eta(&self, j: usize, k: Merge, merges: &Merges) -> f64 {
        let Some(eta) = merges.eta[k as usize] else {
            return 0.0;
        };
        let sigma = self.sigma(j) as f64;
        let cover = if self.long { self.tr[j] as f64 } else { 1.0 };
        match (self.site[j], k) {
            (Site::Surface, Merge::Surface) => eta,
            (Site::Medium, Merge::Point3d) => eta,
            (Site::Medium, Merge::PointBeam2d) => eta / (sigma * cover),
            (Site::Medium, Merge::BeamBeam1d) if self.sin[j] >= MIN_BEAM_SIN => {
                eta * self.sin[j] as f64 / (sigma * sigma * cover)
            }
            _ => 0.0,
        }
    }

    /// The technique's density times its sample count.
    pub fn density(&self, t: Technique, merges: &Merges, light_paths: f32) -> f64 {
        let n = self.n;
        let both = |s: usize| -> f64 {
            let light: f64 = (0..s).map(|i| self.fwd(i) as f64).product();
            light * (s..n).map(|i| self.bwd(i) as f64).product::<f64>()
        };
        match t {
            Technique::Connect(1) => {
                let camera: f64 = (1..n).map(|i| self.bwd(i) as f64).product();
                (self.pick * self.a_direct) as f64 * camera
            }
            Technique::Connect(s) if s == n => light_paths as f64 * both(n),
            Technique::Connect(s) => both(s),
            Technique::Merge(j, k) => self.eta(j, k, merges) * both(j) * self.fwd(j) as f64,
        }
    }

    /// Grittmann et al.'s correlation factor rho_j of a merge at x_j (the module
    /// notes), with the surrogate footprint from the first camera segment (a disc at
    /// surfaces, a ball in media) and at least 1 / `light_paths`.
    pub fn correlation(&self, j: usize, light_paths: f32) -> f64 {
        let n = self.n;
        if j + 1 >= n {
            return 1.0; // the first camera vertex: no correlation
        }
        let fp = Footprint::new(self.d2[n - 1].sqrt());
        let accept = |i: usize, p: f32| fp.accept(p, self.site[i] == Site::Medium);
        let cam: f64 = (j..n).map(|i| accept(i, self.bwd(i))).product();
        // A light at infinity has no position to accept: its direction's density
        // is not an area density.
        let first = usize::from(self.infinite);
        let light: f64 = (first..=j).map(|i| accept(i, self.fwd(i))).product();
        rho(cam, light, light_paths as f64)
    }

    /// The techniques that can sample this path: connections where `connects`, and
    /// each estimator of `merges` at each vertex where it can sit (not the first
    /// camera vertex unless `merge_first`; under `merge_depth: first`, `first_medium`,
    /// no merge in a medium with a medium vertex between it and the camera).
    pub fn techniques(
        &self,
        merges: &Merges,
        connects: bool,
        merge_first: bool,
        first_medium: bool,
    ) -> Vec<Technique> {
        let n = self.n;
        let mut out = Vec::new();
        if connects {
            out.extend((0..=n).map(Technique::Connect));
        }
        let last = if merge_first { n } else { n - 1 };
        for j in 1..last {
            let camera_side_medium = (j + 1..n).any(|i| self.site[i] == Site::Medium);
            let cut = first_medium && self.site[j] == Site::Medium && camera_side_medium;
            let ks = [
                Merge::Surface,
                Merge::Point3d,
                Merge::PointBeam2d,
                Merge::BeamBeam1d,
            ];
            let can = ks
                .into_iter()
                .filter(|&k| !cut && self.eta(j, k, merges) > 0.0);
            out.extend(can.map(|k| Technique::Merge(j, k)));
        }
        out
    }

    /// The weight of technique `t` among `techs` under `heuristic`, each merge's
    /// density scaled by its correlation factor when `correlated`.
    pub fn weight(
        &self,
        t: Technique,
        techs: &[Technique],
        (merges, light_paths): (&Merges, f32),
        heuristic: Heuristic,
        correlated: bool,
    ) -> f64 {
        let p = |t: Technique| {
            let mut p = self.density(t, merges, light_paths);
            if let (Technique::Merge(j, _), true) = (t, correlated) {
                p *= self.correlation(j, light_paths);
            }
            match heuristic {
                Heuristic::Balance => p,
                Heuristic::Power => p * p,
            }
        };
        let total: f64 = techs.iter().map(|&u| p(u)).sum();
        if total > 0.0 {
            p(t) / total
        } else {
            0.0
        }
    }
}
