//! The virtual lights of one iteration, made from the light pass's store: virtual
//! point lights at light-subpath vertices, ray lights along their segments through
//! media, and the distributions gathers draw them from.

use crate::integrator::estimators::light_tree::{Emitter, LightTree, Query};
use crate::integrator::many::vrl::Segment;
use crate::integrator::memory::{array, refilled};
use crate::integrator::paths::light_vertex::LightVertex;
use crate::integrator::paths::segments::{extent, LightSegment};
use crate::integrator::paths::store::Store as LightStore;
use crate::integrator::transport::Stream;
use crate::math::{max_component, Rgb, Vec2, Vec3};
use crate::scene::Scene;

/// A virtual point light: a stored light-subpath vertex, its power already divided by
/// the number of light paths of the iteration.
#[derive(Clone, Copy, Debug)]
pub(super) struct Vpl {
    pub p: Vec3,
    pub p_err: Vec3,
    pub ng: Vec3,
    pub ns: Vec3,
    /// The shading frame's twist about `ns` (`Frame::twisted`).
    pub twist: f32,
    /// Towards where the light came from.
    pub wo: Vec3,
    pub beta: Rgb,
    /// The surface's material; None at a scattering point in a medium.
    pub material: Option<u32>,
    /// Texture coordinates at a surface.
    pub uv: Vec2,
    /// The medium a medium vertex scatters in, or at a surface the one on `wo`'s side.
    pub medium: Option<u32>,
    /// Segments from the light to the vertex.
    pub len: u32,
}

impl Vpl {
    fn new(v: &LightVertex, inv_paths: f32) -> Self {
        let scatters = v.scattering_medium();
        Vpl {
            p: v.p,
            p_err: v.p_err,
            ng: v.ng,
            ns: v.ns,
            twist: v.twist,
            wo: v.wo,
            beta: v.throughput * inv_paths,
            material: scatters.is_none().then_some(v.material),
            uv: v.uv,
            medium: scatters.or(v.arrival_medium()),
            len: v.len,
        }
    }
}

/// A ray light: a light-subpath segment through one medium, every point of which
/// scatters the power that reaches it.
///
/// A segment that ends at a surface (or where a heterogeneous medium's field ends) is
/// used whole, from its origin to that end, with the transmittance from the origin to
/// each point (the long form). An unbounded segment in a homogeneous medium is cut at
/// a distance drawn from exp(-sigma u) (sigma: the smallest non-zero extinction of its
/// channels); dividing by the probability exp(-sigma u) that the cut lies beyond u
/// keeps every point's expected weight T(u) (the short form of photon beams, Jarosz et
/// al. 2011, sec. 5.1), and the weight T(u) / exp(-sigma u) <= 1.
#[derive(Clone, Copy, Debug)]
pub(super) struct RayLight {
    pub seg: Segment,
    /// Power entering the segment, divided by the number of light paths.
    pub beta: Rgb,
    pub medium: u32,
    /// Segments from the light to the end of this one.
    pub len: u32,
    /// Rate of the cut (0: not cut).
    pub cut: f32,
}

/// Draws among virtual lights for a query, in proportion to an estimate of their
/// contribution there (power over distance, `estimators::light_tree`); the gather divides by
/// the probability. The cost of a draw grows with the tree's depth, not with the
/// number of lights.
#[derive(Default)]
pub(super) struct Picker {
    tree: LightTree,
    items: Vec<Emitter>,
}

impl Picker {
    fn build(&mut self, items: impl Iterator<Item = Emitter>) {
        self.items.clear();
        self.items.extend(items);
        self.tree.build(&self.items);
    }

    /// An index and its probability for the query, from the uniform number `u`.
    #[inline]
    pub fn pick(&self, q: &Query, u: f32) -> Option<(usize, f32)> {
        self.tree.sample(q, u).filter(|&(_, p)| p > 0.0)
    }

    pub fn is_empty(&self) -> bool {
        self.tree.is_empty()
    }

    fn bytes(&self) -> usize {
        self.tree.bytes() + self.items.capacity() * std::mem::size_of::<Emitter>()
    }
}

/// What an iteration's gathers draw from.
#[derive(Default)]
pub(super) struct Lights {
    pub vpls: Vec<Vpl>,
    pub rays: Vec<RayLight>,
    pub vpl_pick: Picker,
    pub ray_pick: Picker,
}

/// Which virtual lights a method makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Kinds {
    /// Medium vertices become VPLs too (`vpl`); otherwise only surface vertices do and
    /// media light by ray lights.
    pub medium_vpls: bool,
    pub ray_lights: bool,
}

impl Kinds {
    /// `vpl`'s (every vertex a VPL), or else `vrl`'s and `vbl`'s (ray lights in media).
    pub fn of_vpl(vpl: bool) -> Kinds {
        Kinds {
            medium_vpls: vpl,
            ray_lights: !vpl,
        }
    }
}

impl Lights {
    /// Rebuilds from the light pass of `iteration`.
    pub fn build(
        &mut self,
        scene: &Scene,
        store: &LightStore,
        kinds: Kinds,
        seed: u64,
        iteration: u64,
    ) {
        let inv_paths = 1.0 / store.paths().max(1) as f32;
        self.vpls.clear();
        self.vpls.extend(
            store
                .vertices()
                .filter(|v| kinds.medium_vpls || v.scattering_medium().is_none())
                .map(|v| Vpl::new(v, inv_paths)),
        );
        self.vpl_pick.build(
            self.vpls
                .iter()
                .map(|v| Emitter::point(v.p, max_component(v.beta))),
        );
        self.rays.clear();
        if kinds.ray_lights {
            for (i, s) in store.segments().enumerate() {
                let mut rng = Stream::VirtualLights.rng(seed, iteration, i as u64);
                if let Some(r) = ray_light(scene, s, inv_paths, rng.next_f32()) {
                    self.rays.push(r);
                }
            }
        }
        self.ray_pick.build(self.rays.iter().map(|r| Emitter {
            a: r.seg.o,
            b: r.seg.at(r.seg.tmax),
            power: ray_power(scene, r),
        }));
    }

    /// Bytes held once built over `vpls` virtual point lights and `rays` ray lights
    /// (what [`Lights::bytes`] then reports): each array as it is refilled, and each
    /// picker's copy of the lights and tree.
    pub fn bytes_for(vpls: f64, rays: f64) -> f64 {
        let picker = |n: f64| array::<Emitter>(refilled(n, 0.0)) + LightTree::bytes_for(n);
        array::<Vpl>(refilled(vpls, 0.0))
            + picker(vpls)
            + array::<RayLight>(refilled(rays, 0.0))
            + picker(rays)
    }

    pub fn bytes(&self) -> usize {
        self.vpls.capacity() * std::mem::size_of::<Vpl>()
            + self.rays.capacity() * std::mem::size_of::<RayLight>()
            + self.vpl_pick.bytes()
            + self.ray_pick.bytes()
    }
}

fn ray_light(scene: &Scene, s: &LightSegment, inv_paths: f32, xi: f32) -> Option<RayLight> {
    let m = &scene.media[s.medium as usize];
    let (len, cut) = extent(m, s.o, s.d, s.tmax, xi)?;
    Some(RayLight {
        seg: Segment::new(s.o, s.d, len),
        beta: s.beta * inv_paths,
        medium: s.medium,
        len: s.len,
        cut,
    })
}

/// The selection weight of a ray light: its power times the fraction a grey medium of
/// the sampling extinction would scatter over its length, times the largest albedo.
fn ray_power(scene: &Scene, r: &RayLight) -> f32 {
    let m = &scene.media[r.medium as usize];
    let sigma = m.sampling_sigma_t();
    let scattered = -(-sigma * r.seg.tmax).exp_m1();
    max_component(r.beta) * scattered * max_component(m.albedo_at(r.seg.o)).max(1e-3)
}
