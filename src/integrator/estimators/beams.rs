//! Photon beams: the light subpaths' segments through media (the bidirectional store's
//! `LightSegment`s), each carrying the power that entered it, with the weight of each
//! point along it.
//!
//! A beam represents the light travelling along it: a point at distance u from its
//! origin stands for power beta T(u) reaching u. Two forms (Jarosz et al. 2011,
//! "Progressive photon beams", sec. 5.1):
//! - `long`: from the origin to the next surface (or the end of a heterogeneous
//!   medium's field), weight T(0, u) (exact in homogeneous media, ratio tracking
//!   otherwise). An unbounded segment in a homogeneous medium is cut at a distance
//!   drawn from exp(-sigma u) (sigma the smallest channel extinction) with the survival
//!   weight exp(sigma u), as the ray lights of `many` are: the expected weight of every
//!   point stays T(u).
//! - `short`: to where the light subpath's free flight ended (its scattering point, or
//!   the surface when it passed), weight T(u) / P(flight passes u). In a homogeneous
//!   medium P is sum_c p_c T_c(u), p the channel probabilities the flight was sampled
//!   with (`medium::channel_probabilities` of the throughput entering the segment), so
//!   a grey medium's weight is exactly 1. Spectral tracking in heterogeneous media has no
//!   closed-form P: there, beams are long whatever the setting.

use crate::integrator::estimators::Bounded;
use crate::integrator::paths::segments::{extent, LightSegment};
use crate::integrator::transport::Stream;
use crate::math::{Rgb, Rng, Vec3};
use crate::medium::{channel_probabilities, Medium};
use crate::scene::Scene;
use serde::{Deserialize, Serialize};

/// Which part of a light segment a beam covers (module notes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BeamForm {
    /// To the free flight's end.
    #[default]
    Short,
    /// To the next surface, weighted by transmittance.
    Long,
}

/// How a beam weights the points along it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Weight {
    /// T(0, u), times exp(cut u) when the beam was cut (`cut` > 0).
    Long { cut: f32 },
    /// T(u) / sum_c p_c T_c(u) in a homogeneous medium.
    Short { p: Rgb },
    /// The same in a grey medium, where it is exactly 1 (no transmittance to
    /// evaluate per merge).
    One,
}

/// One photon beam, or a piece of one: long beams are stored as pieces of bounded
/// length, whose boxes the BVH can separate (a diagonal beam's box is mostly empty).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Beam {
    /// Where the piece starts.
    pub o: Vec3,
    /// Unit direction.
    pub d: Vec3,
    /// The piece's length.
    pub len: f32,
    /// Distance from the beam's origin to the piece's start.
    pub start: f32,
    /// Power entering the beam, over the number of light paths.
    pub beta: Rgb,
    pub medium: u32,
    /// Segments from the light to the beam's far end (this one included).
    pub depth: u32,
    pub weight: Weight,
    /// The index of the light segment it was made of, in the order given to
    /// [`collect`].
    pub seg: u32,
}

impl Bounded for Beam {
    #[inline(always)]
    fn bounds(&self) -> (Vec3, Vec3) {
        let e = self.o + self.d * self.len;
        (self.o.min(e), self.o.max(e))
    }
}

impl Beam {
    /// The beam of light segment `s` (None when nothing on it can scatter), with the
    /// uniform number `xi` for a cut.
    pub fn new(
        scene: &Scene,
        s: &LightSegment,
        form: BeamForm,
        inv_paths: f32,
        xi: f32,
    ) -> Option<Self> {
        let m = &scene.media[s.medium as usize];
        let (len, weight) = match (form, m.as_homogeneous()) {
            (BeamForm::Short, Some(h)) => {
                let len = s.t.min(s.tmax);
                let weight = if h.is_grey() {
                    Weight::One
                } else {
                    Weight::Short {
                        p: channel_probabilities(s.beta),
                    }
                };
                (len, weight)
            }
            _ => {
                let (len, cut) = extent(m, s.o, s.d, s.tmax, xi)?;
                (len, Weight::Long { cut })
            }
        };
        (len > 0.0 && len.is_finite() && s.beta != Rgb::ZERO).then_some(Beam {
            o: s.o,
            d: s.d,
            len,
            start: 0.0,
            beta: s.beta * inv_paths,
            medium: s.medium,
            depth: s.len,
            weight,
            seg: 0,
        })
    }

    /// The weight of the point at distance `u` along the piece (module notes).
    #[inline]
    pub fn weight_at(&self, m: &Medium, u: f32, rng: &mut Rng) -> Rgb {
        let (origin, u) = (self.o - self.d * self.start, self.start + u);
        match self.weight {
            Weight::One => Rgb::ONE,
            Weight::Short { p } => {
                let tr = m.transmittance(origin, self.d, u, rng);
                let pass = (p * tr).element_sum();
                if pass > 0.0 {
                    tr / pass
                } else {
                    Rgb::ZERO
                }
            }
            Weight::Long { cut } => {
                let tr = m.transmittance(origin, self.d, u, rng);
                if cut > 0.0 {
                    tr * (cut * u).exp()
                } else {
                    tr
                }
            }
        }
    }

    /// Appends the beam cut into pieces of at most `piece` (the last one shorter).
    pub fn split_into(&self, piece: f32, out: &mut Vec<Beam>) {
        let n = (self.len / piece).ceil().clamp(1.0, MAX_PIECES as f32) as u32;
        let step = self.len / n as f32;
        out.extend((0..n).map(|k| {
            let start = self.start + step * k as f32;
            Beam {
                o: self.o + self.d * (step * k as f32),
                len: if k + 1 == n {
                    self.len - step * k as f32
                } else {
                    step
                },
                start,
                ..*self
            }
        }));
    }
}

/// Most pieces one beam is cut into.
const MAX_PIECES: u32 = 256;

/// The beams of an iteration's light store, in the store's order, in pieces of at
/// most `piece`; returns the number of beams.
#[allow(clippy::too_many_arguments)]
pub(crate) fn collect(
    scene: &Scene,
    segments: impl Iterator<Item = LightSegment>,
    paths: usize,
    form: BeamForm,
    piece: f32,
    seed: u64,
    iteration: u64,
    out: &mut Vec<Beam>,
) -> usize {
    let inv_paths = 1.0 / paths.max(1) as f32;
    out.clear();
    let mut beams = 0;
    for (i, s) in segments.enumerate() {
        let mut rng = Stream::PhotonBeams.rng(seed, iteration, i as u64);
        if let Some(mut b) = Beam::new(scene, &s, form, inv_paths, rng.next_f32()) {
            b.seg = i as u32;
            b.split_into(piece, out);
            beams += 1;
        }
    }
    beams
}

/// Beams are stored in pieces of at most this fraction of the scene's bounding-sphere
/// radius. Measured on fog-cornell (256 x 256, `light_paths` 0.05: 11k beams, 3.3 M
/// merges per iteration, r = 0.006): 2.27 s per iteration whole, 1.07 s in pieces of
/// R / 32, 0.82-0.87 s at R / 16 and R / 8, 1.50 s at R / 64 (vertex storage 5.7, 41,
/// 23 and 79 MiB).
pub(crate) const PIECE: f32 = 1.0 / 16.0;
