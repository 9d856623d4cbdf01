//! Pixel (reconstruction) filters as Mitsuba 3 defines them: the same functions, the
//! same parameters and defaults, separable in x and y, with pixel centres at half
//! integers. A filtered film spreads each camera sample over every pixel within the
//! radius and divides the weighted sum by the summed weights ([`super::Film`]).
//!
//! Where Mitsuba tabulates a filter (its scalar variants look weights up in a 31-step
//! table; its vectorised ones evaluate the function), caustic evaluates the function.

use serde::{Deserialize, Serialize};

/// The largest filter radius a film takes, in pixels: it bounds the pixels one sample
/// touches (at most 9 x 9), so that a scene cannot make each sample arbitrarily costly.
pub const MAX_RADIUS: f64 = 4.0;

/// Most pixels a sample touches along one axis: 2 * MAX_RADIUS + 1.
pub const MAX_TAPS: usize = 9;

/// A one-dimensional filter in pixel units, applied along x and along y. Its serde
/// form is the scene format's (`{"type": "gaussian", "stddev": 0.5}`), parameters
/// named and defaulted as Mitsuba 3's.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Filter {
    /// 1 on [-radius, radius). Radius 0.5, one pixel wide, is the default filter:
    /// a pixel is then the mean radiance over its area.
    Box {
        #[serde(default = "half")]
        radius: f32,
    },
    /// max(0, 1 - |x| / radius).
    Tent {
        #[serde(default = "one")]
        radius: f32,
    },
    /// exp(-x^2 / (2 stddev^2)), less its value at the radius 4 stddev so that it
    /// reaches zero there.
    Gaussian {
        #[serde(default = "half")]
        stddev: f32,
    },
    /// The Mitchell-Netravali cubic with parameters B and C, radius 2.
    Mitchell {
        #[serde(rename = "B", default = "third")]
        b: f32,
        #[serde(rename = "C", default = "third")]
        c: f32,
    },
    /// sinc(x) sinc(x / lobes), radius `lobes`.
    Lanczos {
        #[serde(default = "three")]
        lobes: u32,
    },
}

fn half() -> f32 {
    0.5
}

fn one() -> f32 {
    1.0
}

fn third() -> f32 {
    1.0 / 3.0
}

fn three() -> u32 {
    3
}

impl Default for Filter {
    fn default() -> Self {
        Filter::Box { radius: 0.5 }
    }
}

/// Below this |x|, Lanczos is 1 (its 0/0 limit).
const LANCZOS_EPSILON: f64 = 1e-8;

impl Filter {
    /// Where the filter becomes zero, in pixels.
    pub fn radius(&self) -> f64 {
        match *self {
            Filter::Box { radius } | Filter::Tent { radius } => radius as f64,
            Filter::Gaussian { stddev } => 4.0 * stddev as f64,
            Filter::Mitchell { .. } => 2.0,
            Filter::Lanczos { lobes } => lobes as f64,
        }
    }

    /// The one-pixel box, which a film takes by its fast path: each sample adds to the
    /// pixel it lies in with weight one.
    #[inline]
    pub fn is_pixel_box(&self) -> bool {
        *self == Filter::default()
    }

    /// The filter's value at `x` pixels from the centre.
    pub fn eval(&self, x: f64) -> f64 {
        match *self {
            Filter::Box { radius } => {
                let r = radius as f64;
                if (-r..r).contains(&x) {
                    1.0
                } else {
                    0.0
                }
            }
            Filter::Tent { radius } => (1.0 - x.abs() / radius as f64).max(0.0),
            Filter::Gaussian { stddev } => {
                let s = stddev as f64;
                let a = -0.5 / (s * s);
                let r = 4.0 * s;
                ((a * x * x).exp() - (a * r * r).exp()).max(0.0)
            }
            Filter::Mitchell { b, c } => mitchell(x.abs(), b as f64, c as f64),
            Filter::Lanczos { lobes } => {
                let (x, r) = (x.abs(), lobes as f64);
                if x < LANCZOS_EPSILON {
                    1.0
                } else if x >= r {
                    0.0
                } else {
                    let (a, b) = (std::f64::consts::PI * x, std::f64::consts::PI * x / r);
                    a.sin() * b.sin() / (a * b)
                }
            }
        }
    }

    /// The integral of the filter over [a, b]: Gauss-Legendre on the pieces between the
    /// points where it is not smooth, which integrates the box, tent and Mitchell
    /// filters exactly and the others to rounding.
    pub fn integral(&self, a: f64, b: f64) -> f64 {
        let r = self.radius();
        let (a, b) = (a.max(-r), b.min(r));
        if a >= b {
            return 0.0;
        }
        let mut cuts = vec![a];
        cuts.extend([-1.0, 0.0, 1.0].into_iter().filter(|&k| a < k && k < b));
        cuts.push(b);
        cuts.windows(2)
            .map(|w| self.gauss_legendre(w[0], w[1]))
            .sum()
    }

    fn gauss_legendre(&self, a: f64, b: f64) -> f64 {
        const PIECES: usize = 32;
        let h = (b - a) / PIECES as f64;
        (0..PIECES)
            .map(|i| {
                let mid = a + (i as f64 + 0.5) * h;
                GL5.iter()
                    .map(|&(t, w)| w * self.eval(mid + 0.5 * h * t))
                    .sum::<f64>()
                    * 0.5
                    * h
            })
            .sum()
    }
}

/// Mitchell and Netravali's cubic at |x| (1988, eq. 8): 1/6 of a cubic on [0, 1) and
/// another on [1, 2).
fn mitchell(x: f64, b: f64, c: f64) -> f64 {
    let (x2, x3) = (x * x, x * x * x);
    let v = if x < 1.0 {
        (12.0 - 9.0 * b - 6.0 * c) * x3 + (-18.0 + 12.0 * b + 6.0 * c) * x2 + (6.0 - 2.0 * b)
    } else if x < 2.0 {
        (-b - 6.0 * c) * x3
            + (6.0 * b + 30.0 * c) * x2
            + (-12.0 * b - 48.0 * c) * x
            + (8.0 * b + 24.0 * c)
    } else {
        0.0
    };
    v / 6.0
}

/// Five-point Gauss-Legendre nodes and weights on [-1, 1].
const GL5: [(f64, f64); 5] = [
    (0.0, 128.0 / 225.0),
    (0.538_469_310_105_683_1, 0.478_628_670_499_366_47),
    (-0.538_469_310_105_683_1, 0.478_628_670_499_366_47),
    (0.906_179_845_938_664, 0.236_926_885_056_189_08),
    (-0.906_179_845_938_664, 0.236_926_885_056_189_08),
];

/// The pixels along one axis that a sample reaches, with their filter weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Taps {
    /// The first pixel.
    pub first: u32,
    pub count: usize,
    pub weights: [f64; MAX_TAPS],
}

impl Taps {
    /// (pixel, weight) of each tap.
    pub fn iter(&self) -> impl Iterator<Item = (u32, f64)> + '_ {
        (self.first..).zip(self.weights[..self.count].iter().copied())
    }

    /// (x, y, weight) of every pixel that x taps `tx` and y taps `ty` reach, row by
    /// row: the product of the two weights, as a separable filter's.
    #[inline]
    pub fn pairs((tx, ty): &(Taps, Taps)) -> impl Iterator<Item = (u32, u32, f64)> + '_ {
        ty.iter()
            .flat_map(move |(y, wy)| tx.iter().map(move |(x, wx)| (x, y, wx * wy)))
    }
}

/// A validated filter, as a film applies it: which pixels a sample at a film position
/// reaches, with what weights.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelFilter {
    filter: Filter,
}

impl PixelFilter {
    /// Panics if the filter's radius is not in (0, [`MAX_RADIUS`]]: scenes are
    /// validated before they get here.
    pub fn new(filter: Filter) -> Self {
        let r = filter.radius();
        assert!(
            r > 0.0 && r <= MAX_RADIUS,
            "PixelFilter::new: radius {r} out of range"
        );
        PixelFilter { filter }
    }

    pub fn filter(&self) -> &Filter {
        &self.filter
    }

    /// Whether samples take the one-pixel box's fast path.
    #[inline]
    pub fn is_pixel_box(&self) -> bool {
        self.filter.is_pixel_box()
    }

    /// Pixels beyond a tile that its samples reach, on each side.
    pub fn border(&self) -> u32 {
        if self.is_pixel_box() {
            0
        } else {
            (self.filter.radius() + 0.5).floor() as u32
        }
    }

    /// The pixels of a row (`n` pixels) that a sample at coordinate `p` reaches, and the
    /// filter's weight for each, evaluated at the pixel's centre, as Mitsuba's image
    /// block does: pixels from ceil(p - 1/2 - r) to floor(p - 1/2 + r), clipped to the
    /// film.
    #[inline]
    pub fn taps(&self, p: f32, n: u32) -> Taps {
        let r = self.filter.radius();
        let centre = p as f64 - 0.5;
        let lo = (centre - r).ceil().max(0.0);
        let hi = (centre + r).floor().min(n as f64 - 1.0);
        let mut t = Taps {
            first: lo as u32,
            count: 0,
            weights: [0.0; MAX_TAPS],
        };
        if hi < lo {
            return t;
        }
        t.count = ((hi - lo) as usize + 1).min(MAX_TAPS);
        for (i, w) in t.weights[..t.count].iter_mut().enumerate() {
            *w = self.filter.eval(lo + i as f64 - centre);
        }
        t
    }

    /// [`PixelFilter::taps`] for a light-tracing splat: the weights divided by their
    /// sum, so that the splat adds its whole value to the film, as Mitsuba 3's
    /// adjoint integrators do (a normalising image block, without a border: the sum is
    /// over the pixels inside the film). None if the weights sum to zero (a sample
    /// between the pixels of a filter narrower than a pixel), which Mitsuba drops too.
    #[inline]
    pub fn splat_taps(&self, p: f32, n: u32) -> Option<Taps> {
        let mut t = self.taps(p, n);
        let sum: f64 = t.weights[..t.count].iter().sum();
        if sum == 0.0 || !sum.is_finite() {
            return None;
        }
        for w in &mut t.weights[..t.count] {
            *w /= sum;
        }
        Some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: [Filter; 5] = [
        Filter::Box { radius: 0.5 },
        Filter::Tent { radius: 1.0 },
        Filter::Gaussian { stddev: 0.5 },
        Filter::Mitchell {
            b: 1.0 / 3.0,
            c: 1.0 / 3.0,
        },
        Filter::Lanczos { lobes: 3 },
    ];

    /// The closed forms at chosen points, written out independently of the code.
    #[test]
    fn filters_match_their_closed_forms() {
        let tent = Filter::Tent { radius: 1.25 };
        assert_eq!(tent.eval(0.0), 1.0);
        assert!((tent.eval(-0.5) - 0.6).abs() < 1e-15);
        assert_eq!(tent.eval(1.25), 0.0);
        let g = Filter::Gaussian { stddev: 0.5 };
        let bias = (-8.0f64).exp();
        assert!((g.eval(0.5) - ((-0.5f64).exp() - bias)).abs() < 1e-15);
        assert!((g.eval(-1.0) - ((-2.0f64).exp() - bias)).abs() < 1e-15);
        assert_eq!(g.eval(2.0), 0.0);
        assert_eq!(g.eval(-2.5), 0.0);
        // B = C = 1/3: 8/9 at 0, 1/18 at 1 ([MN88] with these values, to f32's 1/3).
        let m = ALL[3];
        assert!((m.eval(0.0) - 8.0 / 9.0).abs() < 1e-7);
        assert!((m.eval(1.0) - 1.0 / 18.0).abs() < 1e-7);
        assert!((m.eval(-1.0) - 1.0 / 18.0).abs() < 1e-7, "even");
        // B = 0, C = 1/2 (Catmull-Rom): 1 at 0, 0 at 1, -1/16 at 3/2.
        let cr = Filter::Mitchell { b: 0.0, c: 0.5 };
        assert_eq!((cr.eval(0.0), cr.eval(1.0)), (1.0, 0.0));
        assert!((cr.eval(1.5) + 1.0 / 16.0).abs() < 1e-15);
        assert_eq!(m.eval(2.0), 0.0);
        // Continuity at 1 for other B, C too.
        let m2 = Filter::Mitchell { b: 0.2, c: 0.55 };
        assert!((m2.eval(1.0 - 1e-9) - m2.eval(1.0 + 1e-9)).abs() < 1e-7);
        let l = ALL[4];
        assert_eq!(l.eval(0.0), 1.0);
        let pi = std::f64::consts::PI;
        let want = (pi * 0.5).sin() * (pi / 6.0).sin() / (pi * 0.5 * pi / 6.0);
        assert!((l.eval(0.5) - want).abs() < 1e-15);
        assert!(
            l.eval(1.0).abs() < 1e-15 && l.eval(1.5) < 0.0,
            "a negative lobe"
        );
        assert_eq!(l.eval(3.0), 0.0);
        let b = Filter::Box { radius: 1.5 };
        assert_eq!((b.eval(-1.5), b.eval(1.4999), b.eval(1.5)), (1.0, 1.0, 0.0));
    }

    /// Integrals against their closed forms: box 2r, tent r, Mitchell 1 (a partition
    /// of unity), the truncated Gaussian through erf, and Lanczos against a fine sum.
    #[test]
    fn integrals_match_closed_forms() {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1.0);
        assert!(close(Filter::Box { radius: 1.5 }.integral(-9.0, 9.0), 3.0));
        assert!(close(
            Filter::Tent { radius: 1.25 }.integral(-2.0, 2.0),
            1.25
        ));
        assert!(close(
            Filter::Tent { radius: 1.0 }.integral(0.0, 0.5),
            0.375
        ));
        let m = Filter::Mitchell { b: 0.3, c: 0.35 };
        assert!(close(m.integral(-2.0, 2.0), 1.0));
        // Truncated, shifted Gaussian: s sqrt(2 pi) erf(r / (s sqrt 2)) - 2 r e^(-r^2/2s^2),
        // with r / (s sqrt 2) = 2 sqrt 2 and erf(2 sqrt 2) = 0.99993665751633381...
        let s = 0.5;
        let g = Filter::Gaussian { stddev: s as f32 };
        let want = s * (2.0 * std::f64::consts::PI).sqrt() * 0.999_936_657_516_333_8
            - 2.0 * 2.0 * (-8.0f64).exp();
        assert!(
            close(g.integral(-2.0, 2.0), want),
            "{}",
            g.integral(-2.0, 2.0)
        );
        // Lanczos against a midpoint sum of 2^20 steps.
        let l = Filter::Lanczos { lobes: 3 };
        let n = 1 << 20;
        let h = 6.0 / n as f64;
        let fine: f64 = (0..n)
            .map(|i| l.eval(-3.0 + (i as f64 + 0.5) * h) * h)
            .sum();
        assert!((l.integral(-3.0, 3.0) - fine).abs() < 1e-10);
        assert!(close(l.integral(-3.0, 0.0) * 2.0, l.integral(-3.0, 3.0)));
    }

    #[test]
    fn radius_and_border_follow_mitsuba() {
        let radii: Vec<f64> = ALL.iter().map(Filter::radius).collect();
        assert_eq!(radii, [0.5, 1.0, 2.0, 2.0, 3.0]);
        let borders: Vec<u32> = ALL.iter().map(|f| PixelFilter::new(*f).border()).collect();
        assert_eq!(borders, [0, 1, 2, 2, 3]);
    }

    /// A sample reaches exactly the pixels whose centres lie within the radius, with
    /// the filter's value at each centre; the film's edges clip them.
    #[test]
    fn taps_cover_the_pixels_within_the_radius() {
        let pf = PixelFilter::new(Filter::Tent { radius: 1.5 });
        let t = pf.taps(4.2, 10);
        // Centres 2.5 .. 5.5 are within 1.5 of 4.2 (3.5, 4.5, 5.5).
        assert_eq!((t.first, t.count), (3, 3));
        for (k, w) in t.iter() {
            let d = k as f64 + 0.5 - 4.2f32 as f64;
            assert!((w - (1.0 - d.abs() / 1.5)).abs() < 1e-12);
        }
        let edge = pf.taps(0.3, 10);
        assert_eq!((edge.first, edge.count), (0, 2));
        let gauss = PixelFilter::new(Filter::Gaussian { stddev: 0.5 });
        assert_eq!(
            gauss.taps(5.0, 10).count,
            4,
            "centres 3.5 .. 6.5 within 2 of 5"
        );
        let centred = gauss.taps(5.5, 10);
        assert_eq!(
            (centred.first, centred.count),
            (3, 5),
            "3.5 .. 7.5 within 2 of 5.5"
        );
        assert_eq!((centred.weights[0], centred.weights[4]), (0.0, 0.0));
        assert_eq!(gauss.taps(9.9, 10).count, 2);
    }

    /// A splat keeps its whole value wherever it lands, edges included: its weights
    /// sum to one.
    #[test]
    fn splat_weights_sum_to_one() {
        // (The one-pixel box takes the film's fast path: the pixel a sample lies in.)
        for f in &ALL[1..] {
            let pf = PixelFilter::new(*f);
            for p in [0.0f32, 0.01, 0.5, 0.99, 3.3, 7.5, 11.99, 12.0] {
                let t = pf.splat_taps(p, 12).expect("a pixel within reach");
                let sum: f64 = t.iter().map(|(_, w)| w).sum();
                assert!((sum - 1.0).abs() < 1e-14, "{f:?} at {p}: {sum}");
            }
        }
        let narrow = PixelFilter::new(Filter::Box { radius: 0.25 });
        assert_eq!(
            narrow.splat_taps(0.1, 12),
            None,
            "between the pixels' reach"
        );
    }

    /// What splats spread uniformly over a row of 16 pixels converge to, pixel by
    /// pixel: 1 where the footprint of every splat reaching the pixel lies inside the
    /// film (the weights over their sum, integrated over a period of the pixel grid),
    /// and near the edges the values of Mitsuba 3's normalisation, which keeps each
    /// splat's energy in the film. The references come from an independent script
    /// (160,000-step midpoint sums of each filter's closed form, in Python).
    #[test]
    fn uniform_splats_converge_as_mitsubas() {
        let cases = [
            (ALL[2], [0.990045, 1.009907, 1.000048, 1.0, 1.0]),
            (ALL[3], [1.005331, 0.994219, 1.000449, 1.0, 1.0]),
            (ALL[4], [1.016823, 0.971047, 1.014703, 0.997162, 1.000265]),
            (ALL[1], [1.0; 5]),
        ];
        let n = 16;
        for (f, edge) in cases {
            let pf = PixelFilter::new(f);
            let steps = 64_000;
            let h = n as f64 / steps as f64;
            let mut acc = vec![0.0; n as usize];
            for i in 0..steps {
                let p = ((i as f64 + 0.5) * h) as f32;
                for (k, w) in pf.splat_taps(p, n).unwrap().iter() {
                    acc[k as usize] += w * h;
                }
            }
            let want: Vec<f64> = (0..n as usize)
                .map(|k| edge.get(k.min(n as usize - 1 - k)).copied().unwrap_or(1.0))
                .collect();
            for (k, (a, b)) in acc.iter().zip(&want).enumerate() {
                assert!((a - b).abs() < 2e-5, "{f:?} pixel {k}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn filters_are_even_and_vanish_beyond_their_radius() {
        for f in &ALL[1..] {
            let r = f.radius();
            for i in 0..200 {
                let x = i as f64 * 0.0217;
                assert_eq!(f.eval(x), f.eval(-x), "{f:?} at {x}");
                if x >= r {
                    assert_eq!(f.eval(x), 0.0, "{f:?} at {x}");
                }
            }
        }
    }
}
