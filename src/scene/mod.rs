//! Scenes: the file format, loading and validation, and the compiled [`Scene`] that
//! integrators render (BVH, materials, lights, camera).
//!
//! Layers, bottom up (each imports only those before it): `error`, `budget`,
//! `format`; `files` (references and path checks), `meshes` (OBJ/PLY), `cube`;
//! `validate`; `mitsuba` (the XML importer); `load` (scene files: JSON or XML);
//! `materials`, `textures`, `media`, `shapes`, `tangent`, `shading`, `emitters`,
//! `lights`; `compile`. Below the scene sit `geometry`, `material`, `light` and
//! `medium`, which never import it.

mod budget;
mod compile;
mod cube;
mod emitters;
pub mod error;
pub mod files;
pub mod format;
mod lights;
pub mod load;
mod materials;
mod media;
mod meshes;
pub mod mitsuba;
mod shading;
mod shapes;
pub mod tangent;
mod textures;
pub mod validate;

pub use budget::CompileBudget;
pub use error::SceneError;
pub use format::SceneFile;

use crate::camera::Camera;
use crate::geometry::{Accel, Hit, Interaction, Ray, TexCoords};
use crate::light::{AreaLight, Light, LightSampler, SceneSphere};
use crate::material::normal_map::{Perturb, Shadowed, SurfaceFrame};
use crate::material::texture::Texture;
use crate::material::textured::{MaterialRef, Textured};
use crate::material::Material;
use crate::math::{Frame, Rgb, Rng, Vec2, Vec3};
use crate::medium::Medium;
use error::Result;
use std::path::Path;
use std::time::Duration;
use tangent::Tangents;

/// Index-matched boundaries a ray may cross before it is given up as lost (a guard
/// against rays trapped between coincident null surfaces).
pub const MAX_NULL_CROSSINGS: u32 = 256;

/// What [`Scene::next_scattering`] found.
pub enum Surfacing<'a> {
    Hit(Interaction, MaterialRef<'a>),
    /// Left the scene (environment lights apply).
    Escaped,
    /// Crossed more than MAX_NULL_CROSSINGS null boundaries.
    Lost,
}

/// Per-shape data the integrators need after a hit.
#[derive(Clone, Debug)]
pub struct ShapeInfo {
    pub name: String,
    pub material: u32,
    /// Index into `Scene::lights` when the shape emits.
    pub light: Option<u32>,
    /// Normals reversed by `flip_normals`.
    pub flip: bool,
    /// World-space vertex normals, for smooth shading of meshes.
    pub shading: Option<shapes::ShadingNormals>,
    /// Texture coordinates, for shapes whose material reads a texture.
    pub uvs: Option<TexCoords>,
    /// dp/du and dp/dv, for shapes whose material has a normal or bump map or is
    /// anisotropic.
    pub tangents: Option<tangent::Tangents>,
    /// The material is anisotropic: its shading frame follows dp/du (`shading`).
    pub oriented: bool,
    /// Medium on the side opposite the normal (index into `Scene::media`).
    pub interior: Option<u32>,
    /// Medium on the side the normal points to.
    pub exterior: Option<u32>,
}

impl ShapeInfo {
    /// Crossing the shape changes the medium (Mitsuba's rule: a shape that names no
    /// medium leaves the ray's medium as it was).
    #[inline]
    pub fn is_medium_boundary(&self) -> bool {
        self.interior.is_some() || self.exterior.is_some()
    }
}

/// Figures about the compiled scene, printed in render statistics.
#[derive(Clone, Debug, Default)]
pub struct SceneStats {
    pub triangles: usize,
    /// Pairs of triangles merged into parallelograms (counted in `triangles` too).
    pub quads: usize,
    pub spheres: usize,
    pub disks: usize,
    pub degenerate_dropped: usize,
    pub bvh_build: Duration,
    /// Threads of the rayon pool the BVH was built on (a server's: its `--workers`).
    pub bvh_threads: usize,
    pub bvh_bytes: usize,
    /// Decoded texture images.
    pub texture_bytes: usize,
}

/// `template` with its textures evaluated at `uv`; out of line, so the untextured
/// path through [`Scene::material_at`] stays a load and a pointer.
#[inline(never)]
fn resolved<'a>(t: &Textured, template: &Material, uv: Vec2) -> MaterialRef<'a> {
    MaterialRef::owned(t.resolve(template, uv))
}

/// Whether `ray` passes through a mask of `opacity` at texture coordinates `uv`.
#[inline(never)]
fn mask_passes(opacity: &Texture, uv: Vec2, ray: &Ray) -> bool {
    ray_hash(ray) >= opacity.eval_scalar(uv)
}

/// A number in [0, 1) from the bits of a ray's origin and direction: rays differ in
/// their low bits wherever they start, so it serves as an independent uniform sample
/// per ray (pbrt-v4's `HashFloat(r.o, r.d)`).
fn ray_hash(ray: &Ray) -> f32 {
    let mut h: u64 = 0x9E37_79B9_7F4A_7C15;
    for x in [ray.o.x, ray.o.y, ray.o.z, ray.d.x, ray.d.y, ray.d.z] {
        h = (h ^ u64::from(x.to_bits())).wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
    }
    h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    h ^= h >> 33;
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

/// The rest of shadow segment `r` after it crosses the null boundary at `it`: from
/// just past the boundary to the same end point, or on along the direction when the
/// segment is unbounded.
#[inline(always)]
fn beyond(it: &Interaction, r: &Ray, end: Vec3) -> Ray {
    let o = crate::geometry::offset_ray_origin(it.p, it.p_err, it.ng, r.d);
    if r.tmax.is_finite() {
        Ray {
            o,
            d: end - o,
            tmax: 1.0 - crate::geometry::offset::SHADOW_EPSILON,
        }
    } else {
        Ray::new(o, r.d)
    }
}

/// What an any-hit query met first on a shadow segment.
enum Blocker {
    Nothing,
    Opaque,
    Null,
}

pub struct Scene {
    pub accel: Accel,
    pub shapes: Vec<ShapeInfo>,
    pub materials: Vec<Material>,
    /// The textures of each material (index as `materials`; None: all constant).
    pub textured: Vec<Option<Textured>>,
    /// The opacity of each masked material (index as `materials`).
    pub opacity: Vec<Option<Texture>>,
    /// The normal or bump map of each material (index as `materials`).
    pub perturb: Vec<Option<Perturb>>,
    pub lights: Vec<Light>,
    /// Lights seen by rays that leave the scene (constant and map environments).
    pub env_lights: Vec<u32>,
    pub light_sampler: LightSampler,
    pub camera: Camera,
    /// The film's pixel filter (what camera samples and light-tracing splats are
    /// spread over the pixels by).
    pub filter: crate::film::PixelFilter,
    pub sphere: SceneSphere,
    /// Default integrator settings from the scene file.
    pub integrator: Option<serde_json::Value>,
    pub stats: SceneStats,
    /// The tree holds index-matched (`null`) boundaries (only scenes with media keep
    /// them: elsewhere they change nothing and are left out), so shadow rays must
    /// look through them.
    pub has_null: bool,
    /// Participating media, indexed by `ShapeInfo::interior` / `exterior`.
    pub media: Vec<Medium>,
    /// The medium the camera sits in.
    pub camera_medium: Option<u32>,
    /// A shape or the camera refers to a medium: rays must track media. Declared but
    /// unused media leave this false, and the scene renders as if they did not exist.
    pub has_media: bool,
    /// The medium each light emits into (index as `lights`), for light tracing.
    pub light_media: Vec<Option<u32>>,
}

impl Scene {
    /// Loads, validates and compiles a scene file; assets resolve next to it.
    pub fn load(path: &Path) -> Result<Scene> {
        Scene::load_within(path, &CompileBudget::LOCAL)
    }

    /// [`Scene::load`], refusing a scene that exceeds `budget`.
    pub fn load_within(path: &Path, budget: &CompileBudget) -> Result<Scene> {
        let file = load::read_scene_file(path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        Scene::compile_within(&file, Some(base), budget)
    }

    /// Compiles a parsed scene. Without `base`, file references are refused.
    pub fn compile(file: &SceneFile, base: Option<&Path>) -> Result<Scene> {
        Scene::compile_within(file, base, &CompileBudget::LOCAL)
    }

    /// [`Scene::compile`], refusing a scene that exceeds `budget`. The compile's
    /// parallel parts (the BVH build) run on the calling thread's rayon pool.
    pub fn compile_within(
        file: &SceneFile,
        base: Option<&Path>,
        budget: &CompileBudget,
    ) -> Result<Scene> {
        validate::validate(file)?;
        compile::compile(file, base, budget)
    }

    /// Closest surface along the ray, with normals on the shape's front side.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray) -> Option<Interaction> {
        let hit = self.hit(ray)?;
        Some(self.interaction(ray, &hit))
    }

    /// Distance and primitive of the closest hit only; [`Scene::interaction`] makes
    /// the surface point when it is needed (a free flight often ends before it).
    #[inline(always)]
    pub fn hit(&self, ray: &Ray) -> Option<Hit> {
        self.accel.intersect(ray)
    }

    /// The surface point of a hit, with the shape's normal flip and shading normals.
    #[inline(always)]
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> Interaction {
        let mut it = self.accel.interaction(ray, hit);
        let shape = &self.shapes[it.shape as usize];
        if shape.flip {
            it.ng = -it.ng;
        }
        it.ns = match &shape.shading {
            Some(s) => s.normal(it.local, hit.uv, it.ng),
            None => it.ng,
        };
        if let Some(t) = &shape.tangents {
            it.ns = self.perturbed_normal(it, shape, t, -ray.d);
        }
        it
    }

    /// The shading normal of a hit on a normal- or bump-mapped shape, for light
    /// arriving from `wo` (see `material::normal_map`).
    #[cold]
    #[inline(never)]
    fn perturbed_normal(&self, it: Interaction, shape: &ShapeInfo, t: &Tangents, wo: Vec3) -> Vec3 {
        let (Some(p), Some(uvs)) = (&self.perturb[shape.material as usize], &shape.uvs) else {
            return it.ns;
        };
        let (dpdu, dpdv) = t.at(&it);
        let frame = SurfaceFrame {
            ns: it.ns,
            ng: it.ng,
            dpdu,
            dpdv,
        };
        p.normal(uvs.uv(&it), &frame, wo)
    }

    /// The next point where `ray` scatters: the closest hit that is not an
    /// index-matched (`null`) boundary, which light passes straight through. `ray` is
    /// advanced past the boundaries; each extra ray traced is added to `rays`.
    #[inline(always)]
    pub fn next_scattering(&self, ray: &mut Ray, rays: &mut u64) -> Surfacing<'_> {
        for _ in 0..=MAX_NULL_CROSSINGS {
            let Some(it) = self.intersect(ray) else {
                return Surfacing::Escaped;
            };
            if !self.passes(&it, ray) {
                let m = self.material(&it);
                return Surfacing::Hit(it, m);
            }
            *ray = crate::geometry::spawn_ray(it.p, it.p_err, it.ng, ray.d);
            *rays += 1;
        }
        Surfacing::Lost
    }

    /// [`next_scattering`](Self::next_scattering) along `ray` and
    /// [`visible`](Self::visible) along `shadow` (true when there is none), the two
    /// traversals interleaved where the tree holds no null boundaries.
    ///
    /// Without a shadow ray the paired kernel still runs, with an empty any-hit ray
    /// (tmax -1, whose walk it skips): one traversal kernel then stays hot in the
    /// caches and branch predictors (Cornell box `pt`: 2-5% faster than the single-ray
    /// kernel for camera rays).
    #[inline(always)]
    pub fn next_scattering_and_visible(
        &self,
        ray: &mut Ray,
        shadow: Option<&Ray>,
        rays: &mut u64,
    ) -> (Surfacing<'_>, bool) {
        if self.has_null {
            let visible = shadow.is_none_or(|s| self.visible(s));
            return (self.next_scattering(ray, rays), visible);
        }
        // A constant, not a copy of `ray`: copying the ray just written by the
        // caller's scalar stores stalled on store forwarding (perf, Cornell box).
        const NONE: Ray = Ray {
            o: Vec3::ZERO,
            d: Vec3::Z,
            tmax: -1.0,
        };
        let shadow = shadow.unwrap_or(&NONE);
        let (hit, occluded) = self.accel.intersect_and_occluded(ray, shadow);
        let surfacing = match hit {
            // Without null boundaries in the tree the first hit scatters.
            Some(hit) => {
                let it = self.interaction(ray, &hit);
                let m = self.material(&it);
                Surfacing::Hit(it, m)
            }
            None => Surfacing::Escaped,
        };
        (surfacing, !occluded)
    }

    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.accel.occluded(ray)
    }

    /// True when nothing opaque blocks the shadow ray. Index-matched (`null`) surfaces
    /// let light through; scenes without them take the plain any-hit query, inlined
    /// into the callers' kernels.
    #[inline(always)]
    pub fn visible(&self, ray: &Ray) -> bool {
        if !self.has_null {
            return !self.accel.occluded(ray);
        }
        self.visible_through_null(ray)
    }

    /// [`visible`](Self::visible) in a scene with null boundaries.
    #[inline(never)]
    fn visible_through_null(&self, ray: &Ray) -> bool {
        match self.any_blocker(ray) {
            Blocker::Nothing => return true,
            Blocker::Opaque => return false,
            Blocker::Null => {}
        }
        let end = ray.at(ray.tmax);
        let mut r = *ray;
        for _ in 0..MAX_NULL_CROSSINGS {
            let Some(hit) = self.accel.intersect(&r) else {
                return true;
            };
            let it = self.accel.interaction(&r, &hit);
            if !self.passes(&it, &r) {
                return false;
            }
            r = beyond(&it, &r, end);
        }
        false
    }

    /// The medium a ray is in after leaving surface point `it` in direction `w`,
    /// coming from `current`.
    #[inline]
    pub fn medium_after(&self, it: &Interaction, w: Vec3, current: Option<u32>) -> Option<u32> {
        let s = &self.shapes[it.shape as usize];
        if !s.is_medium_boundary() {
            current
        } else if w.dot(it.ng) > 0.0 {
            s.exterior
        } else {
            s.interior
        }
    }

    /// The medium at point `p`, found by walking a ray to the first medium boundary
    /// (any direction works when boundaries are closed). A point outside every
    /// boundary is in vacuum, unless the scene has no boundaries at all: then it is in
    /// the camera's (unbounded) medium.
    pub fn medium_at(&self, p: Vec3) -> Option<u32> {
        if !self.has_media {
            return None;
        }
        if !self.shapes.iter().any(|s| s.is_medium_boundary()) {
            return self.camera_medium;
        }
        // An irrational-looking direction, to avoid grazing edges of axis-aligned boxes.
        let d = Vec3::new(0.2718, 0.5772, 0.7705).normalize();
        let mut ray = Ray::new(p, d);
        for _ in 0..4 * MAX_NULL_CROSSINGS {
            let it = self.intersect(&ray)?;
            let s = &self.shapes[it.shape as usize];
            if s.is_medium_boundary() {
                // Leaving through the boundary means we were on its inner side.
                return if d.dot(it.ng) > 0.0 {
                    s.interior
                } else {
                    s.exterior
                };
            }
            ray = crate::geometry::spawn_ray(it.p, it.p_err, it.ng, d);
        }
        None
    }

    /// Transmittance along a shadow ray (its segment t in (0, tmax), any direction
    /// length) that starts in `medium`: zero if an opaque surface blocks it; media
    /// change at boundaries on the way. Estimated with `rng` in heterogeneous media.
    #[inline(always)]
    pub fn transmittance(
        &self,
        ray: &Ray,
        medium: Option<u32>,
        rng: &mut Rng,
        rays: &mut u64,
    ) -> Rgb {
        self.transmittance_mis(ray, medium, rng, rays, false).0
    }

    /// [`Scene::transmittance`], and the grey optical depth that bidirectional MIS
    /// assigns the segment: the sum of `Medium::mis_depth` over the media it crosses
    /// (heterogeneous ones only when `local`). A deterministic function of the segment,
    /// unlike the estimate; only meaningful when the estimate is not zero.
    #[inline(always)]
    pub fn transmittance_mis(
        &self,
        ray: &Ray,
        mut medium: Option<u32>,
        rng: &mut Rng,
        rays: &mut u64,
        local: bool,
    ) -> (Rgb, f32) {
        if !self.has_media {
            let tr = if self.visible(ray) {
                Rgb::ONE
            } else {
                Rgb::ZERO
            };
            return (tr, 0.0);
        }
        let mut tr = Rgb::ONE;
        let mut depth = 0.0f32;
        match self.any_blocker(ray) {
            Blocker::Opaque => return (Rgb::ZERO, 0.0),
            Blocker::Nothing => {
                if let Some(m) = medium {
                    self.attenuate(ray, (ray.tmax, local), m, rng, &mut tr, &mut depth);
                }
                return (tr, depth);
            }
            Blocker::Null => {}
        }
        let end = ray.at(ray.tmax);
        let mut r = *ray;
        for _ in 0..MAX_NULL_CROSSINGS {
            let hit = self.hit(&r);
            if let Some(m) = medium {
                let t_end = hit.as_ref().map_or(r.tmax, |h| h.t);
                self.attenuate(&r, (t_end, local), m, rng, &mut tr, &mut depth);
                if tr == Rgb::ZERO {
                    return (tr, depth);
                }
            }
            let Some(hit) = hit else {
                return (tr, depth);
            };
            let it = self.interaction(&r, &hit);
            if !self.passes(&it, &r) {
                return (Rgb::ZERO, depth);
            }
            medium = self.medium_after(&it, r.d, medium);
            *rays += 1;
            r = beyond(&it, &r, end);
        }
        (Rgb::ZERO, depth)
    }

    /// Multiplies `tr` by medium `m`'s transmittance along `r` up to parameter `t_end`,
    /// and adds the segment's optical depth for MIS to `depth`.
    #[inline(always)]
    fn attenuate(
        &self,
        r: &Ray,
        (t_end, local): (f32, bool),
        m: u32,
        rng: &mut Rng,
        tr: &mut Rgb,
        depth: &mut f32,
    ) {
        let len = r.d.length();
        let med = &self.media[m as usize];
        *tr *= med.transmittance(r.o, r.d / len, t_end * len, rng);
        *depth += match med.mis_sigma_t() {
            Some(s) if s > 0.0 => s * t_end * len,
            Some(_) => 0.0,
            None => med.mis_depth(r.o, r.d / len, 0.0, t_end * len, local),
        };
    }

    /// Solid-angle density with which next-event estimation picks an escaping
    /// direction `d` (all environment lights, selection included).
    #[inline]
    pub fn env_pdf(&self, d: Vec3) -> f32 {
        self.env_lights
            .iter()
            .map(|&l| {
                self.light_sampler.pmf(l as usize)
                    * self.lights[l as usize].pdf_li(Vec3::ZERO, d, Vec3::ZERO, Vec3::ZERO)
            })
            .sum()
    }

    /// What one any-hit query finds on the segment. Most shadow rays cross no
    /// index-matched boundary, and then this settles them without the closest-hit walk:
    /// an opaque surface anywhere on the segment blocks it, wherever it lies.
    #[inline(always)]
    fn any_blocker(&self, ray: &Ray) -> Blocker {
        match self.accel.any_hit(ray) {
            None => Blocker::Nothing,
            Some(prim) => {
                let shape = &self.shapes[self.accel.meta(prim).shape as usize];
                match self.materials[shape.material as usize] {
                    Material::Null => Blocker::Null,
                    _ if self.opacity[shape.material as usize].is_some() => Blocker::Null,
                    _ => Blocker::Opaque,
                }
            }
        }
    }

    /// The texture coordinates of a hit (zero on shapes whose material reads no
    /// texture).
    #[inline(always)]
    pub fn uv(&self, it: &Interaction) -> Vec2 {
        // A match, not `Option::map_or`: that call was left out of line in the light
        // pass, and its closure's reference kept the hit (and its vertex) in memory.
        match &self.shapes[it.shape as usize].uvs {
            None => Vec2::ZERO,
            Some(t) => t.uv(it),
        }
    }

    /// Whether `ray` goes on through the surface it hit at `it`: an index-matched
    /// (`null`) boundary, or a masked surface where the ray meets a hole. A mask of
    /// opacity a stops a ray with probability a, decided by a hash of the ray (pbrt-v4's
    /// stochastic alpha test), so the same ray always gets the same answer and camera
    /// rays, light paths and shadow rays all see the mask.
    #[inline(always)]
    pub fn passes(&self, it: &Interaction, ray: &Ray) -> bool {
        let m = self.shapes[it.shape as usize].material;
        match &self.opacity[m as usize] {
            None => matches!(self.materials[m as usize], Material::Null),
            Some(opacity) => mask_passes(opacity, self.uv(it), ray),
        }
    }

    /// Whether the surface hit is an index-matched (`null`) boundary.
    #[inline(always)]
    pub fn is_null(&self, it: &Interaction) -> bool {
        let m = self.shapes[it.shape as usize].material;
        matches!(self.materials[m as usize], Material::Null)
    }

    /// The material at a hit, its textures evaluated there.
    #[inline(always)]
    pub fn material(&self, it: &Interaction) -> MaterialRef<'_> {
        let s = &self.shapes[it.shape as usize];
        match &s.uvs {
            None => MaterialRef::plain(&self.materials[s.material as usize]),
            Some(_) => self.material_with_uv(*it),
        }
    }

    /// [`material`](Self::material) on a shape with texture coordinates. Out of line,
    /// and the hit by value: a reference taken anywhere in the kernels kept every
    /// hit in memory and copied it through `Surfacing` (pt 10 % slower on the Cornell
    /// box, with 1 % more instructions).
    #[inline(never)]
    fn material_with_uv(&self, it: Interaction) -> MaterialRef<'_> {
        let material = self.shapes[it.shape as usize].material;
        self.material_in(material, self.uv(&it), it.ng, || self.shading_frame(&it))
    }

    /// Material `index` at texture coordinates `uv` on a surface with geometric normal
    /// `ng`, evaluated in the local shading `frame` (for stored vertices):
    /// [`material_at`], wrapped in the shadowing term of its normal or bump map if it
    /// has one.
    ///
    /// [`material_at`]: Self::material_at
    #[inline(always)]
    pub fn material_on(&self, index: u32, uv: Vec2, ng: Vec3, frame: &Frame) -> MaterialRef<'_> {
        self.material_in(index, uv, ng, || *frame)
    }

    /// [`material_on`](Self::material_on), the frame built only if it is needed.
    #[inline(always)]
    fn material_in(
        &self,
        index: u32,
        uv: Vec2,
        ng: Vec3,
        frame: impl FnOnce() -> Frame,
    ) -> MaterialRef<'_> {
        match &self.perturb[index as usize] {
            Some(p) if p.use_shadowing_function => self.shadowed(index, uv, ng, &frame()),
            _ => self.material_at(index, uv),
        }
    }

    #[cold]
    #[inline(never)]
    fn shadowed(&self, index: u32, uv: Vec2, ng: Vec3, frame: &Frame) -> MaterialRef<'_> {
        let nested = self.material_at(index, uv).clone();
        MaterialRef::owned(Material::Shadowed(Box::new(Shadowed::new(
            nested, ng, frame,
        ))))
    }

    /// Material `index` itself, when it reads no texture and no normal or bump map
    /// wraps it in a shadowing term: then [`material_on`](Self::material_on) is this
    /// material at every point, and a stored vertex needs neither its (u, v) nor its
    /// frame to find it.
    #[inline(always)]
    pub fn plain_material(&self, index: u32) -> Option<&Material> {
        let i = index as usize;
        let shadowed = matches!(&self.perturb[i], Some(p) if p.use_shadowing_function);
        // Not `bool::then`: a closure left out of line takes the kernels' values to
        // memory (see `uv`).
        if self.textured[i].is_none() && !shadowed {
            Some(&self.materials[i])
        } else {
            None
        }
    }

    /// Material `index` at texture coordinates `uv` (for stored vertices).
    #[inline(always)]
    pub fn material_at(&self, index: u32, uv: Vec2) -> MaterialRef<'_> {
        let m = &self.materials[index as usize];
        match &self.textured[index as usize] {
            None => MaterialRef::plain(m),
            Some(t) => resolved(t, m, uv),
        }
    }

    /// The area light of the shape that was hit, with its index.
    #[inline]
    pub fn area_light(&self, it: &Interaction) -> Option<(usize, &AreaLight)> {
        let l = self.shapes[it.shape as usize].light? as usize;
        match &self.lights[l] {
            Light::Area(a) => Some((l, a)),
            _ => None,
        }
    }

    /// Radiance from environment lights along an escaping direction.
    #[inline]
    pub fn env_radiance(&self, d: Vec3) -> Rgb {
        self.env_lights
            .iter()
            .map(|&l| self.lights[l as usize].le_escaped(d))
            .sum()
    }

    pub fn width(&self) -> u32 {
        self.camera.width
    }

    pub fn height(&self) -> u32 {
        self.camera.height
    }
}
