//! GGX / Trowbridge-Reitz: D and visible-normal sampling (Heitz 2018, "Sampling the
//! GGX Distribution of Visible Normals", JCGT 7(4)).

use super::stretch;
use crate::math::{safe_sqrt, warp::sin_cos_2pi, Vec2, Vec3, PI};

/// D(m) = 1 / (pi au av (x^2/au^2 + y^2/av^2 + z^2)^2), for m.z > 0.
#[inline]
pub(super) fn d(m: Vec3, au: f32, av: f32) -> f32 {
    let t = (m.x / au).powi(2) + (m.y / av).powi(2) + m.z * m.z;
    1.0 / (PI * au * av * t * t)
}

/// Stretch `w` to unit roughness, sample the projected area of the visible hemisphere
/// (a disk, half of it warped towards the view), lift the point onto the hemisphere
/// and unstretch its normal.
#[inline]
pub(super) fn sample_visible(w: Vec3, au: f32, av: f32, u: Vec2) -> Vec3 {
    let vh = stretch(w, au, av);
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len2 > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    let r = u.x.sqrt();
    let (sin_phi, cos_phi) = sin_cos_2pi(u.y);
    let p1 = r * cos_phi;
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * safe_sqrt(1.0 - p1 * p1) + s * r * sin_phi;
    let nh = p1 * t1 + p2 * t2 + safe_sqrt(1.0 - p1 * p1 - p2 * p2) * vh;
    Vec3::new(au * nh.x, av * nh.y, nh.z.max(1e-7)).normalize()
}
