//! Subpaths, as every algorithm that traces light paths shares them: the vertex
//! (a surface with its BSDF, or a scattering point in a medium), the state a walk
//! carries and its scattering move, the walk through media, the partial MIS
//! quantities each vertex carries ([`partial`]), the one light tracer of the
//! bidirectional family with its store of vertices and segments ([`light_path`], run
//! alone by [`light_pass`]), and the photon walk of the estimators without MIS
//! ([`photons`]). Both tracers run in the light-path loop of
//! [`crate::integrator::drive::light`].
//!
//! Below the algorithms and the estimators: imports [`crate::integrator::transport`],
//! [`crate::integrator::drive`] and [`crate::integrator::memory`] only. The
//! bidirectional family adds its MIS weights and its camera walk on top; the
//! many-light methods and photon beams take the store of [`light_pass`]; the photon
//! mappers gather [`photons`] with the estimators.

pub(crate) mod correlation;
#[cfg(test)]
pub(crate) mod full_path;
pub(crate) mod layers;
mod lens;
pub(crate) mod light_pass;
pub(crate) mod light_path;
pub(crate) mod light_vertex;
pub(crate) mod media;
pub(crate) mod partial;
pub(crate) mod parts;
pub(crate) mod photons;
pub(crate) mod segments;
pub(crate) mod store;
pub(crate) mod vertex;
pub(crate) mod walk;

use crate::material::Material;
use crate::math::{max_component, Rgb};
use crate::scene::Scene;
use layers::Layers;
use partial::{Merge, Mis};

/// What the light tracer does with its subpaths: the techniques' needs, as flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Tracing {
    /// Pure light tracing: every camera connection has weight 1.
    pub lt: bool,
    /// Light vertices are kept after the light pass.
    pub stores: bool,
    /// Light vertices connect to the camera (splats).
    pub splats: bool,
    /// Light vertices are gathered by the surface or 3D point estimators.
    pub merges: bool,
}

impl Tracing {
    /// The light pass alone, for estimators outside the bidirectional family: vertices
    /// (and segments, when kept) stored, nothing connected.
    pub const STORE: Tracing = Tracing {
        lt: false,
        stores: true,
        splats: false,
        merges: false,
    };
}

/// Per-iteration constants shared by both subpath tracers.
pub(crate) struct Pass<'a> {
    pub scene: &'a Scene,
    pub tracing: Tracing,
    pub max_depth: u32,
    pub russian_roulette: bool,
    pub max_vertex_mib: f32,
    pub mis: Mis,
    /// Each merge estimator's radius in this iteration, and its kernel's
    /// normalisation 1 / eta (0 where it is not used).
    pub radii: [f32; Merge::COUNT],
    pub norms: [f32; Merge::COUNT],
    pub light_paths: usize,
    /// Light paths whose segments become photon beams (`upbp`).
    pub beam_paths: usize,
    pub layers: &'a Layers,
    /// Light subpaths keep their segments through media (`segments`), for the
    /// estimators made of them.
    pub keep_segments: bool,
    /// The `radii` layers, each weighted from the same subpaths ([`parts`]).
    pub radius_layers: Vec<parts::RadiusLayer>,
    /// Per-pixel merge estimators (efficiency-aware selection), if any.
    pub selection: Option<parts::Selection<'a>>,
}

impl Pass<'_> {
    /// Whether estimator `k` is used in this scene this iteration.
    #[inline(always)]
    pub fn uses(&self, k: Merge) -> bool {
        self.norms[k as usize] > 0.0
    }

    /// Whether camera segments through media are query beams (`upbp`'s beam
    /// estimators).
    #[inline(always)]
    pub fn query_beams(&self) -> bool {
        self.uses(Merge::PointBeam2d) || self.uses(Merge::BeamBeam1d)
    }

    /// Whether a subpath (a camera one when `camera`) keeps its [`parts::Parts`]:
    /// light subpaths for `merge_depth: first`'s cuts in media, both for the `radii`
    /// layers. `M` and `RADII` are the pass's compile-time choices, so that in the
    /// usual pass (no layers) this is a constant.
    #[inline(always)]
    pub fn tracks_parts<M: vertex::Media, const RADII: bool>(&self, camera: bool) -> bool {
        RADII || (!camera && M::ON && self.mis.first_medium)
    }

    /// Whether the subpaths are weighted under more than the pass's own MIS (radius
    /// layers, per-pixel selection, correlation-aware weights), and so keep their
    /// [`parts::Parts`]: decided once per pass, as the tracers' `RADII` parameter.
    #[inline(always)]
    pub fn reweights(&self) -> bool {
        !self.radius_layers.is_empty() || self.selection.is_some() || self.mis.correlated
    }

    /// Whether the subpaths keep [`correlation::Link`]s: only in the reweighting pass
    /// (`RADII`), so that the usual one compiles without them.
    #[inline(always)]
    pub fn correlates<const RADII: bool>(&self) -> bool {
        RADII && self.mis.correlated
    }

    /// Russian-roulette continuation probability at a vertex with material `m`.
    #[inline]
    pub fn continuation(&self, m: &Material) -> f32 {
        if self.russian_roulette {
            max_component(m.albedo()).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }

    /// The same at a medium vertex whose single-scattering albedo is `albedo`.
    #[inline]
    pub fn medium_continuation(&self, albedo: Rgb) -> f32 {
        if self.russian_roulette {
            max_component(albedo).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }
}

/// A light-tracing contribution: (film position, value, layer or u16::MAX).
pub(crate) type Splat = (crate::math::Vec2, Rgb, u16);
