//! The gathers: what a camera path collects from the virtual lights at a surface point
//! and along a segment through a medium, and the direct light along such a segment.
//!
//! Notation: y is a point of a virtual light (a VPL, or y(u) on a ray light), x the
//! camera path's point (a surface point, or x(t) on the camera segment), d = |x - y|,
//! w the unit direction between them. With N light paths, the stored powers beta
//! already hold 1 / N, and every estimate below is a sum over the virtual lights,
//! estimated by K draws (`vl_samples`) with probabilities P(i): (1 / K) sum_k c_i / P(i).
//!
//! - VPL to a point (Keller 1997): beta f_y(w) f_x(w) T(x, y) V / d^2, the f's with
//!   their cosines at surfaces; `vpl` may cap G = |cos_x| |cos_y| / d^2 at b.
//! - VPL to a camera segment: the same at x(t), with t drawn equi-angularly about the
//!   VPL (Kulla and Fajardo 2012, whose density cancels the 1 / d^2), times
//!   T(0, t) sigma_s(x) / p(t).
//! - Ray light to a camera segment (Novák et al. 2012, eq. 3): beta T(0, u) sigma_s(y)
//!   f_p(d_l, w) T(y, x) V f_p(w, -d_c) sigma_s(x) T(0, t) / d^2, at (u, t) from one of
//!   the five pair samplers, divided by p(u, t).
//! - Ray light to a surface point (eq. 2): beta T(0, u) sigma_s(y) f_p(d_l, w)
//!   T(y, x) V f_s(w) |cos_x| / d^2, u drawn by the sampler's light-ray density.
//!
//! Transmittances are exact in homogeneous media and ratio-tracking estimates in
//! heterogeneous ones; the distance densities use a grey extinction (the mean, or the
//! majorant) and the estimate divides by the density used, so chromatic and
//! heterogeneous media stay unbiased.

use super::lights::{Lights, Picker, RayLight, Vpl};
use crate::geometry::offset::SHADOW_EPSILON;
use crate::geometry::{spawn_ray, spawn_ray_to, Interaction, Ray};
use crate::integrator::estimators::light_tree::Query;
use crate::integrator::many::vrl::{
    Beam, BeamOffset, Distance, Exponential, Pair, PairMedia, Phases, Sampler, Segment,
};
use crate::integrator::transport::adjoint::adjoint_correction;
use crate::integrator::transport::camera::sample_bsdf;
use crate::integrator::transport::equiangular::EquiAngular;
use crate::integrator::transport::medium_walk::{MediumWalk, Step};
use crate::integrator::transport::nee::{direct_unweighted, Origin};
use crate::integrator::RenderStats;
use crate::light::Light;
use crate::material::{Material, Mode};
use crate::math::{Frame, Rgb, Rng, Vec3};
use crate::scene::Scene;

/// A camera path's point that gathers.
#[derive(Clone, Copy)]
pub(super) enum At<'a> {
    /// A non-specular surface point; `wo` (local) points back along the path, `medium`
    /// is the one the path arrived in.
    Surface {
        it: &'a Interaction,
        frame: Frame,
        wo: Vec3,
        m: &'a Material,
        medium: Option<u32>,
    },
    /// A point of a medium, reached travelling along `d`.
    Medium { p: Vec3, d: Vec3, medium: u32 },
}

impl At<'_> {
    fn p(&self) -> Vec3 {
        match self {
            At::Surface { it, .. } => it.p,
            At::Medium { p, .. } => *p,
        }
    }

    /// f |cos| (the phase function in a medium) for light arriving from unit
    /// direction `w`, and the |cos| of G (1 in a medium).
    #[inline]
    fn eval(&self, scene: &Scene, w: Vec3) -> Option<(Rgb, f32)> {
        match self {
            At::Surface {
                it, frame, wo, m, ..
            } => {
                let wi = frame.to_local(w);
                // Light from behind the geometric surface would leak through it.
                if (w.dot(it.ng) > 0.0) != (wi.z > 0.0) {
                    return None;
                }
                let f = m.eval_pdfs(*wo, wi, Mode::Radiance).0;
                (f != Rgb::ZERO).then_some((f, wi.z.abs()))
            }
            At::Medium { d, medium, .. } => {
                let ph = scene.media[*medium as usize].phase().eval(*d, w);
                (ph > 0.0).then_some((Rgb::splat(ph), 1.0))
            }
        }
    }

    /// The shadow ray towards `q` (a surface point with its error bound and normal, or
    /// a medium point with zeros) and the medium it starts in.
    #[inline]
    fn ray_to(&self, scene: &Scene, q: Vec3, q_err: Vec3, q_n: Vec3) -> (Ray, Option<u32>) {
        match self {
            At::Surface { it, medium, .. } => {
                let ray = spawn_ray_to(it.p, it.p_err, it.ng, q, q_err, q_n);
                (ray, scene.medium_after(it, ray.d, *medium))
            }
            At::Medium { p, medium, .. } => (
                spawn_ray_to(*p, Vec3::ZERO, Vec3::ZERO, q, q_err, q_n),
                Some(*medium),
            ),
        }
    }
}

/// A camera segment through a medium as the gathers see it: from `o` along unit `d`
/// for `len` (the first surface, the field's end, or a cut at rate `cut`, see
/// `lights::extent`). `full` is where the medium really ends (infinite when
/// unbounded): gathers about a point sample the whole of it, since equi-angular
/// sampling has a proper density on an unbounded ray and a cut would put the point's
/// glow behind a survival weight exp(cut t) that grows without bound.
#[derive(Clone, Copy, Debug)]
pub(super) struct CamSeg {
    pub o: Vec3,
    pub d: Vec3,
    pub len: f32,
    pub cut: f32,
    pub full: f32,
    pub medium: u32,
}

impl CamSeg {
    /// T(0, t) sigma_s(x(t)), over the probability that the cut lies beyond t: the
    /// weight of a point drawn on [0, len].
    #[inline]
    fn weight(&self, scene: &Scene, t: f32, rng: &mut Rng) -> Rgb {
        self.scattering(scene, t, rng) * (self.cut * t).exp()
    }

    /// T(0, t) sigma_s(x(t)): the weight of a point drawn on [0, full].
    #[inline]
    fn scattering(&self, scene: &Scene, t: f32, rng: &mut Rng) -> Rgb {
        let m = &scene.media[self.medium as usize];
        m.transmittance(self.o, self.d, t, rng) * m.sigma_s_at(self.o + self.d * t)
    }

    /// Equi-angular sampling about `p` over the whole segment.
    #[inline]
    fn about(&self, p: Vec3) -> Option<EquiAngular> {
        EquiAngular::new(&Ray::new(self.o, self.d), self.full, p)
    }

    fn segment(&self) -> Segment {
        Segment::new(self.o, self.d, self.len)
    }

    fn query(&self) -> Query {
        Query {
            o: self.o,
            d: self.d,
            tmax: self.len,
        }
    }
}

impl RayLight {
    /// T(0, u) sigma_s(y(u)) along `seg` (the ray light itself, or its displaced copy
    /// in a beam), over the probability that its cut lies beyond u.
    #[inline]
    fn weight(&self, scene: &Scene, seg: &Segment, u: f32, rng: &mut Rng) -> Rgb {
        let m = &scene.media[self.medium as usize];
        let tr = m.transmittance(seg.o, seg.d, u, rng);
        tr * m.sigma_s_at(seg.at(u)) * (self.cut * u).exp()
    }
}

/// The many-light estimators of one iteration.
pub(super) struct Gather<'a> {
    pub scene: &'a Scene,
    pub lights: &'a Lights,
    pub max_depth: u32,
    /// K; 0 takes every virtual light once.
    pub vl_samples: u32,
    /// `vpl`'s cap on G, and whether the capped energy is compensated.
    pub clamp: Option<(f32, bool)>,
    /// The pair sampler, when ray lights are on.
    pub sampler: Option<Sampler>,
    /// `vbl`'s beam radius this iteration; 0 for ray lights.
    pub beam_radius: f32,
}

impl Gather<'_> {
    /// `vpl compensate`: the capped energy is re-estimated.
    #[inline]
    pub fn compensates(&self) -> bool {
        matches!(self.clamp, Some((_, true)))
    }

    /// The ray light a gather uses: `r`'s segment itself, or for a beam (radius > 0)
    /// the segment displaced by an offset drawn over the beam's disk, with the weight
    /// (1 / (pi r^2)) / p(offset) (`vrl::beam`: averaging the ray light's transport
    /// over the disk is the beam's, and r = 0 is exactly `vrl`). None when the offset's
    /// weight is 0 (an offset of measure zero).
    #[inline]
    fn beam_of(&self, r: &RayLight, how: BeamOffset, rng: &mut Rng) -> Option<(Segment, f32)> {
        if self.beam_radius <= 0.0 {
            return Some((r.seg, 1.0));
        }
        let b = Beam::new(&r.seg, self.beam_radius).sample(how, [rng.next_f32(), rng.next_f32()]);
        (b.weight > 0.0 && b.weight.is_finite()).then_some((b.light, b.weight))
    }

    /// Draw `k` of `n` virtual lights: the index and the factor 1 / (K P(i)).
    #[inline]
    fn draw(
        &self,
        picker: &Picker,
        q: &Query,
        n: usize,
        k: usize,
        rng: &mut Rng,
    ) -> Option<(usize, f32)> {
        if self.vl_samples == 0 {
            return Some((k, 1.0));
        }
        let (i, p) = picker.pick(q, rng.next_f32())?;
        (i < n).then(|| (i, 1.0 / (self.vl_samples as f32 * p)))
    }

    fn draws(&self, picker: &Picker, n: usize) -> usize {
        if picker.is_empty() {
            0
        } else if self.vl_samples == 0 {
            n
        } else {
            self.vl_samples as usize
        }
    }

    /// Everything a non-specular surface point gathers, camera segments `j` from the
    /// eye: direct light, VPLs, ray lights and (for `vpl compensate`) the residual.
    #[allow(clippy::too_many_arguments)]
    pub fn surface(
        &self,
        it: &Interaction,
        frame: Frame,
        wo: Vec3,
        m: &Material,
        medium: Option<u32>,
        j: u32,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> Rgb {
        let mut l = Rgb::ZERO;
        if j < self.max_depth {
            let at = Origin::Surface {
                it,
                frame: &frame,
                wo,
                m,
            };
            l += direct_unweighted(self.scene, &at, medium, rng, stats);
        }
        let x = At::Surface {
            it,
            frame,
            wo,
            m,
            medium,
        };
        l += self.vpls_at(&x, j, rng, stats);
        l += self.rays_at_surface(&x, j, rng, stats);
        l + self.residual(&x, j, rng, stats)
    }

    /// What a medium point reached by a free flight gathers (the compensation's
    /// continuation only, so no ray lights): direct light, VPLs, residual.
    fn medium_point(&self, x: &At, j: u32, rng: &mut Rng, stats: &mut RenderStats) -> Rgb {
        let At::Medium { p, d, medium } = *x else {
            return Rgb::ZERO;
        };
        let mut l = Rgb::ZERO;
        if j < self.max_depth {
            let phase = self.scene.media[medium as usize].phase();
            let at = Origin::Medium { p, d, phase };
            l += direct_unweighted(self.scene, &at, Some(medium), rng, stats);
        }
        l += self.vpls_at(x, j, rng, stats);
        l + self.residual(x, j, rng, stats)
    }

    /// Everything a camera segment through a medium gathers, per unit of the
    /// throughput at its start.
    pub fn segment(&self, c: &CamSeg, j: u32, rng: &mut Rng, stats: &mut RenderStats) -> Rgb {
        self.direct_on(c, j, rng, stats)
            + self.vpls_on(c, j, rng, stats)
            + self.rays_on(c, j, rng, stats)
    }

    /// VPLs at a point.
    fn vpls_at(&self, x: &At, j: u32, rng: &mut Rng, stats: &mut RenderStats) -> Rgb {
        let (vpls, pick) = (&self.lights.vpls, &self.lights.vpl_pick);
        let q = Query::point(x.p());
        let mut l = Rgb::ZERO;
        for k in 0..self.draws(pick, vpls.len()) {
            let Some((i, w)) = self.draw(pick, &q, vpls.len(), k, rng) else {
                continue;
            };
            let y = &vpls[i];
            if y.len + 1 + j <= self.max_depth {
                l += self.vpl_link(x, y, rng, stats) * w;
            }
        }
        l
    }

    /// One VPL's light at x, capped when `clamp` says so.
    #[inline]
    fn vpl_link(&self, x: &At, y: &Vpl, rng: &mut Rng, stats: &mut RenderStats) -> Rgb {
        let to = y.p - x.p();
        let d2 = to.length_squared();
        if !(d2 > 0.0 && d2.is_finite()) {
            return Rgb::ZERO;
        }
        let w = to / d2.sqrt();
        let Some((fx, cos_x)) = x.eval(self.scene, w) else {
            return Rgb::ZERO;
        };
        let Some((fy, cos_y)) = vpl_eval(self.scene, y, -w) else {
            return Rgb::ZERO;
        };
        let g = cos_x * cos_y / d2;
        let cap = match self.clamp {
            Some((b, _)) if g > b => b / g,
            _ => 1.0,
        };
        stats.connections += 1;
        stats.shadow_rays += 1;
        let (ray, medium) = x.ray_to(self.scene, y.p, y.p_err, y.ng);
        let tr = self
            .scene
            .transmittance(&ray, medium, rng, &mut stats.shadow_rays);
        y.beta * fy * fx * tr * (cap / d2)
    }

    /// VPLs along a camera segment, each at an equi-angular distance about it over the
    /// whole segment (uniform on the cut one where the VPL lies on the segment's line,
    /// which equi-angular cannot serve).
    fn vpls_on(&self, c: &CamSeg, j: u32, rng: &mut Rng, stats: &mut RenderStats) -> Rgb {
        let (vpls, pick) = (&self.lights.vpls, &self.lights.vpl_pick);
        let q = c.query();
        let mut l = Rgb::ZERO;
        for k in 0..self.draws(pick, vpls.len()) {
            let Some((i, w)) = self.draw(pick, &q, vpls.len(), k, rng) else {
                continue;
            };
            let y = &vpls[i];
            if y.len + 1 + j > self.max_depth {
                continue;
            }
            let xi = rng.next_f32();
            let (t, pdf, whole) = match c.about(y.p) {
                Some(ea) => {
                    let (t, pdf) = ea.sample(xi);
                    (t, pdf, true)
                }
                None => (xi * c.len, 1.0 / c.len, false),
            };
            if !(pdf > 0.0 && pdf.is_finite()) {
                continue;
            }
            let x = At::Medium {
                p: c.o + c.d * t,
                d: c.d,
                medium: c.medium,
            };
            let e = self.vpl_link(&x, y, rng, stats);
            if e != Rgb::ZERO {
                let wt = if whole {
                    c.scattering(self.scene, t, rng)
                } else {
                    c.weight(self.scene, t, rng)
                };
                l += e * wt * (w / pdf);
            }
        }
        l
    }

    /// Single scattering of the lights along a camera segment: one light by the scene's
    /// light sampler, a distance on the segment (`distance_for`) and a point on the
    /// light seen from there.
    fn direct_on(&self, c: &CamSeg, j: u32, rng: &mut Rng, stats: &mut RenderStats) -> Rgb {
        let scene = self.scene;
        if j >= self.max_depth || scene.lights.is_empty() {
            return Rgb::ZERO;
        }
        let (li, sel, _) = scene.light_sampler.sample(rng.next_f32());
        let light = &scene.lights[li];
        let Some((t, wt)) = self.distance_for(c, light, rng) else {
            return Rgb::ZERO;
        };
        if sel <= 0.0 {
            return Rgb::ZERO;
        }
        let x = c.o + c.d * t;
        let Some(ls) = light.sample_li(x, rng.next_2d()) else {
            return Rgb::ZERO;
        };
        let ph = scene.media[c.medium as usize].phase().eval(c.d, ls.wi());
        if ls.pdf <= 0.0 || ls.pdf.is_nan() || ph == 0.0 || ls.li() == Rgb::ZERO {
            return Rgb::ZERO;
        }
        stats.connections += 1;
        stats.shadow_rays += 1;
        let ray = if ls.dist.is_finite() {
            Ray {
                o: x,
                d: ls.p() - x,
                tmax: 1.0 - SHADOW_EPSILON,
            }
        } else {
            Ray::new(x, ls.wi())
        };
        let tr = scene.transmittance(&ray, Some(c.medium), rng, &mut stats.shadow_rays);
        if tr == Rgb::ZERO {
            return Rgb::ZERO;
        }
        wt * tr * ls.li() * (ph / (sel * ls.pdf))
    }

    /// A distance t on the whole camera segment for direct light from `light`, with the
    /// weight T(0, t) sigma_s(x(t)) / p(t): equi-angular about a point or spot light
    /// (Kulla and Fajardo 2012); otherwise an exponential in a homogeneous medium, and
    /// in a heterogeneous one a free flight by spectral tracking, whose weight stays
    /// bounded where a fixed rate would let T(t) / p(t) grow without bound in thin
    /// regions. None: no scattering point.
    fn distance_for(&self, c: &CamSeg, light: &Light, rng: &mut Rng) -> Option<(f32, Rgb)> {
        let m = &self.scene.media[c.medium as usize];
        let ea = match light {
            Light::Point(l) => c.about(l.position),
            Light::Spot(l) => c.about(l.position),
            _ => None,
        };
        let (t, pdf) = match (ea, m.as_homogeneous()) {
            (Some(ea), _) => ea.sample(rng.next_f32()),
            (None, Some(_)) => {
                // Unbounded: the cut's rate, the smallest extinction of the channels,
                // keeps T(t) / p(t) bounded in every channel.
                let sigma = if c.full.is_finite() {
                    m.sampling_sigma_t()
                } else {
                    c.cut
                };
                let e = Exponential {
                    sigma: sigma as f64,
                    len: c.full as f64,
                };
                let t = e.sample(rng.next_f32() as f64).0 as f32;
                (t, e.pdf(t as f64) as f32)
            }
            (None, None) => {
                // Heterogeneous media end where their field does (`lights::extent`).
                return match m.sample_flight(c.o, c.d, c.full, Rgb::ONE, rng) {
                    crate::medium::Flight::Scatter { t, weight } => Some((t, weight)),
                    _ => None,
                };
            }
        };
        let ok = pdf > 0.0 && pdf.is_finite() && t.is_finite();
        ok.then(|| (t, c.scattering(self.scene, t, rng) / pdf))
    }

    /// Ray lights along a camera segment (volume to volume).
    fn rays_on(&self, c: &CamSeg, j: u32, rng: &mut Rng, stats: &mut RenderStats) -> Rgb {
        let Some(sampler) = self.sampler else {
            return Rgb::ZERO;
        };
        let scene = self.scene;
        let (rays, pick) = (&self.lights.rays, &self.lights.ray_pick);
        let cm = &scene.media[c.medium as usize];
        let cam = c.segment();
        let q = c.query();
        let mut l = Rgb::ZERO;
        for k in 0..self.draws(pick, rays.len()) {
            let Some((i, w)) = self.draw(pick, &q, rays.len(), k, rng) else {
                continue;
            };
            let r = &rays[i];
            if r.len + 1 + j > self.max_depth {
                continue;
            }
            // Volume to volume the uniform offset suffices: the pair samplers already
            // cancel the (logarithmic) singularity of close rays.
            let Some((light, wb)) = self.beam_of(r, BeamOffset::Uniform, rng) else {
                continue;
            };
            let Some(pair) = Pair::new(light, cam) else {
                continue;
            };
            let lm = &scene.media[r.medium as usize];
            let media = PairMedia {
                sigma_light: lm.sampling_sigma_t(),
                sigma_cam: cm.sampling_sigma_t(),
                phases: Phases {
                    light: *lm.phase(),
                    cam: *cm.phase(),
                },
            };
            let s = sampler.sample(&pair, &media, [rng.next_f32(), rng.next_f32()]);
            if !(s.pdf > 0.0 && s.pdf.is_finite()) {
                continue;
            }
            let (y, x) = (light.at(s.u), cam.at(s.t));
            let to = x - y;
            let d2 = to.length_squared();
            if !(d2 > 0.0 && d2.is_finite()) {
                continue;
            }
            let dir = to / d2.sqrt();
            let f = lm.phase().eval(light.d, dir) * cm.phase().eval(dir, -c.d);
            if f == 0.0 {
                continue;
            }
            stats.connections += 1;
            stats.shadow_rays += 1;
            let ray = Ray {
                o: y,
                d: to,
                tmax: 1.0 - SHADOW_EPSILON,
            };
            let tr = scene.transmittance(&ray, Some(r.medium), rng, &mut stats.shadow_rays);
            if tr == Rgb::ZERO {
                continue;
            }
            let wl = r.weight(scene, &light, s.u, rng);
            let wc = c.weight(scene, s.t, rng);
            l += r.beta * wl * wc * tr * (f * w * wb / (d2 * s.pdf));
        }
        l
    }

    /// Ray lights at a surface point (volume to surface).
    fn rays_at_surface(&self, x: &At, j: u32, rng: &mut Rng, stats: &mut RenderStats) -> Rgb {
        let Some(sampler) = self.sampler else {
            return Rgb::ZERO;
        };
        let scene = self.scene;
        let (rays, pick) = (&self.lights.rays, &self.lights.ray_pick);
        let density = sampler.surface();
        let p = x.p();
        let q = Query::point(p);
        let mut l = Rgb::ZERO;
        for k in 0..self.draws(pick, rays.len()) {
            let Some((i, w)) = self.draw(pick, &q, rays.len(), k, rng) else {
                continue;
            };
            let r = &rays[i];
            if r.len + 1 + j > self.max_depth {
                continue;
            }
            // Polar about p: the offset's density cancels the 1 / h of the displaced
            // line's distance to p, the singularity the beam exists to remove.
            let Some((light, wb)) = self.beam_of(r, BeamOffset::AboutPoint(p), rng) else {
                continue;
            };
            let lm = &scene.media[r.medium as usize];
            let (u, pdf) = density.sample(&light, lm.sampling_sigma_t(), p, rng.next_f32());
            if !(pdf > 0.0 && pdf.is_finite()) {
                continue;
            }
            let y = light.at(u);
            let to = y - p;
            let d2 = to.length_squared();
            if !(d2 > 0.0 && d2.is_finite()) {
                continue;
            }
            let dir = to / d2.sqrt();
            let Some((fx, _)) = x.eval(scene, dir) else {
                continue;
            };
            let fy = lm.phase().eval(light.d, -dir);
            if fy == 0.0 {
                continue;
            }
            stats.connections += 1;
            stats.shadow_rays += 1;
            let (ray, medium) = x.ray_to(scene, y, Vec3::ZERO, Vec3::ZERO);
            let tr = scene.transmittance(&ray, medium, rng, &mut stats.shadow_rays);
            if tr == Rgb::ZERO {
                continue;
            }
            let wl = r.weight(scene, &light, u, rng);
            l += r.beta * wl * fx * tr * (fy * w * wb / (d2 * pdf));
        }
        l
    }

    /// Kollig and Keller's compensation (2004) of what the cap on G removed at x: the
    /// path continues by sampling x's BSDF (or phase function) to the next event y',
    /// whose gathered light (direct, VPLs, and its own residual: the recursion) counts
    /// with the weight max(0, 1 - b / G(x, y')). Emission at y' does not count (direct
    /// light at x is next-event estimation's, uncapped), nor does a specular y' (no
    /// VPL lies on one).
    pub fn residual(&self, x: &At, j: u32, rng: &mut Rng, stats: &mut RenderStats) -> Rgb {
        let Some((b, true)) = self.clamp else {
            return Rgb::ZERO;
        };
        if j + 2 > self.max_depth {
            return Rgb::ZERO;
        }
        let scene = self.scene;
        let (mut ray, beta, medium, cos_x) = match *x {
            At::Surface {
                it,
                frame,
                wo,
                m,
                medium,
            } => {
                let Some((wi, s)) = sample_bsdf(it, &frame, wo, m, rng) else {
                    return Rgb::ZERO;
                };
                if s.delta {
                    return Rgb::ZERO;
                }
                let ray = spawn_ray(it.p, it.p_err, it.ng, wi);
                let medium = scene.medium_after(it, wi, medium);
                (ray, Rgb::from(s.weight), medium, s.wi.z.abs())
            }
            At::Medium { p, d, medium } => {
                let phase = scene.media[medium as usize].phase();
                let (wi, _) = phase.sample(d, rng.next_2d());
                (Ray::new(p, wi), Rgb::ONE, Some(medium), 1.0)
            }
        };
        stats.rays += 1;
        let mut walk = MediumWalk { beta, medium };
        let (y, cos_y, j2) = match walk.next(scene, &mut ray, &mut (), rng, stats) {
            Step::Surface(it, m) if !m.is_delta() => {
                let cos_y = it.ns.dot(ray.d).abs();
                let frame = scene.shading_frame(&it);
                let wo = frame.to_local(-ray.d);
                let g = cos_x * cos_y / (it.p - x.p()).length_squared();
                let rw = (1.0 - b / g).max(0.0);
                if rw <= 0.0 || rw.is_nan() {
                    return Rgb::ZERO;
                }
                let l = self.surface(&it, frame, wo, &m, walk.medium, j + 1, rng, stats);
                return walk.beta * l * rw;
            }
            Step::Scatter { seg, t, .. } => (seg.ray.at(t), 1.0, seg.medium),
            _ => return Rgb::ZERO,
        };
        let g = cos_x * cos_y / (y - x.p()).length_squared();
        let rw = (1.0 - b / g).max(0.0);
        if rw <= 0.0 || rw.is_nan() {
            return Rgb::ZERO;
        }
        let at = At::Medium {
            p: y,
            d: ray.d,
            medium: j2,
        };
        walk.beta * self.medium_point(&at, j + 1, rng, stats) * rw
    }
}

/// f |cos| (or the phase function) with which VPL y scatters the light it received
/// into unit direction `v`, and the |cos| of G (1 in a medium).
#[inline]
fn vpl_eval(scene: &Scene, y: &Vpl, v: Vec3) -> Option<(Rgb, f32)> {
    match y.material {
        None => {
            let medium = y.medium?;
            let ph = scene.media[medium as usize].phase().eval(-y.wo, v);
            (ph > 0.0).then_some((Rgb::splat(ph), 1.0))
        }
        Some(mi) => {
            let frame = Frame::twisted(y.ns, y.twist);
            let wi = frame.to_local(v);
            if (v.dot(y.ng) > 0.0) != (wi.z > 0.0) {
                return None;
            }
            let wo = frame.to_local(y.wo);
            let f = scene
                .material_on(mi, y.uv, y.ng, &frame)
                .eval_pdfs(wo, wi, Mode::Importance)
                .0
                * adjoint_correction(y.ns, y.ng, y.wo, v);
            (f != Rgb::ZERO).then_some((f, wi.z.abs()))
        }
    }
}
