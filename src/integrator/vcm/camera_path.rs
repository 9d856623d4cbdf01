//! Camera subpaths: emitter hits, light sampling, connections to the paired light
//! subpath and merging with all stored light vertices, each weighted by [`super::mis`].

use super::light_path::{scatter, Surface, Walk, MIN_COS};
use super::{Pass, Workspace};
use crate::geometry::{spawn_ray, spawn_ray_to, Interaction, Ray};
use crate::integrator::RenderStats;
use crate::light::Light;
use crate::material::Mode;
use crate::math::{Frame, Rgb, Rng, Vec3};
use crate::scene::Surfacing;

/// Radiance along one camera ray of pixel `pixel`.
#[inline(always)]
pub(super) fn radiance(
    pass: &Pass,
    ws: &Workspace,
    pixel: usize,
    mut ray: Ray,
    rng: &mut Rng,
    stats: &mut RenderStats,
    layers: &mut [Rgb],
) -> Rgb {
    let scene = pass.scene;
    let mut walk = Walk {
        origin: ray.o,
        throughput: Rgb::ONE,
        len: 1,
        q: pass.mis.camera_start(scene.camera.pdf_dir(ray.d)),
        specular: true,
    };
    let mut l = Rgb::ZERO;
    loop {
        let (it, m) = match scene.next_scattering(&mut ray, &mut stats.rays) {
            Surfacing::Hit(it, m) => (it, m),
            Surfacing::Escaped => {
                let v = walk.throughput * escaped(pass, &walk, ray.d);
                record(layers, pass.layers.connection(0, walk.len + 1), v);
                l += v;
                break;
            }
            Surfacing::Lost => break,
        };
        let cos_in = it.ns.dot(ray.d).abs();
        if cos_in < MIN_COS {
            break;
        }
        let dist2 = (it.p - walk.origin).length_squared();
        walk.q = pass.mis.on_hit(walk.q, Some(dist2), cos_in);
        let v = walk.throughput * emitter_hit(pass, &walk, &it, ray.d, dist2);
        record(layers, pass.layers.connection(0, walk.len + 1), v);
        l += v;
        if walk.len >= pass.s.max_depth {
            break;
        }
        let frame = Frame::from_normal(it.ns);
        let surface = Surface {
            m,
            frame,
            ng: it.ng,
            wo: frame.to_local(-ray.d),
            cont: pass.continuation(m),
        };
        if !m.is_delta() {
            if pass.technique.connects() {
                let v = walk.throughput * light_sample(pass, &walk, &it, &surface, rng, stats);
                record(layers, pass.layers.connection(1, walk.len + 1), v);
                l += v;
                l += connect(pass, ws, pixel, &walk, &it, &surface, stats, layers);
            }
            if pass.technique.merges() && (walk.len > 1 || pass.s.merge_first) {
                let v = walk.throughput * merge(pass, ws, &walk, &it, &surface, stats);
                record(layers, pass.layers.merge(), v);
                l += v;
            }
        }
        let len = walk.len;
        let Some(next) = scatter(
            pass,
            rng,
            &mut walk,
            &it,
            &surface,
            Mode::Radiance,
            Some(len),
        ) else {
            break;
        };
        ray = next;
        stats.rays += 1;
    }
    l
}

#[inline]
fn record(layers: &mut [Rgb], layer: Option<usize>, v: Rgb) {
    if let Some(l) = layer.and_then(|i| layers.get_mut(i)) {
        *l += v;
    }
}

/// Weight for radiance found by the camera subpath itself: always 1 for emitters
/// seen directly; photon mapping alone counts it only after purely specular paths
/// (merging covers the rest).
#[inline]
fn own_weight(pass: &Pass, walk: &Walk, direct: impl FnOnce() -> (f32, f32)) -> f32 {
    if walk.len == 1 {
        return 1.0;
    }
    if !pass.technique.connects() {
        return if walk.specular { 1.0 } else { 0.0 };
    }
    let (direct, emission) = direct();
    pass.mis.weight_emitter_hit(walk.q, direct, emission)
}

/// An area light reached by the camera subpath ([TR] eqs. 42-43).
#[inline]
fn emitter_hit(pass: &Pass, walk: &Walk, it: &Interaction, d: Vec3, dist2: f32) -> Rgb {
    let scene = pass.scene;
    let Some((li, area)) = scene.area_light(it) else {
        return Rgb::ZERO;
    };
    let le = area.le(it.ng, -d);
    if le == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let w = own_weight(pass, walk, || {
        let pick = scene.light_sampler.pmf(li);
        let cos = it.ng.dot(d).abs();
        let direct = pick * area.pdf_li(walk.origin, it.p, it.ng) * cos / dist2;
        let (pos, dir) = area.pdf_le(it.ng, -d);
        (direct, pick * pos * dir)
    });
    le * w
}

/// Environment lights seen by a ray that leaves the scene.
#[inline]
fn escaped(pass: &Pass, walk: &Walk, d: Vec3) -> Rgb {
    let scene = pass.scene;
    let mut l = Rgb::ZERO;
    for &li in &scene.env_lights {
        let light = &scene.lights[li as usize];
        let le = light.le_escaped(d);
        if le == Rgb::ZERO {
            continue;
        }
        let w = own_weight(pass, walk, || {
            let pick = scene.light_sampler.pmf(li as usize);
            let direct = pick * light.pdf_li(Vec3::ZERO, d, Vec3::ZERO, Vec3::ZERO);
            let (pos, dir) = light.pdf_le(&scene.sphere, Vec3::ZERO, -d);
            (direct, pick * pos * dir)
        });
        l += le * w;
    }
    l
}

/// Light sampling from a camera vertex ([TR] eqs. 44-45).
#[inline]
fn light_sample(
    pass: &Pass,
    walk: &Walk,
    it: &Interaction,
    surface: &Surface,
    rng: &mut Rng,
    stats: &mut RenderStats,
) -> Rgb {
    let scene = pass.scene;
    if scene.lights.is_empty() {
        return Rgb::ZERO;
    }
    let (li, pick, _) = scene.light_sampler.sample(rng.next_f32());
    let u = rng.next_2d();
    let light = &scene.lights[li];
    let Some(ls) = light.sample_li(it.p, u) else {
        return Rgb::ZERO;
    };
    let Some(e) = surface.eval(ls.wi, Mode::Radiance) else {
        return Rgb::ZERO;
    };
    // SmallVCM's conventions: point-like lights have unit area density, so their
    // solid-angle density is dist^2; lights without a surface have cos 1.
    let (direct, cos_light) = match light {
        Light::Area(_) => (ls.pdf, ls.n.dot(ls.wi).abs()),
        Light::Point(_) | Light::Spot(_) => (ls.dist * ls.dist, 1.0),
        _ => (ls.pdf, 1.0),
    };
    let (pos, dir) = light.pdf_le(&scene.sphere, ls.n, -ls.wi);
    let bsdf_dir = if light.is_delta() {
        0.0
    } else {
        e.pdf_dir * surface.cont
    };
    let w = pass.mis.weight_light_sample(
        walk.q,
        walk.len,
        pick,
        direct,
        pos * dir,
        cos_light,
        e.cos,
        bsdf_dir,
        e.pdf_rev * surface.cont,
    );
    stats.connections += 1;
    stats.shadow_rays += 1;
    let ray = if ls.dist.is_finite() {
        spawn_ray_to(it.p, it.p_err, it.ng, ls.p, Vec3::ZERO, Vec3::ZERO)
    } else {
        spawn_ray(it.p, it.p_err, it.ng, ls.wi)
    };
    if !scene.visible(&ray) {
        return Rgb::ZERO;
    }
    e.f * ls.li * (w / (pick * ls.pdf))
}

/// Connections to the vertices of the light subpath paired with this pixel
/// ([TR] eqs. 40-41), throughput included.
#[allow(clippy::too_many_arguments)]
#[inline]
fn connect(
    pass: &Pass,
    ws: &Workspace,
    pixel: usize,
    walk: &Walk,
    it: &Interaction,
    surface: &Surface,
    stats: &mut RenderStats,
    layers: &mut [Rgb],
) -> Rgb {
    let scene = pass.scene;
    let path = pixel % ws.path_ends.len().max(1);
    let Some(&end) = ws.path_ends.get(path) else {
        return Rgb::ZERO;
    };
    let begin = if path == 0 { 0 } else { ws.path_ends[path - 1] };
    let mut l = Rgb::ZERO;
    for y in &ws.vertices[begin as usize..end as usize] {
        // Vertices are stored in order of path length.
        if y.len + 1 + walk.len > pass.s.max_depth {
            break;
        }
        let to_light = y.p - it.p;
        let dist2 = to_light.length_squared();
        if dist2 <= 0.0 {
            continue;
        }
        let dir = to_light / dist2.sqrt();
        let Some(ec) = surface.eval(dir, Mode::Radiance) else {
            continue;
        };
        let ym = &scene.materials[y.material as usize];
        let yframe = Frame::from_normal(y.ns);
        let ys = Surface {
            m: ym,
            frame: yframe,
            ng: y.ng,
            wo: yframe.to_local(y.wo),
            cont: y.cont,
        };
        let Some(el) = ys.eval(-dir, Mode::Importance) else {
            continue;
        };
        let w = pass.mis.weight_connection(
            y.q,
            walk.q,
            walk.len,
            ec.pdf_dir * surface.cont * el.cos / dist2,
            el.pdf_dir * ys.cont * ec.cos / dist2,
            el.pdf_rev * ys.cont,
            ec.pdf_rev * surface.cont,
        );
        stats.connections += 1;
        stats.shadow_rays += 1;
        let ray = spawn_ray_to(it.p, it.p_err, it.ng, y.p, y.p_err, y.ng);
        if !scene.visible(&ray) {
            continue;
        }
        let v = walk.throughput * y.throughput * ec.f * el.f * (w / dist2);
        record(layers, pass.layers.connection(y.len + 1, walk.len + 1), v);
        l += v;
    }
    l
}

/// Merging with every stored light vertex within the radius ([TR] eqs. 38-39), with
/// the constant kernel 1 / (pi r^2) and the 1 / N of the light paths.
#[inline]
fn merge(
    pass: &Pass,
    ws: &Workspace,
    walk: &Walk,
    it: &Interaction,
    surface: &Surface,
    stats: &mut RenderStats,
) -> Rgb {
    let mut sum = Rgb::ZERO;
    let mut merges = 0u64;
    ws.grid.query_sorted(it.p, |k, _| {
        let y = &ws.merge[k];
        if y.len + walk.len > pass.s.max_depth {
            return;
        }
        let Some(e) = surface.eval(y.wo, Mode::Radiance) else {
            return;
        };
        if e.cos < MIN_COS {
            return;
        }
        let w = pass
            .mis
            .weight_merge(y.q, walk.q, e.pdf_dir * surface.cont, e.pdf_rev * y.cont);
        merges += 1;
        // The photon's flux already holds the cosine at its surface: f without it.
        sum += y.throughput * e.f * (w / e.cos);
    });
    stats.merges += merges;
    sum * pass.vm_norm
}
