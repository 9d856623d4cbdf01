//! Error metrics against a reference image, as logged per snapshot.

use glam::Vec3 as Rgb;

use super::png_io::srgb_eotf;
use super::{FilmError, Image};

/// The per-snapshot error figures of the design notes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorMetrics {
    pub rmse: f64,
    pub rel_mse: f64,
}

/// Both metrics of `a` against `reference`.
pub fn compare(a: &Image, reference: &Image) -> Result<ErrorMetrics, FilmError> {
    Ok(ErrorMetrics {
        rmse: rmse(a, reference)?,
        rel_mse: rel_mse(a, reference)?,
    })
}

/// sqrt of the mean of (a - b)^2 over all pixels and all three channels.
pub fn rmse(a: &Image, b: &Image) -> Result<f64, FilmError> {
    Ok(mean_over_values(a, b, |x, y| (x - y) * (x - y))?.sqrt())
}

/// Mean of (a - r)^2 / (r^2 + 0.01) over all values; the 0.01 keeps black
/// reference pixels from dominating.
pub fn rel_mse(a: &Image, reference: &Image) -> Result<f64, FilmError> {
    mean_over_values(a, reference, |x, r| (x - r) * (x - r) / (r * r + 0.01))
}

fn check_sizes(a: &Image, b: &Image) -> Result<(), FilmError> {
    if a.size() == b.size() {
        Ok(())
    } else {
        Err(FilmError::SizeMismatch {
            a: a.size(),
            b: b.size(),
        })
    }
}

/// Sums serially in f64, so the figure is the same on any thread count. Zero for
/// empty images.
fn mean_over_values(a: &Image, b: &Image, f: impl Fn(f64, f64) -> f64) -> Result<f64, FilmError> {
    check_sizes(a, b)?;
    let mut sum = 0.0;
    for (p, q) in a.pixels().iter().zip(b.pixels()) {
        for c in 0..3 {
            sum += f(p[c] as f64, q[c] as f64);
        }
    }
    let n = 3 * a.pixels().len();
    Ok(if n == 0 { 0.0 } else { sum / n as f64 })
}

/// A false-colour picture of where `a` and `b` differ: the luminance of |a - b|
/// per pixel, mapped through a viridis-like ramp (dark purple = equal, yellow =
/// large). It is normalised by the 99th percentile of the per-pixel differences
/// rather than the maximum, so that one firefly does not turn the rest of the
/// picture dark; pixels above it saturate to yellow. If fewer than 1% of the
/// pixels differ, the maximum is used instead. Non-finite differences show as
/// yellow. The result is linear, ready for [`super::write_png`] at exposure 0.
pub fn false_colour_diff(a: &Image, b: &Image) -> Result<Image, FilmError> {
    check_sizes(a, b)?;
    let diffs: Vec<f32> = a
        .pixels()
        .iter()
        .zip(b.pixels())
        .map(|(p, q)| luminance((*p - *q).abs()))
        .collect();
    let scale = robust_max(&diffs);
    let pixels = diffs.iter().map(|&d| ramp(normalise(d, scale))).collect();
    Ok(Image::from_pixels(a.width(), a.height(), pixels))
}

// Rec. 709 / sRGB primaries, matching the linear RGB the renderer works in.
fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Nearest-rank 99th percentile of the finite values, or their maximum when that
/// percentile is zero; zero when every value is zero or non-finite.
fn robust_max(values: &[f32]) -> f32 {
    let mut finite: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return 0.0;
    }
    finite.sort_by(f32::total_cmp);
    let rank = (0.99 * finite.len() as f64).ceil() as usize;
    let p99 = finite[rank.clamp(1, finite.len()) - 1];
    if p99 > 0.0 {
        p99
    } else {
        finite[finite.len() - 1]
    }
}

fn normalise(d: f32, scale: f32) -> f32 {
    if !d.is_finite() {
        1.0
    } else if scale > 0.0 {
        (d / scale).min(1.0)
    } else {
        0.0
    }
}

/// Samples of matplotlib's viridis at t = 0, 1/4, 1/2, 3/4, 1, as sRGB bytes.
/// Interpolated in sRGB (where the map was designed to be perceptually even),
/// then decoded to linear for the image.
const RAMP: [[u8; 3]; 5] = [
    [68, 1, 84],
    [59, 82, 139],
    [33, 145, 140],
    [94, 201, 98],
    [253, 231, 37],
];

fn ramp(t: f32) -> Rgb {
    let s = t.clamp(0.0, 1.0) * (RAMP.len() - 1) as f32;
    let i = (s as usize).min(RAMP.len() - 2);
    let f = s - i as f32;
    let c = |k: usize| Rgb::from_array(RAMP[k].map(|v| v as f32 / 255.0));
    let srgb = c(i).lerp(c(i + 1), f);
    Rgb::new(srgb_eotf(srgb.x), srgb_eotf(srgb.y), srgb_eotf(srgb.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img2(a: [f32; 3], b: [f32; 3]) -> Image {
        Image::from_pixels(2, 1, vec![Rgb::from_array(a), Rgb::from_array(b)])
    }

    #[test]
    fn rmse_by_hand() {
        let a = img2([1.0, 2.0, 3.0], [0.0, 0.0, 0.0]);
        let b = img2([1.0, 0.0, 3.0], [1.0, 0.0, 1.0]);
        // Squared differences: 0, 4, 0, 1, 0, 1 -> mean 1, rmse 1.
        assert_eq!(rmse(&a, &b).unwrap(), 1.0);
        let c = img2([0.5, 0.0, 0.0], [0.0, 0.0, 0.0]);
        // 0.25 / 6 -> sqrt = 0.2041241...
        let expected = (0.25f64 / 6.0).sqrt();
        assert!((rmse(&c, &Image::new(2, 1)).unwrap() - expected).abs() < 1e-15);
        assert_eq!(rmse(&a, &a).unwrap(), 0.0);
    }

    #[test]
    fn rel_mse_by_hand() {
        // Binary-exact f32 values, so the f64 arithmetic below is the same.
        let a = img2([1.0, 0.0, 0.5], [0.25, 0.0, 0.0]);
        let r = img2([0.0, 0.0, 1.0], [0.0, 0.0, 0.0]);
        // 1/0.01 = 100; 0.25/1.01; 0.0625/0.01 = 6.25; others 0.
        let expected = (100.0 + 0.25 / 1.01 + 6.25) / 6.0;
        let got = rel_mse(&a, &r).unwrap();
        assert!((got - expected).abs() < 1e-12, "{got} vs {expected}");
        // Asymmetric: the reference is the denominator.
        assert!(rel_mse(&r, &a).unwrap() != got);
    }

    #[test]
    fn compare_bundles_both() {
        let a = img2([1.0, 2.0, 3.0], [0.0, 0.0, 0.0]);
        let b = img2([1.0, 0.0, 3.0], [1.0, 0.0, 1.0]);
        let m = compare(&a, &b).unwrap();
        assert_eq!(m.rmse, rmse(&a, &b).unwrap());
        assert_eq!(m.rel_mse, rel_mse(&a, &b).unwrap());
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let a = Image::new(2, 1);
        let b = Image::new(1, 2);
        let e = rmse(&a, &b).unwrap_err();
        assert!(matches!(
            e,
            FilmError::SizeMismatch {
                a: (2, 1),
                b: (1, 2)
            }
        ));
        assert!(e.to_string().contains("2x1 vs 1x2"));
        assert!(rel_mse(&a, &b).is_err());
        assert!(compare(&a, &b).is_err());
        assert!(false_colour_diff(&a, &b).is_err());
    }

    #[test]
    fn ramp_ends_are_viridis() {
        let lo = ramp(0.0);
        let hi = ramp(1.0);
        assert!((srgb_oetf_u8(lo) == [68, 1, 84]) && (srgb_oetf_u8(hi) == [253, 231, 37]));
        // Luminance rises monotonically along the ramp.
        let lum: Vec<f32> = (0..=20).map(|i| luminance(ramp(i as f32 / 20.0))).collect();
        assert!(lum.windows(2).all(|w| w[0] < w[1]), "{lum:?}");
    }

    fn srgb_oetf_u8(c: Rgb) -> [u8; 3] {
        let img = Image::from_pixels(1, 1, vec![c]);
        let b = super::super::to_srgb8(&img, 0.0);
        [b[0], b[1], b[2]]
    }

    #[test]
    fn one_firefly_does_not_wash_out_the_diff() {
        let n = 200u32;
        let reference = Image::new(n, 1);
        let mut a = Image::from_pixels(
            n,
            1,
            (0..n)
                .map(|i| Rgb::splat(i as f32 / n as f32 * 0.1))
                .collect(),
        );
        a.set(0, 0, Rgb::splat(1e6));
        a.set(1, 0, Rgb::splat(f32::NAN));
        let d = false_colour_diff(&a, &reference).unwrap();
        assert_eq!(d.get(0, 0), ramp(1.0));
        assert_eq!(d.get(1, 0), ramp(1.0));
        // A pixel at half the 99th percentile sits mid-ramp, not near the bottom.
        let mid = luminance(d.get(n / 2, 0));
        assert!(mid > luminance(ramp(0.4)) && mid < luminance(ramp(0.6)));
    }

    #[test]
    fn sparse_or_no_difference() {
        let reference = Image::new(1000, 1);
        let mut a = reference.clone();
        a.set(3, 0, Rgb::splat(0.5));
        let d = false_colour_diff(&a, &reference).unwrap();
        assert_eq!(d.get(3, 0), ramp(1.0), "falls back to the maximum");
        assert_eq!(d.get(0, 0), ramp(0.0));
        let same = false_colour_diff(&reference, &reference).unwrap();
        assert!(same.pixels().iter().all(|&p| p == ramp(0.0)));
    }
}
