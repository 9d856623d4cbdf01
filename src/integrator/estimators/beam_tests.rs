//! The beam x beam estimate's geometry and normalisation, and the beam BVH.

use super::beam_estimate::{meet, Gather, Meeting, SIN_PARALLEL};
use super::beams::{Beam, Weight};
use crate::geometry::Ray;
use crate::integrator::estimators::Lbvh;
use crate::integrator::transport::density_camera::MediumGather;
use crate::integrator::transport::medium_walk::Segment;
use crate::integrator::RenderStats;
use crate::math::{Rgb, Rng, Vec3};
use crate::scene::Scene;

/// A camera in an unbounded grey medium (sigma_s = sigma_t = `sigma`, HG g = 0.5).
fn fog(sigma: f32) -> Scene {
    let text = format!(
        r#"{{"format": 1,
        "camera": {{"look_at": {{"origin": [0, 0, 0], "target": [0, 0, 1], "up": [0, 1, 0]}},
                   "fov": 40, "medium": "fog"}},
        "film": {{"width": 8, "height": 8}},
        "media": {{"fog": {{"type": "homogeneous", "sigma_a": [0, 0, 0],
                           "sigma_s": [{sigma}, {sigma}, {sigma}],
                           "phase": {{"type": "henyey_greenstein", "g": 0.5}}}}}},
        "lights": [{{"type": "point", "position": [0, 0, 1], "intensity": [1, 1, 1]}}]}}"#
    );
    crate::scene::load::parse_scene(&text)
        .and_then(|f| Scene::compile(&f, None))
        .unwrap()
}

fn beam(o: Vec3, d: Vec3, len: f32) -> Beam {
    Beam {
        o,
        d: d.normalize(),
        len,
        start: 0.0,
        beta: Rgb::ONE,
        medium: 0,
        depth: 1,
        weight: Weight::Short {
            p: Rgb::splat(1.0 / 3.0),
        },
        seg: 0,
    }
}

/// Closest points between two lines by brute force: the minimum of the distance over
/// a fine grid of t on the first, the second's point projected.
fn closest_brute(o: Vec3, d: Vec3, b: &Beam) -> (f32, f32, f32) {
    let mut best = (f32::INFINITY, 0.0, 0.0);
    for i in 0..=200_000 {
        let t = -10.0 + 20.0 * i as f32 / 200_000.0;
        let x = o + d * t;
        let s = (x - b.o).dot(b.d);
        let dist = (x - (b.o + b.d * s)).length();
        if dist < best.0 {
            best = (dist, t, s);
        }
    }
    best
}

#[test]
fn crossing_pairs_meet_at_their_closest_points() {
    let mut rng = Rng::new(5, 0, 1);
    let mut crossings = 0;
    for _ in 0..40 {
        let rv = |rng: &mut Rng| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
        let (o, d) = (rv(&mut rng), rv(&mut rng).normalize());
        let b = beam(rv(&mut rng), rv(&mut rng), 1.5);
        let (u, tc, tb) = closest_brute(o, d, &b);
        let r = u + 0.05;
        match meet(o, d, 5.0, &b, r, SIN_PARALLEL) {
            Some(Meeting::Cross { tc: c, tb: s, sin }) => {
                crossings += 1;
                assert!(sin >= SIN_PARALLEL);
                assert!(
                    (c - tc).abs() < 2e-3 && (s - tb).abs() < 2e-3,
                    "{c} {s} vs {tc} {tb}"
                );
            }
            Some(Meeting::Along { .. }) => assert!(d.cross(b.d).length() < SIN_PARALLEL),
            None => assert!(
                !(0.0..5.0).contains(&tc) || !(0.0..1.5).contains(&tb),
                "missed a pair at distance {u} (t {tc}, s {tb})"
            ),
        }
        // Just beyond the distance nothing meets.
        if d.cross(b.d).length() >= SIN_PARALLEL {
            assert_eq!(meet(o, d, 5.0, &b, u * 0.98, SIN_PARALLEL), None);
        }
    }
    assert!(crossings > 5, "{crossings}");
}

#[test]
fn parallel_pairs_meet_along_their_overlap() {
    // A beam parallel to the camera ray at distance 0.3, from z = 1 to z = 4; the
    // camera segment covers z in [0, 3).
    let b = beam(Vec3::new(0.3, 0.0, 1.0), Vec3::Z, 3.0);
    let m = meet(Vec3::ZERO, Vec3::Z, 3.0, &b, 0.5, SIN_PARALLEL);
    assert_eq!(m, Some(Meeting::Along { s0: 0.0, s1: 2.0 }));
    assert_eq!(meet(Vec3::ZERO, Vec3::Z, 3.0, &b, 0.2, SIN_PARALLEL), None);
    // Opposite directions: the same overlap, from the beam's side.
    let b = beam(Vec3::new(0.3, 0.0, 4.0), -Vec3::Z, 3.0);
    let Some(Meeting::Along { s0, s1 }) = meet(Vec3::ZERO, Vec3::Z, 3.0, &b, 0.5, SIN_PARALLEL)
    else {
        panic!()
    };
    assert!(
        (s0 - 1.0).abs() < 1e-5 && (s1 - 3.0).abs() < 1e-5,
        "{s0} {s1}"
    );
    // Slightly tilted: the part of the beam within r of the line.
    let d = Vec3::new(0.02, 0.0, 1.0).normalize();
    let b = beam(Vec3::new(0.0, 0.0, 1.0), d, 20.0);
    let Some(Meeting::Along { s0, s1 }) = meet(Vec3::ZERO, Vec3::Z, 100.0, &b, 0.1, SIN_PARALLEL)
    else {
        panic!()
    };
    // x(s) = 0.02 s / |(0.02, 0, 1)| < 0.1.
    let expect = 0.1 * (1.0f32 + 0.0004).sqrt() / 0.02;
    assert!(
        s0 == 0.0 && (s1 - expect).abs() < 1e-3 * expect,
        "{s1} vs {expect}"
    );
}

/// Integrated over every camera ray of direction d (over the plane of origins
/// perpendicular to d), the blurred estimate gives back the beam's exact contribution
/// int_0^len sigma_s f T_c(t(s)) ds for any radius: the kernels are normalised and the
/// 1 / sin(theta) of the 1D estimate is the Jacobian it should be. Checked for
/// crossing pairs and for near-parallel ones (2D kernel along the overlap).
#[test]
fn the_blur_integrates_to_the_beam_for_every_angle() {
    let sigma = 0.4f32;
    let scene = fog(sigma);
    let m = &scene.media[0];
    let d = Vec3::Z;
    let behind = -6.0f32; // the plane of camera origins, z = behind
    for (k, angle_deg) in [90.0f32, 35.0, 7.0, 3.0, 0.0].into_iter().enumerate() {
        let a = angle_deg.to_radians();
        let bd = Vec3::new(a.sin(), 0.0, a.cos());
        let b = beam(Vec3::new(-0.5 * a.sin(), 0.0, -0.5), bd, 1.2);
        // In pieces, as the integrator stores beams: the pieces' estimates add up to
        // the beam's.
        let mut beams = Vec::new();
        b.split_into(0.5, &mut beams);
        assert_eq!(beams.len(), 3);
        let mut bvh = Lbvh::default();
        bvh.build(&mut beams);
        let r = 0.05;
        let g = Gather {
            scene: &scene,
            beams: &beams,
            bvh: &bvh,
            radius: r,
            max_depth: 64,
        };
        let f = m.phase().eval(bd, -d);
        // Exact: t(s) = z of the beam point minus the plane's z.
        let n = 4000;
        let exact: f64 = (0..n)
            .map(|i| {
                let s = b.len * (i as f32 + 0.5) / n as f32;
                let t = (b.o + b.d * s).z - behind;
                (sigma * f * (-sigma * t).exp()) as f64 * (b.len / n as f32) as f64
            })
            .sum();
        // Origins uniform on a rectangle of the plane that covers the beam within r.
        let (x0, x1) = (-0.5 * a.sin() - 2.0 * r, 0.7 * a.sin() + 2.0 * r);
        let (y0, y1) = (-2.0 * r, 2.0 * r);
        let area = ((x1 - x0) * (y1 - y0)) as f64;
        let mut rng = Rng::new(11, k as u64, 2);
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        let samples = 200_000;
        let mut stats = RenderStats::default();
        for _ in 0..samples {
            let o = Vec3::new(
                x0 + (x1 - x0) * rng.next_f32(),
                y0 + (y1 - y0) * rng.next_f32(),
                behind,
            );
            let seg = Segment {
                ray: Ray::new(o, d),
                tmax: 20.0,
                medium: 0,
                beta: Rgb::ONE,
            };
            let e = g.segment(&seg, 0, &mut rng, &mut stats).x as f64 * area;
            sum += e;
            sum2 += e * e;
        }
        let mean = sum / samples as f64;
        let se = ((sum2 / samples as f64 - mean * mean) / samples as f64).sqrt();
        assert!(
            (mean - exact).abs() < 4.0 * se + 1e-3 * exact,
            "angle {angle_deg}: {mean} +- {se}, exact {exact}"
        );
    }
}

/// Beams in random positions and directions, many short, some long and some parallel
/// to an axis.
fn random_beams(n: usize, rng: &mut Rng) -> Vec<Beam> {
    (0..n)
        .map(|i| {
            let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
            let d = if i % 9 == 0 {
                Vec3::Y
            } else {
                Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5
            };
            let len = if i % 13 == 0 {
                3.0
            } else {
                0.3 * rng.next_f32()
            };
            let mut b = beam(o, d, len);
            b.depth = i as u32;
            b
        })
        .collect()
}

/// What a query finds, in the order it reports it (beam ids and meetings).
fn found(bvh: &Lbvh<Beam>, beams: &[Beam], o: Vec3, d: Vec3, tmax: f32, r: f32) -> Vec<u32> {
    let mut out = Vec::new();
    bvh.visit(beams, o, d, tmax, r, |b| {
        if meet(o, d, tmax, b, r, SIN_PARALLEL).is_some() {
            out.push(b.depth);
        }
    });
    out
}

#[test]
fn the_beam_bvh_finds_what_brute_force_finds() {
    let mut rng = Rng::new(2, 3, 4);
    let original = random_beams(3000, &mut rng);
    let mut beams = original.clone();
    let mut bvh = Lbvh::default();
    bvh.build(&mut beams);
    for q in 0..200 {
        let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 5.0 - 2.5;
        let d = if q % 7 == 0 {
            Vec3::Y
        } else {
            (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5).normalize()
        };
        let tmax = if q % 5 == 0 {
            f32::INFINITY
        } else {
            4.0 * rng.next_f32()
        };
        let r = 0.01 + 0.1 * rng.next_f32();
        let mut got = found(&bvh, &beams, o, d, tmax, r);
        let mut expect: Vec<u32> = original
            .iter()
            .filter(|b| meet(o, d, tmax, b, r, SIN_PARALLEL).is_some())
            .map(|b| b.depth)
            .collect();
        got.sort_unstable();
        expect.sort_unstable();
        assert_eq!(got, expect, "query {q}");
    }
}

#[test]
fn the_beam_bvh_does_not_depend_on_the_thread_count() {
    let mut rng = Rng::new(9, 9, 9);
    let original = random_beams(20_000, &mut rng);
    let build = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut beams = original.clone();
            let mut bvh = Lbvh::default();
            bvh.build(&mut beams);
            (beams, bvh)
        })
    };
    let (b1, t1) = build(1);
    let (b4, t4) = build(4);
    assert!(b1.iter().zip(&b4).all(|(x, y)| x.depth == y.depth));
    for q in 0..50 {
        let o = Vec3::new(q as f32 * 0.07 - 1.7, 0.1, -2.5);
        let d = Vec3::new(0.1, 0.2 - q as f32 * 0.01, 1.0).normalize();
        assert_eq!(
            found(&t1, &b1, o, d, 5.0, 0.05),
            found(&t4, &b4, o, d, 5.0, 0.05)
        );
    }
}

/// The beam x beam estimator's MIS density is the measure of the beams it accepts
/// (issue 39: SmallUPBP writes 0.5 r N where caustic writes 2 r N, and only one can
/// be the box kernel's). Isotropic long beams from a point at distance `D` from the
/// query line, near the query segment's start or middle: the beams `meet` accepts,
/// binned by where they cross the query, must number n p_w / dist^2 eta(sin) dt per
/// unit length t of the query (p_w = 1 / (4 pi), eta the MIS's `eta` for one light
/// path in a medium of sigma_t 1, under the balance heuristic), within 5 binomial
/// standard errors in every bin. With 0.5 r the counts would be 4 times too high.
#[test]
fn beam_beam_acceptance_is_the_mis_density_of_the_estimator() {
    use crate::integrator::paths::partial::{Merge, Merges, Mis};
    use crate::integrator::transport::Heuristic;
    use crate::math::warp::square_to_uniform_sphere;
    let r = 0.02f32;
    let mis = Mis::new(
        Heuristic::Balance,
        1.0,
        true,
        Merges::default().with(Merge::BeamBeam1d, r, 1.0),
    );
    let tmax = 2.0f32;
    let bins = 4;
    let n = 400_000;
    for (case, (dist, z0)) in [(1.0f32, 1.0f32), (0.5, 0.0), (2.0, -0.5)]
        .into_iter()
        .enumerate()
    {
        let y = Vec3::new(dist, 0.0, z0);
        let mut rng = Rng::new(39, case as u64, 1);
        let mut counts = vec![0u64; bins];
        for _ in 0..n {
            let b = beam(y, square_to_uniform_sphere(rng.next_2d()), 100.0);
            match meet(Vec3::ZERO, Vec3::Z, tmax, &b, r, SIN_PARALLEL) {
                Some(Meeting::Cross { tc, .. }) => {
                    counts[((tc / tmax * bins as f32) as usize).min(bins - 1)] += 1
                }
                Some(Meeting::Along { .. }) => panic!("no beam here is near-parallel"),
                None => {}
            }
        }
        for (k, &count) in counts.iter().enumerate() {
            // Midpoint quadrature of n p_w eta(sin(t)) / dist(t)^2 over the bin.
            let steps = 2000;
            let width = tmax / bins as f32;
            let expected: f64 = (0..steps)
                .map(|i| {
                    let t = width * (k as f32 + (i as f32 + 0.5) / steps as f32);
                    let to = Vec3::new(0.0, 0.0, t) - y;
                    let sin = to.normalize().cross(Vec3::Z).length();
                    let eta = mis.eta(Merge::BeamBeam1d, 1.0, sin, 1.0);
                    n as f64 / (4.0 * std::f64::consts::PI) * eta / to.length_squared() as f64
                        * (width / steps as f32) as f64
                })
                .sum();
            let p = expected / n as f64;
            let se = (n as f64 * p * (1.0 - p)).sqrt();
            assert!(
                (count as f64 - expected).abs() < 5.0 * se,
                "point at ({dist}, 0, {z0}), bin {k}: {count} beams accepted, {expected:.1} +- {se:.1} expected"
            );
        }
    }
}
