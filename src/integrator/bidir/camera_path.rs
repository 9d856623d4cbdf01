//! Camera subpaths: emitter hits, light sampling and connections to the paired light
//! subpath ([`super::connect`]), and merging with all stored light vertices
//! ([`super::camera_merge`]), each weighted by [`super::mis`].

use super::beams::{self, Correlated};
use super::camera_merge::{merge, merge_medium};
use super::connect::{connect, light_sample};
use super::radius_layers::{camera_q, record_radii};
use super::selection::camera_main;
use super::{Pass, Workspace};
use crate::geometry::Ray;
use crate::integrator::drive::pixels::PathKernel;
use crate::integrator::paths::correlation::{
    light_origin, CameraSide, Carry, FlightLinks, Footprint, Link,
};
use crate::integrator::paths::light_vertex::LightVertex;
use crate::integrator::paths::media::{next_event, next_event_with, Event, Owner};
use crate::integrator::paths::partial::Mis;
use crate::integrator::paths::partial::{Merge, Partial};
use crate::integrator::paths::parts::{Candidate, Parts};
use crate::integrator::paths::segments::{FlightOrigin, FlightStart, LightSegment, SegmentSink};
use crate::integrator::paths::vertex::{Media, Vertex};
use crate::integrator::paths::walk::Walk;
use crate::integrator::transport::medium_walk::{seen_emission, sees_emission};
use crate::integrator::RenderStats;
use crate::material::Mode;
use crate::math::{Rgb, Rng, Vec3};
use std::marker::PhantomData;
use std::sync::atomic::{AtomicU32, Ordering};

/// The camera pass of one iteration, as
/// [`render_paths`](crate::integrator::drive::pixels::render_paths) drives it: `M` says whether
/// the scene has media and `RADII` whether the pass has radius layers (both decided
/// once per pass, so that the usual pass compiles without the layers' work).
pub(super) struct CameraPass<'a, M, const RADII: bool> {
    pass: &'a Pass<'a>,
    ws: &'a Workspace,
    /// Per pixel, its `layers` values (three f32 bit patterns each, zero at the start
    /// of the pass); each pixel's slots are touched only by that pixel's one path.
    side: &'a [AtomicU32],
    layers: usize,
    /// In a pilot iteration, per pixel, the merges of each estimator (else empty).
    merges: &'a [AtomicU32],
    media: PhantomData<M>,
}

impl<'a, M, const RADII: bool> CameraPass<'a, M, RADII> {
    pub fn new(
        pass: &'a Pass<'a>,
        ws: &'a Workspace,
        (side, merges): (&'a [AtomicU32], &'a [AtomicU32]),
        layers: usize,
    ) -> Self {
        CameraPass {
            pass,
            ws,
            side,
            layers,
            merges,
            media: PhantomData,
        }
    }

    /// Counts `n` merges of estimator `k` in `pixel` (pilot iterations only).
    #[inline(always)]
    fn count(&self, pixel: usize, k: Merge, n: u64) {
        if let Some(c) = self.merges.get(pixel * Merge::COUNT + k as usize) {
            c.fetch_add(n.min(u32::MAX as u64) as u32, Ordering::Relaxed);
        }
    }
}

/// A camera subpath in flight.
pub(super) struct CameraPath<'a> {
    pixel: usize,
    /// The stored vertices of the light subpath paired with this pixel, and with
    /// radius layers their [`Parts`].
    light: &'a [LightVertex],
    light_parts: &'a [Parts],
    light_links: &'a [Link],
    ray: Ray,
    walk: Walk,
    l: Rgb,
    /// The last vertex's light sample, whose shadow ray (without media) is traced
    /// together with the ray that continues the path.
    pending: Option<(Ray, Rgb)>,
    /// The medium segments of the current flight, for the beam estimators.
    pieces: Vec<LightSegment>,
    /// The pixel's candidate under per-pixel selection (None: the job's weights).
    cand: Option<&'a Candidate>,
    /// With correlation-aware MIS, the stored vertices' links and the footprint.
    links: Vec<Link>,
    fp: Footprint,
}

impl<'a, M: Media + Sync, const RADII: bool> PathKernel for CameraPass<'a, M, RADII> {
    type Path = CameraPath<'a>;

    #[inline(always)]
    fn start(&self, index: u64, ray: Ray) -> CameraPath<'a> {
        let scene = self.pass.scene;
        let pixel = index as usize;
        let ws = self.ws;
        let camera_pdf = scene.camera.pdf_dir(ray.d);
        CameraPath {
            pixel,
            light: if ws.store.paths == 0 {
                &[]
            } else {
                ws.store.light_path(pixel % ws.store.paths)
            },
            light_parts: if ws.store.paths == 0 || !RADII {
                &[]
            } else {
                ws.store.light_path_parts(pixel % ws.store.paths)
            },
            light_links: if ws.store.paths == 0 || !self.pass.correlates::<RADII>() {
                &[]
            } else {
                ws.store.light_path_links(pixel % ws.store.paths)
            },
            walk: Walk {
                origin: ray.o,
                throughput: Rgb::ONE,
                len: 1,
                q: self.pass.mis.camera_start(camera_pdf),
                pending: Parts::default(),
                parts: Parts::default(),
                medium_seen: false,
                tr: 1.0,
                specular: true,
                medium: if M::ON { scene.camera_medium } else { None },
                carry: Carry::start(camera_pdf, 1.0, f32::INFINITY),
            },
            ray,
            l: Rgb::ZERO,
            pending: None,
            pieces: Vec::new(),
            links: Vec::new(),
            fp: Footprint::new(1.0),
            cand: match RADII {
                true => self.pass.selection.as_ref().and_then(|s| s.at(pixel)),
                false => None,
            },
        }
    }

    #[inline(always)]
    fn advance(
        &self,
        p: &mut CameraPath<'a>,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> Option<Rgb> {
        if self.step(p, rng, stats) {
            return None;
        }
        // A path that ends at a vertex with a light sample traces its shadow ray alone.
        if let Some((shadow, e)) = p.pending.take() {
            if self.pass.scene.visible(&shadow) {
                let layer = self.light_layer(p.walk.len);
                add(&mut p.l, self.slots(p.pixel), layer, e);
            }
        }
        Some(p.l)
    }
}

/// What a flight's start gives [`CameraPass::seen_emission`]: the ray, the medium it
/// starts in and the throughput there.
type Seen = (Ray, Option<u32>, Rgb);

impl<'a, M: Media, const RADII: bool> CameraPass<'a, M, RADII> {
    /// The path's side of correlation-aware weights (None without them).
    #[inline(always)]
    fn side<'p>(&self, (links, fp): (&'p [Link], Footprint)) -> Option<CameraSide<'p>> {
        self.pass
            .correlates::<RADII>()
            .then_some(CameraSide { links, fp })
    }

    /// The path's candidate: always None where the pass reweighs nothing (`RADII`
    /// false), so that the usual pass compiles without the candidates' branches.
    #[inline(always)]
    fn cand<'p>(p: &CameraPath<'p>) -> Option<&'p Candidate> {
        if RADII {
            p.cand
        } else {
            None
        }
    }

    /// Pixel `pixel`'s layer slots.
    #[inline(always)]
    fn slots(&self, pixel: usize) -> &[AtomicU32] {
        if self.layers == 0 {
            // The usual case, without the slice's arithmetic and bounds checks.
            return &[];
        }
        let n = 3 * self.layers;
        &self.side[pixel * n..(pixel + 1) * n]
    }

    /// The layer of a light sample taken at the camera subpath's vertex `len`.
    #[inline(always)]
    fn light_layer(&self, len: u32) -> Option<usize> {
        self.pass.layers.connection(1, len + 1)
    }

    /// One traced segment and what its vertex contributes; false when the path ends.
    /// The phases, each a function below: the flight, emission found by the flight's
    /// transmittance, the arrival (an escape, or the vertex's emitter hit), the
    /// estimates at the vertex (light sample, connections, merges), and the scatter.
    #[inline(always)]
    fn step(&self, p: &mut CameraPath, rng: &mut Rng, stats: &mut RenderStats) -> bool {
        let pass = self.pass;
        let layers = self.slots(p.pixel);
        // Taken before the flight moves the walk on.
        let seen = (M::ON && p.walk.specular).then_some((p.ray, p.walk.medium, p.walk.throughput));
        let mut owner = Owner::default();
        let (event, tr) = self.fly(p, layers, &mut owner, rng, stats);
        if let Some(seen) = &seen {
            self.seen_emission(p, seen, &event, layers, rng, stats);
        }
        let v = match event {
            Event::Surface(it, m) => Vertex::<M>::surface(pass, it, m, p.ray.d),
            Event::Medium(x, medium) => Vertex::medium(pass, medium, x, p.ray.d),
            Event::Escaped => {
                self.escape(p, tr, seen.is_some(), layers);
                return false;
            }
            Event::End => return false,
        };
        // By reference: moving the vertex out of the Option copied it whole (2.5% of
        // gbs_p bpt's camera-pass instructions).
        let Some(v) = &v else {
            return false;
        };
        self.arrive(p, v, tr, seen.is_some(), layers);
        if p.walk.len >= pass.s.max_depth {
            return false;
        }
        if !v.skips_connections() {
            self.estimate(p, v, layers, rng, stats);
        }
        let len = p.walk.len;
        let track = pass.tracks_parts::<M, RADII>(true);
        let Some(next) = v.scatter(pass, rng, &mut p.walk, Mode::Radiance, Some(len), track) else {
            return false;
        };
        if pass.correlates::<RADII>() && !v.skips_connections() {
            if let Some(l) = p.links.last_mut() {
                l.back_pdf = p.walk.carry.rev;
            }
        }
        p.ray = next;
        stats.rays += 1;
        true
    }

    /// Phase 1, the flight to the next event, as the scene needs it: without media
    /// with the previous vertex's shadow ray alongside, in media with the MIS
    /// transmittance of the segment (returned; 1 without media), and where beams are
    /// queried gathering them along the flight's medium segments.
    #[inline(always)]
    fn fly<'o>(
        &self,
        p: &mut CameraPath,
        layers: &[AtomicU32],
        owner: &'o mut Owner<'a>,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> (Event<'o>, f32) {
        if !M::ON {
            return (self.fly_with_shadow(p, layers, owner, stats), 1.0);
        }
        if self.pass.query_beams() {
            let r = self.fly_keeping_segments(p, owner, rng, stats);
            self.gather_beams(p, layers, rng, stats);
            return r;
        }
        let scene = self.pass.scene;
        let at = (scene, self.pass.mis.local_media);
        next_event::<M>(at, &mut p.ray, &mut p.walk, rng, stats, None, owner)
    }

    /// Without media: the flight and the pending shadow ray are traced together (the
    /// traversals overlap, as in `pt`); the light sample counts if it is unblocked.
    #[inline(always)]
    fn fly_with_shadow<'o>(
        &self,
        p: &mut CameraPath,
        layers: &[AtomicU32],
        owner: &'o mut Owner<'a>,
        stats: &mut RenderStats,
    ) -> Event<'o> {
        let scene = self.pass.scene;
        let shadow = p.pending.as_ref().map(|p| &p.0);
        let (event, visible) = next_event_with(scene, &mut p.ray, shadow, &mut stats.rays, owner);
        // Read in place, then cleared: `take` copied the whole pending sample.
        if let Some(&(_, e)) = p.pending.as_ref().filter(|_| visible) {
            add(&mut p.l, layers, self.light_layer(p.walk.len - 1), e);
        }
        p.pending = None;
        event
    }

    /// In media with beams to query: the flight keeps its medium segments in
    /// `p.pieces` (reused from flight to flight).
    #[inline(always)]
    fn fly_keeping_segments<'o>(
        &self,
        p: &mut CameraPath,
        owner: &'o mut Owner<'a>,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> (Event<'o>, f32) {
        let walk = &mut p.walk;
        p.pieces.clear();
        let mut over = false;
        let mut sink = SegmentSink {
            out: &mut p.pieces,
            parts: None,
            links: None,
            budget: usize::MAX,
            over_budget: &mut over,
            start: FlightStart {
                len: walk.len,
                q: walk.q,
                pending: 0.0,
                vol: 0.0,
                from: walk.origin,
                origin: FlightOrigin::Vertex,
                // The query segments' parts are the flight's start's (gather_beams).
                parts: [Parts::default(); 2],
                // And their links the path's (gather_beams).
                links: FlightLinks::NONE,
            },
        };
        let scene = self.pass.scene;
        let at = (scene, self.pass.mis.local_media);
        next_event::<M>(at, &mut p.ray, walk, rng, stats, Some(&mut sink), owner)
    }

    /// The beam estimators along the medium segments the flight kept.
    #[inline(always)]
    fn gather_beams(
        &self,
        p: &mut CameraPath,
        layers: &[AtomicU32],
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) {
        let corr = self.side((&p.links, p.fp)).map(|side| Correlated {
            side,
            carry: p.walk.carry,
            chunks: &self.ws.store.chunks,
        });
        let (store, pixel) = ((&self.ws.beams, Self::cand(p), corr), p.pixel);
        let (pass, l, len) = (self.pass, &mut p.l, p.walk.len);
        if pass.mis.cuts(p.walk.medium_seen) {
            return;
        }
        // The walk's parts are still those where the flight began.
        let pieces = (&p.pieces[..], p.walk.parts);
        beams::gather::<RADII>(pass, store, pieces, len, rng, stats, layers, |k, v, n| {
            add(l, layers, pass.layers.merge(k, len), v);
            if RADII {
                self.count(pixel, k, n);
            }
        });
    }

    /// Phase 2, in media: emission that only the camera subpath can find (seen
    /// directly or after delta bounces alone: MIS weight 1) comes from the segment's
    /// transmittance (medium_walk::seen_emission), not from the flight, whose free
    /// flights would rarely reach an emitter through a dense medium.
    #[inline(always)]
    fn seen_emission(
        &self,
        p: &mut CameraPath,
        seen: &Seen,
        event: &Event,
        layers: &[AtomicU32],
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) {
        let scene = self.pass.scene;
        let (first, medium, throughput) = seen;
        let surface = match event {
            Event::Surface(it, _) => Some(it),
            _ => None,
        };
        if sees_emission(scene, surface, matches!(event, Event::Escaped)) {
            let v = *throughput * seen_emission(scene, first, *medium, rng, stats);
            // Weight 1: no other technique finds it, under any radius.
            record_radii::<RADII>(self.pass, layers, v, |_| 1.0);
            add(
                &mut p.l,
                layers,
                self.pass.layers.connection(0, p.walk.len + 1),
                v,
            );
        }
    }

    /// Phase 3, a path that leaves the scene: environment lights, unless phase 2 found
    /// them (`seen`).
    #[inline(always)]
    fn escape(&self, p: &mut CameraPath, tr: f32, seen: bool, layers: &[AtomicU32]) {
        let pass = self.pass;
        if M::ON {
            // The escaping segment's T enters the density of the vertex at infinity;
            // there is no distance and no cosine (mis.rs).
            p.walk.q = pass.mis.on_hit(p.walk.q, 1.0 / tr, 1.0);
        }
        if !seen {
            let walk = (&p.walk, Self::cand(p));
            let hit = (1.0 / tr, tr, 1.0);
            let side = self
                .side((&p.links, p.fp))
                .map(|s| (s, pass.mis.carry_hit(p.walk.carry, 0.0, hit, false)));
            let v = p.walk.throughput * escaped::<RADII>(pass, walk, (p.ray.d, side), layers);
            add(
                &mut p.l,
                layers,
                pass.layers.connection(0, p.walk.len + 1),
                v,
            );
        }
    }

    /// Phase 3, a path that reaches vertex `v`: the vertex's density enters the MIS
    /// quantities, and an emitter there counts unless phase 2 found it (`seen`).
    #[inline(always)]
    fn arrive(&self, p: &mut CameraPath, v: &Vertex<M>, tr: f32, seen: bool, layers: &[AtomicU32]) {
        let (pass, cand) = (self.pass, Self::cand(p));
        let walk = &mut p.walk;
        let dist2 = (v.p() - walk.origin).length_squared();
        walk.q = pass.mis.on_hit(walk.q, dist2 / tr, v.d_in());
        if RADII {
            let none = Parts::default();
            walk.parts = pass.mis.hit_parts(walk.parts, none, 1.0, v.d_in());
        }
        walk.tr = tr;
        let link = pass.correlates::<RADII>().then(|| {
            if walk.len == 1 {
                p.fp = Footprint::new(dist2.sqrt());
            }
            let medium = matches!(v, Vertex::Medium { .. });
            pass.mis
                .carry_hit(walk.carry, 0.0, (dist2 / tr, tr, v.d_in()), medium)
        });
        if let (Vertex::Surface { it, .. }, false) = (v, seen) {
            let ray = (p.ray.d, dist2);
            let side = self.side((&p.links, p.fp)).zip(link);
            let walk = (&p.walk, cand);
            let e = p.walk.throughput * emitter_hit::<RADII>(pass, walk, (it, side), ray, layers);
            add(
                &mut p.l,
                layers,
                pass.layers.connection(0, p.walk.len + 1),
                e,
            );
        }
        if let Some(link) = link {
            p.walk.carry = if v.skips_connections() {
                link.carry_through(&p.walk.carry)
            } else {
                p.links.push(link);
                link.carry_on()
            };
        }
    }

    /// Phase 4, the estimates at a vertex that takes them: a light sample (its shadow
    /// ray left pending without media, to be traced with the next flight) and
    /// connections to the paired light subpath where the technique connects, and
    /// merges from the second vertex on (or the first with `merge_first`).
    #[inline(always)]
    fn estimate(
        &self,
        p: &mut CameraPath,
        v: &Vertex<M>,
        layers: &[AtomicU32],
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) {
        let (pass, ws) = (self.pass, self.ws);
        let side = self.side((&p.links, p.fp));
        let (walk, cand) = (&p.walk, Self::cand(p));
        if pass.technique.connects() {
            let at = (walk, cand, side);
            let (e, shadow) = light_sample::<M, RADII>(pass, at, v, rng, stats, layers);
            let e = walk.throughput * e;
            match shadow {
                Some(ray) => p.pending = Some((ray, e)),
                None => add(&mut p.l, layers, self.light_layer(walk.len), e),
            }
            let light = (p.light, p.light_parts, p.light_links);
            let e = connect::<M, RADII>(pass, light, (walk, cand, side), v, rng, stats, layers);
            p.l += e;
        }
        if walk.len > 1 || pass.s.merge_first {
            let before = stats.merges;
            let (k, e) = match v {
                Vertex::Surface { it, s: surface, .. } => {
                    let at = (walk, cand, side);
                    let e = merge::<RADII>(pass, ws, at, (it, surface), stats, layers);
                    (Merge::Surface, walk.throughput * e)
                }
                Vertex::Medium { p: x, m } => {
                    let x = (*x, M::get(m));
                    let e = merge_medium::<RADII>(pass, ws, (walk, cand, side), x, stats, layers);
                    (Merge::Point3d, e)
                }
            };
            add(&mut p.l, layers, pass.layers.merge(k, walk.len), e);
            if RADII {
                self.count(p.pixel, k, stats.merges - before);
            }
        }
    }
}

/// Records `v` in its layer and adds it to the path's radiance `l`.
#[inline(always)]
fn add(l: &mut Rgb, layers: &[AtomicU32], layer: Option<usize>, v: Rgb) {
    record(layers, layer, v);
    *l += v;
}

#[inline(always)]
pub(super) fn record(layers: &[AtomicU32], layer: Option<usize>, v: Rgb) {
    let Some(slot) = layer.and_then(|i| layers.get(3 * i..3 * i + 3)) else {
        return;
    };
    for (c, a) in slot.iter().enumerate() {
        let sum = f32::from_bits(a.load(Ordering::Relaxed)) + v[c];
        a.store(sum.to_bits(), Ordering::Relaxed);
    }
}

/// Weight for radiance found by the camera subpath itself: always 1 for emitters
/// seen directly; photon mapping alone counts it only after purely specular paths
/// (merging covers the rest).
#[inline(always)]
fn own_weight(
    pass: &Pass,
    (mis, q): (&Mis, Partial),
    (walk, side): (&Walk, Option<(CameraSide, Link)>),
    direct: impl Fn() -> Emitted,
) -> f32 {
    if walk.len == 1 {
        return 1.0;
    }
    if !pass.technique.connects() {
        return if walk.specular { 1.0 } else { 0.0 };
    }
    let e = direct();
    // Correlation-aware: the emitter's point is the camera side's junction, the
    // light's densities of it and of the camera's last vertex its crossing ones.
    let q = side.map_or(q, |(side, tail)| {
        let other = side.fp.accept(e.origin, false);
        side.chain(Some(tail), e.rev)
            .fix(mis, &side.fp, other)
            .apply(q)
    });
    mis.weight_emitter_hit(q, e.direct, e.emission)
}

/// What the emitter-hit weight needs of an emitter: light sampling's and emission's
/// densities (as [`Mis::weight_emitter_hit`]), and for correlation-aware weights the
/// density of the emitted direction (a light at infinity: of the position on its
/// disk) and pick times the position's density (infinite at infinity).
struct Emitted {
    direct: f32,
    emission: f32,
    rev: f32,
    origin: f32,
}

/// An area light reached by the camera subpath ([TR] eqs. 42-43).
#[inline(always)]
fn emitter_hit<const RADII: bool>(
    pass: &Pass,
    (walk, cand): (&Walk, Option<&Candidate>),
    (it, side): (&crate::geometry::Interaction, Option<(CameraSide, Link)>),
    (d, dist2): (Vec3, f32),
    slots: &[AtomicU32],
) -> Rgb {
    let scene = pass.scene;
    let Some((li, area)) = scene.area_light(it) else {
        return Rgb::ZERO;
    };
    let le = area.le(it, -d);
    if le == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let direct = || {
        let pick = scene.light_sampler.pmf(li);
        let cos = it.ng.dot(d).abs();
        let direct = pick * area.pdf_li(walk.origin, it.p, it.ng) * cos / dist2;
        let (pos, dir) = area.pdf_le(it.ng, -d);
        let (origin, rev) = light_origin(false, false, pick, (pos, dir));
        Emitted {
            direct,
            emission: pick * pos * dir,
            rev,
            origin,
        }
    };
    record_radii::<RADII>(pass, slots, walk.throughput * le, |l| {
        own_weight(
            pass,
            (&l.mis, camera_q(pass, walk, l)),
            (walk, None),
            direct,
        )
    });
    le * own_weight(pass, camera_main(pass, cand, walk), (walk, side), direct)
}

/// Environment lights seen by a ray that leaves the scene.
#[inline(always)]
fn escaped<const RADII: bool>(
    pass: &Pass,
    (walk, cand): (&Walk, Option<&Candidate>),
    (d, side): (Vec3, Option<(CameraSide, Link)>),
    slots: &[AtomicU32],
) -> Rgb {
    let scene = pass.scene;
    let mut l = Rgb::ZERO;
    for &li in &scene.env_lights {
        let light = &scene.lights[li as usize];
        let le = light.le_escaped(d);
        if le == Rgb::ZERO {
            continue;
        }
        let direct = || {
            let pick = scene.light_sampler.pmf(li as usize);
            let direct = pick * light.pdf_li(Vec3::ZERO, d, Vec3::ZERO, Vec3::ZERO);
            let (pos, dir) = light.pdf_le(&scene.sphere, Vec3::ZERO, -d);
            let (origin, rev) = light_origin(true, light.is_delta(), pick, (pos, dir));
            Emitted {
                direct,
                emission: pick * pos * dir,
                rev,
                origin,
            }
        };
        record_radii::<RADII>(pass, slots, walk.throughput * le, |l| {
            own_weight(
                pass,
                (&l.mis, camera_q(pass, walk, l)),
                (walk, None),
                direct,
            )
        });
        l += le * own_weight(pass, camera_main(pass, cand, walk), (walk, side), direct);
    }
    l
}
