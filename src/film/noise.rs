//! How noisy an image is, from its own iterations: no reference needed (issue 40).
//!
//! A job's image is the mean of N iteration images X_1..X_N, independent by the random
//! number rule. Next to the sums of X_i the job keeps, per pixel and channel, the
//! exact sum of X_i^2 (`ExactSums::add_iteration`), so the estimate is the same
//! wherever and in whatever grouping the iterations ran, and survives a resume. The
//! variance of the mean is then estimated without bias by the sample variance over N:
//!
//!   Var[mean] ~ s^2 / N,   s^2 = (sum X_i^2 - N m^2) / (N - 1),   m = sum X_i / N.
//!
//! From it come the expected RMSE and relative MSE of the image against the converged
//! one, in the same form as `metrics::rmse` and `metrics::rel_mse` take against a
//! reference (m standing in for the reference in rel_mse's denominator).
//!
//! What it measures is the spread of the iterations. For an unbiased method that is the
//! whole error. For a consistent one (photon mapping, VCM, UPBP's merges, VBL) it is
//! the variance alone, not the bias of the current radius; where the radius shrinks from
//! iteration to iteration, the iterations' means differ too and add a little to s^2.
//! With a pixel filter wider than the box, X_i is the iteration's own developed pixel
//! (weighted sum over its weights), so the estimate is the delta-method one.

use super::accum::Film;
use super::exact::{from_fixed, to_fixed, ExactSums, LIMIT};
use super::image::Image;
use glam::Vec3 as Rgb;

/// Iterations below which no estimate is given (one iteration has no spread).
pub const MIN_ITERATIONS: u64 = 2;

/// The noise figures of an image, per pixel and summed up.
#[derive(Clone, Debug)]
pub struct Noise {
    width: u32,
    height: u32,
    /// Estimated variance of each pixel's mean, per channel.
    variance: Vec<[f64; 3]>,
    /// The mean itself (the image, in f64).
    mean: Vec<[f64; 3]>,
}

impl ExactSums {
    /// The noise of the image these sums make after `iterations` iterations, if every
    /// one of them was added with its second moments and there are at least
    /// [`MIN_ITERATIONS`]. `film` is [`ExactSums::to_film`]'s (passed in because the
    /// caller has usually made it already).
    pub fn noise(&self, film: &Film, iterations: u64) -> Option<Noise> {
        let (moments, n) = self.moments()?;
        if n != iterations || n < MIN_ITERATIONS {
            return None;
        }
        let nf = n as f64;
        let (mean, variance) = (0..moments.len())
            .map(|i| {
                let m = film.pixel(i, 1.0 / nf);
                let q = moments[i].map(from_fixed);
                // The exact sums make the difference accurate; rounding can still take
                // a constant pixel a hair below zero.
                let s2 = |c: usize| ((q[c] / nf - m[c] * m[c]) * nf / (nf - 1.0)).max(0.0);
                (m, [s2(0) / nf, s2(1) / nf, s2(2) / nf])
            })
            .unzip();
        Some(Noise {
            width: film.width(),
            height: film.height(),
            variance,
            mean,
        })
    }
}

impl Noise {
    /// Bytes the estimate of a `width` x `height` image holds (what a job's memory
    /// estimate counts for it).
    pub fn bytes_for(width: u32, height: u32) -> u64 {
        (super::image::pixel_count(width, height) * 2 * std::mem::size_of::<[f64; 3]>()) as u64
    }

    /// Expected RMSE of the image: sqrt of the mean estimated variance over all pixels
    /// and channels (`metrics::rmse`'s form).
    pub fn rmse(&self) -> f64 {
        self.mean_over(|v, _| v).sqrt()
    }

    /// Expected relative MSE: the mean of variance / (m^2 + 0.01) (`metrics::rel_mse`'s
    /// form, with the mean standing in for the reference).
    pub fn rel_mse(&self) -> f64 {
        self.mean_over(|v, m| v / (m * m + 0.01))
    }

    /// The relative error `halt.noise` compares with: sqrt of [`Noise::rel_mse`].
    pub fn rel_error(&self) -> f64 {
        self.rel_mse().sqrt()
    }

    /// The per-pixel estimated variance of the mean, as an image.
    pub fn variance_image(&self) -> Image {
        let pixels = self
            .variance
            .iter()
            .map(|v| Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32))
            .collect();
        Image::from_pixels(self.width, self.height, pixels)
    }

    /// Serial, so the figure is the same on any thread count.
    fn mean_over(&self, f: impl Fn(f64, f64) -> f64) -> f64 {
        let mut sum = 0.0;
        for (v, m) in self.variance.iter().zip(&self.mean) {
            for c in 0..3 {
                sum += f(v[c], m[c]);
            }
        }
        let n = 3 * self.variance.len();
        if n == 0 {
            0.0
        } else {
            sum / n as f64
        }
    }
}

/// Adds the squares of one iteration's pixel values (`film` holds that iteration
/// alone) to `moments`, an empty one first becoming zeros.
pub(super) fn add_squares(moments: &mut Vec<[i128; 3]>, film: &Film) {
    use rayon::prelude::*;
    let n = film.sums().len();
    if moments.is_empty() {
        *moments = vec![[0; 3]; n];
    }
    let limit = to_fixed(LIMIT * 0.5).unwrap_or(0);
    moments
        .par_chunks_mut(1 << 14)
        .enumerate()
        .for_each(|(k, chunk)| {
            for (j, m) in chunk.iter_mut().enumerate() {
                let v = film.pixel(k * (1 << 14) + j, 1.0);
                for c in 0..3 {
                    // The film holds finite values only; a square out of range is
                    // held at the limit (see `ExactSums::add_iteration`).
                    let q = to_fixed(v[c] * v[c]).unwrap_or(limit);
                    m[c] = m[c].saturating_add(q);
                }
            }
        });
}

/// Adds `other`'s moments to `moments` (an empty one takes them as they are). Squares
/// are never negative, so the saturating sum is still associative: any grouping of
/// ranges gives the same bits, as the plain sums do.
pub(super) fn add_moments(moments: &mut Vec<[i128; 3]>, other: &[[i128; 3]]) {
    if moments.is_empty() {
        moments.extend_from_slice(other);
        return;
    }
    for (m, o) in moments.iter_mut().zip(other) {
        for c in 0..3 {
            m[c] = m[c].saturating_add(o[c]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Iteration `i` of a 20 x 10 film whose every value is `base + spread * u`, u
    /// uniform in [0, 1) and independent per pixel, channel and iteration.
    fn iteration(i: u64, base: f64, spread: f64) -> Film {
        let mut film = Film::new(20, 10);
        let mut s = (i + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let mut u = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for p in film.sums_mut() {
            *p = [0, 1, 2].map(|c| base * (1.0 + c as f64) + spread * u());
        }
        film
    }

    fn sums_of(films: impl Iterator<Item = Film>) -> (ExactSums, u64) {
        let mut sums = ExactSums::new(20, 10);
        let mut n = 0;
        for f in films {
            sums.add_iteration(&f).unwrap();
            n += 1;
        }
        (sums, n)
    }

    #[test]
    fn the_estimate_matches_a_known_variance_within_its_own_noise() {
        let (n, spread) = (64u64, 0.5);
        let (sums, _) = sums_of((0..n).map(|i| iteration(i, 0.2, spread)));
        let noise = sums.noise(&sums.to_film(), n).unwrap();
        // Var of one value is spread^2 / 12, of the mean that over n.
        let truth = spread * spread / 12.0 / n as f64;
        let est = noise.rmse().powi(2);
        // One pixel's s^2 has relative variance 2 / (n - 1) + kurtosis / n, with the
        // uniform's excess kurtosis -1.2; 600 values are averaged.
        let rel_se = ((2.0 / (n - 1) as f64 - 1.2 / n as f64) / 600.0).sqrt();
        let z = (est / truth - 1.0) / rel_se;
        assert!(
            z.abs() < 4.0,
            "estimate {est:e}, truth {truth:e}, z = {z:.2}"
        );
        // rel_mse divides each pixel's variance by its mean^2 + 0.01.
        let means = [0.2 + 0.25, 0.4 + 0.25, 0.6 + 0.25];
        let rel: f64 = means.iter().map(|m| truth / (m * m + 0.01)).sum::<f64>() / 3.0;
        let z = (noise.rel_mse() / rel - 1.0) / rel_se;
        assert!(
            z.abs() < 4.0,
            "rel_mse {:e} against {rel:e}",
            noise.rel_mse()
        );
        assert!((noise.rel_error() - noise.rel_mse().sqrt()).abs() < 1e-18);
    }

    #[test]
    fn a_constant_image_has_no_noise_and_one_iteration_has_no_estimate() {
        let (sums, n) = sums_of((0..5).map(|_| iteration(7, 0.3, 1e-3)));
        let noise = sums.noise(&sums.to_film(), n).unwrap();
        // Zero but for f64 rounding in sum X^2 / N - m^2: relative 1e-16 of m^2 at most
        // per value (m is about 0.3 to 0.9 here).
        let floor = 1e-15f64;
        assert!(
            noise.rmse() < floor.sqrt(),
            "five copies: {:e}",
            noise.rmse()
        );
        let pixels = noise.variance_image();
        assert!(pixels
            .pixels()
            .iter()
            .all(|p| p.max_element() < floor as f32));
        let (one, _) = sums_of(std::iter::once(iteration(1, 0.3, 0.1)));
        assert!(one.noise(&one.to_film(), 1).is_none());
        // Moments that miss some of the image's iterations give no estimate either.
        assert!(sums.noise(&sums.to_film(), n + 1).is_none());
        let mut plain = ExactSums::new(20, 10);
        plain.add_film(&iteration(1, 0.3, 0.1)).unwrap();
        assert!(plain.noise(&plain.to_film(), 1).is_none());
    }

    #[test]
    fn moments_merge_in_any_grouping_and_round_trip_as_version_3() {
        let films: Vec<Film> = (0..10).map(|i| iteration(i, 1e-3, 5.0)).collect();
        let (sequential, _) = sums_of(films.iter().cloned());
        let mut merged = ExactSums::new(20, 10);
        for range in [6..10, 0..3, 3..6] {
            let (part, _) = sums_of(films[range].iter().cloned());
            merged.merge(&part).unwrap();
        }
        assert_eq!(merged, sequential);
        let bytes = sequential.encode();
        assert_eq!(&bytes[..8], b"CAUSTEX3");
        assert_eq!(ExactSums::decode(&bytes).unwrap(), sequential);
        for cut in [bytes.len() - 1, bytes.len() - 48 * 200] {
            assert!(ExactSums::decode(&bytes[..cut]).is_err(), "cut at {cut}");
        }
    }

    #[test]
    fn huge_values_saturate_the_moments_instead_of_wrapping() {
        let mut film = Film::new(1, 1);
        film.sums_mut()[0] = [1e18, 1.0, 0.0];
        let mut sums = ExactSums::new(1, 1);
        for _ in 0..4 {
            sums.add_iteration(&film).unwrap();
        }
        let noise = sums.noise(&sums.to_film(), 4).unwrap();
        assert!(noise.rmse().is_finite());
        assert!(noise.variance_image().pixels()[0].x >= 0.0);
    }
}
