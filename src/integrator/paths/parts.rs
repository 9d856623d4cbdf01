//! The partial weights split by merge estimator, so that one set of subpaths can be
//! weighted as if each estimator's kernel had another support, or were switched off.
//!
//! dvc and dvm ([`Partial`]) are sums over the techniques of a subpath's vertices.
//! Merges enter both recursions alike: each scattering vertex x adds M(x), the sum of
//! Mis(eta_k(x)) over the estimators k, which every later step multiplies by factors
//! that do not depend on eta ([TR] eqs. 34-36 and the media notes of [`Mis`]). So
//! dvc = base_c + sum_k S_k and dvm = base_m + sum_k S_k, with S_k the part that
//! estimator k's merges contribute, proportional to its constant Mis(eta_k), and the
//! bases free of merging. Scaling Mis(eta_k) by lambda_k (another radius: lambda_k =
//! Mis(s^dim_k) for a radius scaled by s; an estimator turned off: 0) scales S_k by
//! lambda_k and leaves the rest, so the weights of every technique under the scaled
//! constants follow from the unscaled subpaths in O(Merge::COUNT) per weight
//! (Georgiev's technical report allows per-vertex radii; the VCM thesis, sec. 5.5,
//! renders several radii in one run on the same observation).
//!
//! `merge_depth: first` already keeps the sum of the media estimators' parts (`vol`);
//! [`Parts`] keeps each estimator's on its own.
//!
//! [TR]: super::partial

use super::partial::{Merge, Mis, Partial, Site};

/// Per merge estimator, a quantity of the MIS: a vertex's terms Mis(eta_k(x)) of
/// M(x), or the parts S_k of a subpath's dvc and dvm (the module notes).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Parts(pub [f64; Merge::COUNT]);

/// A factor per merge estimator on its Mis(eta_k): 1 each renders as the subpaths
/// were traced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale(pub [f64; Merge::COUNT]);

/// Every estimator, in index order.
pub const ALL: [Merge; Merge::COUNT] = [
    Merge::Surface,
    Merge::Point3d,
    Merge::PointBeam2d,
    Merge::BeamBeam1d,
];

/// The estimators that sit in media: `merge_depth: first` cuts their parts.
pub const MEDIA: [Merge; 3] = [Merge::Point3d, Merge::PointBeam2d, Merge::BeamBeam1d];

/// The query beams' estimators, whose terms take [`Mis::beam_scale`].
const BEAMS: [Merge; 2] = [Merge::PointBeam2d, Merge::BeamBeam1d];

impl Parts {
    #[inline]
    pub fn sum(&self) -> f64 {
        self.0.iter().sum()
    }

    /// Estimator `k`'s part `x`, the others 0.
    #[inline]
    pub fn one(k: Merge, x: f64) -> Parts {
        let mut out = Parts::default();
        out.0[k as usize] = x;
        out
    }

    /// The sum with each part scaled.
    #[inline]
    pub fn dot(&self, scale: &Scale) -> f64 {
        self.0.iter().zip(scale.0).map(|(p, s)| p * s).sum()
    }

    /// Every part times `x`.
    #[inline]
    pub fn times(self, x: f64) -> Parts {
        Parts(self.0.map(|p| p * x))
    }

    /// `self + other`, part by part.
    #[inline]
    pub fn plus(self, other: Parts) -> Parts {
        let mut out = self;
        for (o, b) in out.0.iter_mut().zip(other.0) {
            *o += b;
        }
        out
    }

    /// The media estimators' parts summed (what `merge_depth: first` calls `vol`).
    #[inline]
    pub fn media(&self) -> f64 {
        MEDIA.iter().map(|&k| self.0[k as usize]).sum()
    }

    /// The parts without the media estimators' (a cut, [`Mis::cuts`]).
    #[inline]
    pub fn without_media(self) -> Parts {
        let mut out = self;
        for k in MEDIA {
            out.0[k as usize] = 0.0;
        }
        out
    }

    /// The query beams' terms only.
    #[inline]
    pub fn beams(self) -> Parts {
        let mut out = Parts::default();
        for k in BEAMS {
            out.0[k as usize] = self.0[k as usize];
        }
        out
    }

    /// The point estimators' terms only.
    #[inline]
    pub fn points(self) -> Parts {
        let mut out = self;
        for k in BEAMS {
            out.0[k as usize] = 0.0;
        }
        out
    }
}

impl Scale {
    /// The factors that take `base`'s Mis(eta_k) to `other`'s (0 where `base` has
    /// no estimator k).
    pub fn between(base: &Mis, other: &Mis) -> Scale {
        let mut out = Scale([0.0; Merge::COUNT]);
        for ((o, b), x) in out.0.iter_mut().zip(base.merge).zip(other.merge) {
            if b > 0.0 {
                *o = x / b;
            }
        }
        out
    }
}

/// One `radii` layer of an iteration: its MIS as a job with its radii would build
/// it, the factors that take the pass's own weights there, each estimator's radius
/// and kernel normalisation (as `Pass::radii` and `Pass::norms`), and its layer.
pub(crate) struct RadiusLayer {
    pub mis: Mis,
    pub scale: Scale,
    pub radii: [f32; Merge::COUNT],
    pub norms: [f32; Merge::COUNT],
    pub layer: usize,
}

/// A pixel's choice of merge estimators (efficiency-aware selection, Grittmann et
/// al. 2022): weights as if the estimators outside the choice were off (`scale` 0,
/// `mis` the job's MIS so scaled), except on the paths that only they sample, which
/// keep the job's weights. The weights of every path still sum to one: where a kept
/// technique has density, the dropped merges weigh 0 and the rest are the balance
/// over the kept ones; where none has, the kept ones never sample the path and the
/// dropped merges keep the job's weights, which sum to one alone (the limit of
/// scaling the dropped estimators by epsilon -> 0).
#[derive(Clone, Debug)]
pub(crate) struct Candidate {
    pub scale: Scale,
    pub mis: Mis,
    /// Per estimator, `mis` with that estimator's Mis(eta_k) given back: a dropped
    /// merge's weight under it is 1 exactly where no kept technique samples its path.
    pub restored: [Mis; Merge::COUNT],
}

impl Candidate {
    /// `job`'s MIS keeping the estimators `keep`.
    pub fn new(job: &Mis, keep: [bool; Merge::COUNT]) -> Candidate {
        let scale = Scale(keep.map(|k| if k { 1.0 } else { 0.0 }));
        let mis = job.scaled(&scale);
        let restored = ALL.map(|k| {
            let mut m = mis;
            m.merge[k as usize] = job.merge[k as usize];
            m
        });
        Candidate {
            scale,
            mis,
            restored,
        }
    }

    #[inline(always)]
    pub fn keeps(&self, k: Merge) -> bool {
        self.scale.0[k as usize] > 0.0
    }
}

/// A dropped merge's weight under a [`Candidate`], from its weight under the
/// candidate's MIS with the estimator given back (`restored`) and under the job's
/// (`full`, evaluated only where needed): 0 where a kept technique samples the path.
#[inline(always)]
pub(crate) fn dropped_weight(restored: f32, full: impl FnOnce() -> f32) -> f32 {
    // 1 - 2^-20: a kept technique whose density is 10^-6 of the merge's is as good
    // as none (the bias is below 10^-6 of such paths' share).
    if restored >= 1.0 - 1.0 / (1u32 << 20) as f32 {
        full()
    } else {
        0.0
    }
}

/// Per-pixel candidates of a pass: `choice` (one byte per pixel, row-major) indexes
/// `candidates`, whose first entry keeps every estimator (the job's own weights).
pub(crate) struct Selection<'a> {
    pub candidates: Vec<Candidate>,
    pub choice: &'a [u8],
    pub width: u32,
}

impl Selection<'_> {
    /// Pixel `pixel`'s candidate, None for the job's own weights.
    #[inline(always)]
    pub fn at(&self, pixel: usize) -> Option<&Candidate> {
        match self.choice.get(pixel).copied().unwrap_or(0) {
            0 => None,
            c => self.candidates.get(c as usize),
        }
    }

    /// The candidate of the pixel at film position `raster`.
    #[inline(always)]
    pub fn at_raster(&self, raster: crate::math::Vec2) -> Option<&Candidate> {
        let (x, y) = (raster.x.max(0.0) as usize, raster.y.max(0.0) as usize);
        self.at(y * self.width as usize + x.min(self.width as usize - 1))
    }
}

impl Mis {
    /// Each estimator's term Mis(eta_k(x)) of M(x) ([`Mis::merges`], which is their
    /// sum up to rounding), with the same arguments.
    #[inline]
    pub fn merge_terms(
        &self,
        site: Site,
        sigma: f32,
        sin: f32,
        camera_len: Option<u32>,
        tc: f32,
    ) -> Parts {
        let mut t = self.unsettled_terms(site, sigma, sin, camera_len);
        for k in BEAMS {
            t.0[k as usize] *= self.beam_scale(tc);
        }
        t
    }

    /// The terms as [`Mis::merge_parts`] splits them: the query beams' before their
    /// [`Mis::beam_scale`].
    #[inline]
    pub fn unsettled_terms(
        &self,
        site: Site,
        sigma: f32,
        sin: f32,
        camera_len: Option<u32>,
    ) -> Parts {
        let mut t = Parts::default();
        if camera_len == Some(1) && !self.merge_first {
            return t;
        }
        let ks: &[Merge] = match site {
            Site::Surface => &[Merge::Surface],
            Site::Medium => &MEDIA,
        };
        // At T = 1 a long beam's factor is 1: these are the short beams' terms.
        for &k in ks {
            t.0[k as usize] = self.eta(k, sigma, sin, 1.0);
        }
        t
    }

    /// A light subpath's scattering vertex's terms split in two: those it adds now,
    /// and with long query beams the beams' terms it leaves pending (times
    /// on_scatter's factor of the sampled direction) until the segment it leaves along
    /// ends, whose T their [`Mis::beam_scale`] needs ([`Mis::light_hit`]).
    #[inline]
    pub fn defer_terms(&self, terms: Parts, cos_out: f32, pdf_dir: f32) -> (Parts, Parts) {
        if self.long_query {
            let g = self.f(cos_out as f64 / pdf_dir as f64);
            (terms.points(), terms.beams().times(g))
        } else {
            (terms, Parts::default())
        }
    }

    /// Scattering's update of the parts (as [`Mis::on_scatter`] updates dvc and dvm),
    /// with the vertex's `terms` (0 for the terms it defers, [`Mis::defer`]).
    #[inline]
    pub fn scatter_parts(
        &self,
        parts: Parts,
        terms: Parts,
        cos_out: f32,
        pdf_dir: f32,
        pdf_rev: f32,
        delta: bool,
    ) -> Parts {
        let g = self.f(cos_out as f64 / pdf_dir as f64);
        let r = self.f(pdf_rev);
        if delta {
            return parts.times(g * r);
        }
        parts.times(r).plus(terms).times(g)
    }

    /// The end of a light subpath's segment (as [`Mis::light_hit`]): the deferred
    /// beam terms `pending` (with on_scatter's factor) completed by the segment's T
    /// `tr`, then the hit's 1 / Mis(D).
    #[inline]
    pub fn hit_parts(&self, parts: Parts, pending: Parts, tr: f32, cos: f32) -> Parts {
        let mut out = parts;
        for (o, p) in out.0.iter_mut().zip(pending.0) {
            *o = self.hit_share(*o, p, tr, cos);
        }
        out
    }

    /// The partial weights as they would be with every estimator's Mis(eta_k) scaled
    /// by `scale`, from their unscaled value `q` and its `parts`.
    #[inline]
    pub fn rescale(&self, q: Partial, parts: &Parts, scale: &Scale) -> Partial {
        let (sum, scaled) = (parts.sum(), parts.dot(scale));
        // The bases are differences that rounding leaves a residue of about 1e-16 of
        // the whole in where the parts were all there was: such a residue is 0, so
        // that a technique without density never seems to have some.
        let base = |x: f64| {
            let b = x - sum;
            if b > 1e-12 * x {
                b
            } else {
                0.0
            }
        };
        Partial {
            dvcm: q.dvcm,
            dvc: base(q.dvc) + scaled,
            dvm: base(q.dvm) + scaled,
        }
    }

    /// The same MIS with every estimator's Mis(eta_k) scaled by `scale`.
    pub fn scaled(&self, scale: &Scale) -> Mis {
        let mut m = *self;
        for (c, s) in m.merge.iter_mut().zip(scale.0) {
            *c *= s;
        }
        m
    }
}
