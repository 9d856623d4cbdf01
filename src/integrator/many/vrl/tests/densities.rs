//! Every one-dimensional density integrates to one over its segment, and its sampler
//! inverts its CDF: cdf(sample(xi)) = xi, and cdf(t) = the quadrature of pdf on [0, t].

use super::super::advanced::Advanced;
use super::super::distance::{Distance, EquiAngular, Exponential, Uniform};
use super::super::marginal::Marginal;
use super::super::pair::v64;
use super::super::samplers::equiangular_about;
use super::quadrature::integrate;
use super::{cameras, pair, pair_with, phases, GS};

pub struct Case {
    pub name: String,
    pub dist: Box<dyn Distance>,
    pub len: f64,
    /// Where the density peaks or kinks.
    pub splits: Vec<f64>,
}

fn case(name: String, dist: impl Distance + 'static, len: f64, splits: Vec<f64>) -> Case {
    Case {
        name,
        dist: Box::new(dist),
        len,
        splits,
    }
}

/// The advanced density about y(u) of a named pair.
pub fn advanced(pair_name: &str, u: f64, g: f32, nodes: usize) -> (Advanced, f64) {
    let p = pair(pair_name);
    let (ea, n) = equiangular_about(&p, u);
    let a = Advanced::new(ea, v64(p.light.d), v64(p.cam.d), n, &phases(g), nodes);
    (a, p.cam.tmax as f64)
}

/// Every 1D density the samplers are built of, in the configurations they must take.
pub fn cases() -> Vec<Case> {
    let mut v = vec![case("uniform".into(), Uniform { len: 2.0 }, 2.0, vec![])];
    for sigma in [1e-9, 0.5, 30.0, 1e4] {
        let d = Exponential { sigma, len: 2.0 };
        v.push(case(format!("exponential sigma={sigma}"), d, 2.0, vec![]));
    }
    for (delta, h) in [(0.7, 0.05), (-0.5, 0.3), (1.0, 1e-5), (2.5, 0.1)] {
        let d = EquiAngular::new(delta, h, 2.0);
        v.push(case(
            format!("equiangular {delta} {h}"),
            d,
            2.0,
            vec![delta],
        ));
    }
    for (name, c) in cameras() {
        let p = pair_with(c);
        let m = Marginal::new(&p);
        v.push(case(format!("marginal {name}"), m, 2.0, vec![p.u0]));
    }
    for g in GS {
        for (pair_name, u) in [
            ("general", 1.0),
            ("close", 0.9),
            ("nearly_intersecting", 1.0),
        ] {
            let (a, len) = advanced(pair_name, u, g, 10);
            let k = a.kinks();
            v.push(case(format!("advanced g={g} {pair_name}"), a, len, k));
        }
    }
    let (a, len) = advanced("general", 0.3, 0.5, 2);
    let k = a.kinks();
    v.push(case("advanced 2 nodes".into(), a, len, k));
    v
}

#[test]
fn every_density_integrates_to_one() {
    for c in cases() {
        let i = integrate(|t| c.dist.pdf(t), 0.0, c.len, &c.splits, 1e-10);
        eprintln!("{}: integral {i:.9}", c.name);
        assert!((i - 1.0).abs() < 1e-6, "{}: integral {i}", c.name);
        assert_eq!(c.dist.pdf(-1e-3), 0.0, "{}", c.name);
        assert_eq!(c.dist.pdf(c.len + 1e-3), 0.0, "{}", c.name);
    }
}

#[test]
fn samples_invert_the_cdf_and_the_cdf_integrates_the_pdf() {
    for c in cases() {
        for k in 0..=40 {
            let xi = (k as f64 / 40.0).min(1.0 - 1e-9);
            let (t, pdf) = c.dist.sample(xi);
            assert!((0.0..=c.len).contains(&t), "{}: t = {t}", c.name);
            assert!(pdf > 0.0 && pdf.is_finite(), "{}: pdf {pdf}", c.name);
            assert_eq!(pdf, c.dist.pdf(t), "{}: sample and pdf disagree", c.name);
            let f = c.dist.cdf(t);
            assert!((f - xi).abs() < 1e-9, "{} xi={xi}: cdf(t) = {f}", c.name);
            let q = integrate(|s| c.dist.pdf(s), 0.0, t, &c.splits, 1e-10);
            assert!(
                (q - f).abs() < 1e-6,
                "{} t={t}: quadrature {q} vs cdf {f}",
                c.name
            );
        }
        assert_eq!(c.dist.cdf(0.0), 0.0, "{}", c.name);
        assert!((c.dist.cdf(c.len) - 1.0).abs() < 1e-12, "{}", c.name);
    }
}
