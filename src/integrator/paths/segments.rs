//! The light subpaths' segments through media, kept beside their vertices when an
//! estimator asks for them (`Pass::keep_segments`): ray lights and photon beams are
//! made of these. A segment is the part of a light subpath's ray inside one medium,
//! from its origin (a vertex, or a null boundary it crossed) to where the free flight
//! ended (`t`: the scattering point, or the segment's end when the flight passed it),
//! with the distance to the next surface along the ray (`tmax`), so that an estimator
//! can use the short form (to the flight's end) or the long one (to the surface,
//! weighted by transmittance). Kept in path order per chunk, like the vertices, so the
//! store never depends on the thread count.

use super::correlation::FlightLinks;
use super::partial::Partial;
use super::parts::Parts;
use crate::integrator::transport::medium_walk::Segment;
use crate::math::{Rgb, Vec3};
use crate::medium::Medium;

/// One light-subpath segment in a medium.
#[derive(Clone, Copy, Debug)]
// Read by the ray-light and photon-beam estimators.
pub(crate) struct LightSegment {
    pub o: Vec3,
    /// Unit direction.
    pub d: Vec3,
    /// To the end of the free flight (the scattering point, or `tmax` when it passed).
    pub t: f32,
    /// To the next surface or null boundary; infinite when the ray leaves the scene.
    pub tmax: f32,
    pub medium: u32,
    /// The subpath's throughput at `o`, before the flight's weight: the power the
    /// light carries into the segment.
    pub beta: Rgb,
    /// Segments from the light to the vertex the ray leads to (this one included).
    pub len: u32,
    /// What the MIS of a point on the segment needs (`upbp`'s beams): the subpath's
    /// partial weights where the flight began (the light's first segment from an area
    /// light: with dvcm still to be completed at the point, see `area`), that vertex,
    /// and the MIS optical depth from it to `o` (null boundaries crossed on the way).
    pub q: Partial,
    /// The query beams' terms of that vertex's M(x) still to be settled, summed
    /// ([`Walk::pending`]).
    ///
    /// [`Walk::pending`]: super::walk::Walk::pending
    pub pending: f64,
    /// And the part of its dvc and dvm that merges in media contribute (the media's
    /// of [`Walk::parts`](super::walk::Walk::parts)).
    pub vol: f64,
    pub from: Vec3,
    pub depth0: f32,
    /// What the flight left, where a point's MIS needs more than `from`.
    pub origin: FlightOrigin,
}

/// What a flight left, as the MIS of a point on it sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum FlightOrigin {
    /// A vertex (or a light with a delta position): `from` is all a point needs.
    Vertex,
    /// An area light, on a light subpath's first segment: the light and its normal
    /// at `from` (the light-sampling density of a point depends on where it is).
    Area(u32, Vec3),
    /// A light at infinity, on a light subpath's first segment: the segment has no
    /// length for the MIS ([TR] sec. 5.1), only its transmittance.
    Infinite,
}

/// Where a subpath's flight began, for the segments it lays down.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FlightStart {
    pub len: u32,
    pub q: Partial,
    pub pending: f64,
    pub vol: f64,
    pub from: Vec3,
    pub origin: FlightOrigin,
    /// With radius layers, the subpath's [`Parts`] and its pending ones where the
    /// flight began (the per-estimator form of `q`'s dvc and dvm, and of `pending`).
    pub parts: [Parts; 2],
    /// With correlation-aware MIS, the flight's start as its points' links see it.
    pub links: FlightLinks,
}

impl LightSegment {
    #[inline(always)]
    pub fn new(seg: &Segment, t: f32, start: &FlightStart, depth0: f32) -> Self {
        LightSegment {
            o: seg.ray.o,
            d: seg.ray.d,
            t,
            tmax: seg.tmax,
            medium: seg.medium,
            beta: seg.beta,
            len: start.len,
            q: start.q,
            pending: start.pending,
            vol: start.vol,
            from: start.from,
            depth0,
            origin: start.origin,
        }
    }

    /// The end of the free flight.
    #[allow(dead_code)]
    #[inline]
    pub fn end(&self) -> Vec3 {
        self.o + self.d * self.t
    }
}

/// The cut of an unbounded homogeneous segment: the smallest extinction that removes
/// light (a channel without extinction does not scatter either: sigma_s <= sigma_t).
fn cut_rate(m: &Medium) -> f32 {
    let Some(h) = m.as_homogeneous() else {
        return 0.0;
    };
    let s = h.sigma_t;
    [s.x, s.y, s.z]
        .into_iter()
        .filter(|&v| v > 0.0)
        .fold(f32::INFINITY, f32::min)
}

/// Where a segment of a medium ends for the estimators, and the rate of its cut: the
/// first surface (or the field's end), or, when unbounded, a distance drawn from
/// exp(-rate u) with the uniform number `xi`. None when nothing can scatter on it.
pub(crate) fn extent(m: &Medium, o: Vec3, d: Vec3, tmax: f32, xi: f32) -> Option<(f32, f32)> {
    let end = m.support_end(o, d, tmax);
    if end.is_finite() {
        return (end > 0.0).then_some((end, 0.0));
    }
    let rate = cut_rate(m);
    if !rate.is_finite() {
        return None;
    }
    let len = -(1.0 - xi).ln() / rate;
    (len > 0.0 && len.is_finite()).then_some((len, rate))
}

/// Where a subpath's walk puts its segments, and how many it may still add; with
/// radius layers (and correlation-aware MIS), where it puts each segment's
/// `start.parts` (`start.links`), in the same order.
pub(crate) struct SegmentSink<'a> {
    pub out: &'a mut Vec<LightSegment>,
    pub parts: Option<&'a mut Vec<[Parts; 2]>>,
    /// With correlation-aware MIS, where it puts each segment's `start.links`.
    pub links: Option<&'a mut Vec<FlightLinks>>,
    pub budget: usize,
    pub over_budget: &'a mut bool,
    pub start: FlightStart,
}

impl SegmentSink<'_> {
    /// Keeps `seg`, its flight ending at `t`, with the MIS depth `depth0` before it.
    #[inline(always)]
    pub fn push(&mut self, seg: &Segment, t: f32, depth0: f32) {
        if self.out.len() < self.budget {
            self.out
                .push(LightSegment::new(seg, t, &self.start, depth0));
            if let Some(parts) = self.parts.as_mut() {
                parts.push(self.start.parts);
            }
            if let Some(links) = self.links.as_mut() {
                links.push(self.start.links);
            }
        } else {
            *self.over_budget = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::light_pass::LightPass;
    use crate::integrator::transport::light_paths::LightPaths;
    use crate::math::PI;
    use crate::scene::Scene;

    /// A point light of intensity I in an infinite grey medium around the camera.
    fn fog(sigma_t: f32) -> Scene {
        let text = format!(
            r#"{{"format": 1,
            "camera": {{"look_at": {{"origin": [0, 0, 0], "target": [0, 0, 1], "up": [0, 1, 0]}},
                       "fov": 40, "medium": "fog"}},
            "film": {{"width": 64, "height": 64}},
            "media": {{"fog": {{"type": "homogeneous", "sigma_t": [{sigma_t}, {sigma_t}, {sigma_t}],
                               "albedo": [0.6, 0.6, 0.6]}}}},
            "lights": [{{"type": "point", "position": [0.5, 0, 2], "intensity": [3, 3, 3]}}]}}"#
        );
        crate::scene::load::parse_scene(&text)
            .and_then(|f| Scene::compile(&f, None))
            .unwrap()
    }

    #[test]
    fn light_subpaths_keep_their_segments_through_media_on_request() {
        let sigma_t = 2.0f32;
        let scene = fog(sigma_t);
        let pass = || LightPass::new(64, LightPaths::Multiple(4.0), 2048.0);
        let ((), _) = pass().keeping_segments().run(&scene, 5, 0, |ws| {
            let (mut sum, mut sum2, mut n) = (0.0f64, 0.0f64, 0usize);
            let power = 4.0 * PI * 3.0;
            for path in 0..ws.paths() {
                let segs = ws.light_segments(path);
                assert!(
                    !segs.is_empty(),
                    "path {path}: no segment in an infinite medium"
                );
                let first = &segs[0];
                assert!((first.o - glam::Vec3::new(0.5, 0.0, 2.0)).length() < 1e-6);
                assert!(
                    (first.beta.x - power).abs() < 1e-5 * power,
                    "{:?}",
                    first.beta
                );
                assert_eq!(first.len, 1);
                for (a, b) in segs.iter().zip(&segs[1..]) {
                    // Each segment starts where the previous flight scattered.
                    let gap = (b.o - a.end()).length();
                    assert!(gap <= 1e-5 * (1.0 + a.end().length()), "gap {gap}");
                    assert_eq!(b.len, a.len + 1);
                }
                for seg in segs {
                    assert!(seg.tmax.is_infinite() && seg.t.is_finite() && seg.t >= 0.0);
                    assert!((seg.d.length() - 1.0).abs() < 1e-5);
                }
                let t = first.t as f64;
                sum += t;
                sum2 += t * t;
                n += 1;
            }
            // The first flight from the light is exponential with rate sigma_t.
            let mean = sum / n as f64;
            let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
            let expect = 1.0 / sigma_t as f64;
            assert!(
                (mean - expect).abs() < 4.0 * se,
                "mean first segment {mean} +- {se}, expected {expect}"
            );
        });
        // Without the request nothing is kept.
        let (kept, _) = pass().run(&scene, 5, 0, |ws| ws.segments().count());
        assert_eq!(kept, 0);
    }
}
