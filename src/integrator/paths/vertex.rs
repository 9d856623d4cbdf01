//! A subpath vertex as both subpath tracers and the connections see it: a surface with
//! its BSDF, or a scattering point in a medium with its phase function. A medium
//! vertex has no cosine anywhere: its contributions use the phase function alone, and
//! its MIS factor D is the medium's grey sigma_t there, from both sides (see
//! [`super::partial`]).
//!
//! The subpath loops are compiled twice, chosen once per path: for [`WithMedia`] and
//! for [`NoMedia`], whose medium vertices are of an uninhabited type. Without media
//! the vertex enums therefore have a single possible variant, which the compiler keeps
//! in registers and never tests for, and the surface-only code costs what it did
//! before media existed.

use super::partial::{Mis, Site};
use super::parts::Parts;
use super::walk::{scatter, Eval, Surface, Walk, MIN_COS};
use super::Pass;
use crate::geometry::{spawn_ray, spawn_ray_to, Interaction, Ray};
use crate::material::{Material, Mode};
use crate::math::{Rgb, Rng, Vec3};
use crate::medium::Phase;
use std::convert::Infallible;

/// Whether a scene has media, as a type (see the module notes).
pub(crate) trait Media {
    const ON: bool;
    /// What a medium vertex holds.
    type Point<'a>: Copy;
    /// `m` as a medium vertex; None where there are none.
    fn wrap(m: MediumPoint<'_>) -> Option<Self::Point<'_>>;
    fn get<'a: 'b, 'b>(p: &'b Self::Point<'a>) -> &'b MediumPoint<'a>;
}

/// Scenes with media.
pub(crate) enum WithMedia {}

/// Scenes without media: no medium vertex can exist.
pub(crate) enum NoMedia {}

impl Media for WithMedia {
    const ON: bool = true;
    type Point<'a> = MediumPoint<'a>;

    #[inline(always)]
    fn wrap(m: MediumPoint<'_>) -> Option<MediumPoint<'_>> {
        Some(m)
    }

    #[inline(always)]
    fn get<'a: 'b, 'b>(p: &'b MediumPoint<'a>) -> &'b MediumPoint<'a> {
        p
    }
}

impl Media for NoMedia {
    const ON: bool = false;
    type Point<'a> = Infallible;

    #[inline(always)]
    fn wrap(_: MediumPoint<'_>) -> Option<Infallible> {
        None
    }

    #[inline(always)]
    fn get<'a: 'b, 'b>(p: &'b Infallible) -> &'b MediumPoint<'a> {
        match *p {}
    }
}

/// A scattering point in a medium.
#[derive(Clone, Copy)]
pub(crate) struct MediumPoint<'a> {
    pub phase: &'a Phase,
    /// Towards the previous vertex, world space.
    pub wo: Vec3,
    /// The MIS factor D: the medium's grey sigma_t here, or 1 where it is 0.
    pub sigma: f32,
    /// Russian-roulette continuation probability.
    pub cont: f32,
}

impl<'a> MediumPoint<'a> {
    /// The point `p` of medium `medium`, reached travelling along `wo`'s opposite.
    #[inline]
    pub fn new(pass: &Pass<'a>, medium: u32, p: Vec3, wo: Vec3) -> Self {
        let med = &pass.scene.media[medium as usize];
        MediumPoint {
            phase: med.phase(),
            wo,
            sigma: mis_sigma(pass, medium, p),
            cont: pass.medium_continuation(med.albedo_at(p)),
        }
    }

    /// The phase function towards `wi`, as [`Surface::eval`] gives f |cos|. Both
    /// densities equal the value: every phase function here depends only on the
    /// angle between the directions before and after scattering, which is the same
    /// for the reverse event, and is sampled exactly.
    #[inline]
    fn eval(&self, wi: Vec3) -> Option<Eval> {
        let ph = self.phase.eval(-self.wo, wi);
        (ph > 0.0).then_some(Eval {
            f: Rgb::splat(ph),
            cos: self.sigma,
            pdf_dir: ph,
            pdf_rev: ph,
        })
    }
}

impl MediumPoint<'_> {
    /// M(x) of this point with `other` the direction of its other path segment and
    /// `tc` the MIS transmittance of its camera-side segment (see
    /// [`Mis::merges`](super::partial::Mis::merges)), `camera_len` as there.
    #[inline]
    pub fn merges(&self, mis: &Mis, other: Vec3, camera_len: Option<u32>, tc: f32) -> f64 {
        let sin = mis.sine(self.wo, other);
        mis.merges(Site::Medium, self.sigma, sin, camera_len, tc)
    }
}

/// The MIS factor D of a vertex at `p` in `medium` (partial.rs: the grey sigma_t
/// there; 1 where it is 0, which no scattering vertex can be, so that D never divides
/// by 0).
#[inline]
pub(crate) fn mis_sigma(pass: &Pass, medium: u32, p: Vec3) -> f32 {
    let s = pass.scene.media[medium as usize].mis_sigma_at(p, pass.mis.local_media);
    if s > 0.0 {
        s
    } else {
        1.0
    }
}

/// What scatters at a vertex.
pub(crate) enum Scatterer<'a, M: Media> {
    Surface(Surface<'a>),
    Medium(M::Point<'a>),
}

impl<M: Media> Scatterer<'_, M> {
    /// f D towards `wi` (D: |cos| at surfaces, 1 in media) with the solid-angle
    /// densities of both directions; `cos` of the result is the MIS factor D.
    #[inline(always)]
    pub fn eval(&self, wi: Vec3, mode: Mode) -> Option<Eval> {
        match self {
            Scatterer::Surface(s) => s.eval(wi, mode),
            Scatterer::Medium(m) => M::get(m).eval(wi),
        }
    }

    #[inline(always)]
    pub fn cont(&self) -> f32 {
        match self {
            Scatterer::Surface(s) => s.cont,
            Scatterer::Medium(m) => M::get(m).cont,
        }
    }

    /// M(x) of the vertex with `other` the direction of its other path segment and
    /// `tc` the MIS transmittance of its camera-side segment.
    #[inline(always)]
    pub fn merges(&self, mis: &Mis, other: Vec3, camera_len: Option<u32>, tc: f32) -> f64 {
        match self {
            Scatterer::Surface(_) => mis.merges(Site::Surface, 1.0, 0.0, camera_len, 1.0),
            Scatterer::Medium(m) => M::get(m).merges(mis, other, camera_len, tc),
        }
    }
}

/// The vertex a subpath has just reached.
pub(crate) enum Vertex<'a, M: Media> {
    Surface {
        it: Interaction,
        s: Surface<'a>,
        /// |cos| towards the previous vertex.
        cos_in: f32,
    },
    Medium {
        p: Vec3,
        m: M::Point<'a>,
    },
}

impl<'a, M: Media> Vertex<'a, M> {
    /// A surface reached along `d`; None when it is met too grazingly for the MIS
    /// quantities, which divide by the cosine.
    #[inline(always)]
    pub fn surface(pass: &Pass, it: Interaction, m: &'a Material, d: Vec3) -> Option<Self> {
        let cos_in = it.ns.dot(d).abs();
        if cos_in < MIN_COS {
            return None;
        }
        let frame = pass.scene.shading_frame(&it);
        let cont = pass.continuation(m);
        let s = Surface {
            m,
            frame,
            ng: it.ng,
            wo: frame.to_local(-d),
            cont,
        };
        Some(Vertex::Surface { it, s, cos_in })
    }

    /// A scattering point `p` in `medium` reached along `d` (None without media).
    #[inline]
    pub fn medium(pass: &Pass<'a>, medium: u32, p: Vec3, d: Vec3) -> Option<Self> {
        let m = M::wrap(MediumPoint::new(pass, medium, p, -d))?;
        Some(Vertex::Medium { p, m })
    }

    #[inline(always)]
    pub fn p(&self) -> Vec3 {
        match self {
            Vertex::Surface { it, .. } => it.p,
            Vertex::Medium { p, .. } => *p,
        }
    }

    /// The MIS factor D towards the previous vertex.
    #[inline(always)]
    pub fn d_in(&self) -> f32 {
        match self {
            Vertex::Surface { cos_in, .. } => *cos_in,
            Vertex::Medium { m, .. } => M::get(m).sigma,
        }
    }

    /// Connections, merging and storage skip specular surfaces, and surfaces that
    /// scatter nothing arriving from the vertex's side (the back of a one-sided
    /// surface): every technique would find zero there.
    #[inline(always)]
    pub fn skips_connections(&self) -> bool {
        match self {
            Vertex::Surface { s, .. } => s.m.is_delta() || s.m.is_black_from(s.wo),
            Vertex::Medium { .. } => false,
        }
    }

    /// As [`Scatterer::eval`].
    #[inline(always)]
    pub fn eval(&self, wi: Vec3, mode: Mode) -> Option<Eval> {
        match self {
            Vertex::Surface { s, .. } => s.eval(wi, mode),
            Vertex::Medium { m, .. } => M::get(m).eval(wi),
        }
    }

    #[inline(always)]
    pub fn cont(&self) -> f32 {
        match self {
            Vertex::Surface { s, .. } => s.cont,
            Vertex::Medium { m, .. } => M::get(m).cont,
        }
    }

    /// M(x) of the vertex with `other` the direction of its other path segment and
    /// `tc` the MIS transmittance of its camera-side segment
    /// ([`Mis::merges`](super::partial::Mis::merges)), `camera_len` as there.
    #[inline(always)]
    pub fn merges(&self, mis: &Mis, other: Vec3, camera_len: Option<u32>, tc: f32) -> f64 {
        match self {
            Vertex::Surface { .. } => mis.merges(Site::Surface, 1.0, 0.0, camera_len, 1.0),
            Vertex::Medium { m, .. } => M::get(m).merges(mis, other, camera_len, tc),
        }
    }

    /// The medium a ray leaving here along `w` starts in, for a walk that arrived in
    /// `current` (a surface that bounds media switches it by side).
    #[inline(always)]
    pub fn medium_towards(&self, pass: &Pass, w: Vec3, current: Option<u32>) -> Option<u32> {
        match self {
            Vertex::Surface { it, .. } if M::ON => pass.scene.medium_after(it, w, current),
            _ => current,
        }
    }

    /// A shadow ray from here to `target` (with its error bound and normal, zero for
    /// points that are no surface), and the medium it starts in.
    #[inline(always)]
    pub fn ray_to(
        &self,
        pass: &Pass,
        current: Option<u32>,
        target: Vec3,
        target_err: Vec3,
        target_n: Vec3,
    ) -> (Ray, Option<u32>) {
        let ray = match self {
            Vertex::Surface { it, .. } => {
                spawn_ray_to(it.p, it.p_err, it.ng, target, target_err, target_n)
            }
            // No offset off a medium point: spawn_ray_to with zero error and normal.
            Vertex::Medium { p, .. } => {
                spawn_ray_to(*p, Vec3::ZERO, Vec3::ZERO, target, target_err, target_n)
            }
        };
        let medium = self.medium_towards(pass, ray.d, current);
        (ray, medium)
    }

    /// A shadow ray from here along direction `d` to infinity, and its medium.
    #[inline(always)]
    pub fn ray_along(&self, pass: &Pass, current: Option<u32>, d: Vec3) -> (Ray, Option<u32>) {
        let ray = match self {
            Vertex::Surface { it, .. } => spawn_ray(it.p, it.p_err, it.ng, d),
            Vertex::Medium { p, .. } => Ray::new(*p, d),
        };
        (ray, self.medium_towards(pass, d, current))
    }

    /// Samples the next direction (BSDF or phase function), updating throughput, MIS
    /// state and, past a surface that bounds media, the walk's medium. None ends the
    /// path; `camera_len` is Some on camera subpaths, and `track` says whether the walk
    /// keeps its [`Parts`] ([`Pass::tracks_parts`]).
    #[inline(always)]
    pub fn scatter(
        &self,
        pass: &Pass,
        rng: &mut Rng,
        walk: &mut Walk,
        mode: Mode,
        camera_len: Option<u32>,
        track: bool,
    ) -> Option<Ray> {
        match self {
            Vertex::Surface { it, s, .. } => {
                let ray = scatter(pass, rng, walk, it, s, mode, (camera_len, track))?;
                if M::ON {
                    walk.medium = self.medium_towards(pass, ray.d, walk.medium);
                }
                Some(ray)
            }
            Vertex::Medium { p, m } => {
                scatter_medium(pass, rng, walk, *p, M::get(m), (camera_len, track))
            }
        }
    }
}

/// Phase-function sampling at a medium vertex ([TR] eqs. 34-36 with D = sigma for the
/// cosine); the phase function is sampled exactly, so only roulette changes the
/// throughput.
#[inline]
fn scatter_medium(
    pass: &Pass,
    rng: &mut Rng,
    walk: &mut Walk,
    p: Vec3,
    m: &MediumPoint,
    (camera_len, track): (Option<u32>, bool),
) -> Option<Ray> {
    let (wi, pdf) = m.phase.sample(-m.wo, rng.next_2d());
    if m.cont < 1.0 && rng.next_f32() >= m.cont {
        return None;
    }
    let pdf_dir = pdf * m.cont;
    if pdf_dir.is_nan() || pdf_dir <= 0.0 {
        return None;
    }
    // A camera vertex's camera-side segment is the one it was reached by; a light
    // vertex's is the one it leaves along, whose T is settled at its end.
    let mis = &pass.mis;
    let sin = mis.sine(m.wo, wi);
    let (points, beams) = mis.merge_parts(Site::Medium, m.sigma, sin, camera_len);
    let vm = match camera_len {
        Some(_) => {
            let cut = mis.cuts(walk.medium_seen);
            if track {
                let terms = match cut {
                    true => Parts::default(),
                    false => mis.merge_terms(Site::Medium, m.sigma, sin, camera_len, walk.tr),
                };
                walk.parts = mis.scatter_parts(walk.parts, terms, m.sigma, pdf_dir, pdf_dir, false);
            }
            match cut {
                true => 0.0,
                false => points + beams * mis.beam_scale(walk.tr),
            }
        }
        None => {
            if mis.first_medium {
                // This vertex is on the camera side of every earlier one.
                walk.q = mis.cut(walk.q, walk.parts.media());
                walk.parts = walk.parts.without_media();
            }
            let terms = mis.unsettled_terms(Site::Medium, m.sigma, sin, None);
            let (now, later) = mis.defer_terms(terms, m.sigma, pdf_dir);
            walk.parts = mis.scatter_parts(walk.parts, now, m.sigma, pdf_dir, pdf_dir, false);
            walk.pending = later;
            points + if mis.long_query { 0.0 } else { beams }
        }
    };
    walk.q = mis.on_scatter(walk.q, vm, m.sigma, pdf_dir, pdf_dir, false);
    if track && mis.correlated {
        walk.carry = mis.carry_scatter(walk.carry, vm, m.sigma, pdf_dir, pdf_dir, false);
    }
    walk.medium_seen = true;
    walk.specular = false;
    walk.throughput /= m.cont;
    walk.origin = p;
    walk.len += 1;
    Some(Ray::new(p, wi))
}
