//! The recursive MIS quantities of vertex connection and merging (Georgiev 2012,
//! "Implementing Vertex Connection and Merging", referred to as [TR] below).
//!
//! Each subpath vertex carries dVCM, dVC and dVM: partial sums over the techniques
//! that would have sampled the same path with the connection or merge moved towards
//! this subpath's origin, expressed relative to the current technique. A full path's
//! weight then costs O(1) per connection or merge ([TR] eq. 37). All functions here are
//! pure, so the unit tests can check that the weights of every technique sum to one.
//!
//! Densities follow [TR]: solid-angle pdfs of the BSDF include the Russian-roulette
//! continuation probability; "emission" pdfs include the light selection probability.
//!
//! Media. [TR] has surface vertices only. With distance sampling, the area-measure
//! density of a vertex x reached along a segment from x' is
//!
//!   p_A(x) = p_w(x' -> x) D(x) T(x', x) / |x - x'|^2,
//!   D(x) = |cos theta_x| at a surface, sigma_t(x) at a medium vertex,
//!
//! (volume measure at medium vertices, no cosine there, as in the path space of Pauly
//! et al. 2000, "Metropolis light transport for participating media"): T is the
//! probability that a free flight passes the segment, and sigma_t T the density of
//! stopping at x. T(x', x)
//! enters the density of whichever endpoint the segment is traced towards, exactly as
//! 1 / d^2 does, and D(x) stands where [TR] has the cosine at x. Every recursive formula
//! of [TR] therefore holds with d^2 replaced by d^2 / T and cos by D, in the MIS
//! quantities only (contributions keep the true d^2 and cosines): callers pass
//! `seg = d^2 / T` to [`Mis::on_hit`], divide light-sampling and connection densities'
//! d^2 by the connecting segment's T, and give D as the cosine of medium vertices.
//!
//! Which sigma_t and T: free flights pick a channel's exponential with probability
//! proportional to the path throughput, so their true density depends on the subpath's
//! history, is different from the two sides, and is no function of the path. MIS uses
//! a grey proxy, the same from both sides: sigma = the channel mean of sigma_t in
//! homogeneous media and T = exp(-sigma length), in closed form (exact for grey media).
//! Heterogeneous media have no closed form (the images' T is estimated by ratio
//! tracking, and a random estimate in a weight would bias it): by default a vertex
//! there has D = 1 and a piece of a segment T = 1; with `local_media_mis` D is the grey
//! sigma_t at its point and T comes from the optical depth of a fixed midpoint rule
//! over the piece (`Medium::mis_depth`), symmetric, so that both ends find the same
//! (it measured no lower variance on smoke-room and procedural-noise, at 30-45% more
//! time per iteration, hence off by default). Weights built from any positive, deterministic function of the path
//! that every technique evaluates alike still sum to one over the techniques, which is
//! all unbiasedness needs; the proxies only rank techniques less well where a medium is
//! strongly chromatic or varies faster than the quadrature sees. (D at a medium vertex
//! is a factor of every connection technique's density, so it cancels in `lt` and
//! `bpt`; a merge there has it twice, from both subpaths, which is why merging against
//! connecting needs the local sigma_t.) T is clamped below at exp(-MAX_MIS_DEPTH) so
//! that 1 / T stays finite under the power heuristic's squares.

use crate::integrator::transport::Heuristic;
use crate::math::Vec3;

/// Where a merge estimator can sit. Each site has its own kernel, whose normalisation
/// eta (the kernel's support times the number of light subpaths) ranks merging there
/// against connecting: [TR] eq. 20 has one, eta_VCM = pi r^2 N, for surfaces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Site {
    Surface = 0,
    Medium = 1,
}

/// The merge estimators (Křivánek et al. 2014, "Unifying points, beams and paths in
/// volumetric light transport simulation", referred to as [UPBP] below): photon points
/// on surfaces (2D kernel), and in media photon points at a camera point (3D), photon
/// points along a camera beam (2D) and photon beams along a camera beam (1D).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Merge {
    Surface = 0,
    Point3d = 1,
    PointBeam2d = 2,
    BeamBeam1d = 3,
}

impl Merge {
    pub const COUNT: usize = 4;
}

/// Pairs of beams closer to parallel than this sine are no beam x beam technique (its
/// density, proportional to the sine, is ~0 there, and its estimate divides by it):
/// both the estimate and the MIS leave them to the other techniques.
pub const MIN_BEAM_SIN: f32 = 1e-4;

/// The merge estimators of a technique set: eta (the kernel's support times the number
/// of light subpaths) of each, None where it is not used.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Merges {
    pub eta: [Option<f64>; Merge::COUNT],
}

impl Merges {
    /// Surface merging with radius r over N light subpaths ([TR] eq. 20).
    #[cfg(test)]
    pub fn surface(radius: f32, light_paths: f32) -> Self {
        Merges::default().with(Merge::Surface, radius, light_paths)
    }

    /// The same with estimator `k` of radius r over N light subpaths added: eta =
    /// pi r^2 N (surface; point x beam 2D), 4/3 pi r^3 N (point x point 3D), 2 r N
    /// (beam x beam 1D): each kernel's support, as [UPBP]'s normalisation.
    pub fn with(mut self, k: Merge, radius: f32, light_paths: f32) -> Self {
        let (r, n) = (radius as f64, light_paths as f64);
        let support = match k {
            Merge::Surface | Merge::PointBeam2d => std::f64::consts::PI * r * r,
            Merge::Point3d => 4.0 / 3.0 * std::f64::consts::PI * r * r * r,
            Merge::BeamBeam1d => 2.0 * r,
        };
        self.eta[k as usize] = Some(support * n);
        self
    }

    /// The kernel's normalisation 1 / eta of estimator `k`, which scales its estimate
    /// (0 where it is not used).
    pub fn norm(&self, k: Merge) -> f32 {
        self.eta[k as usize].map_or(0.0, |eta| (1.0 / eta) as f32)
    }
}

/// Per-iteration MIS constants.
///
/// With one eta, [TR] keeps dVM relative to the merge density, eta included. Here
/// each vertex x has its own sum M(x) of Mis(eta_k(x)) over the merge estimators that
/// can sit there (see [`Mis::merges`]), unknown while a subpath is traced, so
/// `Partial::dvm` is [TR]'s dVM times Mis(eta) of the merging vertex: the recursion's
/// constant 1 becomes M(x) of the vertex x it stands for, its Mis(1 / eta) becomes
/// [connections in use], and a merge's weight is Mis(eta_k(x)) / (others + M(x)).
/// With one estimator this is [TR]'s algebra exactly.
///
/// Relative to a connection at a medium vertex x (the light's density p_l(x) of x, in
/// volume measure, times the rest of the path), each volume estimator of [UPBP] has
/// density p_l(x) eta_k(x) with: point x point 3D, eta; point x beam 2D, eta / sigma
/// (a short camera beam reaches x with probability T, where the camera's free flight
/// had density sigma T: the camera's sigma is all that differs); beam x beam 1D,
/// eta sin / sigma^2 (both sides' sigma, and the 1D kernel 1 / (2 r sin) between
/// beams meeting at sine `sin` puts sin in the density). sigma is the vertex's MIS
/// factor D.
#[derive(Clone, Copy, Debug)]
pub struct Mis {
    pub heuristic: Heuristic,
    /// Mis(eta) of each merge estimator, 0 where it is not used.
    pub(crate) merge: [f64; Merge::COUNT],
    /// 1 when connections are used, else 0.
    pub(crate) vc: f64,
    /// Light subpaths per iteration (the light-tracing technique's sample count).
    pub light_paths: f64,
    /// Merging at the first camera vertex is a technique; when false it is removed
    /// from every denominator as well as from the estimator.
    pub merge_first: bool,
    /// Camera (query) beams are long and weighted as such: see [`Mis::beam_scale`].
    pub long_query: bool,
    /// `merge_depth: first`: a merge at a medium point is a technique only where the
    /// path has no medium vertex between that point and the camera (see
    /// [`Mis::cuts`]).
    pub first_medium: bool,
    /// `local_media_mis`: heterogeneous media's D and T proxies from their density
    /// (see the module notes), else 1.
    pub local_media: bool,
    /// `correlation_aware`: merges' densities scaled by Grittmann et al.'s rho
    /// ([`super::correlation`]).
    pub correlated: bool,
}

/// Optical depth beyond which the MIS transmittance of a segment stops falling.
pub const MAX_MIS_DEPTH: f32 = 20.0;

/// The MIS transmittance of a segment from its grey optical depth (see the module
/// notes): exp(-depth), clamped so that its inverse stays finite.
#[inline]
pub fn transmittance(depth: f32) -> f32 {
    (-depth.min(MAX_MIS_DEPTH)).exp()
}

/// The three partial weights of a subpath vertex. They are products of squared
/// density ratios along the whole subpath, which overflow f32 (and underflow in the
/// other factor of a weight, giving 0 x inf) in optically thin media, where free
/// flights stop ~1 / sigma_t away and D = sigma_t: hence f64, whose range covers
/// sigma_t down to ~1e-40 with the power heuristic.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Partial {
    pub dvcm: f64,
    pub dvc: f64,
    pub dvm: f64,
}

impl Mis {
    pub fn new(heuristic: Heuristic, light_paths: f32, vc: bool, merges: Merges) -> Self {
        let mut m = Mis {
            heuristic,
            merge: [0.0; Merge::COUNT],
            vc: if vc { 1.0 } else { 0.0 },
            light_paths: light_paths as f64,
            merge_first: true,
            long_query: false,
            first_medium: false,
            local_media: false,
            correlated: false,
        };
        m.merge = merges.eta.map(|eta| eta.map_or(0.0, |eta| m.f(eta)));
        m
    }

    /// The heuristic's power of a density ratio.
    #[inline]
    pub fn f(&self, x: impl Into<f64>) -> f64 {
        let x = x.into();
        match self.heuristic {
            Heuristic::Balance => x,
            Heuristic::Power => x * x,
        }
    }

    /// Mis(eta_k(x)) of estimator `k` at a vertex x whose MIS factor D is `sigma`,
    /// whose two path segments meet at sine `sin`, and whose camera-side segment has
    /// MIS transmittance `tc` (see the notes above and [`Mis::beam_scale`]; 0 where `k`
    /// is not used or cannot sit).
    #[inline]
    pub fn eta(&self, k: Merge, sigma: f32, sin: f32, tc: f32) -> f64 {
        match k {
            Merge::Surface | Merge::Point3d => self.merge[k as usize],
            _ => self.eta_short(k, sigma, sin) * self.beam_scale(tc),
        }
    }

    /// Mis(eta_k(x)) as a short query beam has it.
    #[inline]
    fn eta_short(&self, k: Merge, sigma: f32, sin: f32) -> f64 {
        let m = self.merge[k as usize];
        match k {
            Merge::Surface | Merge::Point3d => m,
            Merge::PointBeam2d => m / self.f(sigma),
            Merge::BeamBeam1d if m > 0.0 && sin >= MIN_BEAM_SIN => {
                m * self.f(sin) / self.f(sigma as f64 * sigma as f64)
            }
            Merge::BeamBeam1d => 0.0,
        }
    }

    /// The factor a query beam's estimators (point x beam, beam x beam) take in the
    /// density of a point x whose camera-side segment has MIS transmittance `tc`:
    /// Mis(P_cover / T), where P_cover is the probability that the camera beam covers
    /// x given that it starts. A short beam covers x when the camera's free flight
    /// passes it (P_cover = T: factor 1, the densities above); a long one always does
    /// (P_cover = 1: factor Mis(1 / T)), so deep along a dense segment it is far
    /// likelier to find x than the camera's own vertex sampling is, and the balance
    /// heuristic gives it that weight ([UPBP]; SmallUPBP's `PathWeight.hxx`).
    #[inline]
    pub fn beam_scale(&self, tc: f32) -> f64 {
        if self.long_query {
            1.0 / self.f(tc)
        } else {
            1.0
        }
    }

    /// The sine between a vertex's two path segments along unit directions `a` and `b`,
    /// as [`Mis::eta`] takes it: only beam x beam reads it, so 0 when that is not used.
    #[inline]
    pub fn sine(&self, a: Vec3, b: Vec3) -> f32 {
        if self.merge[Merge::BeamBeam1d as usize] > 0.0 {
            a.cross(b).length().min(1.0)
        } else {
            0.0
        }
    }

    /// M(x): the sum of Mis(eta_k(x)) over the estimators that can merge at a vertex x
    /// at `site` (as [`Mis::eta`]), `camera_len` segments from the camera on camera
    /// subpaths (0 where merging there is no technique).
    #[inline]
    pub fn merges(
        &self,
        site: Site,
        sigma: f32,
        sin: f32,
        camera_len: Option<u32>,
        tc: f32,
    ) -> f64 {
        let (points, beams) = self.merge_parts(site, sigma, sin, camera_len);
        points + beams * self.beam_scale(tc)
    }

    /// M(x) in two parts: the point estimators', and the query beams' before their
    /// [`Mis::beam_scale`]. A light subpath's vertex needs the split: its camera-side
    /// segment is the one it leaves along, whose T is known only at the next hit (see
    /// [`Mis::light_hit`]).
    #[inline]
    pub fn merge_parts(
        &self,
        site: Site,
        sigma: f32,
        sin: f32,
        camera_len: Option<u32>,
    ) -> (f64, f64) {
        if camera_len == Some(1) && !self.merge_first {
            return (0.0, 0.0);
        }
        match site {
            Site::Surface => (self.merge[Merge::Surface as usize], 0.0),
            Site::Medium => (
                self.merge[Merge::Point3d as usize],
                self.eta_short(Merge::PointBeam2d, sigma, sin)
                    + self.eta_short(Merge::BeamBeam1d, sigma, sin),
            ),
        }
    }

    /// A light subpath's segment ends at a vertex (or the point a beam estimate stands
    /// for) with MIS factor `cos`, `seg` = d^2 / T, T = `tr`: `on_hit`, after the
    /// query beams' terms `pending` of the last vertex's M(x) (held back by
    /// [`Mis::defer_terms`], summed) are completed by T.
    #[inline]
    pub fn light_hit(&self, q: Partial, pending: f64, seg: f32, tr: f32, cos: f32) -> Partial {
        let mut q = q;
        if pending != 0.0 {
            let add = pending * self.beam_scale(tr);
            q.dvc += add;
            q.dvm += add;
        }
        self.on_hit(q, seg, cos)
    }

    /// A share of dvc and dvm (an estimator's part, or the media's) through the same
    /// end of a segment as [`Mis::light_hit`], its own pending terms `pending`.
    #[inline]
    pub fn hit_share(&self, share: f64, pending: f64, tr: f32, cos: f32) -> f64 {
        let share = if pending != 0.0 {
            share + pending * self.beam_scale(tr)
        } else {
            share
        };
        share / self.f(cos)
    }

    /// Whether `merge_depth: first` takes the merges in media out of a path whose
    /// camera side (the vertices from the merge point to the camera) holds a medium
    /// vertex, `medium_seen` telling whether it does. A light subpath's partial
    /// weights then lose the part `vol` those merges contribute ([`Mis::cut`]), and
    /// a medium vertex's M(x) is 0. Which techniques exist is a function of the path
    /// alone, the same from every technique, so the weights still sum to one.
    #[inline(always)]
    pub fn cuts(&self, medium_seen: bool) -> bool {
        self.first_medium && medium_seen
    }

    /// A light subpath's partial weights without the merges in media, whose part of
    /// dvc and dvm is `vol` ([`Mis::cuts`]).
    #[inline]
    pub fn cut(&self, q: Partial, vol: f64) -> Partial {
        Partial {
            dvcm: q.dvcm,
            dvc: (q.dvc - vol).max(0.0),
            dvm: (q.dvm - vol).max(0.0),
        }
    }

    /// A light subpath leaving its emitter ([TR] eqs. 31-33, delta lights 48-50).
    /// `direct` is the density with which light sampling would pick the origin (area
    /// measure, or solid angle for lights at infinity), `emission` the density of the
    /// emitted ray; both include the light selection probability.
    #[inline]
    pub fn light_start(
        &self,
        direct: f32,
        emission: f32,
        cos: f32,
        delta: bool,
        finite: bool,
    ) -> Partial {
        let emission = emission as f64;
        let dvc = if delta {
            0.0
        } else {
            self.f(if finite { cos as f64 } else { 1.0 } / emission)
        };
        Partial {
            dvcm: self.f(direct as f64 / emission),
            dvc,
            dvm: dvc * self.vc,
        }
    }

    /// A camera subpath leaving the lens, whose ray has solid-angle density
    /// `camera_pdf` per unit pixel area ([TR] eqs. 31-33).
    #[inline]
    pub fn camera_start(&self, camera_pdf: f32) -> Partial {
        Partial {
            dvcm: self.f(self.light_paths / camera_pdf as f64),
            dvc: 0.0,
            dvm: 0.0,
        }
    }

    /// Completes the update after a segment reaches a vertex with |cos| (or, in a
    /// medium, D) `cos`. `seg` is d^2 / T of the segment, or 1 / T for a ray from a
    /// light at infinity, which has no distance ([TR] sec. 5.1); T is 1 without media.
    #[inline]
    pub fn on_hit(&self, q: Partial, seg: f32, cos: f32) -> Partial {
        let inv = 1.0 / self.f(cos);
        Partial {
            dvcm: q.dvcm * self.f(seg) * inv,
            dvc: q.dvc * inv,
            dvm: q.dvm * inv,
        }
    }

    /// Scattering at a vertex whose merges sum to `vm` (M(x), [`Mis::merges`]; [TR]
    /// eqs. 34-36; specular 53-55). `pdf_dir` and `pdf_rev` are the sampled
    /// direction's density and the reverse one, with continuation probabilities.
    #[inline]
    pub fn on_scatter(
        &self,
        q: Partial,
        vm: f64,
        cos_out: f32,
        pdf_dir: f32,
        pdf_rev: f32,
        delta: bool,
    ) -> Partial {
        let g = self.f(cos_out as f64 / pdf_dir as f64);
        if delta {
            let r = self.f(pdf_rev);
            return Partial {
                dvcm: 0.0,
                dvc: q.dvc * g * r,
                dvm: q.dvm * g * r,
            };
        }
        let r = self.f(pdf_rev);
        Partial {
            dvc: g * (q.dvc * r + q.dvcm + vm),
            dvm: g * (q.dvm * r + q.dvcm * self.vc + vm),
            dvcm: self.f(1.0 / pdf_dir as f64),
        }
    }
}
