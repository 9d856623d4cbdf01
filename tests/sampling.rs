//! Statistical tests of every sampler against its own density, in the style of
//! Mitsuba's chi2 tests and pbrt-v4's BSDF tests: chi-square goodness of fit for BSDFs,
//! lights and the piecewise-constant distributions, and the identities that tie
//! `sample`, `eval` and `pdf` together (weight = eval / pdf, reciprocity, Fresnel,
//! Snell's law, analytic solid angles and irradiance).
//!
//! Every random number comes from `Rng` with a fixed seed, so each test is
//! deterministic. Chi-square tests are run at significance 0.01 for the whole file,
//! Sidak-corrected for the number of such tests (`CHI2_TESTS`); Monte Carlo means are
//! compared within a stated number of their own standard errors.

use caustic::geometry::Prim;
use caustic::light::{
    AreaLight, Distribution1D, Distribution2D, EnvMap, LatLong, Light, PointLight, SceneSphere,
    SpotLight,
};
use caustic::material::microfacet::{Distribution, Microfacet};
use caustic::material::{
    fresnel, Coating, Conductor, Dielectric, Diffuse, Material, Mirror, Mixture, Mode, Phong,
    Plastic, RoughDielectric, RoughPlastic, ThinDielectric,
};
use caustic::math::{Frame, Mat3, Rgb, Rng, Vec2, Vec3, Vec3A};
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------
// Chi-square machinery
// ---------------------------------------------------------------------------------

/// Significance level of the file as a whole.
const SIGNIFICANCE: f64 = 0.01;
/// Number of chi-square tests in this file that are expected to pass (Sidak correction).
const CHI2_TESTS: usize = 100;
/// Cells whose expected count is below this are pooled (the usual rule of five).
const POOL_THRESHOLD: f64 = 5.0;

/// Per-test significance after the Sidak correction.
fn sidak_alpha() -> f64 {
    1.0 - (1.0 - SIGNIFICANCE).powf(1.0 / CHI2_TESTS as f64)
}

/// ln Gamma(x) for x > 0: Lanczos (g = 7, 9 terms), relative error ~1e-15.
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection formula.
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + 7.5;
    let mut a = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma function Q(a, x) = Gamma(a, x) / Gamma(a): the
/// power series of P for x < a + 1, otherwise the continued fraction of Q evaluated
/// with the modified Lentz method (Numerical Recipes, sec. 6.2), so a small Q is
/// always computed directly rather than as 1 - P.
fn gamma_q(a: f64, x: f64) -> f64 {
    assert!(a > 0.0 && x >= 0.0);
    if x == 0.0 {
        return 1.0;
    }
    let ln_front = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let (mut ap, mut term) = (a, 1.0 / a);
        let mut sum = term;
        for _ in 0..100_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-17 {
                break;
            }
        }
        (1.0 - sum * ln_front.exp()).max(0.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..100_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        ln_front.exp() * h
    }
}

/// Survival function of the chi-square distribution with `dof` degrees of freedom.
fn chi2_sf(stat: f64, dof: usize) -> f64 {
    gamma_q(dof as f64 / 2.0, stat / 2.0)
}

/// Outcome of one goodness-of-fit test.
#[derive(Debug)]
struct Chi2 {
    stat: f64,
    dof: usize,
    p_value: f64,
    /// Samples that landed in cells of expected count exactly zero.
    in_empty_cells: f64,
    /// The unpooled cells that contribute most to the statistic: (index, observed,
    /// expected), for the failure message.
    worst: Vec<(usize, f64, f64)>,
}

/// Pearson's statistic after pooling: cells are sorted by expected count and those
/// below `POOL_THRESHOLD` are merged until the pool reaches it (a remainder joins the
/// smallest large cell), as in Mitsuba's `mi.math.chi2`.
fn pooled_chi2(obs: &[f64], exp: &[f64]) -> Chi2 {
    assert_eq!(obs.len(), exp.len());
    let mut idx: Vec<usize> = (0..obs.len()).collect();
    idx.sort_by(|&a, &b| exp[a].partial_cmp(&exp[b]).unwrap());
    let in_empty_cells: f64 = (0..obs.len())
        .filter(|&i| exp[i] <= 0.0)
        .map(|i| obs[i])
        .sum();
    let (mut stat, mut cells) = (0.0, 0usize);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for &i in &idx {
        let (o, e) = (obs[i], exp[i].max(0.0));
        if e < POOL_THRESHOLD {
            pool_o += o;
            pool_e += e;
            if pool_e >= POOL_THRESHOLD {
                stat += (pool_o - pool_e).powi(2) / pool_e;
                cells += 1;
                pool_o = 0.0;
                pool_e = 0.0;
            }
        } else {
            let (o, e) = (o + pool_o, e + pool_e);
            pool_o = 0.0;
            pool_e = 0.0;
            stat += (o - e).powi(2) / e;
            cells += 1;
        }
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e).powi(2) / pool_e;
        cells += 1;
    } else if pool_o > 0.0 {
        // Samples only in cells that should be empty: infinitely unlikely.
        stat = f64::INFINITY;
    }
    let dof = cells.saturating_sub(1);
    let mut worst: Vec<(usize, f64, f64)> = (0..obs.len())
        .filter(|&i| exp[i] >= POOL_THRESHOLD)
        .map(|i| (i, obs[i], exp[i]))
        .collect();
    worst.sort_by(|a, b| {
        let ca = (a.1 - a.2).powi(2) / a.2;
        let cb = (b.1 - b.2).powi(2) / b.2;
        cb.partial_cmp(&ca).unwrap()
    });
    worst.truncate(6);
    let p_value = if dof == 0 || !stat.is_finite() {
        0.0
    } else {
        chi2_sf(stat, dof)
    };
    Chi2 {
        stat,
        dof,
        p_value,
        in_empty_cells,
        worst,
    }
}

fn assert_chi2(name: &str, r: &Chi2) {
    let alpha = sidak_alpha();
    // Shown with --nocapture: how far each test is from its threshold.
    eprintln!(
        "chi2 {name}: {:.1} / {} dof, p = {:.4}",
        r.stat, r.dof, r.p_value
    );
    assert!(
        r.dof >= 10,
        "{name}: only {} degrees of freedom, the test has no power",
        r.dof
    );
    assert!(
        r.in_empty_cells == 0.0,
        "{name}: {} samples fell in cells where the density integrates to zero",
        r.in_empty_cells
    );
    assert!(
        r.p_value >= alpha,
        "{name}: chi2 = {:.1} with {} dof, p = {:.3e} < {:.3e} (Sidak-corrected 0.01); \
         worst cells (index, observed, expected): {:?}",
        r.stat,
        r.dof,
        r.p_value,
        alpha,
        r.worst
    );
}

/// A rectangle of coordinates (s, t) in [0, 1)^2 that covers the sphere of directions.
#[derive(Clone, Copy)]
enum Param {
    /// s = (cos theta + 1) / 2, t = (phi + pi) / (2 pi) in a frame: equal-area bins.
    CosPhi(Frame),
    /// An environment map's lat-long (u, v), with its world-from-map rotation.
    LatLong(Mat3),
    /// A narrow cap about a frame's normal: s = (1 - cos theta) / `one_minus_z0`,
    /// computed from sin^2 so it keeps its precision for caps of 1e-3 rad. Directions
    /// outside the cap have no bin.
    Cap { frame: Frame, one_minus_z0: f64 },
}

impl Param {
    fn coords(&self, d: Vec3) -> Option<(f64, f64)> {
        match *self {
            Param::CosPhi(frame) => {
                let l = frame.to_local(d).as_dvec3();
                let z = (l.z / l.length()).clamp(-1.0, 1.0);
                let phi = l.y.atan2(l.x);
                Some(((z + 1.0) / 2.0, (phi + PI) / (2.0 * PI)))
            }
            Param::LatLong(rot) => {
                let uv = LatLong::to_uv(rot.transpose() * d);
                Some((uv.x as f64, uv.y as f64))
            }
            Param::Cap {
                frame,
                one_minus_z0,
            } => {
                let l = frame.to_local(d).as_dvec3() / d.as_dvec3().length();
                if l.z <= 0.0 {
                    return None;
                }
                let s = (l.x * l.x + l.y * l.y) / (1.0 + l.z) / one_minus_z0;
                let phi = l.y.atan2(l.x);
                (s < 1.0).then_some((s, (phi + PI) / (2.0 * PI)))
            }
        }
    }

    fn dir(&self, s: f64, t: f64) -> Vec3 {
        match *self {
            Param::CosPhi(frame) => {
                let z = 2.0 * s - 1.0;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = 2.0 * PI * t - PI;
                let l = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                frame.to_world(l)
            }
            Param::LatLong(rot) => rot * LatLong::to_dir(Vec2::new(s as f32, t as f32)),
            Param::Cap {
                frame,
                one_minus_z0,
            } => {
                let omz = s * one_minus_z0;
                let r = (omz * (2.0 - omz)).sqrt();
                let phi = 2.0 * PI * t - PI;
                let l = Vec3::new(
                    (r * phi.cos()) as f32,
                    (r * phi.sin()) as f32,
                    (1.0 - omz) as f32,
                );
                frame.to_world(l)
            }
        }
    }

    /// Solid angle per unit (s, t) area.
    fn jacobian(&self, _s: f64, t: f64) -> f64 {
        match *self {
            Param::CosPhi(_) => 4.0 * PI,
            Param::LatLong(_) => 2.0 * PI * PI * (PI * t).sin(),
            Param::Cap { one_minus_z0, .. } => 2.0 * PI * one_minus_z0,
        }
    }
}

#[derive(Clone, Copy)]
enum Quadrature {
    /// Adaptive tensor Simpson, for smooth or peaked densities with a few
    /// discontinuities: a cell is accepted when its error estimate is below `abs_tol`
    /// times its (s, t) area or `rel_tol` times its mass.
    Adaptive {
        abs_tol: f64,
        rel_tol: f64,
        max_depth: u32,
    },
    /// k x k midpoints per bin, for densities that are constant on each bin.
    Midpoint(usize),
}

fn simpson(f: &impl Fn(f64, f64) -> f64, x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    let (xm, ym) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let (xs, ys, w) = ([x0, xm, x1], [y0, ym, y1], [1.0, 4.0, 1.0]);
    let mut sum = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            sum += w[i] * w[j] * f(xs[i], ys[j]);
        }
    }
    sum * (x1 - x0) * (y1 - y0) / 36.0
}

fn midpoint(f: &impl Fn(f64, f64) -> f64, x0: f64, x1: f64, y0: f64, y1: f64, k: usize) -> f64 {
    let mut m = 0.0;
    for a in 0..k {
        for b in 0..k {
            let x = x0 + (x1 - x0) * (a as f64 + 0.5) / k as f64;
            let y = y0 + (y1 - y0) * (b as f64 + 0.5) / k as f64;
            m += f(x, y);
        }
    }
    m * (x1 - x0) * (y1 - y0) / (k * k) as f64
}

#[allow(clippy::too_many_arguments)]
fn adaptive(
    f: &impl Fn(f64, f64) -> f64,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    whole: f64,
    tol: (f64, f64),
    depth: u32,
) -> f64 {
    if depth == 0 {
        // The cell still straddles a discontinuity (a silhouette): Simpson's nodes
        // on the cell boundary bias such cells, a midpoint grid does not.
        return midpoint(f, x0, x1, y0, y1, 6);
    }
    let (xm, ym) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let q = [
        simpson(f, x0, xm, y0, ym),
        simpson(f, xm, x1, y0, ym),
        simpson(f, x0, xm, ym, y1),
        simpson(f, xm, x1, ym, y1),
    ];
    let sum: f64 = q.iter().sum();
    let (abs_tol, rel_tol) = tol;
    if (sum - whole).abs() <= 15.0 * (abs_tol * (x1 - x0) * (y1 - y0)).max(rel_tol * sum.abs()) {
        return sum + (sum - whole) / 15.0;
    }
    adaptive(f, x0, xm, y0, ym, q[0], tol, depth - 1)
        + adaptive(f, xm, x1, y0, ym, q[1], tol, depth - 1)
        + adaptive(f, x0, xm, ym, y1, q[2], tol, depth - 1)
        + adaptive(f, xm, x1, ym, y1, q[3], tol, depth - 1)
}

/// Probability mass of each bin of an `ns` x `nt` grid over `param` under the
/// solid-angle density `pdf`.
fn bin_masses(
    param: Param,
    ns: usize,
    nt: usize,
    pdf: &impl Fn(Vec3) -> f64,
    quad: Quadrature,
) -> Vec<f64> {
    let f = |s: f64, t: f64| pdf(param.dir(s, t)) * param.jacobian(s, t);
    let mut out = vec![0.0; ns * nt];
    for i in 0..ns {
        for j in 0..nt {
            let (s0, s1) = (i as f64 / ns as f64, (i + 1) as f64 / ns as f64);
            let (t0, t1) = (j as f64 / nt as f64, (j + 1) as f64 / nt as f64);
            let mass = match quad {
                Quadrature::Adaptive {
                    abs_tol,
                    rel_tol,
                    max_depth,
                } => {
                    // Start from 2 x 2 sub-cells so a narrow peak is less likely to
                    // slip between the first nine nodes.
                    let mut m = 0.0;
                    for a in 0..2 {
                        for b in 0..2 {
                            let xa = s0 + (s1 - s0) * a as f64 / 2.0;
                            let xb = s0 + (s1 - s0) * (a + 1) as f64 / 2.0;
                            let ya = t0 + (t1 - t0) * b as f64 / 2.0;
                            let yb = t0 + (t1 - t0) * (b + 1) as f64 / 2.0;
                            let whole = simpson(&f, xa, xb, ya, yb);
                            m += adaptive(&f, xa, xb, ya, yb, whole, (abs_tol, rel_tol), max_depth);
                        }
                    }
                    m
                }
                Quadrature::Midpoint(k) => midpoint(&f, s0, s1, t0, t1, k),
            };
            out[i * nt + j] = mass.max(0.0);
        }
    }
    out
}

/// Result of a direction-sampler test: the chi-square outcome, the integral of the
/// density over the binned domain and the number of failed draws (and of draws
/// outside the domain, for a cap).
struct DirTest {
    chi2: Chi2,
    integral: f64,
    failures: u64,
    n: u64,
}

impl DirTest {
    /// A sampler that returns `None` with probability 1 - integral (the density is
    /// that of the accepted directions, not renormalised): the failure count is
    /// binomial. `slack` covers the quadrature error of `integral`.
    fn assert_failure_rate(&self, name: &str, slack: f64) {
        let p = (1.0 - self.integral).clamp(0.0, 1.0);
        let n = self.n as f64;
        let sigma = (p * (1.0 - p) / n).sqrt();
        let observed = self.failures as f64 / n;
        assert!(
            (observed - p).abs() <= 4.0 * sigma + slack,
            "{name}: failure rate {observed:.5} but 1 - integral of pdf = {p:.5} (4 sigma = {:.5})",
            4.0 * sigma
        );
    }
}

/// Total quadrature error of at most ~1e-6 of the sphere's mass plus 1e-4 of each
/// bin's: at 1e6 samples a bin of expected count E is off by at most 1 + 1e-4 E, far
/// below its standard deviation sqrt(E).
const DEFAULT_ADAPTIVE: Quadrature = Quadrature::Adaptive {
    abs_tol: 1e-6,
    rel_tol: 1e-4,
    max_depth: 8,
};

/// Chi-square test of a direction sampler against a solid-angle density: `n` draws
/// are binned on an `ns` x `nt` grid over `param`; the expected count of each bin is
/// `n` times the integral of `pdf` over it; failed draws form one more cell whose
/// expected count is `n` (1 - integral of `pdf` over the binned domain); with a cap,
/// draws outside it join that cell.
#[allow(clippy::too_many_arguments)]
fn chi2_directions(
    param: Param,
    ns: usize,
    nt: usize,
    n: u64,
    mut sample: impl FnMut() -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f64,
    quad: Quadrature,
) -> DirTest {
    let mut obs = vec![0.0f64; ns * nt + 1];
    let mut failures = 0u64;
    for _ in 0..n {
        match sample() {
            Some(d) if param.coords(d).is_some() => {
                assert!(d.is_finite(), "non-finite direction {d}");
                let (s, t) = param.coords(d).unwrap();
                let i = ((s * ns as f64) as usize).min(ns - 1);
                let j = ((t * nt as f64) as usize).min(nt - 1);
                obs[i * nt + j] += 1.0;
            }
            _ => {
                failures += 1;
                obs[ns * nt] += 1.0;
            }
        }
    }
    let masses = bin_masses(param, ns, nt, &pdf, quad);
    let integral: f64 = masses.iter().sum();
    let mut exp: Vec<f64> = masses.iter().map(|m| m * n as f64).collect();
    exp.push(((1.0 - integral) * n as f64).max(0.0));
    DirTest {
        chi2: pooled_chi2(&obs, &exp),
        integral,
        failures,
        n,
    }
}

// ---------------------------------------------------------------------------------
// Small helpers
// ---------------------------------------------------------------------------------

fn rel_close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

/// Direction at polar angle `theta_deg` from +z and azimuth `phi` (radians).
fn dir_deg(theta_deg: f32, phi: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())
}

fn uniform_sphere(rng: &mut Rng) -> Vec3 {
    let u = rng.next_2d();
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Mean and standard error of a sample.
struct Stats {
    n: f64,
    sum: f64,
    sum2: f64,
}

impl Stats {
    fn new() -> Self {
        Stats {
            n: 0.0,
            sum: 0.0,
            sum2: 0.0,
        }
    }
    fn push(&mut self, x: f64) {
        self.n += 1.0;
        self.sum += x;
        self.sum2 += x * x;
    }
    fn mean(&self) -> f64 {
        self.sum / self.n
    }
    fn std_err(&self) -> f64 {
        let m = self.mean();
        ((self.sum2 / self.n - m * m).max(0.0) / (self.n - 1.0)).sqrt()
    }
}

const PHI0: f32 = 0.4;

/// Outgoing directions at normal incidence, 45 degrees and grazing 85 degrees.
fn standard_wos() -> Vec<Vec3> {
    vec![Vec3::Z, dir_deg(45.0, PHI0), dir_deg(85.0, PHI0)]
}

fn below(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

struct BsdfCase {
    name: String,
    m: Material,
    wos: Vec<Vec3>,
}

impl BsdfCase {
    /// Scatters to both sides of the surface.
    fn transmits(&self) -> bool {
        transmits(&self.m)
    }

    /// Has a delta lobe beside its continuous ones (plastic's coating, a mixture's
    /// delta component).
    fn mixed(&self) -> bool {
        matches!(self.m, Material::Plastic(_) | Material::Mixture(_))
    }
}

/// Whether the continuous lobes reach both sides (a rough dielectric, also inside a
/// mixture).
fn transmits(m: &Material) -> bool {
    match m {
        Material::RoughDielectric(_) => true,
        Material::Mixture(mix) => mix.components.iter().any(transmits),
        _ => false,
    }
}

fn mix(weights: &[f32], components: Vec<Material>) -> Material {
    Material::Mixture(Box::new(Mixture {
        components,
        weights: weights.to_vec(),
    }))
}

/// Mixtures (`mixturebsdf`, `blendbsdf`): of continuous lobes only, with a delta lobe
/// (plastic's coating, a smooth dielectric), transmitting, and nested. 11 chi-square
/// tests.
fn mixture_cases() -> Vec<BsdfCase> {
    use Distribution::{Beckmann, Ggx};
    let eta = 1.49 / 1.000277;
    let plastic = Material::Plastic(Plastic {
        coating: coating(Rgb::new(0.8, 0.3, 0.1), eta, false),
        two_sided: false,
    });
    let inside = below(dir_deg(45.0, PHI0));
    vec![
        BsdfCase {
            name: "mixture 0.6 diffuse + 0.3 GGX gold".into(),
            m: mix(&[0.6, 0.3], vec![diffuse(0.8, false), gold(0.3, false)]),
            wos: standard_wos(),
        },
        BsdfCase {
            name: "blend 0.3 of plastic and anisotropic Beckmann gold".into(),
            m: mix(
                &[0.7, 0.3],
                vec![
                    plastic,
                    rough_gold(Microfacet::new(Beckmann, 0.1, 0.4), false),
                ],
            ),
            wos: standard_wos(),
        },
        BsdfCase {
            name: "blend 0.4 of glass and diffuse".into(),
            m: mix(&[0.6, 0.4], vec![glass(1.5), diffuse(0.7, false)]),
            wos: vec![Vec3::Z, dir_deg(60.0, PHI0)],
        },
        BsdfCase {
            name: "mixture of rough glass and a blend of diffuse and gold, nested".into(),
            m: mix(
                &[0.5, 0.5],
                vec![
                    rough_glass(Microfacet::new(Ggx, 0.3, 0.3), 1.5),
                    mix(&[0.5, 0.5], vec![diffuse(0.5, true), gold(0.2, true)]),
                ],
            ),
            wos: vec![dir_deg(45.0, PHI0), inside, below(dir_deg(60.0, PHI0))],
        },
    ]
}

fn diffuse(r: f32, two_sided: bool) -> Material {
    Material::Diffuse(Diffuse {
        reflectance: Rgb::splat(r),
        two_sided,
    })
}

fn phong(kd: f32, ks: f32, n: f32, two_sided: bool) -> Material {
    Material::Phong(Phong::new(Rgb::splat(kd), Rgb::splat(ks), n, two_sided))
}

/// Gold (eta, k at roughly 650, 550, 450 nm), GGX-rough.
fn gold(alpha: f32, two_sided: bool) -> Material {
    rough_gold(Microfacet::new(Distribution::Ggx, alpha, alpha), two_sided)
}

fn rough_gold(distribution: Microfacet, two_sided: bool) -> Material {
    Material::Conductor(Conductor {
        eta: Rgb::new(0.143, 0.374, 1.442),
        k: Rgb::new(3.983, 2.386, 1.603),
        distribution,
        specular_reflectance: Rgb::ONE,
        two_sided,
    })
}

fn rough_glass(distribution: Microfacet, eta: f32) -> Material {
    Material::RoughDielectric(RoughDielectric {
        eta,
        distribution,
        specular_reflectance: Rgb::ONE,
        specular_transmittance: Rgb::ONE,
    })
}

/// Every non-delta BSDF configuration under test, with its outgoing directions.
fn bsdf_cases() -> Vec<BsdfCase> {
    let mut v = vec![BsdfCase {
        name: "diffuse 0.6".into(),
        m: diffuse(0.6, false),
        wos: standard_wos(),
    }];
    v.push(BsdfCase {
        name: "diffuse 0.6 two-sided, wo below".into(),
        m: diffuse(0.6, true),
        wos: vec![below(dir_deg(45.0, PHI0))],
    });
    for (kd, ks, n) in [(0.0, 1.0, 1.0), (0.3, 0.6, 10.0), (0.1, 0.7, 90.0)] {
        v.push(BsdfCase {
            name: format!("phong kd {kd} ks {ks} n {n}"),
            m: phong(kd, ks, n, false),
            wos: standard_wos(),
        });
    }
    v.push(BsdfCase {
        name: "phong kd 0.2 ks 0.7 n 20 two-sided, wo below".into(),
        m: phong(0.2, 0.7, 20.0, true),
        wos: vec![below(dir_deg(45.0, PHI0))],
    });
    for alpha in [0.05, 0.3, 0.8] {
        v.push(BsdfCase {
            name: format!("conductor GGX alpha {alpha}"),
            m: gold(alpha, false),
            wos: standard_wos(),
        });
    }
    v.push(BsdfCase {
        name: "conductor GGX alpha 0.3 two-sided, wo below".into(),
        m: gold(0.3, true),
        wos: vec![below(dir_deg(45.0, PHI0))],
    });
    v.extend(microfacet_cases());
    v
}

/// Beckmann and anisotropic conductors, and rough dielectrics seen from both sides
/// (60 degrees inside glass is beyond the smooth critical angle).
fn microfacet_cases() -> Vec<BsdfCase> {
    use Distribution::{Beckmann, Ggx};
    let mut v = Vec::new();
    for (kind, au, av) in [
        (Beckmann, 0.1, 0.1),
        (Beckmann, 0.3, 0.3),
        (Ggx, 0.05, 0.4),
        (Beckmann, 0.4, 0.1),
    ] {
        v.push(BsdfCase {
            name: format!("conductor {kind:?} alpha ({au}, {av})"),
            m: rough_gold(Microfacet::new(kind, au, av), false),
            wos: standard_wos(),
        });
    }
    v.push(BsdfCase {
        name: "conductor Beckmann alpha 0.3 two-sided, wo below".into(),
        m: rough_gold(Microfacet::new(Beckmann, 0.3, 0.3), true),
        wos: vec![below(dir_deg(45.0, PHI0))],
    });
    let inside = [below(dir_deg(45.0, PHI0)), below(dir_deg(60.0, PHI0))];
    for kind in [Ggx, Beckmann] {
        v.push(BsdfCase {
            name: format!("rough dielectric {kind:?} alpha 0.3 eta 1.5"),
            m: rough_glass(Microfacet::new(kind, 0.3, 0.3), 1.5),
            wos: [standard_wos(), inside.to_vec()].concat(),
        });
    }
    v.push(BsdfCase {
        name: "rough dielectric Beckmann alpha (0.1, 0.4) eta 1.5".into(),
        m: rough_glass(Microfacet::new(Beckmann, 0.1, 0.4), 1.5),
        wos: vec![dir_deg(45.0, PHI0), dir_deg(85.0, PHI0), inside[0]],
    });
    v.push(BsdfCase {
        name: "rough dielectric GGX alpha 0.05 eta 1/1.33".into(),
        m: rough_glass(Microfacet::new(Ggx, 0.05, 0.05), 1.0 / 1.33),
        wos: vec![dir_deg(45.0, PHI0), inside[0]],
    });
    v.extend(plastic_cases());
    v.extend(mixture_cases());
    v
}

fn coating(diffuse: Rgb, eta: f32, nonlinear: bool) -> Coating {
    Coating {
        diffuse_reflectance: diffuse,
        specular_reflectance: Rgb::ONE,
        eta,
        nonlinear,
    }
}

/// Plastics with Mitsuba's default IORs (polypropylene in air), smooth and rough.
fn plastic_cases() -> Vec<BsdfCase> {
    let eta = 1.49 / 1.000277;
    let colour = Rgb::new(0.8, 0.3, 0.1);
    vec![
        BsdfCase {
            name: "plastic".into(),
            m: Material::Plastic(Plastic {
                coating: coating(Rgb::splat(0.5), eta, false),
                two_sided: false,
            }),
            wos: standard_wos(),
        },
        BsdfCase {
            name: "plastic nonlinear two-sided, wo below".into(),
            m: Material::Plastic(Plastic {
                coating: coating(colour, eta, true),
                two_sided: true,
            }),
            wos: vec![below(dir_deg(45.0, PHI0))],
        },
        BsdfCase {
            // Beyond where Mitsuba's fit of the internal reflectance holds (it
            // exceeds 1 near eta 3.8).
            name: "plastic eta 4".into(),
            m: Material::Plastic(Plastic {
                coating: coating(Rgb::splat(0.2), 4.0, false),
                two_sided: false,
            }),
            wos: vec![dir_deg(45.0, PHI0)],
        },
        BsdfCase {
            name: "roughplastic Beckmann alpha 0.2".into(),
            m: Material::RoughPlastic(RoughPlastic::new(
                coating(Rgb::splat(0.5), eta, false),
                Microfacet::new(Distribution::Beckmann, 0.2, 0.2),
                false,
            )),
            wos: standard_wos(),
        },
        BsdfCase {
            name: "roughplastic GGX alpha 0.4 nonlinear".into(),
            m: Material::RoughPlastic(RoughPlastic::new(
                coating(colour, eta, true),
                Microfacet::new(Distribution::Ggx, 0.4, 0.4),
                false,
            )),
            wos: standard_wos(),
        },
    ]
}

// ---------------------------------------------------------------------------------
// 1. The chi-square helper itself
// ---------------------------------------------------------------------------------

#[test]
fn chi2_survival_function_matches_known_quantiles() {
    // Textbook quantiles of the chi-square distribution.
    for (x, dof, p) in [
        (3.841_458_820_694_124, 1, 0.05),
        (6.634_896_601_021_214, 1, 0.01),
        (23.209_251_158_954_356, 10, 0.01),
        (135.806_722_912_999_4, 100, 0.01),
    ] {
        let q = chi2_sf(x, dof);
        assert!(rel_close(q, p, 1e-6), "sf({x}, {dof}) = {q}, want {p}");
    }
    // Even dof: Q(k, y) = e^-y sum_{i<k} y^i / i! (Poisson tail), exact to compare with
    // on both branches (series and continued fraction) and deep in the tail.
    for k in [1usize, 2, 5, 30, 500, 1000] {
        for y in [
            0.1,
            0.5 * k as f64,
            k as f64 + 0.5,
            1.5 * k as f64 + 10.0,
            3.0 * k as f64 + 40.0,
        ] {
            let mut ln_terms = Vec::new();
            // Sum in log space to avoid underflow of e^-y for large y.
            for i in 0..k {
                ln_terms.push(-y + i as f64 * y.ln() - ln_gamma(i as f64 + 1.0));
            }
            let mx = ln_terms.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let exact = mx.exp() * ln_terms.iter().map(|l| (l - mx).exp()).sum::<f64>();
            let q = chi2_sf(2.0 * y, 2 * k);
            let tol = 1e-9 + 1e-9 * exact;
            assert!(
                (q - exact).abs() <= tol.max(exact * 1e-8),
                "Q({k}, {y}) = {q:e}, exact {exact:e}"
            );
        }
    }
    // ln Gamma at integers and at 1/2.
    assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-13);
    assert!((ln_gamma(10.0) - 362_880f64.ln()).abs() < 1e-12);
}

#[test]
fn chi2_accepts_a_correct_sampler_and_rejects_a_subtly_wrong_one() {
    let frame = Frame::from_normal(Vec3::Z);
    let cos_pow = |d: Vec3, n: f64| {
        let z = d.z as f64;
        if z > 0.0 {
            (n + 1.0) / (2.0 * PI) * z.powf(n)
        } else {
            0.0
        }
    };
    // Cosine-weighted samples (Malley) against the cosine density: accepted.
    let mut rng = Rng::new(11, 0, 0);
    let t = chi2_directions(
        Param::CosPhi(frame),
        32,
        64,
        500_000,
        || {
            let u = rng.next_2d();
            let r = u.x.sqrt();
            let phi = 2.0 * std::f32::consts::PI * u.y;
            Some(Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).sqrt()))
        },
        |d| cos_pow(d, 1.0),
        DEFAULT_ADAPTIVE,
    );
    assert_chi2("cosine vs cosine", &t.chi2);
    assert!((t.integral - 1.0).abs() < 1e-6, "integral {}", t.integral);
    // The same samples against cos^1.05: a 5% change of exponent must be rejected.
    let mut rng = Rng::new(11, 0, 1);
    let t = chi2_directions(
        Param::CosPhi(frame),
        32,
        64,
        500_000,
        || {
            let u = rng.next_2d();
            let r = u.x.sqrt();
            let phi = 2.0 * std::f32::consts::PI * u.y;
            Some(Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).sqrt()))
        },
        |d| cos_pow(d, 1.05),
        DEFAULT_ADAPTIVE,
    );
    assert!(
        t.chi2.p_value < sidak_alpha(),
        "a wrong density passed: chi2 {} dof {} p {}",
        t.chi2.stat,
        t.chi2.dof,
        t.chi2.p_value
    );
}

// ---------------------------------------------------------------------------------
// 2. Non-delta BSDFs
// ---------------------------------------------------------------------------------

/// Chi-square of `sample` against `pdf` for every non-delta BSDF and outgoing
/// direction; the integral of `pdf` over the sphere is 1 for samplers that cannot fail
/// and equals the acceptance rate for those that can (Phong's glossy lobe and GGX
/// reflections can fall below the surface; `pdf` is zero there, so accepted samples
/// follow `pdf` and the failure rate is 1 - its integral).
#[test]
fn bsdf_sampling_matches_pdf_chi2() {
    let mut seed = 0;
    for case in bsdf_cases() {
        for &wo in &case.wos {
            seed += 1;
            let name = format!("{} wo {wo}", case.name);
            let mut rng = Rng::new(100, seed, 0);
            let m = &case.m;
            let t = chi2_directions(
                Param::CosPhi(Frame::from_normal(Vec3::Z)),
                32,
                64,
                1_000_000,
                || {
                    let s = m.sample(wo, rng.next_f32(), rng.next_2d(), Mode::Radiance)?;
                    // A delta lobe's samples have no density: they count with the
                    // failures, whose expected share is 1 - int pdf.
                    (!s.delta).then_some(s.wi.into())
                },
                |wi| m.pdf(wo, wi) as f64,
                DEFAULT_ADAPTIVE,
            );
            assert_chi2(&name, &t.chi2);
            assert!(
                t.integral <= 1.0 + 1e-4,
                "{name}: pdf integrates to {}",
                t.integral
            );
            if matches!(m, Material::Diffuse(_)) {
                assert!(
                    (t.integral - 1.0).abs() < 1e-4,
                    "{name}: integral {}",
                    t.integral
                );
                assert_eq!(t.failures, 0, "{name}: diffuse sampling failed");
            }
            t.assert_failure_rate(&name, 2e-4);
        }
    }
}

/// The sampled weight is eval / pdf, the reported pdf is `pdf`, and both are finite.
#[test]
fn bsdf_weight_equals_eval_over_pdf() {
    for (k, case) in bsdf_cases().into_iter().enumerate() {
        for &wo in &case.wos {
            let mut rng = Rng::new(200, k as u64, 0);
            let mut accepted = 0;
            for _ in 0..100_000 {
                let Some(s) = case
                    .m
                    .sample(wo, rng.next_f32(), rng.next_2d(), Mode::Radiance)
                else {
                    continue;
                };
                accepted += 1;
                if s.delta && case.mixed() {
                    let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
                    let reflects = (Vec3::from(s.wi) - mirror).length() < 1e-6;
                    // A mixture's smooth glass also refracts.
                    let refracts = matches!(case.m, Material::Mixture(_)) && s.wi.z * wo.z < 0.0;
                    assert!(reflects || refracts, "{}", case.name);
                    continue;
                }
                assert!(
                    !s.delta,
                    "{}: non-delta BSDF returned a delta sample",
                    case.name
                );
                assert!(
                    case.transmits() || s.wi.z * wo.z > 0.0,
                    "{}: reflection on the wrong side",
                    case.name
                );
                let f = case.m.eval(wo, s.wi.into(), Mode::Radiance);
                let pdf = case.m.pdf(wo, s.wi.into());
                assert!(
                    pdf > 0.0 && s.pdf > 0.0,
                    "{}: zero pdf for a sample",
                    case.name
                );
                assert!(
                    rel_close(s.pdf as f64, pdf as f64, 1e-3),
                    "{}: sample pdf {} vs pdf {}",
                    case.name,
                    s.pdf,
                    pdf
                );
                for c in 0..3 {
                    let w = s.weight[c] as f64;
                    assert!(
                        w.is_finite() && w >= 0.0,
                        "{}: weight {}",
                        case.name,
                        s.weight
                    );
                    let expect = f[c] as f64 / pdf as f64;
                    assert!(
                        rel_close(w, expect, 1e-3),
                        "{}: wo {wo} wi {}: weight {w} vs eval/pdf {expect}",
                        case.name,
                        s.wi
                    );
                }
            }
            assert!(accepted > 10_000, "{}: only {accepted} samples", case.name);
        }
    }
}

/// pdf > 0 wherever eval > 0 (otherwise MIS and the sampler disagree on the support),
/// and eval = 0 on the side the BSDF does not scatter to.
#[test]
fn bsdf_pdf_positive_where_eval_positive() {
    for (k, case) in bsdf_cases().into_iter().enumerate() {
        let mut rng = Rng::new(300, k as u64, 0);
        for _ in 0..200_000 {
            let wo = uniform_sphere(&mut rng);
            let wi = uniform_sphere(&mut rng);
            let f = case.m.eval(wo, wi, Mode::Radiance);
            let pdf = case.m.pdf(wo, wi);
            assert!(pdf >= 0.0 && pdf.is_finite());
            if f.max_element() > 0.0 {
                assert!(
                    pdf > 0.0,
                    "{}: eval {f} but pdf 0 at wo {wo} wi {wi}",
                    case.name
                );
            }
            if wo.z * wi.z <= 0.0 && !case.transmits() {
                assert_eq!(f, Rgb::ZERO, "{}: transmission from a reflector", case.name);
            }
        }
    }
}

/// Directional albedo: mean of sampled weights <= 1 + 3 standard errors (failed
/// samples count as zero); equal to the reflectance for Diffuse; and equal, within 4
/// combined standard errors, to an independent estimate by uniform hemisphere
/// sampling of `eval` (which ties `sample` to `eval` without going through `pdf`).
/// Transmitting BSDFs are sampled over the whole sphere and in importance mode, whose
/// albedo is bounded by 1 (radiance through an interface is scaled by (n_o / n_i)^2).
#[test]
fn bsdf_albedo_is_bounded_and_agrees_with_uniform_estimate() {
    const N: usize = 400_000;
    for (k, case) in bsdf_cases().into_iter().enumerate() {
        for (j, &wo) in case.wos.iter().enumerate() {
            let name = format!("{} wo {wo}", case.name);
            let mut rng = Rng::new(400, k as u64, j as u64);
            let mut is = [Stats::new(), Stats::new(), Stats::new()];
            // Without the delta lobe, which the uniform estimate cannot see.
            let mut is_smooth = [Stats::new(), Stats::new(), Stats::new()];
            let mut uni = [Stats::new(), Stats::new(), Stats::new()];
            let (mode, solid_angle) = if case.transmits() {
                (Mode::Importance, 4.0 * PI)
            } else {
                (Mode::Radiance, 2.0 * PI)
            };
            for _ in 0..N {
                let s = case.m.sample(wo, rng.next_f32(), rng.next_2d(), mode);
                let w = s.map_or(Rgb::ZERO, |s| s.weight.into());
                let w_smooth = s
                    .filter(|s| !s.delta)
                    .map_or(Rgb::ZERO, |s| s.weight.into());
                // Uniform on the hemisphere on wo's side: pdf 1 / (2 pi), or on the
                // sphere.
                let mut wi = uniform_sphere(&mut rng);
                if wi.z * wo.z < 0.0 && !case.transmits() {
                    wi.z = -wi.z;
                }
                let f = case.m.eval(wo, wi, mode);
                for c in 0..3 {
                    is[c].push(w[c] as f64);
                    is_smooth[c].push(w_smooth[c] as f64);
                    uni[c].push(f[c] as f64 * solid_angle);
                }
            }
            for c in 0..3 {
                let (m, se) = (is[c].mean(), is[c].std_err());
                assert!(
                    m <= 1.0 + 3.0 * se + 1e-6,
                    "{name}: albedo {m} > 1 (se {se})"
                );
                let (m, se) = (is_smooth[c].mean(), is_smooth[c].std_err());
                let (mu, seu) = (uni[c].mean(), uni[c].std_err());
                let tol = 4.0 * (se * se + seu * seu).sqrt();
                assert!(
                    (m - mu).abs() <= tol,
                    "{name} channel {c}: importance-sampled albedo {m} vs uniform {mu} (4 sigma {tol})"
                );
                if let Material::Diffuse(d) = &case.m {
                    let r = d.reflectance[c] as f64;
                    assert!(
                        (m - r).abs() <= 3.0 * se + 1e-6,
                        "{name}: albedo {m} vs {r}"
                    );
                }
                if let Material::Phong(p) = &case.m {
                    let bound = (p.kd()[c] + p.ks()[c]) as f64;
                    assert!(m <= bound + 3.0 * se + 1e-6, "{name}: albedo {m} > kd + ks");
                }
            }
        }
    }
}

/// eval_pdfs is eval, pdf and the reverse pdf in one call, bit for bit, for
/// directions on either side of every BSDF.
#[test]
fn eval_pdfs_matches_the_separate_calls() {
    for (k, case) in bsdf_cases().into_iter().enumerate() {
        let mut rng = Rng::new(501, k as u64, 0);
        let mut nonzero = 0;
        for _ in 0..20_000 {
            let (a, b) = (uniform_sphere(&mut rng), uniform_sphere(&mut rng));
            for mode in [Mode::Radiance, Mode::Importance] {
                let (f, fwd, rev) = case.m.eval_pdfs(a, b, mode);
                let f0 = case.m.eval(a, b, mode);
                for c in 0..3 {
                    assert_eq!(f[c].to_bits(), f0[c].to_bits(), "{}: f", case.name);
                }
                let (fwd0, rev0) = (case.m.pdf(a, b), case.m.pdf(b, a));
                assert_eq!(fwd.to_bits(), fwd0.to_bits(), "{}: pdf", case.name);
                assert_eq!(rev.to_bits(), rev0.to_bits(), "{}: reverse pdf", case.name);
                nonzero += (fwd > 0.0) as u32;
            }
        }
        let delta = case.m.is_delta();
        assert!(
            delta || nonzero > 1000,
            "{}: {nonzero} non-zero pdfs",
            case.name
        );
    }
}

/// Where is_black_from(wo) holds, the BSDF is zero towards every direction and
/// sampling finds nothing; a front side is never black.
#[test]
fn black_from_means_nothing_scatters() {
    let (mut black, mut lit) = (0, 0);
    for (k, case) in bsdf_cases().into_iter().enumerate() {
        let mut rng = Rng::new(502, k as u64, 0);
        for _ in 0..2000 {
            let wo = uniform_sphere(&mut rng);
            let is_black = case.m.is_black_from(wo);
            assert!(
                wo.z <= 0.0 || !is_black,
                "{}: black from the front at {wo}",
                case.name
            );
            if !is_black {
                lit += 1;
                continue;
            }
            black += 1;
            for _ in 0..20 {
                let wi = uniform_sphere(&mut rng);
                for mode in [Mode::Radiance, Mode::Importance] {
                    assert_eq!(case.m.eval(wo, wi, mode), Rgb::ZERO, "{}", case.name);
                }
                assert_eq!(case.m.pdf(wo, wi), 0.0, "{}", case.name);
                let s = case
                    .m
                    .sample(wo, rng.next_f32(), rng.next_2d(), Mode::Radiance);
                assert!(s.is_none(), "{}: sampled {s:?} from {wo}", case.name);
            }
        }
    }
    assert!(black > 1000 && lit > 1000, "{black} black, {lit} lit");
}

/// f(wo, wi) = f(wi, wo): eval(wo, wi) / |cos wi| = eval(wi, wo) / |cos wo|.
#[test]
fn bsdf_reciprocity() {
    for (k, case) in bsdf_cases().into_iter().enumerate() {
        let side = case.wos[0].z.signum();
        let mut rng = Rng::new(500, k as u64, 0);
        let mut checked = 0;
        for _ in 0..100_000 {
            let mut a = uniform_sphere(&mut rng);
            let mut b = uniform_sphere(&mut rng);
            a.z = a.z.abs() * side;
            b.z = b.z.abs() * side;
            let fab = case.m.eval(a, b, Mode::Radiance) / b.z.abs();
            let fba = case.m.eval(b, a, Mode::Radiance) / a.z.abs();
            for c in 0..3 {
                let (x, y) = (fab[c] as f64, fba[c] as f64);
                if x.max(y) < 1e-30 {
                    continue;
                }
                checked += 1;
                // The rough dielectric's Fresnel term is evaluated from either end's
                // cosine, which rounds differently in f32.
                let tol = if case.transmits() { 1e-3 } else { 1e-4 };
                assert!(
                    rel_close(x, y, tol),
                    "{}: f({a}, {b}) = {x} but f({b}, {a}) = {y}",
                    case.name
                );
            }
        }
        // Narrow lobes (Beckmann 0.1) underflow to zero for most random pairs.
        assert!(
            checked > 50_000,
            "{}: only {checked} non-zero pairs",
            case.name
        );
    }
}

/// A narrow Beckmann lobe seen at grazing incidence, too sharp near the horizon for the
/// direction-space quadrature of the chi-square tests: the share of visible normals
/// that reflect below the surface, by sampling and by fine quadrature in normal space.
#[test]
fn narrow_beckmann_at_grazing_loses_what_quadrature_says() {
    use caustic::math::reflect;
    let d = Microfacet::new(Distribution::Beckmann, 0.05, 0.05);
    let wo = dir_deg(85.0, PHI0);
    // Normals beyond 0.4 rad from +z have density below 1e-20.
    let (nt, np, tmax) = (4000, 2000, 0.4f64);
    let (dt, dp) = (tmax / nt as f64, 2.0 * PI / np as f64);
    let (mut below, mut total) = (0.0f64, 0.0f64);
    for i in 0..nt {
        let t = (i as f64 + 0.5) * dt;
        for j in 0..np {
            let p = (j as f64 + 0.5) * dp;
            let (st, ct) = (t.sin(), t.cos());
            let m = Vec3::new((st * p.cos()) as f32, (st * p.sin()) as f32, ct as f32);
            let w = d.pdf_visible(wo, m) as f64 * st * dt * dp;
            total += w;
            if reflect(wo, m).z <= 0.0 {
                below += w;
            }
        }
    }
    assert!(
        (total - 1.0).abs() < 1e-4,
        "visible normals integrate to {total}"
    );
    let mut rng = Rng::new(505, 0, 0);
    let n = 2_000_000;
    let fails = (0..n)
        .filter(|_| reflect(wo, d.sample_visible(wo, rng.next_2d())).z <= 0.0)
        .count();
    let f = fails as f64 / n as f64;
    let se = (f * (1.0 - f) / n as f64).sqrt();
    assert!(
        (f - below).abs() < 4.0 * se + 1e-4,
        "sampled {f} below the surface, quadrature {below} (se {se})"
    );
}

/// Through a rough interface, radiance-mode f is not symmetric but f / n^2 is (Veach
/// 1997, eq. 5.14): f(wo, wi) / n_o^2 = f(wi, wo) / n_i^2, with n_o and n_i the indices
/// on the sides of wo and wi; and importance-mode f is the adjoint,
/// f*(wo, wi) = f(wi, wo).
#[test]
fn rough_dielectric_transmission_reciprocity_with_eta_squared() {
    // The rough glasses themselves (mixtures that hold one transmit too, through
    // their smooth parts as well, which no pointwise f shows).
    let glasses = bsdf_cases().into_iter().filter(|c| c.transmits());
    for case in glasses.filter(|c| matches!(c.m, Material::RoughDielectric(_))) {
        let Material::RoughDielectric(g) = &case.m else {
            unreachable!("filtered to rough dielectrics")
        };
        let mut rng = Rng::new(503, 0, 0);
        let mut checked = 0;
        for _ in 0..100_000 {
            let a = uniform_sphere(&mut rng);
            let mut b = uniform_sphere(&mut rng);
            b.z = -b.z.abs() * a.z.signum();
            // n^2 of the side of a direction (exterior 1).
            let n2 = |w: Vec3| {
                if w.z > 0.0 {
                    1.0
                } else {
                    (g.eta * g.eta) as f64
                }
            };
            let f = |x: Vec3, y: Vec3, mode| case.m.eval(x, y, mode).x as f64 / y.z.abs() as f64;
            let (fab, fba) = (f(a, b, Mode::Radiance), f(b, a, Mode::Radiance));
            // Skip facets seen almost edge-on from one end: that cosine is lost to
            // rounding in f32, and with it F and G1.
            let m = (a * n2(a).sqrt() as f32 + b * n2(b).sqrt() as f32).normalize();
            if fab.max(fba) < 1e-30 || a.dot(m).abs().min(b.dot(m).abs()) < 0.05 {
                continue;
            }
            checked += 1;
            assert!(
                rel_close(fab / n2(a), fba / n2(b), 2e-3),
                "{}: f({a}, {b}) / n_o^2 = {} but f({b}, {a}) / n_i^2 = {}",
                case.name,
                fab / n2(a),
                fba / n2(b)
            );
            let adjoint = f(a, b, Mode::Importance);
            assert!(
                rel_close(adjoint, fba, 2e-3),
                "{}: importance f({a}, {b}) = {adjoint} but f({b}, {a}) = {fba}",
                case.name
            );
        }
        assert!(checked > 2_000, "{}: only {checked} pairs", case.name);
    }
}

/// A plastic's whole albedo, its delta lobe included, is at most one and more than
/// the coating's Fresnel reflectance alone (the base returns some light).
#[test]
fn plastic_albedo_includes_its_coating() {
    for case in plastic_cases() {
        let mut rng = Rng::new(504, 0, 0);
        let wo = case.wos[0];
        let mut stats = Stats::new();
        let n = 200_000;
        for _ in 0..n {
            let w = case
                .m
                .sample(wo, rng.next_f32(), rng.next_2d(), Mode::Radiance)
                .map_or(0.0, |s| s.weight.y as f64);
            stats.push(w);
        }
        let eta = match &case.m {
            Material::Plastic(p) => p.coating.eta,
            Material::RoughPlastic(p) => p.coating.eta,
            _ => unreachable!(),
        };
        let f = fresnel::dielectric(wo.z.abs(), eta).0 as f64;
        let (m, se) = (stats.mean(), stats.std_err());
        assert!(m <= 1.0 + 3.0 * se, "{}: albedo {m}", case.name);
        assert!(m > f, "{}: albedo {m} below the coating's F {f}", case.name);
    }
}

/// Mitsuba 3.9's `thindielectric` (bk7 in air, the defaults), sampled with
/// `deploy/scripts/mitsuba_bsdf_values.py`: (wo, u_lobe, wi, weight, pdf).
#[test]
// The values as Mitsuba printed them.
#[allow(clippy::excessive_precision)]
fn thin_dielectric_matches_mitsuba() {
    #[allow(clippy::type_complexity)]
    let cases: [([f32; 3], f32, [f32; 3], f32, f32); 6] = [
        ([0.0, 0.0, 1.0], 0.01, [0.0, 0.0, 1.0], 1.0, 7.7914335e-02),
        ([0.0, 0.0, 1.0], 0.99, [0.0, 0.0, -1.0], 1.0, 9.2208564e-01),
        ([0.6, 0.0, 0.8], 0.01, [-0.6, 0.0, 0.8], 1.0, 8.5120276e-02),
        ([0.6, 0.0, 0.8], 0.99, [-0.6, 0.0, -0.8], 1.0, 9.1487974e-01),
        (
            [0.0, -0.9, -0.2],
            0.01,
            [0.0, 9.7618705e-01, -2.1693046e-01],
            1.0,
            4.7555730e-01,
        ),
        (
            [0.0, -0.9, -0.2],
            0.99,
            [0.0, 9.7618705e-01, 2.1693046e-01],
            1.0,
            5.2444267e-01,
        ),
    ];
    let thin = Material::ThinDielectric(ThinDielectric {
        eta: 1.5046 / 1.000277,
        specular_reflectance: Rgb::ONE,
        specular_transmittance: Rgb::ONE,
    });
    assert!(thin.is_delta());
    for (wo, u, wi, weight, pdf) in cases {
        let wo = Vec3::from(wo).normalize();
        let s = thin
            .sample(wo, u, Vec2::new(0.5, 0.5), Mode::Importance)
            .unwrap();
        // Mitsuba's wo for the transmitted lobe is -wi exactly; its normalised input
        // differs from ours in the last bit.
        assert!(
            (Vec3::from(s.wi) - Vec3::from(wi)).length() < 1e-6,
            "{wo}: {}",
            s.wi
        );
        assert!((s.weight.x - weight).abs() < 1e-6, "{wo}: {}", s.weight);
        assert!((s.pdf - pdf).abs() < 1e-5, "{wo}: pdf {} vs {pdf}", s.pdf);
        assert!(s.delta);
    }
}

// ---------------------------------------------------------------------------------
// 3. Delta BSDFs
// ---------------------------------------------------------------------------------

#[test]
fn mirror_reflects_with_its_reflectance() {
    let r = Rgb::new(0.9, 0.5, 0.2);
    let one = Material::Mirror(Mirror {
        reflectance: r,
        two_sided: false,
    });
    let two = Material::Mirror(Mirror {
        reflectance: r,
        two_sided: true,
    });
    let mut rng = Rng::new(600, 0, 0);
    for _ in 0..10_000 {
        let mut wo = uniform_sphere(&mut rng);
        wo.z = wo.z.abs().max(1e-3);
        let wo = wo.normalize();
        for (m, wo) in [(&one, wo), (&two, wo), (&two, below(wo))] {
            let s = m
                .sample(wo, rng.next_f32(), rng.next_2d(), Mode::Radiance)
                .expect("mirror sample");
            assert!(s.delta);
            assert_eq!(Vec3::from(s.wi), Vec3::new(-wo.x, -wo.y, wo.z));
            assert_eq!(Rgb::from(s.weight), r);
            assert_eq!(m.eval(wo, s.wi.into(), Mode::Radiance), Rgb::ZERO);
            assert_eq!(m.pdf(wo, s.wi.into()), 0.0);
        }
        assert!(one
            .sample(below(wo), 0.5, Vec2::splat(0.5), Mode::Radiance)
            .is_none());
    }
}

/// Unpolarised Fresnel reflectance of a smooth dielectric, in f64, written
/// independently: `cos_i` > 0 from the outside (index 1) into index `eta`, < 0 from
/// the inside.
fn fresnel_ref(cos_i: f64, eta: f64) -> f64 {
    let (n_i, n_t) = if cos_i >= 0.0 { (1.0, eta) } else { (eta, 1.0) };
    let ci = cos_i.abs();
    let sin_t = n_i / n_t * (1.0 - ci * ci).sqrt();
    if sin_t >= 1.0 {
        return 1.0;
    }
    let ct = (1.0 - sin_t * sin_t).sqrt();
    let rs = (n_i * ci - n_t * ct) / (n_i * ci + n_t * ct);
    let rp = (n_t * ci - n_i * ct) / (n_t * ci + n_i * ct);
    0.5 * (rs * rs + rp * rp)
}

fn glass(eta: f32) -> Material {
    Material::Dielectric(Dielectric {
        eta,
        specular_reflectance: Rgb::ONE,
        specular_transmittance: Rgb::ONE,
    })
}

/// Incidence cosines, outside (> 0) and inside (< 0, all below the critical angle of
/// eta 1.5, which is at cos 0.745).
const DIELECTRIC_COS: [f32; 10] = [1.0, 0.9, 0.6, 0.3, 0.05, -1.0, -0.95, -0.85, -0.8, -0.76];

/// The fraction of reflected samples is the Fresnel reflectance (binomial, 4 sigma),
/// and the reported lobe probability is that reflectance.
#[test]
fn dielectric_reflection_fraction_is_fresnel() {
    const N: usize = 200_000;
    for eta in [1.5f32, 1.0 / 1.33] {
        let m = glass(eta);
        for (k, &c) in DIELECTRIC_COS.iter().enumerate() {
            let wo = Vec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c);
            let wo = Frame::from_normal(Vec3::Z).to_world(wo);
            let r_ref = fresnel_ref(c as f64, eta as f64);
            let (r, _, _) = fresnel::dielectric(c, eta);
            assert!(
                (r as f64 - r_ref).abs() < 1e-5,
                "eta {eta} cos {c}: fresnel {r} vs reference {r_ref}"
            );
            let mut rng = Rng::new(700, k as u64, eta.to_bits() as u64);
            let mut reflected = 0usize;
            for _ in 0..N {
                let s = m
                    .sample(wo, rng.next_f32(), rng.next_2d(), Mode::Radiance)
                    .expect("dielectric sample");
                assert!(s.delta);
                if s.wi.z * wo.z > 0.0 {
                    reflected += 1;
                    assert!((s.pdf as f64 - r_ref).abs() < 1e-5);
                } else {
                    assert!((s.pdf as f64 - (1.0 - r_ref)).abs() < 1e-5);
                }
            }
            let frac = reflected as f64 / N as f64;
            let sigma = (r_ref * (1.0 - r_ref) / N as f64).sqrt();
            assert!(
                (frac - r_ref).abs() <= 4.0 * sigma + 1e-6,
                "eta {eta} cos {c}: reflected {frac}, Fresnel {r_ref} (4 sigma {})",
                4.0 * sigma
            );
        }
    }
}

/// Refraction obeys Snell's law from both sides, stays in the plane of incidence on
/// the other side of the normal, and reflection is the mirror direction.
#[test]
fn dielectric_refraction_obeys_snell_from_both_sides() {
    let eta = 1.5f32;
    let m = glass(eta);
    let mut rng = Rng::new(800, 0, 0);
    let mut refracted = [0, 0];
    for _ in 0..20_000 {
        let mut wo = uniform_sphere(&mut rng);
        if wo.z.abs() < 1e-3 {
            continue;
        }
        wo = wo.normalize();
        // u_lobe just below 1 picks transmission whenever R < 1.
        let s = m
            .sample(wo, 0.999_999, Vec2::splat(0.5), Mode::Radiance)
            .unwrap();
        let (n_i, n_t) = if wo.z > 0.0 {
            (1.0, eta as f64)
        } else {
            (eta as f64, 1.0)
        };
        let sin_i = ((wo.x * wo.x + wo.y * wo.y) as f64).sqrt();
        let critical = sin_i * n_i / n_t >= 1.0;
        if s.wi.z * wo.z > 0.0 {
            assert!(critical || fresnel_ref(wo.z as f64, eta as f64) > 0.999_99);
            assert_eq!(Vec3::from(s.wi), Vec3::new(-wo.x, -wo.y, wo.z));
            continue;
        }
        assert!(!critical, "refraction beyond the critical angle: wo {wo}");
        refracted[(wo.z < 0.0) as usize] += 1;
        let wi = s.wi.as_dvec3();
        assert!((wi.length() - 1.0).abs() < 1e-5, "|wi| = {}", wi.length());
        let sin_t = (wi.x * wi.x + wi.y * wi.y).sqrt();
        assert!(
            (n_i * sin_i - n_t * sin_t).abs() < 2e-6,
            "Snell: {n_i} sin {sin_i} != {n_t} sin {sin_t}"
        );
        // Tangential components anti-parallel to wo's (both directions point away).
        let cross = wo.x as f64 * wi.y - wo.y as f64 * wi.x;
        let dot = wo.x as f64 * wi.x + wo.y as f64 * wi.y;
        assert!(
            cross.abs() < 1e-5 && dot <= 1e-7,
            "wi {wi} not in the plane of wo {wo}"
        );
    }
    assert!(
        refracted[0] > 5_000 && refracted[1] > 2_000,
        "{refracted:?}"
    );
}

/// From inside, beyond the critical angle, every sample reflects with probability 1.
#[test]
fn dielectric_total_internal_reflection() {
    let eta = 1.5f32;
    let m = glass(eta);
    let critical_cos = (1.0 - 1.0 / (eta * eta)).sqrt(); // 0.745
    let mut rng = Rng::new(900, 0, 0);
    for c in [0.74f32, 0.6, 0.3, 0.01] {
        assert!(c < critical_cos);
        let wo = Vec3::new((1.0 - c * c).sqrt() * 0.6, (1.0 - c * c).sqrt() * 0.8, -c);
        for _ in 0..10_000 {
            let s = m
                .sample(wo, rng.next_f32(), rng.next_2d(), Mode::Radiance)
                .unwrap();
            assert_eq!(
                Vec3::from(s.wi),
                Vec3::new(-wo.x, -wo.y, wo.z),
                "cos {c}: no TIR"
            );
            assert_eq!(s.pdf, 1.0);
            assert_eq!(Rgb::from(s.weight), Rgb::ONE);
        }
        // The largest u_lobe an Rng can produce.
        let s = m
            .sample(wo, 1.0 - f32::EPSILON / 2.0, Vec2::ZERO, Mode::Radiance)
            .unwrap();
        assert!(s.wi.z < 0.0);
    }
}

/// Radiance and importance weights agree for reflection and differ by exactly
/// (n_i / n_t)^2 for transmission (radiance is compressed entering a denser medium,
/// importance is not). In importance mode with unit specular colours the expected
/// weight is 1 (energy is conserved); in radiance mode it is R + (1 - R) (n_i/n_t)^2.
#[test]
fn dielectric_importance_and_radiance_weights() {
    const N: usize = 200_000;
    let eta = 1.5f32;
    let m = glass(eta);
    for (k, &c) in DIELECTRIC_COS.iter().enumerate() {
        let wo = Vec3::new(
            (1.0 - c * c).max(0.0).sqrt() * 0.8,
            (1.0 - c * c).max(0.0).sqrt() * 0.6,
            c,
        );
        let ratio = if c > 0.0 {
            1.0 / (eta as f64 * eta as f64)
        } else {
            eta as f64 * eta as f64
        };
        let mut rng = Rng::new(1000, k as u64, 0);
        let (mut imp, mut rad) = (Stats::new(), Stats::new());
        for _ in 0..N {
            let (ul, u) = (rng.next_f32(), rng.next_2d());
            let si = m.sample(wo, ul, u, Mode::Importance).unwrap();
            let sr = m.sample(wo, ul, u, Mode::Radiance).unwrap();
            assert_eq!(si.wi, sr.wi);
            assert_eq!(si.pdf, sr.pdf);
            let transmitted = si.wi.z * wo.z < 0.0;
            for ch in 0..3 {
                let (wi, wr) = (si.weight[ch] as f64, sr.weight[ch] as f64);
                let want = if transmitted { ratio } else { 1.0 };
                assert!(
                    rel_close(wr / wi, want, 1e-6),
                    "cos {c}: radiance / importance = {} want {want}",
                    wr / wi
                );
            }
            imp.push(si.weight.x as f64);
            rad.push(sr.weight.x as f64);
        }
        let r = fresnel_ref(c as f64, eta as f64);
        assert!(
            (imp.mean() - 1.0).abs() <= 3.0 * imp.std_err() + 1e-6,
            "cos {c}: importance weight mean {}",
            imp.mean()
        );
        let want = r + (1.0 - r) * ratio;
        assert!(
            (rad.mean() - want).abs() <= 3.0 * rad.std_err() + 1e-6,
            "cos {c}: radiance weight mean {} want {want}",
            rad.mean()
        );
    }
}

// ---------------------------------------------------------------------------------
// 4. Lights
// ---------------------------------------------------------------------------------

fn a3(x: f32, y: f32, z: f32) -> Vec3A {
    Vec3A::new(x, y, z)
}

/// Quad [-a, a] x [-b, b] at height h, normal -z (facing the origin) unless `up`.
fn quad(a: f32, b: f32, h: f32, up: bool) -> Vec<Prim> {
    let (p00, p10, p11, p01) = (a3(-a, -b, h), a3(a, -b, h), a3(a, b, h), a3(-a, b, h));
    // Counter-clockwise seen from below gives normal -z.
    let tri = |p: Vec3A, q: Vec3A, r: Vec3A| Prim::Tri {
        p0: p,
        e1: q - p,
        e2: r - p,
    };
    if up {
        vec![tri(p00, p10, p11), tri(p00, p11, p01)]
    } else {
        vec![tri(p00, p11, p10), tri(p00, p01, p11)]
    }
}

/// The same rectangle as `quad(a, b, h, false)` (normal -z), as one parallelogram.
fn quad_merged(a: f32, b: f32, h: f32) -> Vec<Prim> {
    vec![Prim::Quad {
        p0: a3(-a, -b, h),
        e1: a3(0.0, 2.0 * b, 0.0),
        e2: a3(2.0 * a, 0.0, 0.0),
    }]
}

struct AreaCase {
    name: &'static str,
    prims: Vec<Prim>,
    flip: bool,
    two_sided: bool,
    p: Vec3,
}

impl AreaCase {
    fn light(&self) -> Light {
        Light::Area(AreaLight::new(
            0,
            self.prims.clone(),
            self.flip,
            Rgb::new(2.0, 3.0, 4.0),
            self.two_sided,
        ))
    }

    /// Nearest point of the emitter along `d` from the reference point, with its
    /// (possibly flipped) front normal.
    fn hit(&self, d: Vec3) -> Option<(Vec3, Vec3)> {
        let o = Vec3A::from(self.p);
        let mut best: Option<(f32, Vec3)> = None;
        for prim in &self.prims {
            if let Some(h) = prim.intersect(o, Vec3A::from(d), f32::INFINITY) {
                if best.is_none_or(|b| h.t < b.0) {
                    let pl = self.p + d * h.t;
                    let n = match *prim {
                        Prim::Tri { e1, e2, .. } | Prim::Quad { e1, e2, .. } => {
                            Vec3::from(e1.cross(e2).normalize())
                        }
                        Prim::Sphere { c, .. } => (pl - Vec3::from(c)).normalize(),
                        Prim::Disk { u, v, .. } => Vec3::from(u.cross(v).normalize()),
                    };
                    best = Some((h.t, n));
                }
            }
        }
        let (t, n) = best?;
        let n = if self.flip { -n } else { n };
        Some((self.p + d * t, n))
    }

    /// Density of directions `sample_li` produces: `pdf_li` where the emitter is seen
    /// from its emitting side, zero elsewhere (no sample is returned there).
    fn pdf(&self, light: &Light, d: Vec3) -> f64 {
        match self.hit(d) {
            Some((pl, n)) if self.two_sided || n.dot(-d) > 0.0 => {
                light.pdf_li(self.p, d, pl, n) as f64
            }
            _ => 0.0,
        }
    }
}

fn sphere(c: Vec3, r: f32) -> Vec<Prim> {
    vec![Prim::Sphere { c: c.into(), r }]
}

fn disk(c: Vec3, radius: f32, facing_down: bool) -> Vec<Prim> {
    // u x v = +z, or -z when facing down.
    let (u, v) = if facing_down {
        (a3(0.0, radius, 0.0), a3(radius, 0.0, 0.0))
    } else {
        (a3(radius, 0.0, 0.0), a3(0.0, radius, 0.0))
    };
    vec![Prim::Disk { c: c.into(), u, v }]
}

fn area_cases() -> Vec<AreaCase> {
    vec![
        AreaCase {
            name: "quad, point below its centre",
            prims: quad(0.5, 0.75, 1.5, false),
            flip: false,
            two_sided: false,
            p: Vec3::ZERO,
        },
        AreaCase {
            name: "quad, point off to the side",
            prims: quad(0.5, 0.75, 1.5, false),
            flip: false,
            two_sided: false,
            p: Vec3::new(1.2, -0.4, 0.3),
        },
        AreaCase {
            name: "skewed parallelogram, point off to the side",
            prims: vec![Prim::Quad {
                p0: a3(-0.5, -0.4, 1.2),
                e1: a3(0.3, 0.9, 0.1),
                e2: a3(0.8, -0.2, 0.0),
            }],
            flip: false,
            two_sided: false,
            p: Vec3::new(0.9, -0.6, 0.1),
        },
        AreaCase {
            name: "two-sided quad seen from its back",
            prims: quad(0.5, 0.75, -1.5, false),
            flip: false,
            two_sided: true,
            p: Vec3::new(0.2, 0.1, 0.0),
        },
        AreaCase {
            name: "disk on axis",
            prims: disk(Vec3::new(0.0, 0.0, 1.0), 0.8, true),
            flip: false,
            two_sided: false,
            p: Vec3::ZERO,
        },
        AreaCase {
            name: "flipped disk off axis",
            prims: disk(Vec3::new(0.3, 0.2, 1.0), 0.8, false),
            flip: true,
            two_sided: false,
            p: Vec3::new(-0.7, 0.4, -0.2),
        },
        AreaCase {
            name: "sphere from outside, near",
            prims: sphere(Vec3::new(0.5, -0.3, 2.0), 1.0),
            flip: false,
            two_sided: false,
            p: Vec3::new(0.1, 0.2, 0.3),
        },
        AreaCase {
            name: "sphere from outside, far",
            prims: sphere(Vec3::new(3.0, 1.0, -4.0), 0.7),
            flip: false,
            two_sided: false,
            p: Vec3::ZERO,
        },
        AreaCase {
            name: "inward sphere from its centre",
            prims: sphere(Vec3::new(0.2, 0.1, -0.3), 1.5),
            flip: true,
            two_sided: false,
            p: Vec3::new(0.2, 0.1, -0.3),
        },
        AreaCase {
            name: "inward sphere from off-centre",
            prims: sphere(Vec3::new(0.2, 0.1, -0.3), 1.5),
            flip: true,
            two_sided: false,
            p: Vec3::new(1.0, -0.5, 0.4),
        },
    ]
}

/// A binning frame whose pole is perpendicular to the direction of the light, so the
/// light sits near the equator where (cos theta, phi) bins are well shaped.
fn frame_perpendicular_to(d: Vec3) -> Frame {
    // A generic helper, so that no straight edge of a light lies along a meridian of
    // the bins (where a row of quadrature nodes could sit on the discontinuity).
    let d = d.normalize();
    let helper = Vec3::new(0.31, 0.72, 0.55).normalize();
    let helper = if d.dot(helper).abs() < 0.9 {
        helper
    } else {
        Vec3::new(0.8, -0.1, 0.3)
    };
    Frame::from_normal(d.cross(helper).normalize())
}

fn light_centre(prims: &[Prim]) -> Vec3 {
    let mut c = Vec3::ZERO;
    for p in prims {
        c += match *p {
            Prim::Tri { p0, e1, e2 } => Vec3::from(p0 + (e1 + e2) / 3.0),
            Prim::Quad { p0, e1, e2 } => Vec3::from(p0 + (e1 + e2) / 2.0),
            Prim::Sphere { c, .. } | Prim::Disk { c, .. } => Vec3::from(c),
        };
    }
    c / prims.len() as f32
}

/// Chi-square test of an area light's `sample_li` from the case's reference point,
/// with per-sample checks: the returned pdf equals `pdf_li` at the returned point and
/// normal, `wi` and `dist` point at that point, and `li` is the radiance.
fn area_light_chi2(case: &AreaCase, rng: &mut Rng, n: u64) -> DirTest {
    let light = case.light();
    let axis = light_centre(&case.prims) - case.p;
    let frame = if axis.length() < 1e-3 {
        Frame::from_normal(Vec3::new(0.3, 0.5, 0.8).normalize())
    } else {
        frame_perpendicular_to(axis)
    };
    chi2_directions(
        Param::CosPhi(frame),
        32,
        64,
        n,
        || {
            let s = light.sample_li(case.p, rng.next_2d())?;
            assert!(!s.delta);
            let pdf = light.pdf_li(case.p, s.wi(), s.p(), s.n());
            assert!(
                rel_close(s.pdf as f64, pdf as f64, 1e-3),
                "{}: sample pdf {} vs pdf_li {pdf}",
                case.name,
                s.pdf
            );
            let to = s.p() - case.p;
            assert!(
                (to.length() - s.dist).abs() <= 1e-4 * s.dist
                    && (to / s.dist - s.wi()).length() < 1e-4,
                "{}: wi/dist do not point at p",
                case.name
            );
            assert_eq!(s.li(), Rgb::new(2.0, 3.0, 4.0));
            Some(s.wi())
        },
        |d| case.pdf(&light, d),
        DEFAULT_ADAPTIVE,
    )
}

/// Chi-square of the directions `sample_li` produces against `pdf_li` (called with
/// the intersection of each direction with the emitter) for quads, disks and spheres
/// seen from outside (solid-angle sampling) and inside (area sampling).
#[test]
fn area_light_sampling_matches_pdf_li_chi2() {
    for (k, case) in area_cases().into_iter().enumerate() {
        let mut rng = Rng::new(1100, k as u64, 0);
        let t = area_light_chi2(&case, &mut rng, 1_000_000);
        assert_chi2(case.name, &t.chi2);
        // Every configuration here sees only the emitting side: nothing should fail
        // and the density integrates to 1 over the directions that reach the light.
        assert!(
            (t.integral - 1.0).abs() < 1e-4,
            "{}: pdf_li integrates to {}",
            case.name,
            t.integral
        );
        t.assert_failure_rate(case.name, 1e-4);
    }
}

/// Distant spheres, whose cone is too narrow for whole-sphere bins: chi-square on a
/// cap 1.5 times the cone's solid angle, for the small-angle series branch of
/// `sample_sphere_cone` (sin^2 theta_max < sin^2 1.5 deg) and just above it.
#[test]
fn distant_sphere_light_sampling_chi2() {
    for (k, (centre, r)) in [
        (Vec3::new(60.0, -80.0, 0.0), 1.0f32),
        (Vec3::new(0.0, 12.0, -16.0), 0.5),
        (Vec3::new(-400.0, 300.0, 866.0), 1.0),
        (Vec3::new(6.0, 0.0, 8.0), 0.3),
    ]
    .into_iter()
    .enumerate()
    {
        let case = AreaCase {
            name: "distant sphere",
            prims: sphere(centre, r),
            flip: false,
            two_sided: false,
            p: Vec3::ZERO,
        };
        let light = case.light();
        let sin2 = (r as f64 / centre.as_dvec3().length()).powi(2);
        let one_minus_cos = sin2 / (1.0 + (1.0 - sin2).sqrt());
        let mut rng = Rng::new(1250, k as u64, 0);
        let t = chi2_directions(
            Param::Cap {
                frame: Frame::from_normal(centre.normalize()),
                one_minus_z0: 1.5 * one_minus_cos,
            },
            32,
            64,
            1_000_000,
            || {
                let s = light.sample_li(case.p, rng.next_2d())?;
                let pdf = light.pdf_li(case.p, s.wi(), s.p(), s.n());
                assert!(rel_close(s.pdf as f64, pdf as f64, 1e-4));
                Some(s.wi())
            },
            |d| case.pdf(&light, d),
            DEFAULT_ADAPTIVE,
        );
        let name = format!("sphere r {r} at {centre} (sin^2 {sin2:.1e})");
        assert_chi2(&name, &t.chi2);
        // Below 1.5 degrees the pdf uses 1 - cos = sin^2 / 2, which is low by a factor
        // 1 + sin^2 / 4 (pbrt-v4 makes the same approximation).
        let tol = 1e-4 + sin2 / 4.0;
        assert!(
            (t.integral - 1.0).abs() < tol,
            "{name}: pdf_li integrates to {}",
            t.integral
        );
        t.assert_failure_rate(&name, tol);
    }
}

/// Monte Carlo estimates of the solid angle (mean of 1/pdf, failed samples counting
/// zero) and of the irradiance at a normal facing the light (mean of li cos / pdf)
/// against closed forms, within 3 standard errors (plus 1e-4 relative for float
/// rounding where the estimator has no variance, as for the uniform cone).
#[test]
fn area_light_solid_angle_and_irradiance() {
    const N: usize = 400_000;
    let radiance = 2.0f64; // red channel of the case radiance
    let rect_omega =
        |a: f64, b: f64, d: f64| 4.0 * (a * b / ((a * a + d * d) * (b * b + d * d)).sqrt()).asin();
    // Irradiance from a parallel rectangle centred on the normal: four corner form
    // factors F = [X/sqrt(1+X^2) atan(Y/sqrt(1+X^2)) + (X <-> Y)] / (2 pi).
    let rect_e = |a: f64, b: f64, d: f64| {
        let (x, y) = (a / d, b / d);
        let f = (x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
            + y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan())
            / (2.0 * PI);
        radiance * PI * 4.0 * f
    };
    struct Expect {
        case: AreaCase,
        normal: Vec3,
        omega: f64,
        irradiance: Option<f64>,
    }
    let (d_s, r_s) = (2.5f64, 0.9f64);
    let sin2 = (r_s / d_s).powi(2);
    let (d_d, r_d) = (1.3f64, 0.7f64);
    let cases = vec![
        Expect {
            case: AreaCase {
                name: "quad on axis",
                prims: quad(0.5, 0.75, 1.5, false),
                flip: false,
                two_sided: false,
                p: Vec3::ZERO,
            },
            normal: Vec3::Z,
            omega: rect_omega(0.5, 0.75, 1.5),
            irradiance: Some(rect_e(0.5, 0.75, 1.5)),
        },
        Expect {
            case: AreaCase {
                name: "rectangle as one parallelogram, on axis",
                prims: quad_merged(0.5, 0.75, 1.5),
                flip: false,
                two_sided: false,
                p: Vec3::ZERO,
            },
            normal: Vec3::Z,
            omega: rect_omega(0.5, 0.75, 1.5),
            irradiance: Some(rect_e(0.5, 0.75, 1.5)),
        },
        Expect {
            case: AreaCase {
                name: "two-sided quad from its back",
                prims: quad(0.5, 0.75, -1.5, false),
                flip: false,
                two_sided: true,
                p: Vec3::ZERO,
            },
            normal: -Vec3::Z,
            omega: rect_omega(0.5, 0.75, 1.5),
            irradiance: Some(rect_e(0.5, 0.75, 1.5)),
        },
        Expect {
            case: AreaCase {
                name: "one-sided quad from its back",
                prims: quad(0.5, 0.75, -1.5, false),
                flip: false,
                two_sided: false,
                p: Vec3::ZERO,
            },
            normal: -Vec3::Z,
            omega: 0.0,
            irradiance: Some(0.0),
        },
        Expect {
            case: AreaCase {
                name: "disk on axis",
                prims: disk(Vec3::new(0.0, 0.0, d_d as f32), r_d as f32, true),
                flip: false,
                two_sided: false,
                p: Vec3::ZERO,
            },
            normal: Vec3::Z,
            omega: 2.0 * PI * (1.0 - d_d / (d_d * d_d + r_d * r_d).sqrt()),
            irradiance: Some(radiance * PI * r_d * r_d / (d_d * d_d + r_d * r_d)),
        },
        Expect {
            case: AreaCase {
                name: "sphere from outside",
                prims: sphere(Vec3::new(0.0, d_s as f32, 0.0), r_s as f32),
                flip: false,
                two_sided: false,
                p: Vec3::ZERO,
            },
            normal: Vec3::Y,
            omega: 2.0 * PI * (1.0 - (1.0 - sin2).sqrt()),
            irradiance: Some(radiance * PI * sin2),
        },
        Expect {
            // sin^2(theta_max) < sin^2(1.5 deg): the small-angle branch.
            case: AreaCase {
                name: "distant small sphere",
                prims: sphere(Vec3::new(0.0, 0.0, 100.0), 1.0),
                flip: false,
                two_sided: false,
                p: Vec3::ZERO,
            },
            normal: Vec3::Z,
            omega: 2.0 * PI * (1.0 - (1.0 - 1e-4f64).sqrt()),
            irradiance: Some(radiance * PI * 1e-4),
        },
        Expect {
            case: AreaCase {
                name: "inward sphere from off-centre",
                prims: sphere(Vec3::ZERO, 1.5),
                flip: true,
                two_sided: false,
                p: Vec3::new(0.4, -0.6, 0.3),
            },
            normal: Vec3::new(0.0, 0.6, 0.8),
            omega: 4.0 * PI,
            irradiance: Some(radiance * PI),
        },
    ];
    for (k, e) in cases.into_iter().enumerate() {
        let light = e.case.light();
        let mut rng = Rng::new(1200, k as u64, 0);
        let (mut omega, mut irr) = (Stats::new(), Stats::new());
        for _ in 0..N {
            match light.sample_li(e.case.p, rng.next_2d()) {
                Some(s) if s.li().x > 0.0 => {
                    omega.push(1.0 / s.pdf as f64);
                    let cos = s.wi().dot(e.normal).max(0.0) as f64;
                    irr.push(s.li().x as f64 * cos / s.pdf as f64);
                }
                _ => {
                    omega.push(0.0);
                    irr.push(0.0);
                }
            }
        }
        let name = e.case.name;
        let tol = 3.0 * omega.std_err() + 1e-4 * e.omega;
        assert!(
            (omega.mean() - e.omega).abs() <= tol,
            "{name}: solid angle {} vs {} (tol {tol})",
            omega.mean(),
            e.omega
        );
        if let Some(ei) = e.irradiance {
            let tol = 3.0 * irr.std_err() + 1e-4 * ei;
            assert!(
                (irr.mean() - ei).abs() <= tol,
                "{name}: irradiance {} vs {ei} (tol {tol})",
                irr.mean()
            );
        }
    }
}

/// A 16 x 8 map with smooth variation, a bright texel and a rotation.
fn synthetic_envmap(black_lower_half: bool) -> (EnvMap, Mat3, Vec<Rgb>) {
    let (w, h) = (16usize, 8usize);
    let mut texels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let u = (x as f32 + 0.5) / w as f32;
            let v = (y as f32 + 0.5) / h as f32;
            let base = 0.3 + 0.2 * (2.0 * std::f32::consts::PI * u).sin() * (3.0 * v).cos();
            let mut c = Rgb::new(base, 0.8 * base + 0.05 * v, 1.2 * base * (1.0 - 0.5 * v));
            if (x, y) == (5, 2) {
                c = Rgb::new(40.0, 35.0, 30.0);
            }
            if black_lower_half && y >= h / 2 {
                c = Rgb::ZERO;
            }
            texels.push(c);
        }
    }
    let rot = Mat3::from_rotation_y(0.7) * Mat3::from_rotation_x(0.3);
    (EnvMap::new(w, h, texels.clone(), rot), rot, texels)
}

/// Chi-square of `sample_li` against `pdf_li` on a 64 x 32 lat-long grid aligned with
/// the texels (4 x 4 bins per texel, where pdf_li times the Jacobian is constant), and
/// per sample: eval(wi) == li and the returned pdf is `pdf_li(wi)`.
#[test]
fn envmap_sampling_matches_pdf_li_chi2() {
    let (env, rot, _) = synthetic_envmap(false);
    let light = Light::EnvMap(env.clone());
    let mut rng = Rng::new(1300, 0, 0);
    let mut mismatched = 0;
    let t = chi2_directions(
        Param::LatLong(rot),
        64,
        32,
        1_000_000,
        || {
            let s = light.sample_li(Vec3::ZERO, rng.next_2d())?;
            assert!(!s.delta && s.dist.is_infinite());
            let pdf = light.pdf_li(Vec3::ZERO, s.wi(), s.p(), s.n());
            if env.eval(s.wi()) != s.li() || !rel_close(s.pdf as f64, pdf as f64, 1e-3) {
                mismatched += 1;
            }
            Some(s.wi())
        },
        |d| light.pdf_li(Vec3::ZERO, d, Vec3::ZERO, Vec3::ZERO) as f64,
        Quadrature::Midpoint(4),
    );
    // Param is LatLong, whose coords swap (u, v) into (s, t) = (u, v): 64 columns of
    // u are the s axis, 32 rows of v the t axis.
    assert_chi2("envmap", &t.chi2);
    assert!(
        (t.integral - 1.0).abs() < 1e-4,
        "pdf_li integrates to {}",
        t.integral
    );
    assert_eq!(t.failures, 0);
    // A sample exactly on a texel edge may round into the neighbour; allow 1 in 1e5.
    assert!(
        mismatched <= 10,
        "{mismatched} samples with eval(wi) != li or pdf != pdf_li"
    );
    // Light::le_escaped agrees with eval, and the bright texel is where the rotation
    // puts it.
    let bright = rot * LatLong::to_dir(Vec2::new(5.5 / 16.0, 2.5 / 8.0));
    assert_eq!(light.le_escaped(bright), Rgb::new(40.0, 35.0, 30.0));
}

/// A sky over a black ground: rows of zero luminance must never be sampled (samples
/// there carry li = 0 and are wasted; the density should follow luminance).
/// Regression test: `Distribution1D::integral()` used to return 1 for all-zero
/// weights, so `Distribution2D` gave every black row marginal weight 1 (61% of the
/// samples of this map went to black texels).
#[test]
fn envmap_never_samples_black_texels() {
    let (env, _, texels) = synthetic_envmap(true);
    let light = Light::EnvMap(env);
    let mut rng = Rng::new(1400, 0, 0);
    let n = 100_000;
    let mut black = 0;
    for _ in 0..n {
        if let Some(s) = light.sample_li(Vec3::ZERO, rng.next_2d()) {
            if s.li() == Rgb::ZERO {
                black += 1;
            }
        }
    }
    assert!(texels.contains(&Rgb::ZERO));
    assert_eq!(black, 0, "{black} of {n} samples went to black texels");
}

#[test]
fn spot_light_falloff_values() {
    let (beam, cutoff) = (20f32.to_radians(), 30f32.to_radians());
    let axis = Vec3::new(0.2, -0.9, 0.4).normalize();
    let spot = SpotLight::new(Vec3::new(1.0, 2.0, 3.0), axis, Rgb::ONE, cutoff, beam);
    // Directions at a given angle from the axis, around several azimuths.
    let f = Frame::from_normal(axis);
    let at = |deg: f32, phi: f32| f.to_world(dir_deg(deg, phi));
    for phi in [0.0f32, 1.0, 2.5, 4.0] {
        for (deg, want) in [
            (0.0, 1.0),
            (10.0, 1.0),
            (19.9, 1.0),
            (22.5, 0.75),
            (25.0, 0.5),
            (27.5, 0.25),
            (30.1, 0.0),
            (60.0, 0.0),
            (90.0, 0.0),
            (150.0, 0.0),
            (180.0, 0.0),
        ] {
            let got = spot.falloff(at(deg, phi));
            assert!(
                (got - want).abs() < 1e-4,
                "falloff at {deg} deg = {got}, want {want}"
            );
        }
    }
    // sample_li: li = I falloff(-wi) / d^2, zero samples outside the cutoff.
    let light = Light::Spot(SpotLight::new(
        Vec3::ZERO,
        Vec3::Z,
        Rgb::new(3.0, 2.0, 1.0),
        cutoff,
        beam,
    ));
    for (deg, want) in [(0.0f32, 1.0f32), (25.0, 0.5), (27.5, 0.25)] {
        let d = 2.5f32;
        let p = dir_deg(deg, 0.7) * d;
        let s = light.sample_li(p, Vec2::ZERO).unwrap();
        assert!(s.delta && s.pdf == 1.0);
        assert!(
            (s.li() - Rgb::new(3.0, 2.0, 1.0) * (want / (d * d))).length()
                < 1e-4 * s.li().length().max(1e-3)
        );
    }
    assert!(light
        .sample_li(dir_deg(31.0, 0.7) * 2.0, Vec2::ZERO)
        .is_none());
    // A beam wider than the cutoff is clamped: a hard edge.
    let hard = SpotLight::new(Vec3::ZERO, Vec3::Z, Rgb::ONE, cutoff, 40f32.to_radians());
    assert_eq!(hard.falloff(dir_deg(29.9, 0.0)), 1.0);
    assert_eq!(hard.falloff(dir_deg(30.1, 0.0)), 0.0);
}

/// power() = I times the integral of the falloff over the sphere, evaluated by a
/// midpoint rule in (theta, phi) on `falloff` itself (1e6 intervals in theta; the
/// integrand has only two kinks, so the rule is accurate to ~1e-9).
#[test]
fn spot_light_power_matches_numerical_integral() {
    let intensity = Rgb::new(1.0, 2.0, 3.0);
    for (cutoff_deg, beam_deg) in [
        (30.0f64, 20.0f64),
        (60.0, 0.0),
        (90.0, 45.0),
        (120.0, 100.0),
        (25.0, 25.0),
        (10.0, 9.9),
        (179.0, 5.0),
    ] {
        let axis = Vec3::new(-0.3, 0.4, 0.5).normalize();
        let spot = SpotLight::new(
            Vec3::ZERO,
            axis,
            intensity,
            cutoff_deg.to_radians() as f32,
            beam_deg.to_radians() as f32,
        );
        let f = Frame::from_normal(axis);
        let (nt, nphi) = (1_000_000usize, 4usize);
        let mut integral = 0.0f64;
        for i in 0..nt {
            let theta = (i as f64 + 0.5) / nt as f64 * PI;
            let (st, ct) = theta.sin_cos();
            let mut ring = 0.0;
            for j in 0..nphi {
                let phi = (j as f64 + 0.37) / nphi as f64 * 2.0 * PI;
                let w = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, ct as f32);
                ring += spot.falloff(f.to_world(w)) as f64;
            }
            integral += ring / nphi as f64 * st;
        }
        integral *= 2.0 * PI * PI / nt as f64;
        let power = spot.power();
        for c in 0..3 {
            let want = intensity[c] as f64 * integral;
            assert!(
                rel_close(power[c] as f64, want, 1e-3),
                "cutoff {cutoff_deg} beam {beam_deg}: power {} vs integral {want}",
                power[c]
            );
        }
    }
}

#[test]
fn point_light_inverse_square() {
    let intensity = Rgb::new(5.0, 7.0, 11.0);
    let pos = Vec3::new(0.3, -1.2, 2.0);
    let light = Light::Point(PointLight {
        position: pos,
        intensity,
    });
    let mut rng = Rng::new(1500, 0, 0);
    for _ in 0..10_000 {
        let p = pos + uniform_sphere(&mut rng) * (0.01 + 10.0 * rng.next_f32());
        let s = light.sample_li(p, rng.next_2d()).unwrap();
        let d = (pos - p).as_dvec3();
        let d2 = d.length_squared();
        assert!(s.delta && s.pdf == 1.0);
        assert_eq!(s.p(), pos);
        assert!(rel_close(s.dist as f64, d2.sqrt(), 1e-6));
        assert!((s.wi().as_dvec3() - d / d2.sqrt()).length() < 1e-6);
        for c in 0..3 {
            assert!(
                rel_close(s.li()[c] as f64, intensity[c] as f64 / d2, 1e-6),
                "li {} vs I/d^2 {}",
                s.li()[c],
                intensity[c] as f64 / d2
            );
        }
        assert_eq!(light.pdf_li(p, s.wi(), s.p(), s.n()), 0.0);
    }
}

// ---------------------------------------------------------------------------------
// 5. Piecewise-constant distributions
// ---------------------------------------------------------------------------------

/// Discrete sampling follows weight / sum (chi-square), pmf() reports it, the
/// returned probability is pmf(i) and the remapped u is uniform within the bin.
#[test]
fn distribution1d_discrete_chi2() {
    let weights: Vec<f32> = (0..40)
        .map(|i| match i {
            3 | 4 | 17 | 39 => 0.0,
            7 => 25.0,
            _ => 0.2 + ((i * 7) % 11) as f32 * 0.3,
        })
        .collect();
    let sum: f64 = weights.iter().map(|&w| w as f64).sum();
    let d = Distribution1D::new(&weights);
    for (i, &w) in weights.iter().enumerate() {
        assert!((d.pmf(i) as f64 - w as f64 / sum).abs() < 1e-6, "pmf({i})");
    }
    let n = 1_000_000;
    let mut rng = Rng::new(1600, 0, 0);
    // Counts per bin, and per bin the remapped u in 4 quarters.
    let mut obs = vec![0.0; weights.len() * 4];
    for _ in 0..n {
        let (i, p, ur) = d.sample_discrete(rng.next_f32());
        assert_eq!(p, d.pmf(i));
        assert!((0.0..1.0).contains(&ur));
        obs[i * 4 + ((ur * 4.0) as usize).min(3)] += 1.0;
    }
    let exp: Vec<f64> = (0..weights.len() * 4)
        .map(|k| n as f64 * weights[k / 4] as f64 / sum / 4.0)
        .collect();
    assert_chi2("Distribution1D::sample_discrete", &pooled_chi2(&obs, &exp));
}

/// Continuous sampling: chi-square of x on a grid 3 times finer than the bins, and
/// the returned density is weight / mean(weight) = pdf_continuous(x).
#[test]
fn distribution1d_continuous_chi2() {
    let weights: Vec<f32> = (0..25)
        .map(|i| {
            if i % 6 == 2 {
                0.0
            } else {
                1.0 + (i as f32 * 0.7).sin()
            }
        })
        .collect();
    let mean: f64 = weights.iter().map(|&w| w as f64).sum::<f64>() / weights.len() as f64;
    let d = Distribution1D::new(&weights);
    assert!((d.integral() as f64 - mean).abs() < 1e-6);
    let n = 1_000_000;
    let k = 3;
    let nb = weights.len() * k;
    let mut obs = vec![0.0; nb];
    let mut rng = Rng::new(1700, 0, 0);
    for _ in 0..n {
        let (x, pdf, i) = d.sample_continuous(rng.next_f32());
        assert!((0.0..1.0).contains(&x));
        assert_eq!(
            i,
            ((x * weights.len() as f32) as usize).min(weights.len() - 1)
        );
        assert!(rel_close(pdf as f64, weights[i] as f64 / mean, 1e-5));
        assert_eq!(pdf, d.pdf_continuous(x));
        obs[((x as f64 * nb as f64) as usize).min(nb - 1)] += 1.0;
    }
    let total: f64 = weights.iter().map(|&w| w as f64).sum();
    let exp: Vec<f64> = (0..nb)
        .map(|b| n as f64 * weights[b / k] as f64 / total / k as f64)
        .collect();
    assert_chi2(
        "Distribution1D::sample_continuous",
        &pooled_chi2(&obs, &exp),
    );
}

/// 2D sampling: chi-square on a grid twice as fine as the cells against
/// weight / sum, and pdf() = weight / mean(weight) = the returned density.
#[test]
fn distribution2d_chi2() {
    let (w, h) = (7usize, 5usize);
    let weights: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if (x + y) % 5 == 3 {
                0.0
            } else {
                0.5 + ((x * 3 + y * 5) % 7) as f32
            }
        })
        .collect();
    let total: f64 = weights.iter().map(|&v| v as f64).sum();
    let mean = total / (w * h) as f64;
    let d = Distribution2D::new(&weights, w, h);
    for y in 0..h {
        for x in 0..w {
            let p = Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
            let want = weights[y * w + x] as f64 / mean;
            assert!(rel_close(d.pdf(p) as f64, want, 1e-5), "pdf({x}, {y})");
        }
    }
    let (sx, sy) = (2 * w, 2 * h);
    let n = 1_000_000;
    let mut obs = vec![0.0; sx * sy];
    let mut rng = Rng::new(1800, 0, 0);
    for _ in 0..n {
        let (p, pdf) = d.sample(rng.next_2d());
        assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
        assert!(pdf > 0.0 && rel_close(pdf as f64, d.pdf(p) as f64, 1e-5));
        let i = ((p.x * sx as f32) as usize).min(sx - 1);
        let j = ((p.y * sy as f32) as usize).min(sy - 1);
        obs[j * sx + i] += 1.0;
    }
    let exp: Vec<f64> = (0..sx * sy)
        .map(|k| {
            let (i, j) = (k % sx, k / sx);
            n as f64 * weights[(j / 2) * w + i / 2] as f64 / total / 4.0
        })
        .collect();
    assert_chi2("Distribution2D::sample", &pooled_chi2(&obs, &exp));
}

/// A row of zero weights must get zero marginal probability, and the integral of
/// all-zero weights is their mean, 0 (regression test, see above).
#[test]
fn distribution2d_zero_row_is_never_sampled() {
    let weights = [0.0f32, 0.0, 0.0, 0.1, 0.2, 0.3];
    let d = Distribution1D::new(&weights[..3]);
    assert_eq!(d.integral(), 0.0, "mean of all-zero weights");
    let d2 = Distribution2D::new(&weights, 3, 2);
    assert_eq!(d2.pdf(Vec2::new(0.5, 0.25)), 0.0, "pdf in the zero row");
    let mut rng = Rng::new(1900, 0, 0);
    for _ in 0..10_000 {
        let (p, _) = d2.sample(rng.next_2d());
        assert!(p.y >= 0.5, "sampled the zero row at {p}");
    }
}

// ---------------------------------------------------------------------------------
// 5. Emission sampling (light paths)
// ---------------------------------------------------------------------------------

/// Mean and standard error, per channel, of `sample_le(..).weight()` (a missing sample
/// counts as zero), checking on the way that `pdf_le` gives the densities each sample
/// reports (only for lights a ray can hit: delta lights have no density to agree on).
fn emission_weight_stats(
    light: &Light,
    sphere: &SceneSphere,
    seed: u64,
    n: usize,
) -> [(f64, f64); 3] {
    let mut rng = Rng::new(seed, 0, 0);
    let mut sum = [0.0f64; 3];
    let mut sum2 = [0.0f64; 3];
    let mut mismatched = 0;
    for _ in 0..n {
        let (u_pos, u_dir) = (rng.next_2d(), rng.next_2d());
        let Some(s) = light.sample_le(sphere, u_pos, u_dir) else {
            continue;
        };
        assert!(
            (s.d.length() - 1.0).abs() < 1e-4 && s.pdf_pos > 0.0 && s.pdf_dir > 0.0,
            "{s:?}"
        );
        if !light.is_delta() {
            let (pp, pd) = light.pdf_le(sphere, s.n, s.d);
            if !rel_close(pp as f64, s.pdf_pos as f64, 1e-3)
                || !rel_close(pd as f64, s.pdf_dir as f64, 1e-3)
            {
                mismatched += 1;
            }
        }
        let w = s.weight();
        for c in 0..3 {
            sum[c] += w[c] as f64;
            sum2[c] += (w[c] as f64).powi(2);
        }
    }
    // An environment sample exactly on a texel edge may round into the neighbour.
    assert!(
        mismatched <= n / 10_000,
        "{mismatched} samples disagree with pdf_le"
    );
    let nf = n as f64;
    std::array::from_fn(|c| {
        let m = sum[c] / nf;
        let var = (sum2[c] / nf - m * m).max(0.0);
        (m, (var / (nf - 1.0)).sqrt())
    })
}

/// The photon power a light emits on average, E[Le cos / (p_pos p_dir)], is the
/// light's power: every light type, within 4 standard errors (plus float slack for
/// estimators with no variance, such as a point light's).
#[test]
fn emission_weight_mean_is_light_power() {
    let bounds = SceneSphere {
        center: Vec3::new(0.3, -0.2, 0.5),
        radius: 2.5,
    };
    let area = |prims: Vec<Prim>, flip: bool, two_sided: bool| {
        Light::Area(AreaLight::new(
            0,
            prims,
            flip,
            Rgb::new(2.0, 3.0, 4.0),
            two_sided,
        ))
    };
    let (env, _, _) = synthetic_envmap(false);
    let cases: Vec<(&str, Light)> = vec![
        ("quad", area(quad(0.5, 0.75, 1.5, false), false, false)),
        (
            "two-sided quad",
            area(quad(0.5, 0.75, -1.5, false), false, true),
        ),
        (
            "disk",
            area(disk(Vec3::new(0.3, 0.2, 1.0), 0.8, false), true, false),
        ),
        (
            "sphere",
            area(sphere(Vec3::new(0.5, -0.3, 2.0), 1.0), false, false),
        ),
        (
            "inward sphere",
            area(sphere(Vec3::new(0.2, 0.1, -0.3), 1.5), true, false),
        ),
        (
            "point",
            Light::Point(PointLight {
                position: Vec3::new(0.3, -1.2, 2.0),
                intensity: Rgb::new(5.0, 7.0, 11.0),
            }),
        ),
        (
            "spot",
            Light::Spot(SpotLight::new(
                Vec3::new(1.0, 2.0, 3.0),
                Vec3::new(0.2, -0.9, 0.4).normalize(),
                Rgb::new(1.0, 2.0, 3.0),
                40f32.to_radians(),
                15f32.to_radians(),
            )),
        ),
        (
            "directional",
            Light::Directional(caustic::light::DirectionalLight {
                direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
                irradiance: Rgb::new(10.0, 4.0, 0.5),
            }),
        ),
        (
            "constant environment",
            Light::Constant {
                radiance: Rgb::new(0.5, 0.7, 1.0),
            },
        ),
        ("environment map", Light::EnvMap(env)),
    ];
    for (k, (name, light)) in cases.iter().enumerate() {
        let stats = emission_weight_stats(light, &bounds, 1600 + k as u64, 400_000);
        let power = light.power(&bounds);
        for (c, (m, se)) in stats.iter().enumerate() {
            let want = power[c] as f64;
            let tol = 4.0 * se + 1e-4 * want.abs();
            assert!(
                (m - want).abs() <= tol,
                "{name}, channel {c}: mean weight {m} +- {se} vs power {want}"
            );
        }
    }
}

// ---------------------------------------------------------------------------------
// Phase functions
// ---------------------------------------------------------------------------------

/// Every phase function's sampled directions follow its density (which is its value),
/// binned in a frame around the propagation direction; g = +-0.99 are the spikes.
#[test]
fn phase_sampling_matches_pdf_chi2() {
    use caustic::medium::Phase;
    let phases = [
        Phase::Isotropic,
        Phase::HenyeyGreenstein { g: 0.3 },
        Phase::HenyeyGreenstein { g: -0.7 },
        Phase::HenyeyGreenstein { g: 0.99 },
        Phase::HenyeyGreenstein { g: -0.99 },
        Phase::Schlick { k: 0.8 },
        Phase::Schlick { k: -0.4 },
        Phase::Rayleigh,
    ];
    let d = Vec3::new(0.36, -0.48, 0.8).normalize();
    for (k, p) in phases.iter().enumerate() {
        let mut rng = Rng::new(300, k as u64, 0);
        let name = format!("{p:?}");
        // The g = +-0.99 lobes hold most of their mass within 1 - mu < 0.01, finer
        // than whole-sphere bins can resolve: bin a cap around the spike instead
        // (draws outside it form the extra cell, expected from the cap's mass).
        let spike = match *p {
            Phase::HenyeyGreenstein { g } if g.abs() > 0.9 => Some(g.signum()),
            _ => None,
        };
        let param = match spike {
            Some(sign) => Param::Cap {
                frame: Frame::from_normal(d * sign),
                one_minus_z0: 0.05,
            },
            None => Param::CosPhi(Frame::from_normal(d)),
        };
        let t = chi2_directions(
            param,
            32,
            64,
            500_000,
            || {
                let (wi, pdf) = p.sample(d, rng.next_2d());
                assert!(pdf > 0.0 && pdf.is_finite(), "{name}: pdf {pdf}");
                // At the g = 0.99 spike an f32 direction fixes 1 - mu only to ~1e-3
                // relative, and the density depends on it steeply.
                assert!(
                    (pdf - p.eval(d, wi)).abs() <= 1e-2 * pdf,
                    "{name}: pdf != eval"
                );
                Some(wi)
            },
            |wi| p.eval(d, wi) as f64,
            DEFAULT_ADAPTIVE,
        );
        assert_chi2(&name, &t.chi2);
        if spike.is_none() {
            assert!(
                (t.integral - 1.0).abs() < 2e-3,
                "{name}: integral {}",
                t.integral
            );
            assert_eq!(t.failures, 0);
        }
    }
}
