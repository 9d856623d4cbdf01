//! The light tracer's splats: each stored light vertex connected to a point on the
//! lens through the media between them, and emission seen directly from the light,
//! with their MIS weights (and radius layers' and correlation-aware ones).

use super::correlation::{Chain, Fix, Footprint, Link};
use super::media::shadow;
use super::partial::{Mis, Partial};
use super::parts::Parts;
use super::store::Chunk;
use super::vertex::{Media, Vertex};
use super::walk::{Eval, Walk};
use super::Pass;
use crate::geometry::{spawn_ray_to, Ray};
use crate::light::Light;
use crate::material::Mode;
use crate::math::{gamma, Rgb, Rng, Vec3};

/// A light vertex's connection to the lens, its shadow ray not yet traced.
pub(super) struct LensShadow {
    pub(super) ray: Ray,
    raster: crate::math::Vec2,
    /// The splat if nothing blocks the ray.
    value: Rgb,
    layer: Option<usize>,
}

/// A lens connection's splats in the radius layers, `value` giving it under a MIS and
/// light partial weights. Out of line: the usual connection has no layers.
#[cold]
#[inline(never)]
fn lens_radii(
    pass: &Pass,
    chunk: &mut Chunk,
    raster: crate::math::Vec2,
    (q, parts): (Partial, &Parts),
    value: &impl Fn(&Mis, Partial) -> Rgb,
) {
    for l in &pass.radius_layers {
        let v = value(&l.mis, pass.mis.rescale(q, parts, &l.scale));
        push_splat(chunk, raster, v, Some(l.layer));
    }
}

/// Keeps a visible lens connection's splat.
#[inline(always)]
pub(super) fn push_lens(chunk: &mut Chunk, l: &LensShadow) {
    push_splat(chunk, l.raster, l.value, l.layer);
}

/// Connects a light vertex to a point on the lens and splats the result, through
/// the media between them ([TR] eqs. 46-47; SmallVCM's ConnectToCamera). Without
/// media the shadow ray is returned untraced, with the splat it decides.
#[inline(always)]
pub(super) fn connect_to_camera<M: Media, const RADII: bool>(
    pass: &Pass,
    rng: &mut Rng,
    chunk: &mut Chunk,
    (walk, link): (&Walk, Option<(std::ops::Range<usize>, Link)>),
    v: &Vertex<M>,
) -> Option<LensShadow> {
    let LensLink {
        lens,
        raster,
        dir,
        dist2,
        camera_pdf,
    } = lens_link(pass, rng, v.p())?;
    let e = v.eval(dir, Mode::Importance)?;
    chunk.stats.connections += 1;
    chunk.stats.shadow_rays += 1;
    let (ray, medium) = v.ray_to(pass, walk.medium, lens, Vec3::ZERO, Vec3::ZERO);
    let layer = pass.layers.connection(walk.len + 1, 1);
    let lens_at = (camera_pdf, dist2);
    // The light side's fix for correlation-aware weights, its chain ending at this
    // vertex. The vertex stands where the first camera vertex would, so the camera's
    // acceptance is that of its density there (and rho there is 1).
    let lens_fix = |tr_mis: f32| {
        link.as_ref().map(|(before, tail)| {
            let chain = Chain {
                links: &chunk.links[before.clone()],
                tail: Some(*tail),
                last_rev: e.pdf_rev * v.cont(),
                camera: false,
            };
            let fp = Footprint::new(dist2.sqrt());
            let camera_a = camera_pdf * e.cos / (dist2 / tr_mis);
            chain.fix(
                &pass.mis,
                &fp,
                fp.accept(camera_a, matches!(v, Vertex::Medium { .. })),
            )
        })
    };
    // Seen from the lens, the vertex would be the first camera vertex, with the
    // connection as its camera-side segment.
    let vm = |mis: &Mis, tc| v.merges(mis, dir, Some(1), tc);
    if !M::ON && !RADII {
        return Some(LensShadow {
            ray,
            raster,
            value: lens_value(
                (pass, &pass.mis),
                walk,
                (&e, walk.q, vm(&pass.mis, 1.0)),
                (v.cont(), None),
                lens_at,
                Rgb::ONE,
                1.0,
            ),
            layer,
        });
    }
    // In media, or with radius layers (whose splats share the ray): traced now.
    let rays = &mut chunk.stats.shadow_rays;
    let at = (pass.scene, pass.mis.local_media);
    let (tr, tr_mis) = shadow::<M>(at, &ray, medium, rng, rays)?;
    let fix = lens_fix(tr_mis);
    // A medium vertex is on the camera side of the light's earlier vertices.
    let cut = matches!(v, Vertex::Medium { .. }) && pass.mis.first_medium;
    let q = if cut {
        pass.mis.cut(walk.q, walk.parts.media())
    } else {
        walk.q
    };
    let value = |mis: &Mis, q| {
        let vm = vm(mis, tr_mis);
        let at = (v.cont(), fix);
        lens_value((pass, mis), walk, (&e, q, vm), at, lens_at, tr, tr_mis)
    };
    if !RADII {
        let v = value(&pass.mis, q);
        push_splat(chunk, raster, v, layer);
        return None;
    }
    let parts = if cut {
        walk.parts.without_media()
    } else {
        walk.parts
    };
    // Under the per-pixel selection, as the pixel the splat lands in weighs it.
    let main = match pass.selection.as_ref().and_then(|s| s.at_raster(raster)) {
        Some(c) => value(&c.mis, pass.mis.rescale(q, &parts, &c.scale)),
        None => value(&pass.mis, q),
    };
    push_splat(chunk, raster, main, layer);
    lens_radii(pass, chunk, raster, (q, &parts), &value);
    None
}

/// The splat of a light vertex connected to the lens: `e` is its scattering towards
/// the lens, `link` the camera ray's density per unit pixel area and the squared
/// distance, `tr` and `tr_mis` the segment's transmittance and MIS transmittance.
#[inline(always)]
fn lens_value(
    (pass, mis): (&Pass, &Mis),
    walk: &Walk,
    (e, q, vm): (&Eval, Partial, f64),
    (cont, fix): (f32, Option<Fix>),
    (camera_pdf, dist2): (f32, f32),
    tr: Rgb,
    tr_mis: f32,
) -> Rgb {
    let camera_a = camera_pdf * e.cos / (dist2 / tr_mis);
    let q = fix.map_or(q, |f| f.apply(q));
    let w = if pass.tracing.lt {
        1.0
    } else {
        mis.weight_camera_connection((q, vm), camera_a, e.pdf_rev * cont)
    };
    // The pixel integral is over unit pixel area: divide the area density by
    // camera_a's conversion, i.e. multiply by camera_pdf / dist2.
    walk.throughput * e.f * (w * camera_pdf / dist2 / pass.light_paths as f32) * tr
}

/// A point connected to a sampled lens point.
struct LensLink {
    lens: Vec3,
    raster: crate::math::Vec2,
    /// Unit direction from the point towards the lens.
    dir: Vec3,
    dist2: f32,
    /// The camera ray's solid-angle density per unit pixel area.
    camera_pdf: f32,
}

#[inline(always)]
fn lens_link(pass: &Pass, rng: &mut Rng, p: Vec3) -> Option<LensLink> {
    let cam = &pass.scene.camera;
    let lens = cam.sample_lens(rng.next_2d());
    let raster = cam.raster(p, lens)?;
    let to_cam = lens - p;
    let dist2 = to_cam.length_squared();
    let dir = to_cam / dist2.sqrt();
    Some(LensLink {
        lens,
        raster,
        dir,
        dist2,
        camera_pdf: cam.pdf_dir(-dir),
    })
}

/// Light tracing alone sees emitters through their own emission: connect the light
/// path's origin to the lens (other techniques see emitters from the camera side),
/// through the media from the camera's.
pub(super) fn splat_emitter<M: Media>(
    pass: &Pass,
    rng: &mut Rng,
    chunk: &mut Chunk,
    es: &crate::light::EmissionSample,
    li: usize,
    pick: f32,
) {
    let Light::Area(area) = &pass.scene.lights[li] else {
        return;
    };
    let Some(LensLink {
        lens,
        raster,
        dir,
        dist2,
        camera_pdf,
    }) = lens_link(pass, rng, es.p)
    else {
        return;
    };
    let le = area.le_sampled(es, dir);
    let cos = es.n.dot(dir).abs();
    if le == Rgb::ZERO || cos <= 0.0 {
        return;
    }
    let v = le * (cos * camera_pdf / (dist2 * pick * es.pdf_pos * pass.light_paths as f32));
    chunk.stats.shadow_rays += 1;
    let ray = spawn_ray_to(
        lens,
        Vec3::ZERO,
        Vec3::ZERO,
        es.p,
        es.p.abs() * gamma(6),
        es.n,
    );
    let scene = pass.scene;
    let medium = scene.camera_medium;
    let rays = &mut chunk.stats.shadow_rays;
    if let Some((tr, _)) = shadow::<M>((scene, false), &ray, medium, rng, rays) {
        push_splat(chunk, raster, v * tr, pass.layers.connection(1, 1));
    }
}

/// Keeps a splat at film position `raster`; the film spreads it by its filter.
#[inline(always)]
fn push_splat(chunk: &mut Chunk, raster: crate::math::Vec2, v: Rgb, layer: Option<usize>) {
    let layer = layer.map_or(u16::MAX, |l| l as u16);
    chunk.splats.push((raster, v, layer));
}
