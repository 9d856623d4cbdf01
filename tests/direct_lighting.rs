//! Analytic direct lighting: a diffuse plane under a point light and under a spot
//! light, compared pixel by pixel with the closed form L = rho / pi * I(w) cos / d^2,
//! integrated over each pixel's footprint by quadrature.

mod common;
use caustic::math::Vec2;
use common::*;
use serde_json::json;

const RHO: f64 = 0.6;
const W: u32 = 24;

fn plane_scene(light: serde_json::Value) -> serde_json::Value {
    json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0.3, -0.2, 2.0], "target": [0.3, -0.2, 0.0], "up": [0, 1, 0]},
                   "fov": 70},
        "film": {"width": W, "height": W},
        "materials": {"plane": {"type": "diffuse", "reflectance": [RHO, RHO, RHO]}},
        "shapes": [{"type": "rectangle", "material": "plane",
                    "transform": {"scale": [3, 3, 1]}}],
        "lights": [light]
    })
}

/// Exitant radiance at plane point (x, y, 0) for a light at `pos` with angular
/// intensity `intensity(direction from light)`.
fn radiance(x: f64, y: f64, pos: [f64; 3], intensity: &dyn Fn([f64; 3]) -> f64) -> f64 {
    if x.abs() > 3.0 || y.abs() > 3.0 {
        return 0.0;
    }
    let d = [x - pos[0], y - pos[1], -pos[2]];
    let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    let dist = d2.sqrt();
    let dir = [d[0] / dist, d[1] / dist, d[2] / dist];
    let cos = pos[2] / dist;
    RHO / std::f64::consts::PI * intensity(dir) * cos / d2
}

fn compare(light: serde_json::Value, pos: [f64; 3], intensity: &dyn Fn([f64; 3]) -> f64) {
    let scene = compile(plane_scene(light));
    let spp = 16;
    let (film, n) = render(&scene, &settings("pt", json!({"max_depth": 2})), 3, spp);
    assert_eq!(film.dropped(), 0);
    let img = channel(&film, n, 0);
    let mut worst: f64 = 0.0;
    for py in 0..W {
        for px in 0..W {
            let (mean, sd) = pixel_quadrature(&scene, px, py, 16, pos, intensity);
            // Quadrature error, estimated from a coarser rule, joins the noise bound.
            let (coarse, _) = pixel_quadrature(&scene, px, py, 8, pos, intensity);
            let tol =
                5.0 * sd / (spp as f64).sqrt() + 2.0 * (mean - coarse).abs() + 1e-4 * mean + 1e-6;
            let got = img[(py * W + px) as usize];
            worst = worst.max((got - mean).abs() / tol);
            assert!(
                (got - mean).abs() <= tol,
                "pixel ({px},{py}): {got} vs analytic {mean} (tolerance {tol})"
            );
        }
    }
    assert!(worst > 0.0);
}

/// Mean of the analytic radiance over a pixel (q x q midpoint rule), and the standard
/// deviation of one jittered sample of it.
fn pixel_quadrature(
    scene: &caustic::scene::Scene,
    px: u32,
    py: u32,
    q: usize,
    pos: [f64; 3],
    intensity: &dyn Fn([f64; 3]) -> f64,
) -> (f64, f64) {
    let mut vals = Vec::with_capacity(q * q);
    for j in 0..q {
        for i in 0..q {
            let s = Vec2::new(
                px as f32 + (i as f32 + 0.5) / q as f32,
                py as f32 + (j as f32 + 0.5) / q as f32,
            );
            let r = scene.camera.generate_ray(s, Vec2::ZERO);
            let t = -r.o.z as f64 / r.d.z as f64;
            let x = r.o.x as f64 + t * r.d.x as f64;
            let y = r.o.y as f64 + t * r.d.y as f64;
            vals.push(radiance(x, y, pos, intensity));
        }
    }
    let (mean, se_q) = mean_se(&vals);
    (mean, se_q * (vals.len() as f64).sqrt())
}

#[test]
fn diffuse_plane_under_point_light_matches_closed_form() {
    let pos = [0.2, 0.4, 1.5];
    let i = 3.0;
    compare(
        json!({"type": "point", "position": pos, "intensity": [i, i, i]}),
        pos,
        &|_| i,
    );
}

#[test]
fn diffuse_plane_under_spot_light_matches_closed_form() {
    let pos = [0.5f64, -0.3, 1.2];
    let target = [0.1f64, -0.1, 0.0];
    let (cutoff, beam) = (30f64.to_radians(), 15f64.to_radians());
    let axis = {
        let d = [target[0] - pos[0], target[1] - pos[1], target[2] - pos[2]];
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        [d[0] / l, d[1] / l, d[2] / l]
    };
    let i = 4.0;
    // Mitsuba's falloff: 1 inside the beam, linear in angle to 0 at the cutoff.
    let falloff = move |w: [f64; 3]| {
        let cos = w[0] * axis[0] + w[1] * axis[1] + w[2] * axis[2];
        let angle = cos.clamp(-1.0, 1.0).acos();
        if angle >= cutoff {
            0.0
        } else if angle <= beam {
            i
        } else {
            i * (cutoff - angle) / (cutoff - beam)
        }
    };
    compare(
        json!({"type": "spot", "position": pos, "target": target, "intensity": [i, i, i],
               "cutoff_angle": 30.0, "beam_width": 15.0}),
        pos,
        &falloff,
    );
}
