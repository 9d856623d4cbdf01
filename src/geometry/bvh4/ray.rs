//! The ray as the kernels take it, its lanes, and the four-box slab test.

use super::Node4;
use crate::geometry::lanes::F4;
use crate::geometry::Ray;
use crate::math::Vec3A;

/// Widening of the slab test's exit distance, 1 + 2 gamma(3), which makes it
/// conservative under rounding (Ize, "Robust BVH Ray Traversal", JCGT 2013).
pub(super) const ROBUST: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// A ray as the kernels take it: origin and direction in four lanes each, so the
/// caller writes them with one vector store apiece and the kernel reads them back
/// with one load. Handed a [`Ray`] (three scalars per vector, written by scalar
/// stores), the kernel's wider loads missed store forwarding and waited for the
/// stores to retire (perf, Cornell box `pt`).
pub(super) struct TraceRay {
    pub(super) o: Vec3A,
    pub(super) d: Vec3A,
    pub(super) tmax: f32,
}

impl From<&Ray> for TraceRay {
    #[inline(always)]
    fn from(r: &Ray) -> Self {
        TraceRay {
            o: r.o.into(),
            d: r.d.into(),
            tmax: r.tmax,
        }
    }
}

/// Per-ray values shared by every slab and triangle test.
pub(super) struct RayLanes {
    o: [F4; 3],
    inv: [F4; 3],
    /// Per axis, 1 when the direction is negative (then the near plane is `hi`).
    neg: [usize; 3],
    pub(super) o3: Vec3A,
    pub(super) d3: Vec3A,
}

impl RayLanes {
    #[inline(always)]
    pub(super) fn new(ray: &TraceRay) -> Self {
        let (o3, d3) = (ray.o, ray.d);
        // 1 / +-0 = +-inf is intended: the slab test below copes with it.
        let d = F4::from_vec3a(d3);
        let inv = F4::splat(1.0) / d;
        // The signs of d and 1 / d agree (-0 gives -inf); taking them from d keeps the
        // division off the path to the first node's loads.
        let neg = d.sign_bits();
        RayLanes {
            o: F4::from_vec3a(o3).broadcast3(),
            inv: inv.broadcast3(),
            neg: [
                neg as usize & 1,
                neg as usize >> 1 & 1,
                neg as usize >> 2 & 1,
            ],
            o3,
            d3,
        }
    }

    /// Bit mask of the children whose box the ray enters before `tmax`, and their
    /// entry distances.
    ///
    /// Robust for axis-parallel rays: a zero direction component gives 1 / 0 = inf,
    /// and 0 * inf = NaN when the origin lies on that slab's plane. `max` and `min`
    /// return their second operand on NaN, and the last operation of each chain has a
    /// second operand that is never NaN (`max(tnz, 0)`, `min(tfz, tmax)`), so a NaN
    /// only drops its slab from the test: the box is kept, never lost. Boxes are
    /// entered only through their near planes (chosen by the direction's signs), which
    /// is what makes empty slots (lo = +inf, hi = -inf) miss. The exit distance, and
    /// with it `tmax`, is widened by 1 + 2 gamma(3) against rounding (Ize 2013).
    #[inline(always)]
    pub(super) fn slab(&self, n: &Node4, tmax: F4) -> (u32, F4) {
        let [x, y, z] = &n.planes;
        // `& 1` lets the compiler drop the bounds checks.
        let [nx, ny, nz] = self.neg.map(|s| s & 1);
        let tnx = (x[nx] - self.o[0]) * self.inv[0];
        let tfx = (x[nx ^ 1] - self.o[0]) * self.inv[0];
        let tny = (y[ny] - self.o[1]) * self.inv[1];
        let tfy = (y[ny ^ 1] - self.o[1]) * self.inv[1];
        let tnz = (z[nz] - self.o[2]) * self.inv[2];
        let tfz = (z[nz ^ 1] - self.o[2]) * self.inv[2];
        let tn = tnx.max(tny).max(tnz.max(F4::splat(0.0)));
        let tf = tfx.min(tfy).min(tfz.min(tmax)) * F4::splat(ROBUST);
        (tn.le(tf).bits(), tn)
    }
}
