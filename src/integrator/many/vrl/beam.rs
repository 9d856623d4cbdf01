//! Virtual beam lights (Novák, Nowrouzezahrai, Dachsbacher and Jarosz 2012,
//! "Progressive virtual beam lights", EGSR): a ray light inflated to a beam of radius
//! r, its power spread evenly over the beam's cross-section, a disk D of radius r
//! perpendicular to the light direction d_l. What the beam delivers is the ray light's
//! transport averaged over the displacements v of the ray light within that disk:
//!
//!   L_r = (1 / (pi r^2)) int_D L_vrl(light segment translated by v) dA(v),
//!
//! which tends to the ray light's L_vrl as r -> 0. One estimate draws one offset v
//! with an area density p(v) and multiplies a ray-light estimate on the displaced
//! segment (`estimate_volume_to_volume`, `estimate_volume_to_surface`) by the weight
//! (1 / (pi r^2)) / p(v). This file draws the offsets; it traces no rays.
//!
//! Why the blur helps. Where the light line passes at distance h of a surface point p,
//! the volume-to-surface integrand has the peak 1 / (h^2 + (u - u_p)^2) along the
//! light, whose integral is pi / h: the ray light's transport to p is ~ pi C / h (C
//! the slowly varying rest of the integrand) and grows without bound as the line nears
//! p, the splotches of VRL renderings. In the beam, h is the distance |v - q| of the
//! offset from q, the projection of p onto the disk's plane (relative to the axis),
//! and 1 / |v - q| is integrable over a disk: its mean over D is 2 / r for q at the
//! centre and 4 / (pi r) for q on the rim, so L_r ~ 2 pi C / r at most: finite, and
//! below the ray light's value once h < r / 2. (Volume to volume the double integral
//! of 1 / |x - y|^2 over two lines at distance h is only logarithmically singular,
//! ~ (2 pi / sin theta) ln(1 / h): the ray-light samplers already cancel it, and the
//! uniform offset needs no help.)
//!
//! The offset densities, both in polar coordinates of the disk's plane:
//!
//! * `BeamOffset::Uniform`: v = r sqrt(xi_0) (cos 2 pi xi_1, sin 2 pi xi_1), density
//!   1 / (pi r^2), weight 1, so a beam estimate is a ray-light estimate of a displaced
//!   ray light (the volume-to-volume choice).
//! * `BeamOffset::AboutPoint(p)`: polar about q when q is inside the disk: the angle
//!   phi uniform on [0, 2 pi), the distance rho uniform on [0, rho_max(phi)], with
//!   rho_max(phi) the distance from q to the rim along e = (cos phi, sin phi). With
//!   dA = rho d rho d phi the area density is
//!
//!     p(v) = (1 / (2 pi)) (1 / rho_max(phi)) / rho = 1 / (2 pi rho rho_max(phi)),
//!
//!   and it integrates to one because every direction gets mass 1 / (2 pi). The weight
//!   is 2 rho rho_max / r^2: the 1 / h = 1 / rho of the integrand is cancelled and what
//!   is left varies with the direction only, between 0 and 8 (rho <= rho_max <= 2 r).
//!   rho_max is where the ray q + rho e leaves the circle |v| = r: with b = q . e and
//!   c = r^2 - |q|^2 > 0, |q + rho e|^2 = r^2 reads rho^2 + 2 b rho - c = 0, whose
//!   positive root is rho_max = -b + sqrt(b^2 + c) = c / (b + sqrt(b^2 + c)); the first
//!   form is used for b <= 0 and the second for b > 0, so neither subtracts two close
//!   numbers. When q is outside the disk (1 / h is bounded there) or r = 0, the
//!   uniform density. The density does not look at where p's foot lies along the
//!   segment (past an end of the light there is no peak to cancel); its weights are
//!   bounded, so that case costs a bounded factor of variance and no bias.
//!
//! Choosing phi with probability proportional to rho_max(phi) would make the density
//! exactly proportional to 1 / |v - q|, but that CDF is an incomplete elliptic
//! integral of the second kind with no closed-form inverse; the uniform angle is
//! exact for q at the centre and costs at most the spread of rho_max elsewhere.
//!
//! Numbers: the frame, the projection of p and the offsets are f64 (q sits at 1e-6 r
//! of a sample after 24-bit uniform numbers, which f32 does not resolve); `pdf`
//! recomputes the density from the f64 offset a sample returns, bit for bit. The
//! displaced segment's origin is rounded to f32, so the offset recovered from it
//! (`Beam::offset_of`) matches to f32 rounding of the origin.

use super::pair::{dot, norm, scale3, sub, v64, Segment};
use crate::math::Vec3;
use std::f64::consts::PI;

/// Offsets this far (relative to r^2 in |v|^2) beyond the rim still count as inside:
/// a sample on the rim computed in f64 may land a few ulps outside it.
const RIM: f64 = 1e-9;

/// How a beam's offset is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BeamOffset {
    /// Uniform over the disk (volume to volume).
    Uniform,
    /// Polar about the projection of this surface point onto the disk's plane, which
    /// cancels the 1 / h of the displaced line's distance to it (volume to surface);
    /// uniform when the point projects outside the disk.
    AboutPoint(Vec3),
}

/// A ray light of radius r: the disk of offsets perpendicular to its direction, with
/// an orthonormal frame (e1, e2) of that plane in which offsets are coordinates.
#[derive(Clone, Copy, Debug)]
pub struct Beam {
    light: Segment,
    radius: f64,
    o: [f64; 3],
    e1: [f64; 3],
    e2: [f64; 3],
}

/// A displaced ray light and the offset it was displaced by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeamSample {
    /// The ray light translated by the offset (origin rounded to f32; same direction
    /// and length).
    pub light: Segment,
    /// The offset, as coordinates along the beam's e1 and e2.
    pub v: [f64; 2],
    /// The area density of v (infinite for r = 0, where the offset is always 0).
    pub pdf: f32,
    /// (1 / (pi r^2)) / pdf, the factor a ray-light estimate on `light` is multiplied
    /// by: 1 for the uniform density (also at r = 0), in [0, 8] for the polar one.
    pub weight: f32,
}

/// A point of the beam's disk about q: the offsets polar about q inside the disk.
#[derive(Clone, Copy, Debug)]
struct Polar {
    q: [f64; 2],
    /// r^2 - |q|^2 > 0.
    c: f64,
}

impl Polar {
    /// The distance from q to the rim along the unit direction e (see the module doc).
    #[inline]
    fn rho_max(&self, e: [f64; 2]) -> f64 {
        let b = self.q[0] * e[0] + self.q[1] * e[1];
        let s = (b * b + self.c).sqrt();
        if b <= 0.0 {
            s - b
        } else {
            self.c / (b + s)
        }
    }
}

impl Beam {
    /// The beam of `light` with radius `radius`; a negative or NaN radius is 0 (the
    /// ray light itself).
    pub fn new(light: &Segment, radius: f32) -> Self {
        let d = v64(light.d);
        let d = scale3(d, 1.0 / norm(d));
        let (e1, e2) = basis(d);
        Beam {
            light: *light,
            radius: radius.max(0.0) as f64,
            o: v64(light.o),
            e1,
            e2,
        }
    }

    pub fn light(&self) -> &Segment {
        &self.light
    }

    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The ray light translated by the offset v (coordinates along e1, e2).
    pub fn displaced(&self, v: [f64; 2]) -> Segment {
        let w = [
            self.e1[0] * v[0] + self.e2[0] * v[1],
            self.e1[1] * v[0] + self.e2[1] * v[1],
            self.e1[2] * v[0] + self.e2[2] * v[1],
        ];
        let o = [self.o[0] + w[0], self.o[1] + w[1], self.o[2] + w[2]];
        Segment::new(
            Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32),
            self.light.d,
            self.light.tmax,
        )
    }

    /// The component across the axis of p - o, as coordinates along e1, e2: where the
    /// point projects onto the disk's plane.
    pub fn project(&self, p: Vec3) -> [f64; 2] {
        let w = sub(v64(p), self.o);
        [dot(w, self.e1), dot(w, self.e2)]
    }

    /// The offset of a displaced ray light (its origin projected onto the disk's plane).
    pub fn offset_of(&self, displaced: &Segment) -> [f64; 2] {
        self.project(displaced.o)
    }

    /// The polar frame about p's projection, when that lies inside a disk of positive
    /// radius.
    fn polar(&self, how: BeamOffset) -> Option<Polar> {
        let BeamOffset::AboutPoint(p) = how else {
            return None;
        };
        let q = self.project(p);
        let c = self.radius * self.radius - (q[0] * q[0] + q[1] * q[1]);
        (self.radius > 0.0 && c > 0.0).then_some(Polar { q, c })
    }

    /// Draws an offset from two uniform numbers in [0, 1): xi[0] sets the distance
    /// (from the centre, or from q), xi[1] the angle.
    pub fn sample(&self, how: BeamOffset, xi: [f32; 2]) -> BeamSample {
        let (s, c) = (2.0 * PI * xi[1] as f64).sin_cos();
        let v = match self.polar(how) {
            // rho in (0, rho_max]: 1 - xi is never 0, so the density stays finite.
            Some(pol) => {
                let rho = pol.rho_max([c, s]) * (1.0 - xi[0] as f64);
                [pol.q[0] + rho * c, pol.q[1] + rho * s]
            }
            None => {
                let rho = self.radius * (xi[0] as f64).sqrt();
                [rho * c, rho * s]
            }
        };
        let (pdf, weight) = self.density(how, v);
        BeamSample {
            light: self.displaced(v),
            v,
            pdf: pdf as f32,
            weight: weight as f32,
        }
    }

    /// The area density of the offset v under `sample`: 0 outside the disk.
    pub fn pdf(&self, how: BeamOffset, v: [f64; 2]) -> f32 {
        self.density(how, v).0 as f32
    }

    /// (1 / (pi r^2)) / pdf at v, computed without the division (finite at r = 0);
    /// 0 outside the disk.
    pub fn weight(&self, how: BeamOffset, v: [f64; 2]) -> f32 {
        self.density(how, v).1 as f32
    }

    /// (pdf, weight) at v, in f64 (the tests integrate it).
    pub(super) fn density(&self, how: BeamOffset, v: [f64; 2]) -> (f64, f64) {
        let r2 = self.radius * self.radius;
        if v[0] * v[0] + v[1] * v[1] > r2 * (1.0 + RIM) {
            return (0.0, 0.0);
        }
        if r2 == 0.0 {
            // The disk is a point: a Dirac density and the unblurred ray light.
            return (f64::INFINITY, 1.0);
        }
        let Some(pol) = self.polar(how) else {
            return (1.0 / (PI * r2), 1.0);
        };
        let w = [v[0] - pol.q[0], v[1] - pol.q[1]];
        let rho = (w[0] * w[0] + w[1] * w[1]).sqrt();
        if rho == 0.0 {
            // v = q, a set of measure zero that `sample` reaches only when rho_max
            // underflows next to the rim.
            return (f64::INFINITY, 0.0);
        }
        let rho_max = pol.rho_max([w[0] / rho, w[1] / rho]);
        let p = 1.0 / (2.0 * PI * rho * rho_max);
        (p, 2.0 * rho * rho_max / r2)
    }
}

/// An orthonormal frame (e1, e2) of the plane perpendicular to the unit vector d
/// (Duff et al. 2017, "Building an orthonormal basis, revisited": branch-free but for
/// the sign, and exact for d = -z, where Frisvad's original fails).
fn basis(d: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let s = 1f64.copysign(d[2]);
    let a = -1.0 / (s + d[2]);
    let b = d[0] * d[1] * a;
    (
        [1.0 + s * d[0] * d[0] * a, s * b, -s * d[0]],
        [b, s + d[1] * d[1] * a, -d[1]],
    )
}
