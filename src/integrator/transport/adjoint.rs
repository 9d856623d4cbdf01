//! The adjoint of a BSDF under a shading normal: importance carried along light paths
//! meets the shading normal where radiance meets the geometric one (Veach 1997, section
//! 5.3.6), which light paths must make up for wherever the two normals differ
//! (interpolated vertex normals, normal and bump maps).

use crate::math::Vec3;

/// Veach's adjoint correction for shading normals, |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|)
/// (Veach 1997, eq. (5.17)), for importance carried along light paths (`wo` towards
/// the light, `wi` onwards, world space): without it light paths over smooth or
/// normal-mapped surfaces estimate another image than camera paths. Exactly 1 where
/// the shading normal is the geometric one, which flat shapes take without a branch
/// into the division.
#[inline(always)]
pub(crate) fn adjoint_correction(ns: Vec3, ng: Vec3, wo: Vec3, wi: Vec3) -> f32 {
    if ns == ng {
        1.0
    } else {
        shading_correction([ns, ng, wo, wi])
    }
}

/// The vectors come gathered in a new array: a `Vec3` passed by value goes by
/// reference, which pointed the call at the caller's vertex and kept that vertex in
/// memory on the flat surfaces that never call it (`bpt`'s connections).
#[cold]
#[inline(never)]
fn shading_correction([ns, ng, wo, wi]: [Vec3; 4]) -> f32 {
    let den = wo.dot(ng).abs() * wi.dot(ns).abs();
    if den > 0.0 {
        wo.dot(ns).abs() * wi.dot(ng).abs() / den
    } else {
        0.0
    }
}
