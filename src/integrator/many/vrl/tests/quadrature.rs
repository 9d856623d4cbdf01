//! Adaptive Gauss-Kronrod (7, 15) quadrature for the references: recursive bisection
//! until the Kronrod and Gauss estimates agree, with caller-given split points where
//! the ray-light integrands peak (closest approach), so no peak hides between nodes.

/// Kronrod abscissae on [-1, 1] (the positive half; the last is 0); the odd-indexed
/// ones are the 7-point Gauss nodes.
const XK: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];
const WK: [f64; 8] = [
    0.022_935_322_010_529_22,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_18,
    0.140_653_259_715_525_92,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_727_83,
];
/// Gauss weights of XK[1], XK[3], XK[5], XK[7].
const WG: [f64; 4] = [
    0.129_484_966_168_869_7,
    0.279_705_391_489_276_7,
    0.381_830_050_505_118_9,
    0.417_959_183_673_469_4,
];

/// (Kronrod estimate, |Kronrod - Gauss|) on [a, b].
fn rule(f: &mut impl FnMut(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
    let (c, r) = (0.5 * (a + b), 0.5 * (b - a));
    let (mut k, mut g) = (0.0, 0.0);
    for i in 0..8 {
        let v = if i == 7 {
            f(c)
        } else {
            f(c - r * XK[i]) + f(c + r * XK[i])
        };
        k += WK[i] * v;
        if i % 2 == 1 {
            g += WG[i / 2] * v;
        }
    }
    (k * r, (k - g).abs() * r)
}

/// Bisects until each piece meets the absolute tolerance (its share of the coarse
/// estimate) or the relative one (so a positive integrand is accurate to `rel` in
/// total): the relative test is what stops the refinement of f32 integrands, whose
/// rounding makes the two rules differ by ~1e-7 of the piece however small it is.
fn adapt(f: &mut impl FnMut(f64) -> f64, a: f64, b: f64, tol: f64, rel: f64, depth: u32) -> f64 {
    let (k, err) = rule(f, a, b);
    if err <= tol || err <= rel * k.abs() || depth == 0 {
        return k;
    }
    let m = 0.5 * (a + b);
    adapt(f, a, m, 0.5 * tol, rel, depth - 1) + adapt(f, m, b, 0.5 * tol, rel, depth - 1)
}

/// The integral of f over [a, b] to about `rel` relative accuracy (no finer than
/// ~1e-6 for an f32 integrand), split at the points of `splits` that lie inside.
pub fn integrate(mut f: impl FnMut(f64) -> f64, a: f64, b: f64, splits: &[f64], rel: f64) -> f64 {
    let mut edges = vec![a];
    edges.extend(splits.iter().copied().filter(|&s| s > a && s < b));
    edges.push(b);
    edges.sort_by(f64::total_cmp);
    // The first estimate sets the absolute tolerance; a missed peak only makes it
    // stricter than needed.
    let coarse: f64 = edges
        .windows(2)
        .map(|w| rule(&mut f, w[0], w[1]).0.abs())
        .sum();
    let tol = (rel * coarse).max(1e-300);
    edges
        .windows(2)
        .map(|w| adapt(&mut f, w[0], w[1], tol * (w[1] - w[0]) / (b - a), rel, 40))
        .sum()
}

/// The double integral of f(u, t) over [u_a, u_b] x [t_a, t_b], split at `u_splits`
/// on the outer axis and at `t_splits(u)` on the inner one.
pub fn integrate2<S: AsRef<[f64]>>(
    f: impl Fn(f64, f64) -> f64,
    (u_a, u_b): (f64, f64),
    (t_a, t_b): (f64, f64),
    u_splits: &[f64],
    t_splits: impl Fn(f64) -> S,
    rel: f64,
) -> f64 {
    let inner = |u: f64| integrate(|t| f(u, t), t_a, t_b, t_splits(u).as_ref(), rel);
    integrate(inner, u_a, u_b, u_splits, rel)
}

#[test]
fn quadrature_integrates_peaks_and_polynomials() {
    // A degree-13 polynomial is integrated exactly by one Gauss-Kronrod rule.
    let p = integrate(|x| x.powi(13) + 3.0 * x * x, 0.0, 2.0, &[], 1e-12);
    assert!((p - (2f64.powi(14) / 14.0 + 8.0)).abs() < 1e-9, "{p}");
    // The equi-angular peak of width h = 1e-5 at x = 0.3 on [0, 1], split at its top.
    let h = 1e-5;
    let exact = ((0.7f64 / h).atan() + (0.3f64 / h).atan()) / h;
    let q = integrate(
        |x| 1.0 / (h * h + (x - 0.3).powi(2)),
        0.0,
        1.0,
        &[0.3],
        1e-10,
    );
    assert!((q / exact - 1.0).abs() < 1e-8, "{q} vs {exact}");
}
