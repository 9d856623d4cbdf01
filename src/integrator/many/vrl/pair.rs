//! The geometry of one ray light against one camera segment: where the two lines come
//! closest, how far apart they are there and at what angle they cross. Every sampler
//! of a pair reads these figures from here, so sample and pdf see the same guarded
//! numbers. Computed in f64: near-parallel lines make the closest-approach parameters
//! a ratio of two small numbers, which f32 does not resolve.

use crate::math::Vec3;

/// A segment of a ray: points o + d t for t in [0, tmax].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub o: Vec3,
    /// Unit direction (the direction light travels, for a ray light; away from the
    /// camera, for a camera segment).
    pub d: Vec3,
    /// Length; finite (the caller clips an infinite ray to its medium's extent).
    pub tmax: f32,
}

impl Segment {
    pub fn new(o: Vec3, d: Vec3, tmax: f32) -> Self {
        Segment { o, d, tmax }
    }

    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }

    #[inline]
    pub(crate) fn at64(&self, t: f64) -> [f64; 3] {
        let (o, d) = (v64(self.o), v64(self.d));
        [o[0] + d[0] * t, o[1] + d[1] * t, o[2] + d[2] * t]
    }
}

/// Below this sine of the crossing angle (relative to how much 1/h varies along the
/// light segment, see `Pair::parallel`) the lines count as parallel.
const PARALLEL: f64 = 1e-6;
/// Smallest distance the samplers use, relative to the pair's size: where two lines
/// (or a line and a point) meet, the densities 1/h would not be normalisable.
pub(crate) const H_MIN_REL: f64 = 1e-5;

/// A (light segment, camera segment) pair. The light segment is y(u) = o_l + d_l u,
/// u in [0, U]; the camera segment x(t) = o_c + d_c t, t in [0, T].
#[derive(Clone, Copy, Debug)]
pub struct Pair {
    pub light: Segment,
    pub cam: Segment,
    /// |d_l x d_c|: the sine of the angle between the lines.
    pub sin: f64,
    /// d_l . d_c.
    pub cos: f64,
    /// Closest approach on the light line (on the infinite lines; may lie outside).
    pub u0: f64,
    /// Closest approach on the camera line.
    pub t0: f64,
    /// Distance between the lines at closest approach.
    pub h0: f64,
    /// The guard: no sampler uses a distance below this.
    pub h_min: f64,
}

impl Pair {
    /// None when either segment has no length or a non-finite figure: there is no
    /// integral to estimate.
    pub fn new(light: Segment, cam: Segment) -> Option<Self> {
        let ok =
            |s: &Segment| s.tmax > 0.0 && s.tmax.is_finite() && s.o.is_finite() && s.d.is_finite();
        if !ok(&light) || !ok(&cam) {
            return None;
        }
        let (dl, dc) = (v64(light.d), v64(cam.d));
        let w0 = sub(v64(light.o), v64(cam.o));
        let n = cross(dl, dc);
        let sin = norm(n);
        let cos = dot(dl, dc);
        let scale = light.tmax as f64 + cam.tmax as f64 + norm(w0);
        let h_min = H_MIN_REL * scale;
        // The component of the light line across the camera line: h(u)^2 = |a + u b|^2
        // with a = w0 - (w0.d_c) d_c and b = d_l - cos d_c, |b| = sin.
        let a = sub(w0, scale3(dc, dot(w0, dc)));
        let (u0, h0) = if sin > 0.0 {
            let b = sub(dl, scale3(dc, cos));
            let u0 = -dot(a, b) / (sin * sin);
            (u0, dot(w0, n).abs() / sin)
        } else {
            (0.0, norm(a))
        };
        let t0 = dot(w0, dc) + u0 * cos;
        Some(Pair {
            light,
            cam,
            sin,
            cos,
            u0,
            t0,
            h0,
            h_min,
        })
    }

    /// True when 1/h(u) is constant along the light segment to within ~1e-12 relative,
    /// so the asinh marginal degenerates to the uniform density (and its closed form
    /// would cancel catastrophically).
    #[inline]
    pub fn parallel(&self) -> bool {
        self.sin * self.light.tmax as f64 <= PARALLEL * self.h0_guarded()
    }

    /// The closest-approach distance the marginal uses: h0, at least `h_min`.
    #[inline]
    pub fn h0_guarded(&self) -> f64 {
        self.h0.max(self.h_min)
    }

    /// `foot` on the camera segment.
    #[inline]
    pub fn camera_foot(&self, p: [f64; 3]) -> (f64, f64, [f64; 3]) {
        foot(&self.cam, p)
    }
}

/// The foot of the perpendicular from the point p onto a segment's line (as its
/// parameter), the distance of p from that line, and the unit direction from the foot
/// to p (any perpendicular direction when p is on the line).
pub fn foot(seg: &Segment, p: [f64; 3]) -> (f64, f64, [f64; 3]) {
    let (o, d) = (v64(seg.o), v64(seg.d));
    let op = sub(p, o);
    let delta = dot(op, d);
    let perp = sub(op, scale3(d, delta));
    let h = norm(perp);
    let n = if h > 0.0 {
        scale3(perp, 1.0 / h)
    } else {
        any_perpendicular(d)
    };
    (delta, h, n)
}

/// An f32 vector as f64 components.
#[inline]
pub(crate) fn v64(v: Vec3) -> [f64; 3] {
    [v.x as f64, v.y as f64, v.z as f64]
}

#[inline]
pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
pub(crate) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[inline]
pub(crate) fn scale3(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

#[inline]
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A unit vector perpendicular to the unit vector d (Duff et al. 2017's branchless
/// basis, first tangent).
fn any_perpendicular(d: [f64; 3]) -> [f64; 3] {
    let s = 1f64.copysign(d[2]);
    let a = -1.0 / (s + d[2]);
    let b = d[0] * d[1] * a;
    [1.0 + s * d[0] * d[0] * a, s * b, -s * d[0]]
}
