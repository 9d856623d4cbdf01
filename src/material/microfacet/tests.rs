use super::*;

fn dists() -> Vec<Microfacet> {
    let mut v = Vec::new();
    for kind in [Distribution::Beckmann, Distribution::Ggx] {
        for (au, av) in [(0.2, 0.2), (0.6, 0.6), (0.15, 0.5)] {
            v.push(Microfacet::new(kind, au, av));
        }
    }
    v
}

/// Midpoint rule over the upper hemisphere in (theta, phi), in f64.
fn hemisphere(f: impl Fn(Vec3) -> f64) -> f64 {
    let (nt, np) = (1500, 200);
    let (dt, dp) = (
        std::f64::consts::FRAC_PI_2 / nt as f64,
        2.0 * std::f64::consts::PI / np as f64,
    );
    let mut sum = 0.0;
    for i in 0..nt {
        let t = (i as f64 + 0.5) * dt;
        for j in 0..np {
            let p = (j as f64 + 0.5) * dp;
            let m = Vec3::new(
                (t.sin() * p.cos()) as f32,
                (t.sin() * p.sin()) as f32,
                t.cos() as f32,
            );
            sum += f(m) * t.sin() * dt * dp;
        }
    }
    sum
}

#[test]
fn d_is_normalised_over_projected_area() {
    for m in dists() {
        let i = hemisphere(|n| m.d(n) as f64 * n.z as f64);
        assert!((i - 1.0).abs() < 2e-3, "{m:?}: int D cos = {i}");
    }
}

/// int G1(w, m) max(0, w.m) D(m) dm = cos(theta_w): the visible projected area of the
/// microsurface is that of the macrosurface, so the density of visible normals
/// integrates to one. This ties G1 to D for each distribution.
#[test]
fn visible_normal_density_integrates_to_one() {
    for m in dists() {
        for w in [
            Vec3::Z,
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::new(-0.3, 0.9, 0.3).normalize(),
            Vec3::new(0.7, 0.7, 0.1).normalize(),
        ] {
            let i = hemisphere(|n| m.pdf_visible(w, n) as f64);
            assert!((i - 1.0).abs() < 3e-3, "{m:?} from {w}: {i}");
        }
    }
}

#[test]
fn sampled_normals_are_visible_and_upper() {
    let mut rng = crate::math::Rng::new(7, 0, 0);
    for m in dists() {
        for w in [Vec3::Z, Vec3::new(0.99, 0.0, 0.14).normalize()] {
            for _ in 0..10_000 {
                let n = m.sample_visible(w, rng.next_2d());
                assert!(n.is_finite() && n.z > 0.0, "{m:?}: {n}");
                assert!((n.length() - 1.0).abs() < 1e-4);
                assert!(m.pdf_visible(w, n) > 0.0 || n.dot(w) < 1e-4, "{m:?}: {n}");
            }
        }
    }
}

#[test]
fn smooth_below_threshold_and_clamped_above() {
    let s = Microfacet::new(Distribution::Ggx, 5e-4, 9e-4);
    assert!(s.is_smooth());
    let r = Microfacet::new(Distribution::Beckmann, 0.0, 0.3);
    assert!(!r.is_smooth());
    assert_eq!(r.alpha_u, MIN_ALPHA);
}

/// Speed of Beckmann visible-normal sampling and masking, in ns per call over a spread
/// of incident angles (a measurement, not a check): `cargo test --release --lib
/// microfacet::tests::beckmann_speed -- --ignored --nocapture`.
#[test]
#[ignore]
fn beckmann_speed() {
    let m = Microfacet::new(Distribution::Beckmann, 0.15, 0.15);
    let views: Vec<Vec3> = (0..64)
        .map(|i| {
            let c = (i as f32 + 0.5) / 64.0;
            Vec3::new((1.0 - c * c).sqrt(), 0.0, c)
        })
        .collect();
    let mut rng = crate::math::Rng::new(3, 0, 0);
    let us: Vec<Vec2> = (0..4096).map(|_| rng.next_2d()).collect();
    let n = 2_000_000;
    let time = |f: &dyn Fn(usize) -> f32| {
        let start = std::time::Instant::now();
        let mut acc = 0.0f32;
        for i in 0..n {
            acc += f(i);
        }
        (start.elapsed().as_nanos() as f64 / n as f64, acc)
    };
    let (sample, a) = time(&|i| {
        let w = views[i % views.len()];
        m.sample_visible(std::hint::black_box(w), us[i % us.len()])
            .z
    });
    let (g1, b) = time(&|i| {
        let w = views[i % views.len()];
        m.g1(std::hint::black_box(w), Vec3::Z)
    });
    println!("beckmann sample_visible {sample:.1} ns, g1 {g1:.1} ns (checksums {a} {b})");
}
