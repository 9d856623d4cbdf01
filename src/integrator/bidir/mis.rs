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
//! Heterogeneous media have no closed form (T is estimated by ratio tracking, and a
//! random estimate in a weight would bias it): their pieces of a segment get T = 1 and
//! their vertices D = 1. Weights built from any positive, deterministic function of the
//! path that every technique evaluates alike still sum to one over the techniques,
//! which is all unbiasedness needs; the proxies only rank techniques less well where a
//! medium is dense or strongly chromatic. (D at a medium vertex is a factor of every
//! connection technique's density, so it cancels in `lt` and `bpt`; a merge there has
//! it twice, from both subpaths, so with merging in media the proxy D = 1 of
//! heterogeneous media ranks merging against connecting less well, still unbiased.) T is clamped below at exp(-MAX_MIS_DEPTH) so
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

impl Site {
    pub const COUNT: usize = 2;
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
    merge: [f64; Merge::COUNT],
    /// 1 when connections are used, else 0.
    vc: f64,
    /// Light subpaths per iteration (the light-tracing technique's sample count).
    pub light_paths: f64,
    /// Merging at the first camera vertex is a technique; when false it is removed
    /// from every denominator as well as from the estimator.
    pub merge_first: bool,
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

    /// Mis(eta_k(x)) of estimator `k` at a vertex x whose MIS factor D is `sigma` and
    /// whose two path segments meet at sine `sin` (see the notes above; 0 where `k` is
    /// not used or cannot sit).
    #[inline]
    pub fn eta(&self, k: Merge, sigma: f32, sin: f32) -> f64 {
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
    pub fn merges(&self, site: Site, sigma: f32, sin: f32, camera_len: Option<u32>) -> f64 {
        if camera_len == Some(1) && !self.merge_first {
            return 0.0;
        }
        match site {
            Site::Surface => self.merge[Merge::Surface as usize],
            Site::Medium => {
                self.eta(Merge::Point3d, sigma, sin)
                    + self.eta(Merge::PointBeam2d, sigma, sin)
                    + self.eta(Merge::BeamBeam1d, sigma, sin)
            }
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

    /// A camera subpath reaches an emitter: the weight of that technique ([TR] eqs.
    /// 42-43). `direct` (area measure, or solid angle at infinity) and `emission` as in
    /// `light_start`, both with the selection probability.
    #[inline]
    pub fn weight_emitter_hit(&self, camera: Partial, direct: f32, emission: f32) -> f32 {
        let w_camera = self.f(direct) * camera.dvcm + self.f(emission) * camera.dvc;
        (1.0 / (1.0 + w_camera)) as f32
    }

    /// Light sampling from a camera vertex ([TR] eqs. 44-45). `bsdf_dir` is the camera
    /// BSDF's density of the light direction (0 for delta lights), `bsdf_rev` the
    /// reverse density; `direct` (solid angle at the vertex) and `emission` exclude
    /// the selection probability `pick`; `cos_at_light` is 1 for lights without a
    /// surface; `cos_at_vertex` is the camera vertex's |cos| towards the light; `vm`
    /// the camera vertex's M(x).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn weight_light_sample(
        &self,
        camera: Partial,
        vm: f64,
        pick: f32,
        direct: f32,
        emission: f32,
        cos_at_light: f32,
        cos_at_vertex: f32,
        bsdf_dir: f32,
        bsdf_rev: f32,
    ) -> f32 {
        let (direct, cos_at_light) = (direct as f64, cos_at_light as f64);
        let w_light = self.f(bsdf_dir as f64 / (pick as f64 * direct));
        let w_camera = self.f(emission as f64 * cos_at_vertex as f64 / (direct * cos_at_light))
            * (vm + camera.dvcm + camera.dvc * self.f(bsdf_rev));
        (1.0 / (w_light + 1.0 + w_camera)) as f32
    }

    /// Connection of a light vertex and a camera vertex ([TR] eqs. 40-41).
    /// `camera_to_light_a` is the camera BSDF's density of the connection converted to
    /// area at the light vertex, `light_to_camera_a` the converse; the reverse densities
    /// are each vertex's density of sampling its own predecessor. Each side comes with
    /// its vertex's M(x).
    #[inline]
    pub fn weight_connection(
        &self,
        light: (Partial, f64),
        camera: (Partial, f64),
        camera_to_light_a: f32,
        light_to_camera_a: f32,
        light_rev: f32,
        camera_rev: f32,
    ) -> f32 {
        let ((light, vm_light), (camera, vm_camera)) = (light, camera);
        let w_light =
            self.f(camera_to_light_a) * (vm_light + light.dvcm + light.dvc * self.f(light_rev));
        let w_camera =
            self.f(light_to_camera_a) * (vm_camera + camera.dvcm + camera.dvc * self.f(camera_rev));
        (1.0 / (w_light + 1.0 + w_camera)) as f32
    }

    /// Connection of a light vertex to the lens ([TR] eqs. 46-47): `camera_a` is the
    /// camera's density of the vertex in area measure per unit pixel area, `light_rev`
    /// the vertex's density of sampling its predecessor. The vertex, whose M(x) comes
    /// with it (as a first camera vertex), sits where a camera path would have its
    /// first vertex.
    #[inline]
    pub fn weight_camera_connection(
        &self,
        light: (Partial, f64),
        camera_a: f32,
        light_rev: f32,
    ) -> f32 {
        let (light, vm) = light;
        let w_light = self.f(camera_a as f64 / self.light_paths)
            * (vm + light.dvcm + light.dvc * self.f(light_rev));
        (1.0 / (w_light + 1.0)) as f32
    }

    /// A merge at vertex x by the estimator whose Mis(eta_k(x)) is `own`, among all
    /// merges there summing to `all` (M(x)) ([TR] eqs. 38-39 with [UPBP]'s estimators).
    /// `light` and `camera` are both subpaths' partial weights at x; `camera_dir` is the
    /// camera side's density of the light's incoming direction, `camera_rev` the
    /// reverse one (with the light side's continuation probability).
    #[inline]
    pub fn weight_merge(
        &self,
        light: Partial,
        camera: Partial,
        (own, all): (f64, f64),
        camera_dir: f32,
        camera_rev: f32,
    ) -> f32 {
        let w_light = light.dvcm * self.vc + light.dvm * self.f(camera_dir);
        let w_camera = camera.dvcm * self.vc + camera.dvm * self.f(camera_rev);
        (own / (w_light + all + w_camera)) as f32
    }
}

#[cfg(test)]
mod tests {
    //! Checks the recursive weights against the balance and power heuristics computed
    //! from explicit path densities ([TR] sec. 2-3), on random non-specular paths with
    //! an area light or a light at infinity and a pinhole camera, for every technique
    //! set. Paths may have medium vertices (D = sigma_t from both sides instead of two
    //! cosines) and segments with transmittance T < 1 in the densities of whatever is
    //! sampled along them; the recursive side gets them as the module notes say.
    use super::*;
    use crate::math::Rng;

    /// A path x0 (light) .. xn (camera) described by its densities and cosines.
    struct Path {
        n: usize,
        d2: Vec<f32>,
        /// MIS transmittance of segment (x_i, x_{i+1}).
        tr: Vec<f32>,
        /// D at x_i towards x_{i+1} (i < n) and towards x_{i-1} (i > 0): cosines at
        /// surfaces, the same sigma_t both ways at medium vertices.
        cf: Vec<f32>,
        cb: Vec<f32>,
        /// Solid-angle densities at scattering vertex i of sampling x_{i+1} (light
        /// direction) and x_{i-1} (camera direction).
        pl: Vec<f32>,
        site: Vec<Site>,
        pc: Vec<f32>,
        /// Sine between the two segments at each vertex (beam x beam's density).
        sin: Vec<f32>,
        pick: f32,
        /// x0 is a direction (environment light): positions come from a disk and
        /// light sampling picks a solid angle, with no distance or cosine at x0.
        infinite: bool,
        /// Density of x0 for light sampling (area, or solid angle at infinity),
        /// emission position (area, or on the disk) and direction.
        a_direct: f32,
        e_pos: f32,
        e_dir: f32,
        camera: f32,
    }

    fn random_path(rng: &mut Rng, n: usize, media: bool, infinite: bool) -> Path {
        let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
        let mut p = Path {
            n,
            d2: (0..n).map(|_| r(0.05, 4.0)).collect(),
            tr: (0..n)
                .map(|_| if media { r(0.01, 1.0) } else { 1.0 })
                .collect(),
            cf: (0..=n).map(|_| r(0.05, 1.0)).collect(),
            cb: (0..=n).map(|_| r(0.05, 1.0)).collect(),
            pl: (0..=n).map(|_| r(0.05, 3.0)).collect(),
            pc: (0..=n).map(|_| r(0.05, 3.0)).collect(),
            site: vec![Site::Surface; n + 1],
            sin: (0..=n)
                .map(|_| if r(0.0, 1.0) < 0.1 { 0.0 } else { r(0.0, 1.0) })
                .collect(),
            pick: r(0.2, 1.0),
            infinite,
            a_direct: r(0.5, 4.0),
            e_pos: r(0.5, 4.0),
            e_dir: r(0.05, 1.0),
            camera: r(0.5, 3.0),
        };
        if media {
            for i in 1..n {
                if r(0.0, 1.0) < 0.5 {
                    let sigma = r(0.05, 5.0);
                    p.cf[i] = sigma;
                    p.cb[i] = sigma;
                    p.site[i] = Site::Medium;
                }
            }
        }
        p
    }

    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Tech {
        /// Connection with s light vertices.
        Vc(usize),
        /// Merge at vertex j by an estimator.
        Vm(usize, Merge),
    }

    const ALL_MERGES: [Merge; Merge::COUNT] = [
        Merge::Surface,
        Merge::Point3d,
        Merge::PointBeam2d,
        Merge::BeamBeam1d,
    ];

    impl Path {
        /// Density of x_i sampled from the light side (area measure, or the
        /// direction for x0 at infinity).
        fn fwd(&self, i: usize) -> f32 {
            match (i, self.infinite) {
                (0, false) => self.pick * self.e_pos,
                (0, true) => self.pick * self.e_dir,
                (1, false) => self.e_dir * self.cb[1] * self.tr[0] / self.d2[0],
                (1, true) => self.e_pos * self.cb[1] * self.tr[0],
                _ => self.pl[i - 1] * self.cb[i] * self.tr[i - 1] / self.d2[i - 1],
            }
        }

        /// Density of x_i sampled from the camera side.
        fn bwd(&self, i: usize) -> f32 {
            if i == self.n - 1 {
                self.camera * self.cf[i] * self.tr[i] / self.d2[i]
            } else if i == 0 && self.infinite {
                self.pc[1] * self.tr[0]
            } else {
                self.pc[i + 1] * self.cf[i] * self.tr[i] / self.d2[i]
            }
        }

        /// D at vertex i as the MIS takes it (1 at surfaces).
        fn sigma(&self, i: usize) -> f32 {
            match self.site[i] {
                Site::Surface => 1.0,
                Site::Medium => self.cf[i],
            }
        }

        /// eta_k(x_j) from its definition ([UPBP], the notes on `Mis`): 0 where the
        /// estimator is not used or cannot sit at x_j.
        fn eta(&self, j: usize, k: Merge, merges: &Merges) -> f64 {
            let Some(eta) = merges.eta[k as usize] else {
                return 0.0;
            };
            let sigma = self.sigma(j) as f64;
            match (self.site[j], k) {
                (Site::Surface, Merge::Surface) => eta,
                (Site::Medium, Merge::Point3d) => eta,
                (Site::Medium, Merge::PointBeam2d) => eta / sigma,
                (Site::Medium, Merge::BeamBeam1d) if self.sin[j] >= MIN_BEAM_SIN => {
                    eta * self.sin[j] as f64 / (sigma * sigma)
                }
                _ => 0.0,
            }
        }

        /// M(x_i) as the recursion takes it.
        fn vm(&self, m: &Mis, i: usize, camera_len: Option<u32>) -> f64 {
            m.merges(self.site[i], self.sigma(i), self.sin[i], camera_len)
        }

        /// The technique's density times its sample count.
        fn density(&self, t: Tech, merges: &Merges, light_paths: f32) -> f64 {
            let n = self.n;
            let both = |s: usize| -> f32 {
                (0..s).map(|i| self.fwd(i)).product::<f32>()
                    * (s..n).map(|i| self.bwd(i)).product::<f32>()
            };
            match t {
                Tech::Vc(1) => {
                    (self.pick * self.a_direct * (1..n).map(|i| self.bwd(i)).product::<f32>())
                        as f64
                }
                Tech::Vc(s) if s == n => (light_paths * both(n)) as f64,
                Tech::Vc(s) => both(s) as f64,
                Tech::Vm(j, k) => self.eta(j, k, merges) * (both(j) * self.fwd(j)) as f64,
            }
        }

        /// d^2 / T of segment i as on_hit takes it (1 / T from infinity).
        fn seg(&self, i: usize) -> f32 {
            if i == 0 && self.infinite {
                1.0 / self.tr[0]
            } else {
                self.d2[i] / self.tr[i]
            }
        }

        fn emission(&self) -> f32 {
            self.pick * self.e_pos * self.e_dir
        }

        /// The light subpath's partial weights at vertex `k` (after the hit).
        fn light_q(&self, m: &Mis, k: usize) -> Partial {
            let direct = self.pick * self.a_direct;
            let mut q = m.light_start(direct, self.emission(), self.cf[0], false, !self.infinite);
            q = m.on_hit(q, self.seg(0), self.cb[1]);
            for i in 1..k {
                let vm = self.vm(m, i, None);
                q = m.on_scatter(q, vm, self.cf[i], self.pl[i], self.pc[i], false);
                q = m.on_hit(q, self.seg(i), self.cb[i + 1]);
            }
            q
        }

        /// The camera subpath's partial weights at vertex `k` (after the hit), with
        /// its length in segments.
        fn camera_q(&self, m: &Mis, k: usize) -> (Partial, u32) {
            let n = self.n;
            let mut q = m.camera_start(self.camera);
            q = m.on_hit(q, self.seg(n - 1), self.cf[n - 1]);
            let mut len = 1;
            for i in (k + 1..n).rev() {
                let (vm, cos) = (self.vm(m, i, Some(len)), self.cb[i]);
                q = m.on_scatter(q, vm, cos, self.pc[i], self.pl[i], false);
                // An escaping ray: no cosine at infinity, only the 1 / T of its
                // segment (as the camera subpath applies on escape).
                let cos = if i == 1 && self.infinite {
                    1.0
                } else {
                    self.cf[i - 1]
                };
                q = m.on_hit(q, self.seg(i - 1), cos);
                len += 1;
            }
            (q, len)
        }

        /// The weight the recursive quantities give technique `t`.
        fn recursive_weight(&self, m: &Mis, t: Tech) -> f32 {
            let n = self.n;
            match t {
                Tech::Vc(0) => {
                    let (q, _) = self.camera_q(m, 0);
                    m.weight_emitter_hit(q, self.pick * self.a_direct, self.emission())
                }
                Tech::Vc(1) => {
                    let (q, len) = self.camera_q(m, 1);
                    // Light sampling's solid-angle density, with the segment's T.
                    let (direct_w, cos_light) = if self.infinite {
                        (self.a_direct, 1.0)
                    } else {
                        (self.a_direct * self.d2[0] / self.cf[0], self.cf[0])
                    };
                    m.weight_light_sample(
                        q,
                        self.vm(m, 1, Some(len)),
                        self.pick,
                        direct_w / self.tr[0],
                        self.e_pos * self.e_dir,
                        cos_light,
                        self.cb[1],
                        self.pc[1],
                        self.pl[1],
                    )
                }
                Tech::Vc(s) if s == n => {
                    let q = self.light_q(m, n - 1);
                    let camera_a = self.camera * self.cf[n - 1] / self.seg(n - 1);
                    let vm = self.vm(m, n - 1, Some(1));
                    m.weight_camera_connection((q, vm), camera_a, self.pc[n - 1])
                }
                Tech::Vc(s) => {
                    let ql = self.light_q(m, s - 1);
                    let (qc, len) = self.camera_q(m, s);
                    let seg = self.seg(s - 1);
                    m.weight_connection(
                        (ql, self.vm(m, s - 1, None)),
                        (qc, self.vm(m, s, Some(len))),
                        self.pc[s] * self.cf[s - 1] / seg,
                        self.pl[s - 1] * self.cb[s] / seg,
                        self.pc[s - 1],
                        self.pl[s],
                    )
                }
                Tech::Vm(j, k) => {
                    let ql = self.light_q(m, j);
                    let (qc, _) = self.camera_q(m, j);
                    let own = m.eta(k, self.sigma(j), self.sin[j]);
                    let all = self.vm(m, j, None);
                    m.weight_merge(ql, qc, (own, all), self.pc[j], self.pl[j])
                }
            }
        }
    }

    /// Merge estimators of the tests: none, surfaces only ([TR]), or surfaces and
    /// media with a different eta (as a volume kernel would have).
    fn merges(vm: bool, volume: bool) -> Merges {
        let (radius, light_paths) = (0.01f32, 1000.0f32);
        let mut m = if vm {
            Merges::surface(radius, light_paths)
        } else {
            Merges::default()
        };
        if vm && volume {
            m = m.with(Merge::Point3d, 0.05, light_paths);
        }
        m
    }

    /// A set of [UPBP]'s estimators: `mask` bit k turns on `ALL_MERGES[k]`, each with
    /// its own radius.
    fn upbp(mask: u32) -> Merges {
        let radii = [0.01f32, 0.05, 0.02, 0.03];
        (0..Merge::COUNT)
            .filter(|k| mask & (1 << k) != 0)
            .fold(Merges::default(), |m, k| {
                m.with(ALL_MERGES[k], radii[k], 1000.0)
            })
    }

    fn check(heuristic: Heuristic, vc: bool, merges: Merges, merge_first: bool, media: bool) {
        let mut rng = Rng::new(3, 1, 4);
        let light_paths = 1000.0f32;
        let mut m = Mis::new(heuristic, light_paths, vc, merges);
        m.merge_first = merge_first;
        for n in 2..7 {
            for k in 0..40 {
                let infinite = k % 2 == 1;
                let path = random_path(&mut rng, n, media, infinite);
                let mut techs = Vec::new();
                if vc {
                    techs.extend((0..=n).map(Tech::Vc));
                }
                let last = if merge_first { n } else { n - 1 };
                for j in 1..last {
                    let can = ALL_MERGES
                        .into_iter()
                        .filter(|&k| path.eta(j, k, &merges) > 0.0);
                    techs.extend(can.map(|k| Tech::Vm(j, k)));
                }
                let p = |t: Tech| m.f(path.density(t, &merges, light_paths));
                if techs.is_empty() {
                    continue; // merging alone, where no estimator can sit on this path
                }
                let total: f64 = techs.iter().map(|&t| p(t)).sum();
                let mut sum = 0.0;
                for &t in &techs {
                    let expect = (p(t) / total) as f32;
                    let got = path.recursive_weight(&m, t);
                    assert!(
                        (got - expect).abs() <= 1e-4 * expect.max(1e-3),
                        "{heuristic:?} vc={vc} {merges:?} merge_first={merge_first} media={media} infinite={infinite} n={n} {t:?}: recursive {got}, explicit {expect}"
                    );
                    sum += got;
                }
                assert!((sum - 1.0).abs() < 1e-4, "weights sum to {sum}");
            }
        }
    }

    #[test]
    fn vcm_weights_match_explicit_heuristics_and_sum_to_one() {
        for h in [Heuristic::Balance, Heuristic::Power] {
            check(h, true, merges(true, false), true, false);
            check(h, true, merges(true, false), false, false);
        }
    }

    #[test]
    fn bpt_and_bpm_weights_sum_to_one() {
        for h in [Heuristic::Balance, Heuristic::Power] {
            check(h, true, merges(false, false), true, false);
            check(h, false, merges(true, false), true, false);
        }
    }

    /// Medium vertices and transmittances in the densities: the recursive weights with
    /// d^2 / T and D in place of d^2 and the cosine are still the explicit heuristics,
    /// with merging at surfaces only or with a second estimator of its own eta in media.
    #[test]
    fn weights_with_medium_vertices_match_explicit_heuristics_and_sum_to_one() {
        for h in [Heuristic::Balance, Heuristic::Power] {
            check(h, true, merges(false, false), true, true);
            for volume in [false, true] {
                check(h, true, merges(true, volume), true, true);
                check(h, true, merges(true, volume), false, true);
                check(h, false, merges(true, volume), true, true);
            }
        }
    }

    /// Every subset of [UPBP]'s estimators, with and without connections: the weights
    /// of all techniques that can produce a path (connections, and each estimator at
    /// each vertex where it can sit: surfaces, medium points, camera beams through
    /// photon points, beams meeting at a sine above MIN_BEAM_SIN) are the explicit
    /// heuristics and sum to one.
    #[test]
    fn upbp_weights_match_explicit_heuristics_and_sum_to_one() {
        for h in [Heuristic::Balance, Heuristic::Power] {
            for mask in 0..(1 << Merge::COUNT) {
                check(h, true, upbp(mask), true, true);
                check(h, true, upbp(mask), false, true);
                if mask != 0 {
                    check(h, false, upbp(mask), true, true);
                }
            }
        }
    }

    #[test]
    fn mis_transmittance_is_clamped() {
        assert_eq!(transmittance(0.0), 1.0);
        assert!((transmittance(2.0) - (-2.0f32).exp()).abs() < 1e-7);
        let floor = transmittance(MAX_MIS_DEPTH);
        assert!(floor > 0.0);
        assert_eq!(transmittance(f32::INFINITY), floor);
        assert_eq!(transmittance(f32::NAN), floor);
    }
}
