//! The radius layers (`radii`) of the camera pass: every estimate at a camera vertex
//! also weighted under each layer's MIS, from the same subpaths and their per-estimator
//! parts ([`crate::integrator::paths::parts`]). Out of line where the usual pass has no
//! layers, so that it pays only a branch.

use super::camera_path::record;
use super::connect::light_side;
use super::merge::{MergeSet, MergeVertex};
use super::Pass;
use crate::integrator::paths::light_vertex::LightVertex;
use crate::integrator::paths::partial::{Merge, Mis, Partial};
use crate::integrator::paths::parts::{Parts, RadiusLayer, Scale};
use crate::integrator::paths::walk::Walk;
use crate::math::Rgb;
use std::sync::atomic::AtomicU32;

/// The camera subpath's partial weights in radius layer `l`.
#[inline(always)]
pub(super) fn camera_q(pass: &Pass, walk: &Walk, l: &RadiusLayer) -> Partial {
    pass.mis.rescale(walk.q, &walk.parts, &l.scale)
}

/// The same in every radius layer, for the loops over light vertices (empty, and
/// no allocation, without layers).
#[inline(always)]
pub(super) fn camera_qs(pass: &Pass, walk: &Walk) -> Vec<Partial> {
    let layers = pass.radius_layers.iter();
    layers.map(|l| camera_q(pass, walk, l)).collect()
}

/// A light vertex's partial weights `q` (cut if `cut`, its media part `vol`) under
/// the factors `scale` (a radius layer's, a candidate's), from its `parts`.
#[inline(always)]
pub(super) fn light_q(
    pass: &Pass,
    (q, vol, parts): (Partial, f64, &Parts),
    cut: bool,
    scale: &Scale,
) -> Partial {
    let mis = &pass.mis;
    match cut {
        true => mis.rescale(mis.cut(q, vol), &parts.without_media(), scale),
        false => mis.rescale(q, parts, scale),
    }
}

/// Records in every radius layer a sample of value `c` times its weight there,
/// `weight(l)`; nothing unless the pass has layers (`RADII`).
#[inline(always)]
pub(super) fn record_radii<const RADII: bool>(
    pass: &Pass,
    slots: &[AtomicU32],
    c: Rgb,
    weight: impl Fn(&RadiusLayer) -> f32,
) {
    if RADII {
        record_radii_cold(pass, slots, c, weight);
    }
}

/// Out of line: the usual sample has no radius layers.
#[cold]
#[inline(never)]
fn record_radii_cold(
    pass: &Pass,
    slots: &[AtomicU32],
    c: Rgb,
    weight: impl Fn(&RadiusLayer) -> f32,
) {
    for l in &pass.radius_layers {
        record(slots, Some(l.layer), c * weight(l));
    }
}

/// A light sample's values in the radius layers, `weight` giving its weight under a
/// MIS and camera partial weights, `c / pdf` its unweighted value. Out of line: the
/// usual sample has no layers.
#[cold]
#[inline(never)]
pub(super) fn light_sample_radii(
    pass: &Pass,
    walk: &Walk,
    weight: &impl Fn(&Mis, Partial) -> f32,
    (c, pdf): (Rgb, f32),
    slots: &[AtomicU32],
) {
    for l in &pass.radius_layers {
        let w = weight(&l.mis, camera_q(pass, walk, l));
        record(slots, Some(l.layer), walk.throughput * (c * (w / pdf)));
    }
}

/// A connection's values in the radius layers: light vertex `y` with its parts (and
/// whether its side is cut), the camera subpath's partial weights in each layer, M(x)
/// of both vertices under a MIS (`vm`: light, camera), the four densities of
/// [`Mis::weight_connection`], and the unweighted value and d^2. Out of line: the
/// usual connection has no layers.
#[cold]
#[inline(never)]
pub(super) fn connection_radii(
    pass: &Pass,
    slots: &[AtomicU32],
    ((y, parts, cut), camera): ((&LightVertex, &Parts, bool), &[Partial]),
    vm: impl Fn(&Mis) -> (f64, f64),
    [a, b, c, d]: [f32; 4],
    (value, dist2): (Rgb, f32),
) {
    for (l, &q) in pass.radius_layers.iter().zip(camera) {
        let (vm_light, vm_camera) = vm(&l.mis);
        let light = light_side(pass, y, cut, |_| vm_light, Some((parts, &l.scale, &l.mis)));
        let w = l.mis.weight_connection(light, (q, vm_camera), a, b, c, d);
        record(slots, Some(l.layer), value * (w / dist2));
    }
}

/// The sums of a merge in the radius layers: each light vertex within a layer's
/// radius, weighted under the layer's MIS, and the layer's kernel normalisation.
/// Without layers (`RADII` false) it holds and does nothing.
pub(super) struct RadiusSums<'p, const RADII: bool> {
    pass: &'p Pass<'p>,
    /// The camera subpath's partial weights in each layer, and the layer's sum.
    layers: Vec<(Partial, Rgb)>,
    k: Merge,
}

impl<'p, const RADII: bool> RadiusSums<'p, RADII> {
    #[inline(always)]
    pub(super) fn new(pass: &'p Pass<'p>, walk: &'p Walk, k: Merge) -> Self {
        let layers = match RADII {
            true => camera_qs(pass, walk)
                .into_iter()
                .map(|q| (q, Rgb::ZERO))
                .collect(),
            false => Vec::new(),
        };
        RadiusSums { pass, layers, k }
    }

    /// Light vertex `y` of `set` at squared distance `d2`, its partial weights cut if
    /// `cut`, whose weighted value under a MIS and both sides' partial weights is
    /// `value`.
    #[inline(always)]
    pub(super) fn add(
        &mut self,
        set: &MergeSet,
        y: &MergeVertex,
        d2: f32,
        cut: bool,
        value: impl Fn(&Mis, Partial, Partial) -> Rgb,
    ) {
        let pass = self.pass;
        if !RADII {
            return;
        }
        let parts = set.parts_of(y);
        for (l, (q, sum)) in pass.radius_layers.iter().zip(&mut self.layers) {
            if d2 <= l.radii[self.k as usize].powi(2) {
                let yq = light_q(pass, (y.q, y.vol(), parts), cut, &l.scale);
                *sum += value(&l.mis, yq, *q);
            }
        }
    }

    /// Records the sums, times `beta` and each layer's kernel normalisation.
    #[inline(always)]
    pub(super) fn record(&self, beta: Rgb, slots: &[AtomicU32]) {
        if !RADII {
            return;
        }
        for (l, &(_, sum)) in self.pass.radius_layers.iter().zip(&self.layers) {
            record(slots, Some(l.layer), beta * sum * l.norms[self.k as usize]);
        }
    }
}

/// The index in `all` of `item`, a reference into it (what a grid or BVH query hands
/// back), for the side arrays kept in the same order.
#[inline(always)]
pub(super) fn index_in<T>(all: &[T], item: &T) -> usize {
    let offset = item as *const T as usize - all.as_ptr() as usize;
    offset / std::mem::size_of::<T>()
}
