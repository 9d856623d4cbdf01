//! Pearson's chi-square goodness of fit with its exact survival function, for the
//! sampler tests. (tests/sampling.rs has the crate's machinery, but integration tests
//! are not reachable from the library; this one is small and computes Q(k/2, x/2) by
//! its finite series, which holds for every whole number of degrees of freedom.)

/// Tests of this module that must all pass: the Sidak correction divides the
/// module's 1% significance among them.
pub const TESTS: usize = 80;
/// Cells expecting fewer samples are merged into one pooled cell (the rule of five).
const POOL: f64 = 5.0;

/// The per-test significance.
pub fn alpha() -> f64 {
    1.0 - 0.99f64.powf(1.0 / TESTS as f64)
}

/// Complementary error function, Chebyshev fit of Numerical Recipes (erfcc),
/// fractional error below 1.2e-7: ample for a test threshold.
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let c = [
        -1.265_512_23,
        1.000_023_68,
        0.374_091_96,
        0.096_784_18,
        -0.186_288_06,
        0.278_868_07,
        -1.135_203_98,
        1.488_515_87,
        -0.822_152_23,
        0.170_872_77,
    ];
    let poly = c.iter().rev().fold(0.0, |acc, &ci| acc * t + ci);
    let r = t * (-z * z + poly).exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// P(X > x) for X chi-square with k degrees of freedom: with y = x / 2,
/// even k:  Q = sum_{i<k/2} e^-y y^i / i!,
/// odd k:   Q = erfc(sqrt y) + sum_{i<(k-1)/2} e^-y y^(i+1/2) / Gamma(i + 3/2);
/// the terms are summed from their logarithms, so large k and x neither overflow nor
/// underflow.
pub fn survival(x: f64, k: usize) -> f64 {
    let y = 0.5 * x;
    if y <= 0.0 {
        return 1.0;
    }
    let half = if k.is_multiple_of(2) { 0.0 } else { 0.5 };
    let terms = k / 2;
    // ln Gamma(1 + half), then ln Gamma(i + 1 + half) by the recurrence.
    let mut ln_gamma = if half == 0.0 {
        0.0
    } else {
        (0.5 * std::f64::consts::PI.sqrt()).ln()
    };
    let mut logs = Vec::with_capacity(terms);
    for i in 0..terms {
        let e = i as f64 + half;
        if i > 0 {
            ln_gamma += e.ln();
        }
        logs.push(-y + e * y.ln() - ln_gamma);
    }
    let max = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let series = if logs.is_empty() {
        0.0
    } else {
        (max + logs.iter().map(|l| (l - max).exp()).sum::<f64>().ln()).exp()
    };
    let head = if half == 0.0 { 0.0 } else { erfc(y.sqrt()) };
    (head + series).min(1.0)
}

/// The statistic, its degrees of freedom and p-value for observed and expected counts.
pub fn pearson(observed: &[f64], expected: &[f64]) -> (f64, usize, f64) {
    let (mut stat, mut cells) = (0.0, 0usize);
    let (mut po, mut pe) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e < POOL {
            po += o;
            pe += e;
        } else {
            stat += (o - e) * (o - e) / e;
            cells += 1;
        }
    }
    if pe > 0.0 {
        stat += (po - pe) * (po - pe) / pe;
        cells += 1;
    } else if po > 0.0 {
        stat = f64::INFINITY;
    }
    let dof = cells.saturating_sub(1);
    (stat, dof, survival(stat, dof))
}

/// Fails unless the counts fit at the Sidak-corrected level; returns the p-value.
pub fn check(name: &str, observed: &[f64], expected: &[f64]) -> f64 {
    let (stat, dof, p) = pearson(observed, expected);
    eprintln!("chi2 {name}: {stat:.1} / {dof} dof, p = {p:.4}");
    assert!(dof >= 10, "{name}: only {dof} degrees of freedom");
    assert!(p >= alpha(), "{name}: chi2 {stat:.1} / {dof}, p = {p:.2e}");
    p
}

#[test]
fn survival_function_matches_tabulated_quantiles() {
    // Upper 1% and 50% points of the chi-square distribution (standard tables).
    for (x, k, p) in [
        (6.635, 1, 0.01),
        (9.210, 2, 0.01),
        (23.209, 10, 0.01),
        (9.342, 10, 0.5),
        (37.566, 20, 0.01),
        (135.807, 100, 0.01),
        (99.334, 100, 0.5),
    ] {
        let q = survival(x, k);
        assert!((q / p - 1.0).abs() < 2e-3, "Q({x}, {k}) = {q}, table {p}");
    }
}
