//! The connections of a camera vertex: its light sample (next event estimation) and
//! its connections to the vertices of the paired light subpath, each weighted by
//! [`super::mis`] and, with radius layers, under every layer's MIS.

use super::camera_path::record;
use super::radius_layers::{camera_qs, connection_radii, light_q, light_sample_radii};
use super::selection::camera_main;
use super::Pass;
use crate::geometry::Ray;
use crate::integrator::paths::correlation::{light_origin, CameraSide, Chain, Link};
use crate::integrator::paths::light_vertex::LightVertex;
use crate::integrator::paths::media::{shadow, Owner};
use crate::integrator::paths::partial::{Mis, Partial, Site};
use crate::integrator::paths::parts::{Candidate, Parts, Scale};
use crate::integrator::paths::vertex::{Media, Vertex};
use crate::integrator::paths::walk::Walk;
use crate::integrator::transport::nee::pick_light;
use crate::integrator::RenderStats;
use crate::light::Light;
use crate::material::Mode;
use crate::math::{Rgb, Rng, Vec3};
use std::sync::atomic::AtomicU32;

/// M(x) of camera vertex `v` with `other` the direction of its other segment: 0 at a
/// medium vertex that `merge_depth: first` takes out (a medium vertex before it).
#[inline(always)]
fn camera_merges<M: Media>(mis: &Mis, walk: &Walk, v: &Vertex<M>, other: Vec3) -> f64 {
    if matches!(v, Vertex::Medium { .. }) && mis.cuts(walk.medium_seen) {
        return 0.0;
    }
    v.merges(mis, other, Some(walk.len), walk.tr)
}

/// Light vertex `y`'s partial weights and M(y) (`merges`, evaluated only if needed)
/// in a connection whose camera side holds a medium vertex when `camera_medium`, as
/// `merge_depth: first` has them ([`Mis::cuts`]): y too is on the camera side of
/// the light's earlier vertices. With `other` (y's parts, and the factors and MIS of
/// a radius layer or candidate), under that MIS.
///
/// [`Mis::cuts`]: crate::integrator::paths::partial::Mis::cuts
#[inline(always)]
pub(super) fn light_side(
    pass: &Pass,
    y: &LightVertex,
    camera_medium: bool,
    merges: impl FnOnce(&Mis) -> f64,
    other: Option<(&Parts, &Scale, &Mis)>,
) -> (Partial, f64) {
    let mis = &pass.mis;
    let medium = y.site() == Site::Medium;
    let cut = mis.cuts(camera_medium || medium);
    let (q, own) = match other {
        None if cut => (mis.cut(y.q, y.vol()), mis),
        None => (y.q, mis),
        Some((parts, scale, own)) => (light_q(pass, (y.q, y.vol(), parts), cut, scale), own),
    };
    (
        q,
        if medium && mis.cuts(camera_medium) {
            0.0
        } else {
            merges(own)
        },
    )
}

/// Light sampling from a camera vertex through the media on the way ([TR] eqs.
/// 44-45, with the segment's MIS transmittance dividing the light's density as it
/// divides d^2, mis.rs). Without media the shadow ray is returned untraced: the
/// contribution counts only if it is unblocked.
#[inline(always)]
pub(super) fn light_sample<M: Media, const RADII: bool>(
    pass: &Pass,
    (walk, cand, side): (&Walk, Option<&Candidate>, Option<CameraSide>),
    v: &Vertex<M>,
    rng: &mut Rng,
    stats: &mut RenderStats,
    slots: &[AtomicU32],
) -> (Rgb, Option<Ray>) {
    let scene = pass.scene;
    let none = (Rgb::ZERO, None);
    let Some((li, pick, ls)) = pick_light(scene, v.p(), rng) else {
        return none;
    };
    let light = &scene.lights[li];
    let Some(e) = v.eval(ls.wi(), Mode::Radiance) else {
        return none;
    };
    stats.connections += 1;
    stats.shadow_rays += 1;
    let (ray, medium) = if ls.dist.is_finite() {
        v.ray_to(pass, walk.medium, ls.p(), Vec3::ZERO, Vec3::ZERO)
    } else {
        v.ray_along(pass, walk.medium, ls.wi())
    };
    let (tr, tr_mis, untraced) = if M::ON {
        let rays = &mut stats.shadow_rays;
        let at = (scene, pass.mis.local_media);
        let Some((tr, tr_mis)) = shadow::<M>(at, &ray, medium, rng, rays) else {
            return none;
        };
        (tr, tr_mis, None)
    } else {
        (Rgb::ONE, 1.0, Some(ray))
    };
    // SmallVCM's conventions: point-like lights have unit area density, so their
    // solid-angle density is dist^2; lights without a surface have cos 1.
    let (direct, cos_light) = match light {
        Light::Area(_) => (ls.pdf, ls.n().dot(ls.wi()).abs()),
        Light::Point(_) | Light::Spot(_) => (ls.dist * ls.dist, 1.0),
        _ => (ls.pdf, 1.0),
    };
    let (pos, dir) = light.pdf_le(&scene.sphere, ls.n(), -ls.wi());
    let cont = v.cont();
    let bsdf_dir = if light.is_delta() {
        0.0
    } else {
        e.pdf_dir * cont
    };
    let weighted = |mis: &Mis, q, rho: f64| {
        mis.weight_light_sample(
            q,
            camera_merges(mis, walk, v, ls.wi()) * rho,
            pick,
            direct / tr_mis,
            pos * dir,
            cos_light,
            e.cos,
            bsdf_dir,
            e.pdf_rev * cont,
        )
    };
    let weight = |mis: &Mis, q| weighted(mis, q, 1.0);
    let (mis, q) = camera_main(pass, cand, walk);
    let w = match side {
        None => weight(mis, q),
        Some(s) => {
            // Correlation-aware: the light's origin and its density of this vertex
            // are the crossing acceptances of the camera's side.
            let medium = matches!(v, Vertex::Medium { .. });
            let infinite = light.is_infinite();
            let (origin, first) = light_origin(infinite, light.is_delta(), pick, (pos, dir));
            // The first segment's density converted to this vertex's measure.
            let geo = match infinite {
                true => e.cos * tr_mis,
                false => e.cos * tr_mis / (ls.dist * ls.dist),
            };
            let other = s.fp.accept(origin, false) * s.fp.accept(first * geo, medium);
            let fix = s.chain(None, e.pdf_rev * cont).fix(mis, &s.fp, other);
            weighted(mis, fix.apply(q), fix.rho)
        }
    };
    let c = e.f * ls.li() * tr;
    if !RADII {
        return (c * (w / (pick * ls.pdf)), untraced);
    }
    // With radius layers the shadow ray is traced now, for all of them at once.
    if untraced.is_some_and(|ray| !scene.visible(&ray)) {
        return none;
    }
    light_sample_radii(pass, walk, &weight, (c, pick * ls.pdf), slots);
    (c * (w / (pick * ls.pdf)), None)
}

/// Connections to the vertices of the light subpath paired with this pixel, through
/// the media between them ([TR] eqs. 40-41 with d^2 / T, mis.rs), throughput included.
#[inline(always)]
pub(super) fn connect<M: Media, const RADII: bool>(
    pass: &Pass,
    (light, light_parts, links): (&[LightVertex], &[Parts], &[Link]),
    (walk, cand, side): (&Walk, Option<&Candidate>, Option<CameraSide>),
    v: &Vertex<M>,
    rng: &mut Rng,
    stats: &mut RenderStats,
    layers: &[AtomicU32],
) -> Rgb {
    let scene = pass.scene;
    let cont = v.cont();
    let mut l = Rgb::ZERO;
    // The camera side of every light vertex holds this one and those before it.
    let cut = walk.medium_seen || matches!(v, Vertex::Medium { .. });
    let camera = match RADII && !light.is_empty() {
        true => camera_qs(pass, walk),
        false => Vec::new(),
    };
    let (mis, q) = camera_main(pass, cand, walk);
    let v_medium = matches!(v, Vertex::Medium { .. });
    let cam_total = side.map_or(1.0, |s| s.chain(None, 0.0).total(&s.fp));
    for (i, y) in light.iter().enumerate() {
        // Vertices are stored in order of path length.
        if y.len + 1 + walk.len > pass.s.max_depth {
            break;
        }
        let to_light = y.p - v.p();
        let dist2 = to_light.length_squared();
        if dist2 <= 0.0 {
            continue;
        }
        let dir = to_light / dist2.sqrt();
        let Some(ec) = v.eval(dir, Mode::Radiance) else {
            continue;
        };
        let mut owner = Owner::default();
        let ys = y.scatterer::<M>(pass, &mut owner);
        let Some(el) = ys.eval(-dir, Mode::Importance) else {
            continue;
        };
        stats.connections += 1;
        stats.shadow_rays += 1;
        let (ray, medium) = v.ray_to(pass, walk.medium, y.p, y.p_err, y.ng);
        let rays = &mut stats.shadow_rays;
        let at = (scene, pass.mis.local_media);
        let Some((tr, tr_mis)) = shadow::<M>(at, &ray, medium, rng, rays) else {
            continue;
        };
        let seg = dist2 / tr_mis;
        let y_cont = ys.cont();
        let densities = [
            ec.pdf_dir * cont * el.cos / seg,
            el.pdf_dir * y_cont * ec.cos / seg,
            el.pdf_rev * y_cont,
            ec.pdf_rev * cont,
        ];
        let [a, b, c, d] = densities;
        let other = cand.map(|c| (&light_parts[i], &c.scale, &c.mis));
        let (mut yq, mut vm_y) =
            light_side(pass, y, cut, |m| ys.merges(m, dir, None, tr_mis), other);
        let (mut xq, mut vm_x) = (q, camera_merges(mis, walk, v, dir));
        if let Some(s) = side {
            // Correlation-aware: each side's acceptance at the junction is the
            // other's whole product times its crossing density's.
            let (lc, cc) = (Chain::light(&links[..=i], c), s.chain(None, d));
            let y_medium = y.site() == Site::Medium;
            let (fl, lt) = lc.fix_total(mis, &s.fp, cam_total * s.fp.accept(a, y_medium));
            let fc = cc.fix(mis, &s.fp, lt * s.fp.accept(b, v_medium));
            (yq, vm_y, xq, vm_x) = (fl.apply(yq), vm_y * fl.rho, fc.apply(xq), vm_x * fc.rho);
        }
        let w = mis.weight_connection((yq, vm_y), (xq, vm_x), a, b, c, d);
        let c = walk.throughput * y.throughput * ec.f * el.f * tr * (w / dist2);
        if RADII {
            let unweighted = walk.throughput * y.throughput * ec.f * el.f * tr;
            let y = (y, &light_parts[i], cut);
            let vm = |m: &Mis| {
                (
                    ys.merges(m, dir, None, tr_mis),
                    camera_merges(m, walk, v, dir),
                )
            };
            connection_radii(
                pass,
                layers,
                (y, &camera),
                vm,
                densities,
                (unweighted, dist2),
            );
        }
        record(layers, pass.layers.connection(y.len + 1, walk.len + 1), c);
        l += c;
    }
    l
}
