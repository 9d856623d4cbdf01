//! Scale-aware ray offsets after pbrt-v4 (Pharr et al., 4th ed., sec. 6.8.6): the
//! origin moves off the surface by the conservative floating-point error bound of the
//! hit point, projected on the normal, then rounded away. The offset scales with the
//! coordinates, so a scene scaled by 1e-3 or 1e4 renders the same image.

use super::Ray;
use crate::math::Vec3;

/// Moves `p` off the surface (normal `n`, error `err`) to the side `w` points to.
///
/// pbrt-v4 rounds each coordinate one ulp further after adding the offset. We double
/// the offset instead: the error bounds are at least gamma(6) |p| >= 3 ulp per axis,
/// so after doubling, the half-ulp rounding of `p + offset` can never bring the point
/// back to the surface, and the hot path avoids three data-dependent branches.
#[inline]
pub fn offset_ray_origin(p: Vec3, err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = 2.0 * n.abs().dot(err);
    let offset = if w.dot(n) < 0.0 { -d * n } else { d * n };
    p + offset
}

/// A ray leaving a surface point in direction `d`.
#[inline]
pub fn spawn_ray(p: Vec3, err: Vec3, n: Vec3, d: Vec3) -> Ray {
    Ray::new(offset_ray_origin(p, err, n, d), d)
}

/// Fraction of a shadow segment left unchecked at its far end, so the target surface
/// itself never occludes (pbrt-v4's ShadowEpsilon).
pub const SHADOW_EPSILON: f32 = 1e-4;

/// A shadow ray from a surface point to a target point; `d` is unnormalised and the
/// segment is t in (0, 1 - SHADOW_EPSILON). `target_n`/`target_err` describe the target
/// surface (zero error for points on lights that are not surfaces).
#[inline]
pub fn spawn_ray_to(
    p: Vec3,
    err: Vec3,
    n: Vec3,
    target: Vec3,
    target_err: Vec3,
    target_n: Vec3,
) -> Ray {
    let o = offset_ray_origin(p, err, n, target - p);
    let t = if target_n == Vec3::ZERO {
        target
    } else {
        offset_ray_origin(target, target_err, target_n, o - target)
    };
    Ray {
        o,
        d: t - o,
        tmax: 1.0 - SHADOW_EPSILON,
    }
}
