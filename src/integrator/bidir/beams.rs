//! The beam estimators of `upbp` (Křivánek et al. 2014, [UPBP]) on the bidirectional
//! core: every camera segment through a medium is a query beam, which gathers the
//! light subpaths' medium vertices within r2 of it (point x beam 2D, kernel
//! 1 / (pi r2^2)) and their segments, as photon beams, within r1 (beam x beam 1D,
//! kernel 1 / (2 r1 sin theta)). Each contribution is weighted by the MIS of
//! [`super::mis`], with both subpaths' partial weights completed at the point the
//! estimate stands for.
//!
//! Photon beams are short ([UPBP]'s choice and SmallUPBP's default for them): a beam
//! ends where the light's free flight did, each point weighted by T / P(the flight
//! passes it) (1 in grey media), so the density of reaching a point is T, as the MIS
//! assumes. Query beams are short by default too, or long (`query_beams`, SmallUPBP's
//! default): a camera segment then gathers along its whole length to the next surface
//! or null boundary, weighted by T, whether or not the camera's flight scattered on
//! the way. Each segment the flight entered is covered once, so this is the expected
//! value of the short query over the flight's distance (Rao-Blackwellised: same mean,
//! never more variance per iteration). A long beam covers a point with probability 1
//! where a short one has T, so its density there is larger by 1 / T of the camera
//! segment up to the point, and the MIS weighs it so (`long_beam_weights`, as
//! SmallUPBP: [`Mis::beam_scale`]); the short beams' weights are kept on request, also
//! a valid partition, since MIS weights only have to sum to one over the techniques
//! for each path. Heterogeneous media have no closed-form P: there both kinds are long
//! (to the surface, weight T by ratio tracking), still an unbiased estimate of the same
//! MIS-weighted integral, whose MIS proxy T is the quadrature of `Medium::mis_depth`.
//!
//! [`Mis::beam_scale`]: crate::integrator::paths::partial::Mis::beam_scale

use super::camera_path::record;
use super::radius_layers::{index_in, light_q};
use super::selection::{rule, Rule};
use super::Pass;
use crate::integrator::estimators::beam_estimate::{meet, Meeting};
use crate::integrator::estimators::beams::{collect, Beam, BeamForm};
use crate::integrator::estimators::{Lbvh, Point, PointBvh};
use crate::integrator::memory::{array, refilled};
use crate::integrator::paths::correlation::{
    merge_fixes, CameraSide, Carry, Chain, FlightLinks, Footprint, Link,
};
use crate::integrator::paths::light_vertex::{LightVertex, MEDIUM_VERTEX};
use crate::integrator::paths::partial::{self as mis, Merge, Mis, Partial, Site, MIN_BEAM_SIN};
use crate::integrator::paths::parts::{Candidate, Parts, Scale, MEDIA};
use crate::integrator::paths::segments::{FlightOrigin, LightSegment};
use crate::integrator::paths::store::{
    links_to, path_segment_links, path_segment_parts, path_segments, Chunk,
};
use crate::integrator::paths::vertex::{mis_sigma, MediumPoint};
use crate::integrator::transport::PATHS_PER_TASK;
use crate::integrator::RenderStats;
use crate::math::{Rgb, Rng, Vec3};
use crate::medium::Medium;
use std::sync::atomic::AtomicU32;

impl Point for LightVertex {
    #[inline(always)]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// Beams are stored in pieces of at most this fraction of the scene's radius (as
/// `ppb` does, for the BVH).
const PIECE: f32 = 1.0 / 16.0;

/// An iteration's photon points (medium vertices) and photon beams, indexed.
#[derive(Default)]
pub(super) struct BeamStore {
    points: Vec<LightVertex>,
    point_bvh: PointBvh<LightVertex>,
    segments: Vec<LightSegment>,
    beams: Vec<Beam>,
    beam_bvh: Lbvh<Beam>,
    /// With radius layers, the points' and the segments' [`Parts`] (theirs, and for a
    /// segment the pending ones of its start), in `points`' and `segments`' order.
    point_parts: Vec<Parts>,
    segment_parts: Vec<[Parts; 2]>,
    /// With correlation-aware MIS, where the points' links are (chunk, vertex) and
    /// the segments' flights began (chunk, start), in the same orders.
    point_origins: Vec<(u32, u32)>,
    segment_links: Vec<(u32, FlightLinks)>,
}

impl BeamStore {
    /// Gathers what the pass's estimators need from the light store.
    pub fn build(&mut self, pass: &Pass, chunks: &[Chunk], seed: u64, iteration: u64) {
        self.points.clear();
        self.segments.clear();
        self.beams.clear();
        self.point_parts.clear();
        self.segment_parts.clear();
        self.point_origins.clear();
        self.segment_links.clear();
        let (radii, correlated) = (pass.reweights(), pass.mis.correlated);
        if pass.technique.uses(Merge::PointBeam2d) {
            let all = chunks.iter().flat_map(|c| c.vertices.iter());
            let medium = all.filter(|v| v.material == MEDIUM_VERTEX);
            self.points.extend(medium.copied());
            if radii {
                let all = chunks.iter().flat_map(|c| c.vertices.iter().zip(&c.parts));
                let medium = all.filter(|(v, _)| v.material == MEDIUM_VERTEX);
                self.point_parts.extend(medium.map(|(_, p)| *p));
            }
            if correlated {
                let at = chunks.iter().enumerate().flat_map(|(c, chunk)| {
                    let vs = chunk.vertices.iter().enumerate();
                    vs.filter(|(_, v)| v.material == MEDIUM_VERTEX)
                        .map(move |(i, _)| (c as u32, i as u32))
                });
                self.point_origins.extend(at);
            }
        }
        self.point_bvh.build(&mut self.points);
        if !self.points.is_empty() {
            // The BVH reordered the points: their side arrays follow.
            reorder(&mut self.point_parts, &self.point_bvh);
            reorder(&mut self.point_origins, &self.point_bvh);
        }
        if pass.technique.uses(Merge::BeamBeam1d) {
            let n = pass.beam_paths.min(pass.light_paths);
            for path in 0..n {
                self.segments.extend_from_slice(path_segments(chunks, path));
                if radii {
                    let parts = path_segment_parts(chunks, path);
                    self.segment_parts.extend_from_slice(parts);
                }
                if correlated {
                    let chunk = (path / PATHS_PER_TASK) as u32;
                    let links = path_segment_links(chunks, path).iter();
                    self.segment_links.extend(links.map(|l| (chunk, *l)));
                }
            }
            let scene = pass.scene;
            let piece = scene.sphere.radius * PIECE;
            let segs = self.segments.iter().copied();
            let (form, out) = (BeamForm::Short, &mut self.beams);
            collect(scene, segs, n, form, piece, seed, iteration, out);
        }
        self.beam_bvh.build(&mut self.beams);
    }

    /// Bytes the store holds once built over `points` medium vertices, `segments`
    /// light segments and the `pieces` of their beams (what [`BeamStore::bytes`] then
    /// reports): each array as it is refilled, and its BVH.
    pub fn bytes_for(points: f64, segments: f64, pieces: f64) -> f64 {
        array::<LightVertex>(refilled(points, 0.0))
            + Lbvh::<LightVertex>::bytes_for(points)
            + array::<LightSegment>(refilled(segments, 0.0))
            + array::<Beam>(refilled(pieces, 0.0))
            + Lbvh::<Beam>::bytes_for(pieces)
    }

    pub fn bytes(&self) -> usize {
        self.point_parts.capacity() * std::mem::size_of::<Parts>()
            + self.point_origins.capacity() * 8
            + self.segment_links.capacity() * std::mem::size_of::<(u32, FlightLinks)>()
            + self.segment_parts.capacity() * std::mem::size_of::<[Parts; 2]>()
            + self.points.capacity() * std::mem::size_of::<LightVertex>()
            + self.segments.capacity() * std::mem::size_of::<LightSegment>()
            + self.beams.capacity() * std::mem::size_of::<Beam>()
            + self.point_bvh.bytes()
            + self.beam_bvh.bytes()
    }
}

/// A side array of the points (empty, or one item per point) put in the order the
/// BVH gave the points.
fn reorder<T: Copy>(side: &mut Vec<T>, bvh: &PointBvh<LightVertex>) {
    if side.is_empty() {
        return;
    }
    let all = std::mem::take(side);
    side.extend(bvh.order().map(|i| all[i]));
}

/// A subpath's partial weights completed at the point x, `u` along segment `s` from its
/// start, where a vertex with MIS factor D = `sigma` would be (as `on_hit` at a vertex
/// reached along the segment's flight), without the merges in media of the light's
/// earlier vertices under `merge_depth: first` (x is on their camera side); the MIS
/// transmittance from the segment's vertex to x, and the squared distance the MIS
/// gives the flight (1 from a light at infinity, as at the subpath's first vertex).
fn partial_at(pass: &Pass, s: &LightSegment, x: Vec3, u: f32, sigma: f32) -> (Partial, f32, f32) {
    let scene = pass.scene;
    let dist2 = match s.origin {
        FlightOrigin::Infinite => 1.0,
        _ => (x - s.from).length_squared(),
    };
    let piece = scene.media[s.medium as usize].mis_depth(s.o, s.d, 0.0, u, pass.mis.local_media);
    let tr = mis::transmittance(s.depth0 + piece);
    let mut q = s.q;
    if let FlightOrigin::Area(li, n0) = s.origin {
        // The first segment from an area light: its light-sampling density at x
        // completes dvcm, as the light subpath does at its first vertex.
        let li = li as usize;
        let light = &scene.lights[li];
        let pick = scene.light_sampler.pmf(li) as f64;
        let (pos, dir) = light.pdf_le(&scene.sphere, n0, s.d);
        let emission = pick * pos as f64 * dir as f64;
        let pdf_w = light.pdf_li(x, -s.d, s.from, n0) as f64;
        let cos0 = n0.dot(s.d).abs() as f64;
        q.dvcm = pass.mis.f(pick * pdf_w * cos0 / (dist2 as f64 * emission));
    }
    let mis = &pass.mis;
    let q = mis.light_hit(q, s.pending, dist2 / tr, tr, sigma);
    if !mis.first_medium {
        return (q, tr, dist2);
    }
    // The pending terms are the query beams', all in media.
    (
        mis.cut(q, mis.hit_share(s.vol, s.pending, tr, sigma)),
        tr,
        dist2,
    )
}

/// The parts of [`partial_at`]'s partial weights, from the segment's start's
/// `[parts, pending parts]` (radius layers).
fn parts_at(pass: &Pass, [parts, pending]: &[Parts; 2], tr: f32, sigma: f32) -> Parts {
    let at = pass.mis.hit_parts(*parts, *pending, tr, sigma);
    match pass.mis.first_medium {
        true => at.without_media(),
        false => at,
    }
}

/// The camera's query beam along camera segment `c`, and the medium it is in.
fn query_beam<'a>(pass: &'a Pass, c: &LightSegment, rng: &mut Rng) -> Option<(Beam, &'a Medium)> {
    let m = &pass.scene.media[c.medium as usize];
    let b = Beam::new(pass.scene, c, pass.s.query_beams, 1.0, rng.next_f32())?;
    Some((b, m))
}

/// What both beam estimators read of the camera side: its segment, query beam, the
/// MIS factor D of its medium (homogeneous; see [`Query::sigma_at`]), the camera
/// subpath's length, and with radius layers the parts where its flight began.
struct Query<'a> {
    c: &'a LightSegment,
    beam: Beam,
    m: &'a Medium,
    sigma: f32,
    camera_len: u32,
    /// In a homogeneous medium, the continuation probability and sigma_s, the same at
    /// every point (read once per query rather than per merge).
    uniform: Option<(f32, Rgb)>,
    parts: Parts,
    /// How the main image weighs this estimator's merges (per-pixel selection).
    rule: Rule<'a>,
    corr: Option<Correlated<'a>>,
}

/// With correlation-aware MIS, what a query's merges read for their correlation
/// factors: the camera subpath's side, its carry where the flight began, and the
/// light store's chunks, which hold the light subpaths' links.
#[derive(Clone, Copy)]
pub(super) struct Correlated<'a> {
    pub side: CameraSide<'a>,
    pub carry: Carry,
    pub chunks: &'a [Chunk],
}

/// Where the two sides of a beam estimate meet, as its MIS reads it: the merged
/// vertex's D (`sigma`), the camera segment's MIS transmittance to it (`tr`), the
/// sine between the two directions, both sides' partial weights (light, camera),
/// their continuation probabilities (camera, light) and the phase function.
struct Meet {
    sigma: f32,
    tr: f32,
    /// The camera flight's squared distance to the meeting.
    dist2: f32,
    sin: f32,
    q: (Partial, Partial),
    cont: (f32, f32),
    ph: f32,
}

impl Meet {
    /// Estimator `k`'s weight under `mis`, the sides' partial weights being `q`.
    #[inline(always)]
    fn weight(&self, mis: &Mis, k: Merge, q: (Partial, Partial)) -> f32 {
        self.weight_rho(mis, k, q, 1.0)
    }

    /// [`Meet::weight`] with the meeting's merge densities scaled by `rho`.
    #[inline(always)]
    fn weight_rho(&self, mis: &Mis, k: Merge, (ql, qc): (Partial, Partial), rho: f64) -> f32 {
        let own = mis.eta(k, self.sigma, self.sin, self.tr) * rho;
        let all = mis.merges(Site::Medium, self.sigma, self.sin, None, self.tr) * rho;
        let (cont_c, cont_l) = self.cont;
        mis.weight_merge(ql, qc, (own, all), self.ph * cont_c, self.ph * cont_l)
    }

    /// Estimator `k`'s correlation-aware weight, the light side's links ending in
    /// `links` and, where the light point is on a segment, `tail`.
    #[inline(always)]
    fn correlated(
        &self,
        (pass, q, c): (&Pass, &Query, &Correlated),
        k: Merge,
        (links, tail): (&[Link], Option<Link>),
    ) -> f32 {
        let mis = &pass.mis;
        let hit = (self.dist2 / self.tr, self.tr, self.sigma);
        let camera_tail = mis.carry_hit(c.carry, 0.0, hit, true);
        // On the camera's first segment the footprint is the meeting's own.
        let fp = match q.camera_len {
            1 => Footprint::new(self.dist2.sqrt()),
            _ => c.side.fp,
        };
        let (cont_c, cont_l) = self.cont;
        let lc = Chain {
            tail,
            ..Chain::light(links, self.ph * cont_c)
        };
        let cc = c.side.chain(Some(camera_tail), self.ph * cont_l);
        let ct = cc.total(&fp);
        let (fl, fc) = merge_fixes(mis, &fp, lc, (cc, ct));
        self.weight_rho(mis, k, (fl.apply(self.q.0), fc.apply(self.q.1)), fc.rho)
    }
}

impl Query<'_> {
    /// The MIS factor D of the merged vertex at `x`: the medium's, or in a
    /// heterogeneous one the grey sigma_t at `x`.
    #[inline(always)]
    fn sigma_at(&self, pass: &Pass, x: Vec3) -> f32 {
        match self.uniform {
            Some(_) => self.sigma,
            None => mis_sigma(pass, self.c.medium, x),
        }
    }

    /// The meeting at the camera point `xc` (`tc` along the query beam), whose vertex
    /// has MIS factor `sigma`, of the light point with partial weights `ql`,
    /// continuation `cont_l` and incoming direction `wl` (towards its predecessor).
    #[inline(always)]
    fn meet(
        &self,
        pass: &Pass,
        (xc, tc, sigma): (Vec3, f32, f32),
        (ql, cont_l, wl): (Partial, f32, Vec3),
        ph: f32,
    ) -> Meet {
        let sin = pass.mis.sine(self.beam.d, wl);
        let (qc, tr, dist2) = partial_at(pass, self.c, xc, tc, sigma);
        let cont_c = self.continuation(pass, xc);
        Meet {
            sigma,
            tr,
            dist2,
            sin,
            q: (ql, qc),
            cont: (cont_c, cont_l),
            ph,
        }
    }

    /// The camera side's partial weights at meeting `m` under the factors `scale` (a
    /// radius layer's, a candidate's).
    #[inline(always)]
    fn camera_q(&self, pass: &Pass, m: &Meet, scale: &Scale) -> Partial {
        let parts = parts_at(pass, &[self.parts, Parts::default()], m.tr, m.sigma);
        pass.mis.rescale(m.q.1, &parts, scale)
    }

    /// The continuation probability of a vertex at x in the query's medium.
    #[inline(always)]
    fn continuation(&self, pass: &Pass, x: Vec3) -> f32 {
        match self.uniform {
            Some((cont, _)) => cont,
            None => MediumPoint::new(pass, self.c.medium, x, -self.beam.d).cont,
        }
    }

    /// sigma_s at x.
    #[inline(always)]
    fn sigma_s(&self, x: Vec3) -> Rgb {
        match self.uniform {
            Some((_, sigma_s)) => sigma_s,
            None => self.m.sigma_s_at(x),
        }
    }
}

/// Each radius layer's sum of one estimator along one query (empty without layers).
fn layer_sums<const RADII: bool>(pass: &Pass) -> Vec<Rgb> {
    match RADII {
        true => vec![Rgb::ZERO; pass.radius_layers.len()],
        false => Vec::new(),
    }
}

/// The widest radius of estimator `k` over the pass and its radius layers.
fn widest(pass: &Pass, k: Merge) -> f32 {
    let layers = pass.radius_layers.iter().map(|l| l.radii[k as usize]);
    layers.fold(pass.radii[k as usize], f32::max)
}

/// Point x beam 2D along the query beam: (1 / (N pi r^2)) sum over the medium light
/// vertices y within r of it of w(t) f(y.wo, -d) beta_y times the MIS weight, per unit
/// of the camera throughput at the segment's start. With radius layers the query
/// reaches the widest radius and each layer sums the vertices within its own into
/// `layers`; vertices outside the job's radius take their w(t) from a copy of the
/// random stream, so that the job's own image is the one it renders without layers.
fn point_beam<const RADII: bool>(
    pass: &Pass,
    store: &BeamStore,
    q: &Query,
    rng: &mut Rng,
    stats: &mut RenderStats,
    layers: &mut [Rgb],
) -> Rgb {
    let b = &q.beam;
    let phase = q.m.phase();
    let (max_depth, mis) = (pass.s.max_depth, &pass.mis);
    let mut sum = Rgb::ZERO;
    let k = Merge::PointBeam2d;
    let r = pass.radii[k as usize];
    let reach = if RADII { widest(pass, k) } else { r };
    let mut spare = rng.clone();
    let points = &store.points;
    store
        .point_bvh
        .query_d2(points, b.o, b.d, b.len, reach, |y, t, d2| {
            if y.medium != q.c.medium || y.len + q.camera_len > max_depth {
                return;
            }
            let ph = phase.eval(b.d, y.wo);
            if ph <= 0.0 {
                return;
            }
            let x = b.o + b.d * t;
            let yq = if mis.first_medium {
                mis.cut(y.q, y.vol())
            } else {
                y.q
            };
            let at = (x, t, q.sigma_at(pass, x));
            let m = q.meet(pass, at, (yq, y.cont, y.wo), ph);
            let own = d2 <= r * r;
            let wt = if own {
                let w = match &q.corr {
                    Some(c) => {
                        let links = links_to(c.chunks, store.point_origins[index_in(points, y)]);
                        m.correlated((pass, q, c), k, (links, None))
                    }
                    None => {
                        let sides = |scale: &_| {
                            let parts = &store.point_parts[index_in(points, y)];
                            let ql = light_q(pass, (y.q, y.vol(), parts), mis.first_medium, scale);
                            (ql, q.camera_q(pass, &m, scale))
                        };
                        let weight = |mis: &Mis, ql, qc| m.weight(mis, k, (ql, qc));
                        q.rule.weight(k, m.q, sides, weight, mis)
                    }
                };
                stats.merges += 1;
                let wt = b.weight_at(q.m, t, rng);
                sum += y.throughput * wt * (ph * w);
                wt
            } else {
                b.weight_at(q.m, t, &mut spare)
            };
            if RADII {
                // The BVH's order indexes the points and their parts alike.
                let parts = &store.point_parts[index_in(points, y)];
                for (l, sum) in pass.radius_layers.iter().zip(layers.iter_mut()) {
                    if d2 <= l.radii[k as usize].powi(2) {
                        let ql = light_q(pass, (y.q, y.vol(), parts), mis.first_medium, &l.scale);
                        let w = m.weight(&l.mis, k, (ql, q.camera_q(pass, &m, &l.scale)));
                        *sum += y.throughput * wt * (ph * w);
                    }
                }
            }
        });
    sum * pass.norms[k as usize]
}

/// A light segment's subpath's links before its flight, from its [`FlightLinks`] in
/// chunk `c` of `chunks`.
#[inline(always)]
fn flight_links<'a>((c, f): &(u32, FlightLinks), chunks: &'a [Chunk]) -> &'a [Link] {
    let (begin, end) = f.links;
    &chunks[*c as usize].links[begin as usize..end as usize]
}

/// Where a photon beam crosses the query beam within a radius: the closest points,
/// along the query (`tc`) and the beam (`tb`), and the sine of their angle.
struct Crossing {
    tc: f32,
    tb: f32,
    sin: f32,
}

/// Beam x beam 1D along the query beam: over the photon beams crossing within r at
/// sine >= MIN_BEAM_SIN, beta_b w_b(t_b) w_c(t_c) sigma_s(x_c) f(d_b, -d) /
/// (2 r sin theta) times the MIS weight (beta_b holds 1 / N of the beam paths). With
/// radius layers, as [`point_beam`]: the widest radius, each layer its own.
fn beam_beam<const RADII: bool>(
    pass: &Pass,
    store: &BeamStore,
    q: &Query,
    rng: &mut Rng,
    stats: &mut RenderStats,
    layers: &mut [Rgb],
) -> Rgb {
    let c = &q.beam;
    let phase = q.m.phase();
    let max_depth = pass.s.max_depth;
    let k = Merge::BeamBeam1d;
    let r = pass.radii[k as usize];
    let reach = if RADII { widest(pass, k) } else { r };
    let mut spare = rng.clone();
    let mut sum = Rgb::ZERO;
    let crossing = |b: &Beam, r: f32| match meet(c.o, c.d, c.len, b, r, MIN_BEAM_SIN) {
        Some(Meeting::Cross { tc, tb, sin }) => Some(Crossing { tc, tb, sin }),
        _ => None,
    };
    store
        .beam_bvh
        .visit(&store.beams, c.o, c.d, c.len, reach, |b| {
            if b.medium != q.c.medium || b.depth + q.camera_len > max_depth {
                return;
            }
            // Tested first: most beams the BVH visits pass farther than r.
            let cross = crossing(b, r);
            if !RADII && cross.is_none() {
                return;
            }
            let ph = phase.eval(b.d, -c.d);
            if ph <= 0.0 {
                return;
            }
            let s = &store.segments[b.seg as usize];
            // The meeting, the light flight's MIS transmittance and squared distance to
            // it, and its value (all but the phase function, the MIS weight and
            // 1 / (2 r sin)).
            let estimate = |x: &Crossing, rng: &mut Rng| {
                let (xc, xl) = (c.o + c.d * x.tc, b.o + b.d * x.tb);
                let sigma = q.sigma_at(pass, xc);
                let (ql, tr_l, dist2_l) = partial_at(pass, s, xl, b.start + x.tb, sigma);
                let cont_l = q.continuation(pass, xl);
                let m = q.meet(pass, (xc, x.tc, sigma), (ql, cont_l, -b.d), ph);
                let wc = c.weight_at(q.m, x.tc, rng);
                let value = b.beta * b.weight_at(q.m, x.tb, rng) * wc * q.sigma_s(xc);
                (m, (tr_l, dist2_l), value)
            };
            let own = cross.map(|x| {
                let (m, (tr_l, dist2_l), value) = estimate(&x, rng);
                stats.merges += 1;
                let w = match &q.corr {
                    Some(corr) => {
                        let flight = &store.segment_links[b.seg as usize];
                        let links = flight_links(flight, corr.chunks);
                        // The light point's link, as the subpath would store it.
                        let hit = (dist2_l / tr_l, tr_l, m.sigma);
                        let tail = pass.mis.carry_hit(flight.1.carry, s.pending, hit, true);
                        m.correlated((pass, q, corr), k, (links, Some(tail)))
                    }
                    None => {
                        let sides = |scale: &_| {
                            let parts = &store.segment_parts[b.seg as usize];
                            let at = parts_at(pass, parts, tr_l, m.sigma);
                            (
                                pass.mis.rescale(m.q.0, &at, scale),
                                q.camera_q(pass, &m, scale),
                            )
                        };
                        let weight = |mis: &Mis, ql, qc| m.weight(mis, k, (ql, qc));
                        q.rule.weight(k, m.q, sides, weight, &pass.mis)
                    }
                };
                sum += value * (ph * w / (2.0 * r * x.sin));
                (m, tr_l, value)
            });
            if !RADII {
                return;
            }
            for (l, sum) in pass.radius_layers.iter().zip(layers.iter_mut()) {
                let rl = l.radii[k as usize];
                let Some(x) = crossing(b, rl) else {
                    continue;
                };
                // The closest points do not depend on the radius: the job's estimate
                // serves where it exists.
                let fresh;
                let (m, tr_l, value) = match &own {
                    Some((m, tr_l, value)) => (m, *tr_l, *value),
                    None => {
                        fresh = estimate(&x, &mut spare);
                        (&fresh.0, fresh.1 .0, fresh.2)
                    }
                };
                let parts = parts_at(pass, &store.segment_parts[b.seg as usize], tr_l, m.sigma);
                let ql = pass.mis.rescale(m.q.0, &parts, &l.scale);
                let w = m.weight(&l.mis, k, (ql, q.camera_q(pass, m, &l.scale)));
                *sum += value * (ph * w / (2.0 * rl * x.sin));
            }
        });
    sum
}

/// Both beam estimators along the camera's segments of one flight (`pieces`, each
/// with the throughput at its start), the camera subpath `camera_len` segments long
/// and its parts `parts` where the flight began; `out(k, value)` receives each
/// estimator's part and its number of merges, and with radius layers (`RADII`) their
/// values go to `slots`.
#[allow(clippy::too_many_arguments)]
pub(super) fn gather<const RADII: bool>(
    pass: &Pass,
    (store, cand, corr): (&BeamStore, Option<&Candidate>, Option<Correlated>),
    (pieces, parts): (&[LightSegment], Parts),
    camera_len: u32,
    rng: &mut Rng,
    stats: &mut RenderStats,
    slots: &[AtomicU32],
    mut out: impl FnMut(Merge, Rgb, u64),
) {
    if camera_len == 1 && !pass.s.merge_first {
        return;
    }
    let (pb, bb) = (pass.uses(Merge::PointBeam2d), pass.uses(Merge::BeamBeam1d));
    let mut layers = layer_sums::<RADII>(pass);
    for c in pieces {
        // Decided before the query beam is sampled: a pixel that queries neither
        // estimator draws nothing, as a job without them.
        let rule_of = |k, used: bool| used.then(|| rule(pass, cand, (c.q, &parts), k, &MEDIA))?;
        let pb_rule = rule_of(Merge::PointBeam2d, pb);
        let bb_rule = rule_of(Merge::BeamBeam1d, bb);
        if pb_rule.is_none() && bb_rule.is_none() {
            continue;
        }
        let Some((beam, m)) = query_beam(pass, c, rng) else {
            continue;
        };
        // Homogeneous: the same D everywhere; else `sigma_at` reads it per merge.
        let sigma = m.mis_sigma_t().filter(|&s| s > 0.0).unwrap_or(1.0);
        let uniform = m.as_homogeneous().map(|h| {
            let cont = pass.medium_continuation(h.albedo());
            (cont, h.sigma_s)
        });
        let mut q = Query {
            c,
            beam,
            m,
            sigma,
            camera_len,
            uniform,
            parts,
            rule: Rule::Job,
            corr,
        };
        if let Some(r) = pb_rule {
            q.rule = r;
            let before = stats.merges;
            let v = point_beam::<RADII>(pass, store, &q, rng, stats, &mut layers);
            out(Merge::PointBeam2d, c.beta * v, stats.merges - before);
            record_layers(pass, slots, Merge::PointBeam2d, c.beta, &mut layers);
        }
        if let Some(r) = bb_rule {
            q.rule = r;
            let before = stats.merges;
            let v = beam_beam::<RADII>(pass, store, &q, rng, stats, &mut layers);
            out(Merge::BeamBeam1d, c.beta * v, stats.merges - before);
            record_layers(pass, slots, Merge::BeamBeam1d, c.beta, &mut layers);
        }
    }
}

/// Records each radius layer's sum of estimator `k` (times `beta`, and for the point
/// estimator its kernel normalisation) and clears it.
fn record_layers(pass: &Pass, slots: &[AtomicU32], k: Merge, beta: Rgb, sums: &mut [Rgb]) {
    for (l, sum) in pass.radius_layers.iter().zip(sums) {
        let norm = match k {
            Merge::PointBeam2d => l.norms[k as usize],
            _ => 1.0,
        };
        record(slots, Some(l.layer), beta * *sum * norm);
        *sum = Rgb::ZERO;
    }
}
