//! The beam x beam estimate along a camera segment (module notes of [`super`]): where
//! a photon beam passes within r of the camera segment, the 1D-blurred estimate at the
//! closest points, or for near-parallel pairs the 2D-blurred one along their overlap.

use super::beams::Beam;
use crate::integrator::estimators::Lbvh;
use crate::integrator::transport::density_camera::MediumGather;
use crate::integrator::transport::medium_walk::Segment;
use crate::integrator::RenderStats;
use crate::math::{Rgb, Rng, Vec3, PI};
use crate::scene::Scene;

/// Below this sine of the angle between a beam and the camera ray the pair is
/// estimated with the 2D kernel along its overlap (module notes): the 1D estimate's
/// 1 / sin(theta) has a second moment int d(theta) / sin(theta) that diverges at
/// theta = 0. A fixed angle, independent of r, so both classes stay consistent.
pub(crate) const SIN_PARALLEL: f32 = 0.1;

/// How a beam meets a camera segment within the radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Meeting {
    /// Closest points at `tc` on the camera segment and `tb` on the beam, the lines at
    /// angle theta (sin theta = `sin`).
    Cross { tc: f32, tb: f32, sin: f32 },
    /// Near-parallel: the beam's points within r of the camera line whose projections
    /// lie on the camera segment, from `s0` to `s1` along the beam.
    Along { s0: f32, s1: f32 },
}

/// Where beam `b` and the camera segment o + t d, t in [0, tmax) (unit d), meet within
/// `r`; None if they do not. Pairs whose sine is below `parallel` meet `Along`.
#[inline]
pub(crate) fn meet(
    o: Vec3,
    d: Vec3,
    tmax: f32,
    b: &Beam,
    r: f32,
    parallel: f32,
) -> Option<Meeting> {
    let n = d.cross(b.d);
    let sin = n.length();
    let w = o - b.o;
    if sin >= parallel {
        // Distance between the lines, and the closest points (both directions unit).
        // Written so that a NaN distance meets nothing.
        let u = w.dot(n).abs() / sin;
        if u.is_nan() || u >= r {
            return None;
        }
        let (c, wd, wb) = (d.dot(b.d), d.dot(w), b.d.dot(w));
        let s2 = sin * sin;
        let tc = (c * wb - wd) / s2;
        let tb = (wb - c * wd) / s2;
        return ((0.0..tmax).contains(&tc) && (0.0..b.len).contains(&tb))
            .then_some(Meeting::Cross { tc, tb, sin });
    }
    // The beam point y(s) = b.o + s b.d lies at q(s) = a + s e across the camera line.
    let p0 = -w;
    let a = p0 - d * p0.dot(d);
    let e = b.d - d * b.d.dot(d);
    let (ee, ae, aa) = (e.dot(e), a.dot(e), a.dot(a) - r * r);
    let (mut s0, mut s1) = (0.0f32, b.len);
    if ee > 1e-12 {
        let disc = ae * ae - ee * aa;
        if disc <= 0.0 {
            return None;
        }
        let root = disc.sqrt();
        s0 = s0.max((-ae - root) / ee);
        s1 = s1.min((-ae + root) / ee);
    } else if aa >= 0.0 {
        return None;
    }
    // Projection t(s) = p0.d + s (b.d . d) within [0, tmax).
    let (t0, dt) = (p0.dot(d), b.d.dot(d));
    if dt.abs() > 1e-12 {
        let (x, y) = ((0.0 - t0) / dt, (tmax - t0) / dt);
        s0 = s0.max(x.min(y));
        s1 = s1.min(x.max(y));
    } else if !(0.0..tmax).contains(&t0) {
        return None;
    }
    (s1 > s0).then_some(Meeting::Along { s0, s1 })
}

/// What the camera pass reads: this iteration's beams and their BVH.
pub(crate) struct Gather<'a> {
    pub scene: &'a Scene,
    pub beams: &'a [Beam],
    pub bvh: &'a Lbvh<Beam>,
    pub radius: f32,
    pub max_depth: u32,
}

impl MediumGather for Gather<'_> {
    fn at_flights(&self) -> bool {
        false
    }

    /// sum over the beams meeting the segment of, for crossing pairs (the beam x beam
    /// estimate with 1D blur of Jarosz et al. 2011, with the kernel 1 / (2 r)),
    /// ```text
    /// beta_b w_b(t_b) T_c(t_c) sigma_s(x_c) f(d_b, -d) / (2 r sin theta)
    /// ```
    /// and for near-parallel ones the 2D kernel 1 / (pi r^2) integrated along their
    /// overlap [s0, s1] on the beam, by one uniform point s:
    /// ```text
    /// (s1 - s0) beta_b w_b(s) T_c(t(s)) sigma_s(x(t(s))) f(d_b, -d) / (pi r^2)
    /// ```
    fn segment(
        &self,
        seg: &Segment,
        cam_depth: u32,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> Rgb {
        let (mi, o, d) = (seg.medium, seg.ray.o, seg.ray.d);
        let m = &self.scene.media[mi as usize];
        let phase = m.phase();
        let tmax = m.support_end(o, d, seg.tmax);
        let r = self.radius;
        let mut sum = Rgb::ZERO;
        self.bvh.visit(self.beams, o, d, tmax, r, |b| {
            if b.medium != mi || b.depth + cam_depth + 1 > self.max_depth {
                return;
            }
            let Some(meeting) = meet(o, d, tmax, b, r, SIN_PARALLEL) else {
                return;
            };
            stats.merges += 1;
            let (tc, tb, scale) = match meeting {
                Meeting::Cross { tc, tb, sin } => (tc, tb, 1.0 / (2.0 * r * sin)),
                Meeting::Along { s0, s1 } => {
                    let s = s0 + (s1 - s0) * rng.next_f32();
                    let tc = (b.o + b.d * s - o).dot(d).clamp(0.0, tmax);
                    (tc, s, (s1 - s0) / (PI * r * r))
                }
            };
            let x = o + d * tc;
            let tr = m.transmittance(o, d, tc, rng);
            let f = phase.eval(b.d, -d);
            sum += b.beta * b.weight_at(m, tb, rng) * tr * m.sigma_s_at(x) * (f * scale);
        });
        sum
    }

    fn point(&self, _: &Segment, _: f32, _: Rgb, _: u32, _: &mut Rng, _: &mut RenderStats) -> Rgb {
        Rgb::ZERO
    }
}
