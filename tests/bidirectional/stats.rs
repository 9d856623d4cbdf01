//! Noise-aware image comparison for the bidirectional tests: per-region means and
//! standard errors estimated from the spread of independent iterations, z-scores of
//! the difference of two renders, and the number of false alarms to expect.
//!
//! Iterations of one render are independent (each is a pure function of (seed,
//! iteration)), so the standard error of a region's mean over n iterations is the
//! sample standard deviation of the per-iteration region means divided by sqrt(n).
//! For progressive photon methods the iterations are independent but not identically
//! distributed (the radius shrinks); the pooled sample variance then also holds the
//! spread of the per-iteration expectations, which only makes the bound wider.

use caustic::film::Film;
use caustic::integrator::Settings;
use caustic::scene::Scene;

/// A pixel rectangle [x0, x1) x [y0, y1), row 0 at the top.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl Rect {
    /// The rectangle given as fractions of the image size: [x0, y0, x1, y1].
    pub fn relative(w: u32, h: u32, r: [f64; 4]) -> Rect {
        let px = |f: f64, n: u32| ((f * n as f64).round() as u32).min(n);
        let rect = Rect {
            x0: px(r[0], w),
            y0: px(r[1], h),
            x1: px(r[2], w),
            y1: px(r[3], h),
        };
        assert!(rect.x0 < rect.x1 && rect.y0 < rect.y1, "empty region {r:?}");
        rect
    }

    pub fn whole(w: u32, h: u32) -> Rect {
        Rect {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        }
    }

    pub fn area(&self) -> f64 {
        ((self.x1 - self.x0) * (self.y1 - self.y0)) as f64
    }
}

/// Square blocks of `b` x `b` pixels tiling the image (partial blocks at the edges).
pub fn blocks(w: u32, h: u32, b: u32) -> Vec<Rect> {
    let mut v = Vec::new();
    for y0 in (0..h).step_by(b as usize) {
        for x0 in (0..w).step_by(b as usize) {
            v.push(Rect {
                x0,
                y0,
                x1: (x0 + b).min(w),
                y1: (y0 + b).min(h),
            });
        }
    }
    v
}

/// A region's mean radiance per channel and its standard error.
#[derive(Clone, Copy, Debug, Default)]
pub struct Estimate {
    pub mean: [f64; 3],
    pub se: [f64; 3],
}

impl Estimate {
    /// Mean and standard error from the sums and sums of squares of `n` independent
    /// samples per channel.
    pub fn from_sums(sum: &[f64; 3], sum2: &[f64; 3], n: u64) -> Estimate {
        let n = n as f64;
        let mut e = Estimate::default();
        for c in 0..3 {
            let mean = sum[c] / n;
            let var = ((sum2[c] - n * mean * mean) / (n - 1.0)).max(0.0);
            e.mean[c] = mean;
            e.se[c] = (var / n).sqrt();
        }
        e
    }
}

/// One render, kept as per-pixel sums and per-region statistics.
pub struct Run {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub iterations: u64,
    /// Per-pixel sums over all iterations, and sums of squares.
    pub sums: Vec<[f64; 3]>,
    pub sums2: Vec<[f64; 3]>,
    /// One estimate per region asked for, then the whole image last.
    pub regions: Vec<Estimate>,
    pub dropped: u64,
    pub seconds: f64,
}

impl Run {
    /// Mean image, row-major.
    pub fn image(&self) -> Vec<[f64; 3]> {
        let k = 1.0 / self.iterations as f64;
        self.sums
            .iter()
            .map(|p| [p[0] * k, p[1] * k, p[2] * k])
            .collect()
    }

    /// Per-pixel, per-channel variance of the mean image (from the iterations' spread).
    pub fn pixel_variance(&self) -> Vec<[f64; 3]> {
        let n = self.iterations as f64;
        self.sums
            .iter()
            .zip(&self.sums2)
            .map(|(s, s2)| {
                let mut v = [0.0; 3];
                for c in 0..3 {
                    let m = s[c] / n;
                    v[c] = ((s2[c] - n * m * m) / (n - 1.0)).max(0.0) / n;
                }
                v
            })
            .collect()
    }

    pub fn whole(&self) -> Estimate {
        *self.regions.last().unwrap()
    }
}

/// Renders `iterations` iterations of `settings` with `seed`, one film per iteration,
/// and gathers the per-iteration means of every region (and of the whole image).
pub fn run(
    scene: &Scene,
    settings: &Settings,
    seed: u64,
    iterations: u64,
    regions: &[Rect],
) -> Run {
    assert!(iterations >= 2, "a standard error needs two iterations");
    let (w, h) = (scene.width(), scene.height());
    let mut all = regions.to_vec();
    all.push(Rect::whole(w, h));
    let integrator = settings.build();
    let mut sums = vec![[0.0f64; 3]; (w * h) as usize];
    let mut sums2 = sums.clone();
    let mut s1 = vec![[0.0f64; 3]; all.len()];
    let mut s2 = vec![[0.0f64; 3]; all.len()];
    let mut film = Film::new(w, h);
    let mut dropped = 0;
    let start = std::time::Instant::now();
    for i in 0..iterations {
        film.clear();
        integrator.iterate(scene, seed, i, &mut film);
        dropped += film.dropped();
        let px = film.sums();
        for ((s, s2), p) in sums.iter_mut().zip(sums2.iter_mut()).zip(px) {
            for c in 0..3 {
                s[c] += p[c];
                s2[c] += p[c] * p[c];
            }
        }
        for (r, rect) in all.iter().enumerate() {
            let mut m = [0.0f64; 3];
            for y in rect.y0..rect.y1 {
                for x in rect.x0..rect.x1 {
                    let p = px[(y * w + x) as usize];
                    for c in 0..3 {
                        m[c] += p[c];
                    }
                }
            }
            for c in 0..3 {
                let v = m[c] / rect.area();
                s1[r][c] += v;
                s2[r][c] += v * v;
            }
        }
    }
    let regions = s1
        .iter()
        .zip(&s2)
        .map(|(a, b)| Estimate::from_sums(a, b, iterations))
        .collect();
    Run {
        name: settings.name().to_string(),
        width: w,
        height: h,
        iterations,
        sums,
        sums2,
        regions,
        dropped,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// z-score of the difference of two estimates of one channel; None when both are
/// exact and equal (e.g. both black), which is no test at all.
pub fn z_score(a: &Estimate, b: &Estimate, c: usize) -> Option<f64> {
    let d = (a.mean[c] - b.mean[c]).abs();
    let se = (a.se[c] * a.se[c] + b.se[c] * b.se[c]).sqrt();
    if se == 0.0 {
        return (d != 0.0).then_some(f64::INFINITY);
    }
    Some(d / se)
}

/// The mean over the first `regions` regions and the three channels of z^2 between two
/// runs: 1 when they agree (their difference is noise), more where one is biased.
pub fn mean_z2(a: &Run, b: &Run, regions: usize) -> f64 {
    let (mut sum, mut n) = (0.0, 0.0);
    for (ea, eb) in a.regions.iter().zip(&b.regions).take(regions) {
        for c in 0..3 {
            if let Some(z) = z_score(ea, eb, c) {
                sum += z * z;
                n += 1.0;
            }
        }
    }
    sum / n
}

/// Two-sided tail probability of a standard normal beyond `z`: erfc(z / sqrt 2).
pub fn normal_tail(z: f64) -> f64 {
    erfc(z / std::f64::consts::SQRT_2)
}

/// erfc with fractional error below 1.2e-7 everywhere (Numerical Recipes' erfcc,
/// a Chebyshev fit).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// The most failures of `tests` independent tests, each failing with probability `p`
/// when nothing is wrong, that a correct renderer exceeds with probability below
/// `family` (binomial tail).
pub fn allowed_failures(tests: usize, p: f64, family: f64) -> usize {
    let n = tests as f64;
    // P(X = k), summed upwards until the tail beyond k is below `family`.
    let mut pk = (1.0 - p).powf(n);
    let mut cdf = pk;
    let mut k = 0;
    while 1.0 - cdf >= family && k < tests {
        pk *= (n - k as f64) / (k as f64 + 1.0) * p / (1.0 - p);
        cdf += pk;
        k += 1;
    }
    k
}

/// The outcome of comparing two renders region by region and channel by channel.
#[derive(Debug)]
pub struct Agreement {
    pub tests: usize,
    /// (region, channel, z) of every test above the threshold.
    pub failures: Vec<(usize, usize, f64)>,
    pub max_z: f64,
    /// Failures a correct renderer stays within with probability 1 - 1e-3.
    pub allowed: usize,
}

/// Compares the first `count` regions of two runs (the whole-image estimate is
/// checked separately) at threshold `z`.
pub fn agreement(a: &Run, b: &Run, count: usize, z: f64) -> Agreement {
    let mut tests = 0;
    let mut failures = Vec::new();
    let mut max_z: f64 = 0.0;
    for r in 0..count {
        for c in 0..3 {
            if let Some(s) = z_score(&a.regions[r], &b.regions[r], c) {
                tests += 1;
                max_z = max_z.max(s);
                if s > z {
                    failures.push((r, c, s));
                }
            }
        }
    }
    Agreement {
        tests,
        failures,
        max_z,
        allowed: allowed_failures(tests, normal_tail(z), 1e-3),
    }
}

/// Asserts that two renders agree within noise: at most the expected number of
/// block tests above 4 sigma, none above 6 sigma (2e-9 per test), and whole-image
/// means within 4 sigma in every channel.
pub fn assert_agree(a: &Run, b: &Run, regions: &[Rect]) {
    assert_regions_agree(a, b, regions);
    let (wa, wb) = (a.whole(), b.whole());
    for c in 0..3 {
        let z = z_score(&wa, &wb, c).unwrap_or(0.0);
        assert!(
            z < 4.0,
            "whole-image mean, channel {c}: {} {:.6} +- {:.6} vs {} {:.6} +- {:.6} (z {z:.1})",
            a.name,
            wa.mean[c],
            wa.se[c],
            b.name,
            wb.mean[c],
            wb.se[c]
        );
    }
}

/// The block part of [`assert_agree`] alone.
pub fn assert_regions_agree(a: &Run, b: &Run, regions: &[Rect]) {
    let ag = agreement(a, b, regions.len(), 4.0);
    let describe = |f: &[(usize, usize, f64)]| {
        f.iter()
            .map(|&(r, c, z)| {
                format!(
                    "{:?} ch{c}: {} {:.5} +- {:.5} vs {} {:.5} +- {:.5} (z {z:.1})",
                    regions[r],
                    a.name,
                    a.regions[r].mean[c],
                    a.regions[r].se[c],
                    b.name,
                    b.regions[r].mean[c],
                    b.regions[r].se[c]
                )
            })
            .collect::<Vec<_>>()
            .join("\n  ")
    };
    eprintln!(
        "{} ({} it, {:.1} s) vs {} ({} it, {:.1} s): {} block tests, max z {:.2}, {} above 4 (allowed {})",
        a.name,
        a.iterations,
        a.seconds,
        b.name,
        b.iterations,
        b.seconds,
        ag.tests,
        ag.max_z,
        ag.failures.len(),
        ag.allowed
    );
    assert!(
        ag.failures.len() <= ag.allowed && ag.max_z < 6.0,
        "{} and {} disagree beyond noise in {} of {} block tests (allowed {}):\n  {}",
        a.name,
        b.name,
        ag.failures.len(),
        ag.tests,
        ag.allowed,
        describe(&ag.failures)
    );
}

/// The run restricted to regions `ks` (in that order), with its whole-image estimate.
pub fn select(r: &Run, ks: &[usize]) -> Run {
    let mut regions: Vec<Estimate> = ks.iter().map(|&k| r.regions[k]).collect();
    regions.push(r.whole());
    Run {
        name: r.name.clone(),
        width: r.width,
        height: r.height,
        iterations: r.iterations,
        sums: r.sums.clone(),
        sums2: r.sums2.clone(),
        regions,
        dropped: r.dropped,
        seconds: r.seconds,
    }
}
