//! The nine scenes of `../shared/scenes/vrl-thesis.md` (built-ins `vrl-cornell-*`,
//! `vrl-cornell-dense-*`, `vrl-point-*`): each renders with `volpath`; in the Cornell
//! box, direct light reaches the floor only through the four ceiling openings, with the
//! closed-form value there, and the directional light's emission disk delivers the
//! flux those openings admit; around the point light in the unbounded medium the image
//! has the symmetry of the set-up, within noise measured from the iterations.

mod common;
#[allow(dead_code)]
#[path = "bidirectional/stats.rs"]
mod stats;

use caustic::geometry::Ray;
use caustic::integrator::transport::nee::{direct_unweighted, Origin};
use caustic::integrator::RenderStats;
use caustic::light::Light;
use caustic::math::{Frame, Rng, Vec2, Vec3};
use caustic::scene::{load::parse_scene, Scene};
use common::*;
use serde_json::json;
use stats::{Rect, Run};

const NAMES: [&str; 9] = [
    "vrl-cornell-gm09",
    "vrl-cornell-g0",
    "vrl-cornell-g09",
    "vrl-cornell-dense-gm09",
    "vrl-cornell-dense-g0",
    "vrl-cornell-dense-g09",
    "vrl-point-gm09",
    "vrl-point-g0",
    "vrl-point-g09",
];

/// The built-in scene `name` at `size` x `size` pixels.
fn builtin(name: &str, size: u32) -> Scene {
    let text = caustic::job::scenes::BUILTIN
        .iter()
        .find(|(n, _)| *n == name)
        .unwrap_or_else(|| panic!("{name} is not a built-in scene"))
        .1;
    let mut file = parse_scene(text).expect("scene parses");
    file.film.width = size;
    file.film.height = size;
    Scene::compile(&file, None).expect("scene compiles")
}

/// The light's direction of travel, normalize([-0.1, -1.0, 0.075]), and the cosine
/// between it and the vertical.
fn sun() -> (Vec3, f64) {
    let d = Vec3::new(-0.1, -1.0, 0.075).normalize();
    (d, -d.y as f64)
}

const OPEN_X: [(f32, f32); 4] = [
    (-0.65, -0.495),
    (-0.425, -0.27),
    (-0.2, -0.045),
    (0.025, 0.18),
];
const OPEN_Z: (f32, f32) = (-3.5, -3.18);
const IRRADIANCE: f64 = 400.0;

/// Which opening the point (x, 2.5, z) of the ceiling plane lies in, if any, and its
/// distance to the nearest opening edge.
fn opening_at(x: f32, z: f32) -> (Option<usize>, f32) {
    let mut edge = (z - OPEN_Z.0).abs().min((z - OPEN_Z.1).abs());
    let mut inside = None;
    for (k, &(x0, x1)) in OPEN_X.iter().enumerate() {
        edge = edge.min((x - x0).abs()).min((x - x1).abs());
        if x > x0 && x < x1 && z > OPEN_Z.0 && z < OPEN_Z.1 {
            inside = Some(k);
        }
    }
    (inside, edge)
}

#[test]
fn every_scene_is_built_in_and_renders_with_volpath() {
    let mut total = 0.0;
    for name in NAMES {
        let start = std::time::Instant::now();
        let scene = builtin(name, 32);
        let (film, n) = render(&scene, &settings("volpath", json!({})), 7, 8);
        let bad = film
            .sums()
            .iter()
            .flatten()
            .filter(|v| !v.is_finite())
            .count();
        let mean = film.to_image(1.0 / n as f64).mean();
        let secs = start.elapsed().as_secs_f64();
        total += secs;
        eprintln!(
            "{name}: mean {:.5}, dropped {}, {secs:.2} s",
            mean.x,
            film.dropped()
        );
        assert_eq!(bad, 0, "{name}: non-finite pixel sums");
        assert_eq!(film.dropped(), 0, "{name}: dropped samples");
        assert!(mean.min_element() > 0.0, "{name}: mean {mean}");
        // Grey media, grey light: the point scenes are grey too.
        if name.starts_with("vrl-point") {
            assert!(mean.x == mean.y && mean.y == mean.z, "{name}: mean {mean}");
        }
    }
    eprintln!("nine scenes in {total:.1} s");
}

/// On a grid over the floor, next-event estimation (light sampling alone, through the
/// medium) sees the directional light exactly where the ray towards it leaves through
/// an opening, with the closed form rho / pi * cos * E * exp(-sigma_t * 5 / cos), and
/// nowhere else. Points within 2 mm of an opening's edge (seen along the light), or
/// above the grey boxes' footprints, are left out.
#[test]
fn direct_light_reaches_the_floor_only_through_the_openings() {
    let (d, cos) = sun();
    for (name, sigma_t) in [("vrl-cornell-g0", 0.11), ("vrl-cornell-dense-g09", 0.35)] {
        let scene = builtin(name, 8);
        // The medium's boundary is closed: the box's inside is in it, the space above
        // the ceiling is not, and the light shines in from there.
        let medium = Some(0);
        assert_eq!(scene.camera_medium, medium);
        for p in [[0.0, 0.0, 0.0], [2.0, -2.0, -4.0], [-0.3, 2.4, -3.3]] {
            assert_eq!(scene.medium_at(Vec3::from(p)), medium, "{name}: at {p:?}");
        }
        assert_eq!(scene.medium_at(Vec3::new(-0.3, 2.6, -3.3)), None);
        assert_eq!(scene.light_media, [None]);
        let expected = 0.5 / std::f64::consts::PI * cos * IRRADIANCE * (-sigma_t * 5.0 / cos).exp();
        let mut rng = Rng::new(1, 0, 0);
        let mut stats = RenderStats::default();
        let (mut lit, mut dark) = ([0usize; 4], 0usize);
        let mut worst: f64 = 0.0;
        let step = 0.01;
        for i in 0..510 {
            for j in 0..500 {
                let (x, z) = (-2.545 + step * i as f32, -4.495 + step * j as f32);
                let in_box1 = (0.24..=1.76).contains(&x) && (-3.76..=-2.74).contains(&z);
                let in_box2 = (-1.76..=-0.24).contains(&x) && z <= -3.74;
                if in_box1 || in_box2 {
                    continue;
                }
                // Where the ray from the floor towards the light meets y = 2.5.
                let s = 5.0 / -d.y;
                let (cx, cz) = (x - s * d.x, z - s * d.z);
                let (opening, edge) = opening_at(cx, cz);
                if edge < 2e-3 {
                    continue;
                }
                let down = Ray::new(Vec3::new(x, -2.4, z), -Vec3::Y);
                let it = scene.intersect(&down).expect("the floor");
                assert_eq!(scene.shapes[it.shape as usize].name, "floor");
                let frame = Frame::from_normal(it.ns);
                let at = Origin::Surface {
                    it: &it,
                    frame: &frame,
                    wo: Vec3::Z,
                    m: &scene.material(&it),
                };
                let l = direct_unweighted(&scene, &at, scene.camera_medium, &mut rng, &mut stats);
                assert!(l.x == l.y && l.y == l.z, "{name}: grey light gave {l}");
                match opening {
                    Some(k) => {
                        lit[k] += 1;
                        let err = (l.x as f64 / expected - 1.0).abs();
                        worst = worst.max(err);
                        assert!(
                            err < 1e-4,
                            "{name}: floor ({x}, {z}) under opening {k}: {} vs {expected}",
                            l.x
                        );
                    }
                    None => {
                        dark += 1;
                        assert_eq!(l.x, 0.0, "{name}: floor ({x}, {z}) is lit");
                    }
                }
            }
        }
        eprintln!(
            "{name}: {lit:?} lit floor points per opening at {expected:.4} \
             (worst relative error {worst:.1e}), {dark} dark"
        );
        // Each opening is 0.155 x 0.32, so its patch on the floor holds about
        // 15 x 32 grid points less the 2 mm margins.
        assert!(lit.iter().all(|&n| (380..=500).contains(&n)), "{lit:?}");
    }
}

/// Light paths from the directional light start on its disk outside the scene's
/// bounding sphere; the flux they carry through the openings (first surface met is an
/// opening) is the irradiance times the openings' area projected across the beam,
/// E * 4 * 0.155 * 0.32 * cos. A stratified grid over the disk makes the estimate
/// nearly exact; a disk that missed part of the box would fall short.
#[test]
fn the_directional_light_emits_the_openings_flux_from_outside_the_box() {
    let (_, cos) = sun();
    let scene = builtin("vrl-cornell-g0", 8);
    let light = &scene.lights[0];
    assert!(matches!(light, Light::Directional(_)));
    let sphere = scene.sphere;
    let n = 1000;
    let mut flux = 0.0f64;
    let mut through = 0;
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let e = light
                .sample_le(&sphere, u, Vec2::splat(0.5))
                .expect("a sample");
            assert!(
                (e.p - sphere.center).length() >= sphere.radius * 0.999,
                "emitted from inside the bounding sphere: {}",
                e.p
            );
            let Some(it) = scene.intersect(&Ray::new(e.p, e.d)) else {
                continue;
            };
            if scene.shapes[it.shape as usize].name.starts_with("opening") {
                through += 1;
                flux += e.weight().x as f64;
            }
        }
    }
    flux /= (n * n) as f64;
    let expected = IRRADIANCE * 4.0 * 0.155 * 0.32 * cos;
    eprintln!(
        "flux through the openings {flux:.3} W vs {expected:.3} W ({through} of {} paths)",
        n * n
    );
    assert!((flux / expected - 1.0).abs() < 0.01, "{flux} vs {expected}");
}

/// The camera looks along -z at the point light on its axis in an unbounded
/// homogeneous medium, so the image is symmetric under mirroring left-right and
/// top-bottom. Each 4 x 4 block of the top-left quarter is compared with its three
/// mirror images; the standard error of each block's mean comes from the spread of
/// its per-iteration means (iterations are independent), and the difference must stay
/// within 4.5 standard errors of the difference (about 7e-6 per comparison for a
/// normal difference; 48 comparisons per scene).
#[test]
fn the_point_light_image_is_symmetric_within_its_noise() {
    const W: u32 = 32;
    const B: u32 = 4;
    // The top-left quarter's blocks: those tiling a half-size image.
    let tl = stats::blocks(W / 2, W / 2, B);
    let mirror_x = |r: &Rect| Rect {
        x0: W - r.x1,
        x1: W - r.x0,
        ..*r
    };
    let mirror_y = |r: &Rect| Rect {
        y0: W - r.y1,
        y1: W - r.y0,
        ..*r
    };
    let mut regions = tl.clone();
    regions.extend(tl.iter().map(mirror_x));
    regions.extend(tl.iter().map(mirror_y));
    regions.extend(tl.iter().map(|r| mirror_x(&mirror_y(r))));
    let k = tl.len();
    for g in ["vrl-point-gm09", "vrl-point-g0", "vrl-point-g09"] {
        let scene = builtin(g, W);
        let run: Run = stats::run(&scene, &settings("volpath", json!({})), 5, 1024, &regions);
        assert_eq!(run.dropped, 0, "{g}: dropped samples");
        let (mut max_z, mut sum_z2, mut max_rel_se) = (0.0f64, 0.0, 0.0f64);
        for j in 1..4 {
            for (i, block) in tl.iter().enumerate() {
                let (a, b) = (&run.regions[i], &run.regions[j * k + i]);
                let z = stats::z_score(a, b, 1).expect("a noisy comparison");
                max_z = max_z.max(z);
                sum_z2 += z * z;
                max_rel_se = max_rel_se.max(a.se[1] / a.mean[1]);
                assert!(
                    z < 4.5,
                    "{g}: block {i} ({block:?}) {:.5} +- {:.5} vs mirror {j} {:.5} +- {:.5}",
                    a.mean[1],
                    a.se[1],
                    b.mean[1],
                    b.se[1]
                );
            }
        }
        eprintln!(
            "{g}: {:.1} s, whole image {:.5} +- {:.5}; block z max {max_z:.2}, \
             mean z^2 {:.2}, largest relative SE of a block {max_rel_se:.3}",
            run.seconds,
            run.whole().mean[1],
            run.whole().se[1],
            sum_z2 / (3 * k) as f64
        );
    }
}
