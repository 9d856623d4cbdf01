//! The state a subpath carries between vertices and the scattering move both subpaths
//! make at surfaces: what the light and camera walks of the bidirectional core share.

use super::correlation::Carry;
use super::partial::{Merge, Partial, Site};
use super::parts::Parts;
use super::Pass;
use crate::geometry::{spawn_ray, Interaction, Ray};
use crate::integrator::transport::adjoint::adjoint_correction;
use crate::material::{Material, Mode};
use crate::math::{Frame, Rgb, Rng, Vec3};

/// Cosines below this end a path: the MIS quantities divide by them.
pub(crate) const MIN_COS: f32 = 1e-6;

/// The shading context of a non-specular vertex, for evaluating connections.
pub(crate) struct Surface<'a> {
    /// Borrowed, not a `MaterialRef`, so that vertices need no dropping (`media::Owner`).
    pub m: &'a Material,
    pub frame: Frame,
    pub ng: Vec3,
    /// Towards the previous vertex, local frame.
    pub wo: Vec3,
    pub cont: f32,
}

/// f |cos| towards a direction, with both solid-angle densities (continuation
/// probability not included). At a medium vertex f is the phase function and `cos` the
/// MIS factor D (see `mis`).
pub(crate) struct Eval {
    pub f: Rgb,
    pub cos: f32,
    pub pdf_dir: f32,
    pub pdf_rev: f32,
}

impl Surface<'_> {
    /// Veach's adjoint correction for importance leaving towards `wi` (world space):
    /// tested on the normals first, so flat shading computes nothing more.
    #[inline(always)]
    fn adjoint(&self, wi: Vec3) -> f32 {
        if self.frame.n == self.ng {
            1.0
        } else {
            adjoint_correction(self.frame.n, self.ng, self.frame.to_world(self.wo), wi)
        }
    }

    #[inline(always)]
    pub fn eval(&self, wi_world: Vec3, mode: Mode) -> Option<Eval> {
        let wi = self.frame.to_local(wi_world);
        // A direction on different sides of the shading and geometric normals would
        // leak light through the surface.
        if (wi_world.dot(self.ng) > 0.0) != (wi.z > 0.0) {
            return None;
        }
        let (mut f, pdf_dir, pdf_rev) = self.m.eval_pdfs(self.wo, wi, mode);
        if mode == Mode::Importance {
            f *= self.adjoint(wi_world);
        }
        if f == Rgb::ZERO {
            return None;
        }
        Some(Eval {
            f,
            cos: wi.z.abs(),
            pdf_dir,
            pdf_rev,
        })
    }
}

/// State of a subpath between vertices.
#[derive(Clone, Copy)]
pub(crate) struct Walk {
    /// The last scattering vertex (or the path's origin).
    pub origin: Vec3,
    pub throughput: Rgb,
    /// Segments traced so far, including the one being traced.
    pub len: u32,
    pub q: Partial,
    /// On a light subpath, the query beams' terms of the last vertex's M(x) awaiting
    /// the transmittance of the segment being traced ([`Mis::defer_terms`]); else 0.
    ///
    /// [`Mis::defer_terms`]: super::partial::Mis::defer_terms
    pub pending: Parts,
    /// Each merge estimator's part of dvc and dvm ([`super::parts`]), on a light
    /// subpath (where `merge_depth: first` cuts the media's, [`Mis::cuts`]) and, with
    /// `radii` layers, on a camera subpath; else 0.
    ///
    /// [`Mis::cuts`]: super::partial::Mis::cuts
    pub parts: Parts,
    /// On a camera subpath, whether a vertex before the current one was in a medium.
    pub medium_seen: bool,
    /// The MIS transmittance of the segment that reached the current vertex: on a
    /// camera subpath, the camera-side T of merges there.
    pub tr: f32,
    /// Every scattering event so far was specular.
    pub specular: bool,
    /// The medium the path travels in (always None in scenes without media).
    pub medium: Option<u32>,
    /// With correlation-aware MIS, what fills the next stored vertex's [`Link`].
    ///
    /// [`Link`]: super::correlation::Link
    pub carry: Carry,
}

/// Samples the next direction and updates throughput and MIS state; None ends the
/// path. `camera_len` is Some on camera subpaths; `track` says whether the walk keeps
/// its [`Parts`] ([`Pass::tracks_parts`]).
#[inline(always)]
pub(crate) fn scatter(
    pass: &Pass,
    rng: &mut Rng,
    walk: &mut Walk,
    it: &Interaction,
    surface: &Surface,
    mode: Mode,
    (camera_len, track): (Option<u32>, bool),
) -> Option<Ray> {
    let u_lobe = rng.next_f32();
    let s = surface.m.sample(surface.wo, u_lobe, rng.next_2d(), mode)?;
    let wi = surface.frame.to_world(s.wi.into());
    if (wi.dot(it.ng) > 0.0) != (s.wi.z > 0.0) {
        return None;
    }
    let cont = surface.cont;
    if cont < 1.0 && rng.next_f32() >= cont {
        return None;
    }
    let pdf_dir = s.pdf * cont;
    let pdf_rev = if s.delta {
        pdf_dir
    } else {
        surface.m.pdf(s.wi.into(), surface.wo) * cont
    };
    if pdf_dir.is_nan() || pdf_dir <= 0.0 {
        return None;
    }
    let mis = &pass.mis;
    let vm = mis.merges(Site::Surface, 1.0, 0.0, camera_len, 1.0);
    let cos_out = s.wi.z.abs();
    walk.q = mis.on_scatter(walk.q, vm, cos_out, pdf_dir, pdf_rev, s.delta);
    if track && mis.correlated {
        walk.carry = mis.carry_scatter(walk.carry, vm, cos_out, pdf_dir, pdf_rev, s.delta);
    }
    if track {
        let terms = Parts::one(Merge::Surface, vm);
        walk.parts = mis.scatter_parts(walk.parts, terms, cos_out, pdf_dir, pdf_rev, s.delta);
    }
    walk.specular &= s.delta;
    walk.throughput *= Rgb::from(s.weight) / cont;
    if mode == Mode::Importance {
        walk.throughput *= surface.adjoint(wi);
    }
    if walk.throughput == Rgb::ZERO {
        return None;
    }
    walk.origin = it.p;
    walk.len += 1;
    Some(spawn_ray(it.p, it.p_err, it.ng, wi))
}
