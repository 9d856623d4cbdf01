//! The light tree's pmf, sampling, unbiasedness and determinism.

use super::*;
use crate::math::Rng;
use std::time::Instant;

fn uniform3(rng: &mut Rng) -> Vec3 {
    Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())
}

fn direction(rng: &mut Rng) -> Vec3 {
    loop {
        let v = uniform3(rng) * 2.0 - 1.0;
        let l = v.length_squared();
        if l > 1e-4 && l <= 1.0 {
            return v / l.sqrt();
        }
    }
}

/// `n` lights in `clusters` clusters of radius `spread` in a cube of side `extent`:
/// a tenth without power, points, short and long segments, powers over 3 decades.
fn lights(rng: &mut Rng, n: usize, clusters: usize, extent: f32, spread: f32) -> Vec<Emitter> {
    let centers: Vec<Vec3> = (0..clusters).map(|_| uniform3(rng) * extent).collect();
    (0..n)
        .map(|_| {
            let c = centers[(rng.next_u32() as usize) % clusters];
            let a = c + (uniform3(rng) * 2.0 - 1.0) * spread;
            let power = 10f32.powf(3.0 * rng.next_f32() - 1.5);
            let kind = rng.next_f32();
            let (b, power) = if kind < 0.1 {
                (a, 0.0)
            } else if kind < 0.55 {
                (a, power)
            } else if kind < 0.85 {
                (a + direction(rng) * spread * 0.5 * rng.next_f32(), power)
            } else {
                (a + direction(rng) * extent * 0.5 * rng.next_f32(), power)
            };
            Emitter { a, b, power }
        })
        .collect()
}

/// Points (half of them on a light), finite segments, unbounded ones (some along x,
/// so that d has zero components), and a few far outside the scene.
fn query(rng: &mut Rng, items: &[Emitter], extent: f32) -> Query {
    let kind = rng.next_f32();
    let o = if rng.next_f32() < 0.5 {
        items[(rng.next_u32() as usize) % items.len()].a
    } else {
        uniform3(rng) * extent
    };
    let o = if rng.next_f32() < 0.05 {
        o + Vec3::splat(100.0 * extent)
    } else {
        o
    };
    let d = if rng.next_f32() < 0.2 {
        Vec3::X
    } else {
        direction(rng)
    };
    let tmax = if kind < 0.4 {
        0.0
    } else if kind < 0.7 {
        extent * rng.next_f32()
    } else {
        f32::INFINITY
    };
    Query { o, d, tmax }
}

/// Distance from the point x to the segment a b, in f64.
fn point_segment(x: [f64; 3], a: Vec3, b: Vec3) -> f64 {
    let (a, b) = (a.as_dvec3(), b.as_dvec3());
    let x = glam::DVec3::from(x);
    let ab = b - a;
    let l2 = ab.length_squared();
    let s = if l2 > 0.0 {
        ((x - a).dot(ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (x - a - ab * s).length()
}

/// The shortest distance between the query and the light (golden section along the
/// query: the distance to a segment is convex along a line).
fn distance(q: &Query, e: &Emitter) -> f64 {
    let at = |t: f64| {
        let p = q.o.as_dvec3() + q.d.as_dvec3() * t;
        point_segment(p.into(), e.a, e.b)
    };
    if q.tmax <= 0.0 {
        return at(0.0);
    }
    let (mut lo, mut hi) = (0.0, (q.tmax as f64).min(1e7));
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..80 {
        let (m1, m2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if at(m1) < at(m2) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    at(0.5 * (lo + hi)).min(at(0.0))
}

/// The test function of the brief: power / (1 + distance^2).
fn f_simple(q: &Query, e: &Emitter) -> f64 {
    let d = distance(q, e);
    e.power as f64 / (1.0 + d * d)
}

/// Transport-like: power spread along the light, 1 / (eps^2 + r^2) integrated along
/// the query segment (closed form), averaged over 16 points of the light.
fn f_transport(q: &Query, e: &Emitter, eps: f64) -> f64 {
    let m = if e.a == e.b { 1 } else { 16 };
    let mut sum = 0.0;
    for j in 0..m {
        let s = (j as f64 + 0.5) / m as f64;
        let y = e.a.as_dvec3() * (1.0 - s) + e.b.as_dvec3() * s;
        let v = y - q.o.as_dvec3();
        if q.tmax <= 0.0 {
            sum += 1.0 / (eps * eps + v.length_squared());
            continue;
        }
        let t0 = v.dot(q.d.as_dvec3());
        let k = (eps * eps + (v.length_squared() - t0 * t0).max(0.0)).sqrt();
        let far = if q.tmax.is_finite() {
            ((q.tmax as f64 - t0) / k).atan()
        } else {
            std::f64::consts::FRAC_PI_2
        };
        sum += (far + (t0 / k).atan()) / k;
    }
    e.power as f64 * sum / m as f64
}

/// Every light's probability, in f64.
fn pmfs(tree: &LightTree, q: &Query, n: usize) -> Vec<f64> {
    (0..n).map(|i| tree.pmf(q, i) as f64).collect()
}

/// Pearson's chi-square of `counts` against `probs` (cells expecting fewer than 5
/// pooled) and the 1e-6 quantile of its distribution (Wilson-Hilferty).
fn chi2(counts: &[u64], probs: &[f64]) -> (f64, f64) {
    let m: u64 = counts.iter().sum();
    let (mut stat, mut cells) = (0.0, 0usize);
    let (mut pooled_n, mut pooled_e) = (0.0, 0.0);
    for (&c, &p) in counts.iter().zip(probs) {
        let e = p * m as f64;
        if e >= 5.0 {
            stat += (c as f64 - e).powi(2) / e;
            cells += 1;
        } else {
            pooled_n += c as f64;
            pooled_e += e;
        }
    }
    if pooled_e > 0.0 {
        stat += (pooled_n - pooled_e).powi(2) / pooled_e;
        cells += 1;
    }
    let k = (cells - 1) as f64;
    let z = 4.75;
    let w = 2.0 / (9.0 * k);
    (stat, k * (1.0 - w + z * w.sqrt()).powi(3))
}

#[test]
fn pmfs_sum_to_one_and_agree_with_samples() {
    let mut rng = Rng::new(7, 0, 0);
    for set in 0..6 {
        let n = 200 + 100 * set;
        let items = lights(&mut rng, n, 1 + set * 3, 10.0, 0.5 + set as f32 * 0.3);
        let mut tree = LightTree::default();
        tree.build(&items);
        let live = items.iter().filter(|e| e.power > 0.0).count();
        assert_eq!(tree.len(), live);
        for k in 0..60 {
            let q = query(&mut rng, &items, 10.0);
            let p = pmfs(&tree, &q, n);
            let sum: f64 = p.iter().sum();
            assert!((sum - 1.0).abs() < 1e-4, "set {set} query {k}: sum {sum}");
            for (i, e) in items.iter().enumerate() {
                if e.power > 0.0 {
                    assert!(p[i] > 0.0 && p[i].is_finite(), "light {i}: {}", p[i]);
                } else {
                    assert_eq!(p[i], 0.0);
                }
            }
            let edges = [0.0, DEFENSIVE as f32, 1.0 - f32::EPSILON / 2.0, 1.0, -0.5];
            let us = (0..200).map(|_| rng.next_f32()).chain(edges);
            for u in us {
                let (i, pi) = tree.sample(&q, u).expect("a light");
                assert!(items[i].power > 0.0, "picked a dark light");
                assert_eq!(pi.to_bits(), tree.pmf(&q, i).to_bits(), "u {u}");
            }
        }
    }
}

#[test]
fn empty_dark_single_and_coincident_sets() {
    let mut tree = LightTree::default();
    let q = Query::point(Vec3::ZERO);
    tree.build(&[]);
    assert!(tree.sample(&q, 0.5).is_none());
    assert_eq!((tree.len(), tree.pmf(&q, 0)), (0, 0.0));
    let dark = [
        Emitter::point(Vec3::ONE, 0.0),
        Emitter::point(Vec3::ONE, f32::NAN),
    ];
    tree.build(&dark);
    assert!(tree.sample(&q, 0.5).is_none());
    assert_eq!(tree.pmf(&q, 1), 0.0);
    tree.build(&[
        Emitter::point(Vec3::ONE, 0.0),
        Emitter::point(Vec3::ONE, 2.0),
    ]);
    assert_eq!(tree.sample(&q, 0.99), Some((1, 1.0)));
    // 10000 lights on one point (one Morton code), queried there and along a line.
    let mut same = vec![Emitter::point(Vec3::splat(0.25), 1.0); 10_000];
    same.push(Emitter {
        a: Vec3::splat(-1e30),
        b: Vec3::splat(1e30),
        power: 1e-30,
    });
    tree.build(&same);
    for q in [
        Query::point(Vec3::splat(0.25)),
        Query {
            o: Vec3::ZERO,
            d: Vec3::Y,
            tmax: f32::INFINITY,
        },
    ] {
        let sum: f64 = pmfs(&tree, &q, same.len()).iter().sum();
        assert!((sum - 1.0).abs() < 1e-4, "sum {sum}");
        assert!(tree.pmf(&q, 10_000) > 0.0);
        for u in [0.0, 0.3, 0.999_999_9] {
            let (i, p) = tree.sample(&q, u).unwrap();
            assert_eq!(p.to_bits(), tree.pmf(&q, i).to_bits());
        }
    }
}

#[test]
fn sampling_frequencies_match_the_pmf() {
    let mut rng = Rng::new(11, 0, 0);
    let items = lights(&mut rng, 300, 5, 10.0, 1.0);
    let mut tree = LightTree::default();
    tree.build(&items);
    let m = 400_000;
    for k in 0..8 {
        let q = query(&mut rng, &items, 10.0);
        let mut counts = vec![0u64; items.len()];
        for _ in 0..m {
            counts[tree.sample(&q, rng.next_f32()).unwrap().0] += 1;
        }
        let p = pmfs(&tree, &q, items.len());
        let (stat, limit) = chi2(&counts, &p);
        eprintln!("query {k}: chi2 {stat:.1}, 1e-6 quantile {limit:.1}");
        assert!(stat < limit, "query {k}: chi2 {stat} >= {limit}");
        // The test can fail: power shares alone are rejected.
        let total: f64 = items.iter().map(|e| e.power as f64).sum();
        let by_power: Vec<f64> = items.iter().map(|e| e.power as f64 / total).collect();
        let (wrong, limit) = chi2(&counts, &by_power);
        assert!(
            wrong > limit,
            "query {k}: power shares pass ({wrong} < {limit})"
        );
    }
}

/// Exact variance of f(i) / p(i) for i drawn with probabilities p.
fn variance(f: &[f64], p: &[f64]) -> f64 {
    let total: f64 = f.iter().sum();
    let second: f64 = f
        .iter()
        .zip(p)
        .filter(|(f, _)| **f > 0.0)
        .map(|(f, p)| f * f / p)
        .sum();
    (second - total * total).max(0.0)
}

#[test]
fn estimates_are_unbiased_and_beat_power_sampling() {
    let mut rng = Rng::new(5, 0, 0);
    // 20 clusters of radius 0.5 in a box of side 40.
    let items = lights(&mut rng, 2000, 20, 40.0, 0.5);
    let eps = 0.05;
    let mut tree = LightTree::default();
    tree.set_min_distance(eps as f32);
    tree.build(&items);
    let total: f64 = items.iter().map(|e| e.power as f64).sum();
    let by_power: Vec<f64> = items.iter().map(|e| e.power as f64 / total).collect();
    let m = 100_000;
    let mut log_ratio = [[0.0f64; 2]; 3];
    let mut queries = [0usize; 3];
    let mut worst = f64::INFINITY;
    for k in 0..24 {
        let q = query(&mut rng, &items, 40.0);
        let kind = if q.tmax == 0.0 {
            0
        } else if q.tmax.is_finite() {
            1
        } else {
            2
        };
        queries[kind] += 1;
        let p = pmfs(&tree, &q, items.len());
        for (which, f) in [
            items.iter().map(|e| f_simple(&q, e)).collect::<Vec<_>>(),
            items.iter().map(|e| f_transport(&q, e, eps)).collect(),
        ]
        .iter()
        .enumerate()
        {
            let exact: f64 = f.iter().sum();
            let (mut s1, mut s2) = (0.0, 0.0);
            for _ in 0..m {
                let (i, pi) = tree.sample(&q, rng.next_f32()).unwrap();
                let x = f[i] / pi as f64;
                s1 += x;
                s2 += x * x;
            }
            let mean = s1 / m as f64;
            let var = (s2 / m as f64 - mean * mean).max(0.0);
            let se = (var / m as f64).sqrt();
            assert!(
                (mean - exact).abs() <= 5.0 * se + 1e-9 * exact,
                "query {k} f{which}: mean {mean} vs {exact} (se {se})"
            );
            let (v_tree, v_pow) = (variance(f, &p), variance(f, &by_power));
            // The sample variance estimates the exact one (a loose check: the
            // defensive mixture bounds the weights, so the tails are light).
            assert!(
                (0.5..2.0).contains(&(var / v_tree)) || v_tree < 1e-12 * exact * exact,
                "query {k} f{which}: variance {var} vs {v_tree}"
            );
            log_ratio[kind][which] += (v_pow / v_tree).ln();
            worst = worst.min(v_pow / v_tree);
        }
    }
    for (kind, name) in ["points", "segments", "unbounded"].iter().enumerate() {
        let n = queries[kind].max(1) as f64;
        eprintln!(
            "{name} ({} queries): variance by power / by tree, geometric mean: \
             1/(1+d^2) {:.2}, transport {:.2}",
            queries[kind],
            (log_ratio[kind][0] / n).exp(),
            (log_ratio[kind][1] / n).exp()
        );
    }
    let all: f64 = log_ratio.iter().flatten().sum::<f64>() / (2 * 24) as f64;
    eprintln!("all: {:.2}, worst query {worst:.2}", all.exp());
    assert!(all.exp() > 2.0, "the tree gains only {:.2}", all.exp());
}

#[test]
fn far_odd_and_unbounded_queries_stay_finite() {
    let mut rng = Rng::new(19, 0, 0);
    let items = lights(&mut rng, 400, 4, 10.0, 1.0);
    let mut tree = LightTree::default();
    tree.build(&items);
    let far = Vec3::splat(1e30);
    let queries = [
        Query::point(far),
        Query {
            o: -far,
            d: Vec3::Z,
            tmax: f32::INFINITY,
        },
        Query {
            o: Vec3::ZERO,
            d: Vec3::new(0.0, -1.0, 0.0),
            tmax: 1e38,
        },
        // Not unit, not finite, negative or NaN lengths: answers stay probabilities.
        Query {
            o: Vec3::ONE,
            d: Vec3::new(3.0, 0.0, 0.0),
            tmax: 5.0,
        },
        Query {
            o: Vec3::ONE,
            d: Vec3::splat(f32::NAN),
            tmax: 5.0,
        },
        Query {
            o: Vec3::splat(f32::NAN),
            d: Vec3::X,
            tmax: 0.0,
        },
        Query {
            o: Vec3::ONE,
            d: Vec3::X,
            tmax: -1.0,
        },
        Query {
            o: Vec3::ONE,
            d: Vec3::X,
            tmax: f32::NAN,
        },
    ];
    for (k, q) in queries.iter().enumerate() {
        let p = pmfs(&tree, q, items.len());
        let sum: f64 = p.iter().sum();
        assert!((sum - 1.0).abs() < 1e-4, "query {k}: sum {sum}");
        for (i, e) in items.iter().enumerate() {
            assert_eq!(p[i] > 0.0, e.power > 0.0, "query {k} light {i}: {}", p[i]);
            assert!(p[i].is_finite());
        }
        for u in [0.0, 0.05, 0.5, 0.999_999_94] {
            let (i, pi) = tree.sample(q, u).unwrap();
            assert_eq!(pi.to_bits(), tree.pmf(q, i).to_bits(), "query {k}");
        }
    }
}

#[test]
fn build_is_deterministic_across_thread_counts() {
    let mut rng = Rng::new(13, 0, 0);
    let items = lights(&mut rng, 20_000, 30, 20.0, 1.0);
    let queries: Vec<Query> = (0..50).map(|_| query(&mut rng, &items, 20.0)).collect();
    let build = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut tree = LightTree::default();
        pool.install(|| tree.build(&items));
        tree
    };
    let one = build(1);
    let mut again = build(2);
    let four = build(4);
    let sig = |tree: &LightTree| -> Vec<u32> {
        let mut v = Vec::new();
        for q in &queries {
            v.extend(
                (0..items.len())
                    .step_by(7)
                    .map(|i| tree.pmf(q, i).to_bits()),
            );
            for k in 0..20 {
                let (i, p) = tree.sample(q, (k as f32 + 0.5) / 20.0).unwrap();
                v.extend([i as u32, p.to_bits()]);
            }
        }
        v
    };
    let reference = sig(&one);
    for tree in [&again, &four] {
        assert_eq!(tree.groups, one.groups);
        assert_eq!(sig(tree), reference);
    }
    // A rebuild into used buffers gives the same tree.
    again.build(&lights(&mut rng, 500, 3, 5.0, 1.0));
    again.build(&items);
    assert_eq!(again.groups, one.groups);
    assert_eq!(sig(&again), reference);
}

#[test]
fn morton_codes_interleave_21_bits() {
    assert_eq!(spread(0x1f_ffff), 0x1249_2492_4924_9249);
    assert_eq!(morton3(1, 0, 0), 1);
    assert_eq!(morton3(0, 1, 0), 2);
    assert_eq!(morton3(0, 0, 1), 4);
    assert_eq!(morton3(1 << 20, 1 << 20, 1 << 20), 7 << 60);
    assert_eq!(morton3(0x1f_ffff, 0x1f_ffff, 0x1f_ffff), (1 << 63) - 1);
}

/// Timing only (printed, never asserted): 1e5 lights, 1e6 samples.
#[test]
fn scale_1e5_lights_1e6_samples() {
    let mut rng = Rng::new(17, 0, 0);
    let items = lights(&mut rng, 100_000, 200, 50.0, 1.0);
    let mut tree = LightTree::default();
    let mut build = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        tree.build(&items);
        build = build.min(t.elapsed().as_secs_f64());
    }
    let queries: Vec<Query> = (0..1000).map(|_| query(&mut rng, &items, 50.0)).collect();
    let t = Instant::now();
    let mut check = 0.0f64;
    for q in &queries {
        for _ in 0..1000 {
            let (_, p) = tree.sample(q, rng.next_f32()).unwrap();
            check += 1.0 / p as f64;
        }
    }
    let sample = t.elapsed().as_secs_f64();
    let t = Instant::now();
    for q in &queries {
        for _ in 0..100 {
            check += tree.pmf(q, (rng.next_u32() % 100_000) as usize) as f64;
        }
    }
    let pmf = t.elapsed().as_secs_f64();
    let depth = (0..tree.leaf_of.len())
        .filter(|&i| tree.leaf_of[i] != NONE)
        .map(|i| {
            let (mut at, mut d) = (tree.leaf_of[i], 0);
            while at != NONE {
                at = tree.parents[at as usize / WIDTH];
                d += 1;
            }
            d
        })
        .fold((0usize, 0usize), |(m, s), d| (m.max(d), s + d));
    eprintln!(
        "1e5 lights ({} with power): build {:.1} ms on {} threads, 1e6 samples {:.0} ms \
         ({:.0} ns each), pmf {:.0} ns, depth mean {:.1} max {}, {:.1} MB ({check:.1e})",
        tree.len(),
        build * 1e3,
        rayon::current_num_threads(),
        sample * 1e3,
        sample * 1e3,
        pmf * 1e4,
        depth.1 as f64 / tree.len() as f64,
        depth.0,
        tree.bytes() as f64 / 1e6
    );
}
