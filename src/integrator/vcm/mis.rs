//! The recursive MIS quantities of vertex connection and merging (Georgiev 2012,
//! "Implementing Vertex Connection and Merging", referred to as [TR] below).
//!
//! Each subpath vertex carries dVCM, dVC and dVM: partial sums over the techniques
//! that would have sampled the same path with the connection or merge moved towards
//! this subpath's origin, expressed relative to the current technique. A full path's
//! weight then costs O(1) per connection or merge ([TR] eq. 37). All functions here are
//! pure, so the unit tests can check that the weights of every technique sum to one.
//!
//! Densities follow [TR]: solid-angle pdfs of the BSDF include the Russian-roulette
//! continuation probability; "emission" pdfs include the light selection probability.

use crate::integrator::pt::Heuristic;

/// Per-iteration MIS constants.
#[derive(Clone, Copy, Debug)]
pub struct Mis {
    pub heuristic: Heuristic,
    /// Mis(eta_VCM) when merging is used, else 0 ([TR] eq. 20, n_VC = 1).
    pub vm: f32,
    /// Mis(1 / eta_VCM) when connections are used, else 0.
    pub vc: f32,
    /// Light subpaths per iteration (the light-tracing technique's sample count).
    pub light_paths: f32,
    /// Merging at the first camera vertex is a technique; when false it is removed
    /// from every denominator as well as from the estimator.
    pub merge_first: bool,
}

/// The three partial weights of a subpath vertex.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Partial {
    pub dvcm: f32,
    pub dvc: f32,
    pub dvm: f32,
}

impl Mis {
    /// eta_VCM = pi r^2 N ([TR] eq. 20).
    pub fn new(heuristic: Heuristic, radius: f32, light_paths: f32, vc: bool, vm: bool) -> Self {
        let mut m = Mis {
            heuristic,
            vm: 0.0,
            vc: 0.0,
            light_paths,
            merge_first: true,
        };
        let eta = crate::math::PI * radius * radius * light_paths;
        if vm {
            m.vm = m.f(eta);
        }
        if vc {
            m.vc = m.f(1.0 / eta);
        }
        m
    }

    /// The heuristic's power of a density ratio.
    #[inline]
    pub fn f(&self, x: f32) -> f32 {
        match self.heuristic {
            Heuristic::Balance => x,
            Heuristic::Power => x * x,
        }
    }

    /// The merge technique's weight factor at a camera vertex `len` segments from the
    /// camera (zero at the first vertex when merging there is off).
    #[inline]
    fn vm_at(&self, camera_len: Option<u32>) -> (f32, f32) {
        if camera_len == Some(1) && !self.merge_first {
            (0.0, 0.0)
        } else {
            (self.vm, 1.0)
        }
    }

    /// A light subpath leaving its emitter ([TR] eqs. 31-33, delta lights 48-50).
    /// `direct` is the density with which light sampling would pick the origin (area
    /// measure, or solid angle for lights at infinity), `emission` the density of the
    /// emitted ray; both include the light selection probability.
    #[inline]
    pub fn light_start(
        &self,
        direct: f32,
        emission: f32,
        cos: f32,
        delta: bool,
        finite: bool,
    ) -> Partial {
        let dvc = if delta {
            0.0
        } else {
            self.f(if finite { cos } else { 1.0 } / emission)
        };
        Partial {
            dvcm: self.f(direct / emission),
            dvc,
            dvm: dvc * self.vc,
        }
    }

    /// A camera subpath leaving the lens, whose ray has solid-angle density
    /// `camera_pdf` per unit pixel area ([TR] eqs. 31-33).
    #[inline]
    pub fn camera_start(&self, camera_pdf: f32) -> Partial {
        Partial {
            dvcm: self.f(self.light_paths / camera_pdf),
            dvc: 0.0,
            dvm: 0.0,
        }
    }

    /// Completes the update after a segment of squared length `dist2` reaches a vertex
    /// at |cos| `cos`; rays from lights at infinity skip the distance ([TR] sec. 5.1).
    #[inline]
    pub fn on_hit(&self, q: Partial, dist2: Option<f32>, cos: f32) -> Partial {
        let mut dvcm = q.dvcm;
        if let Some(d2) = dist2 {
            dvcm *= self.f(d2);
        }
        let c = self.f(cos);
        Partial {
            dvcm: dvcm / c,
            dvc: q.dvc / c,
            dvm: q.dvm / c,
        }
    }

    /// Scattering at a vertex ([TR] eqs. 34-36; specular 53-55). `pdf_dir` and `pdf_rev`
    /// are the sampled direction's density and the reverse one, with continuation
    /// probabilities; `camera_len` is Some(segments) on camera subpaths.
    #[inline]
    pub fn on_scatter(
        &self,
        q: Partial,
        cos_out: f32,
        pdf_dir: f32,
        pdf_rev: f32,
        delta: bool,
        camera_len: Option<u32>,
    ) -> Partial {
        let g = self.f(cos_out / pdf_dir);
        if delta {
            let r = self.f(pdf_rev);
            return Partial {
                dvcm: 0.0,
                dvc: q.dvc * g * r,
                dvm: q.dvm * g * r,
            };
        }
        let (vm, one) = self.vm_at(camera_len);
        let r = self.f(pdf_rev);
        Partial {
            dvc: g * (q.dvc * r + q.dvcm + vm),
            dvm: g * (q.dvm * r + q.dvcm * self.vc + one),
            dvcm: self.f(1.0 / pdf_dir),
        }
    }

    /// A camera subpath reaches an emitter: the weight of that technique ([TR] eqs.
    /// 42-43). `direct` (area measure, or solid angle at infinity) and `emission` as in
    /// `light_start`, both with the selection probability.
    #[inline]
    pub fn weight_emitter_hit(&self, camera: Partial, direct: f32, emission: f32) -> f32 {
        let w_camera = self.f(direct) * camera.dvcm + self.f(emission) * camera.dvc;
        1.0 / (1.0 + w_camera)
    }

    /// Light sampling from a camera vertex ([TR] eqs. 44-45). `bsdf_dir` is the camera
    /// BSDF's density of the light direction (0 for delta lights), `bsdf_rev` the
    /// reverse density; `direct` (solid angle at the vertex) and `emission` exclude
    /// the selection probability `pick`; `cos_at_light` is 1 for lights without a
    /// surface; `cos_at_vertex` is the camera vertex's |cos| towards the light.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn weight_light_sample(
        &self,
        camera: Partial,
        camera_len: u32,
        pick: f32,
        direct: f32,
        emission: f32,
        cos_at_light: f32,
        cos_at_vertex: f32,
        bsdf_dir: f32,
        bsdf_rev: f32,
    ) -> f32 {
        let (vm, _) = self.vm_at(Some(camera_len));
        let w_light = self.f(bsdf_dir / (pick * direct));
        let w_camera = self.f(emission * cos_at_vertex / (direct * cos_at_light))
            * (vm + camera.dvcm + camera.dvc * self.f(bsdf_rev));
        1.0 / (w_light + 1.0 + w_camera)
    }

    /// Connection of a light vertex and a camera vertex ([TR] eqs. 40-41).
    /// `camera_to_light_a` is the camera BSDF's density of the connection converted to
    /// area at the light vertex, `light_to_camera_a` the converse; the reverse densities
    /// are each vertex's density of sampling its own predecessor.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn weight_connection(
        &self,
        light: Partial,
        camera: Partial,
        camera_len: u32,
        camera_to_light_a: f32,
        light_to_camera_a: f32,
        light_rev: f32,
        camera_rev: f32,
    ) -> f32 {
        let (vm_cam, _) = self.vm_at(Some(camera_len));
        let w_light =
            self.f(camera_to_light_a) * (self.vm + light.dvcm + light.dvc * self.f(light_rev));
        let w_camera =
            self.f(light_to_camera_a) * (vm_cam + camera.dvcm + camera.dvc * self.f(camera_rev));
        1.0 / (w_light + 1.0 + w_camera)
    }

    /// Connection of a light vertex to the lens ([TR] eqs. 46-47): `camera_a` is the
    /// camera's density of the vertex in area measure per unit pixel area, `light_rev`
    /// the vertex's density of sampling its predecessor. The vertex sits where a
    /// camera path would have its first vertex.
    #[inline]
    pub fn weight_camera_connection(&self, light: Partial, camera_a: f32, light_rev: f32) -> f32 {
        let (vm, _) = self.vm_at(Some(1));
        let w_light =
            self.f(camera_a / self.light_paths) * (vm + light.dvcm + light.dvc * self.f(light_rev));
        1.0 / (w_light + 1.0)
    }

    /// Merging a light vertex at a camera vertex ([TR] eqs. 38-39). `camera_dir` is the
    /// camera BSDF's density of the light vertex's incoming direction, `camera_rev` the
    /// reverse one (with the light vertex's continuation probability).
    #[inline]
    pub fn weight_merge(
        &self,
        light: Partial,
        camera: Partial,
        camera_dir: f32,
        camera_rev: f32,
    ) -> f32 {
        let w_light = light.dvcm * self.vc + light.dvm * self.f(camera_dir);
        let w_camera = camera.dvcm * self.vc + camera.dvm * self.f(camera_rev);
        1.0 / (w_light + 1.0 + w_camera)
    }
}
