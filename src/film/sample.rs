//! One sample's way into a sum: which samples may enter a film, and the f64 sums
//! they add to. Below both the film and its tile buffers; imports nothing of caustic.

use glam::Vec3 as Rgb;

/// Whether a sample may enter the film. NaN, infinite or negative radiance is a
/// bug upstream; averaging it in would hide the bug, so it is dropped and counted.
pub fn is_valid_sample(v: Rgb) -> bool {
    v.is_finite() && v.cmpge(Rgb::ZERO).all()
}

/// Adds a valid sample to `sum`; counts an invalid one in `dropped`.
pub(super) fn accumulate(sum: &mut [f64; 3], dropped: &mut u64, v: Rgb) {
    if is_valid_sample(v) {
        add3(sum, &[v.x as f64, v.y as f64, v.z as f64]);
    } else {
        *dropped += 1;
    }
}

/// `s += v`, channel by channel.
pub(super) fn add3(s: &mut [f64; 3], v: &[f64; 3]) {
    s[0] += v[0];
    s[1] += v[1];
    s[2] += v[2];
}
