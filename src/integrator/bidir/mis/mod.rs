//! The weights of the bidirectional family's techniques, from the partial MIS
//! quantities both subpaths carry ([`crate::integrator::paths::partial`], after
//! Georgiev 2012, "Implementing Vertex Connection and Merging", [TR] below): emitter
//! hits, light sampling, connections and merges, each O(1) per path ([TR] eq. 37).

use crate::integrator::paths::partial::{Mis, Partial};

impl Mis {
    /// A camera subpath reaches an emitter: the weight of that technique ([TR] eqs.
    /// 42-43). `direct` (area measure, or solid angle at infinity) and `emission` as in
    /// `light_start`, both with the selection probability.
    #[inline]
    pub fn weight_emitter_hit(&self, camera: Partial, direct: f32, emission: f32) -> f32 {
        let w_camera = self.f(direct) * camera.dvcm + self.f(emission) * camera.dvc;
        (1.0 / (1.0 + w_camera)) as f32
    }

    /// Light sampling from a camera vertex ([TR] eqs. 44-45). `bsdf_dir` is the camera
    /// BSDF's density of the light direction (0 for delta lights), `bsdf_rev` the
    /// reverse density; `direct` (solid angle at the vertex) and `emission` exclude
    /// the selection probability `pick`; `cos_at_light` is 1 for lights without a
    /// surface; `cos_at_vertex` is the camera vertex's |cos| towards the light; `vm`
    /// the camera vertex's M(x).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn weight_light_sample(
        &self,
        camera: Partial,
        vm: f64,
        pick: f32,
        direct: f32,
        emission: f32,
        cos_at_light: f32,
        cos_at_vertex: f32,
        bsdf_dir: f32,
        bsdf_rev: f32,
    ) -> f32 {
        let (direct, cos_at_light) = (direct as f64, cos_at_light as f64);
        let w_light = self.f(bsdf_dir as f64 / (pick as f64 * direct));
        let w_camera = self.f(emission as f64 * cos_at_vertex as f64 / (direct * cos_at_light))
            * (vm + camera.dvcm + camera.dvc * self.f(bsdf_rev));
        (1.0 / (w_light + 1.0 + w_camera)) as f32
    }

    /// Connection of a light vertex and a camera vertex ([TR] eqs. 40-41).
    /// `camera_to_light_a` is the camera BSDF's density of the connection converted to
    /// area at the light vertex, `light_to_camera_a` the converse; the reverse densities
    /// are each vertex's density of sampling its own predecessor. Each side comes with
    /// its vertex's M(x).
    #[inline]
    pub fn weight_connection(
        &self,
        light: (Partial, f64),
        camera: (Partial, f64),
        camera_to_light_a: f32,
        light_to_camera_a: f32,
        light_rev: f32,
        camera_rev: f32,
    ) -> f32 {
        let ((light, vm_light), (camera, vm_camera)) = (light, camera);
        let w_light =
            self.f(camera_to_light_a) * (vm_light + light.dvcm + light.dvc * self.f(light_rev));
        let w_camera =
            self.f(light_to_camera_a) * (vm_camera + camera.dvcm + camera.dvc * self.f(camera_rev));
        (1.0 / (w_light + 1.0 + w_camera)) as f32
    }

    /// Connection of a light vertex to the lens ([TR] eqs. 46-47): `camera_a` is the
    /// camera's density of the vertex in area measure per unit pixel area, `light_rev`
    /// the vertex's density of sampling its predecessor. The vertex, whose M(x) comes
    /// with it (as a first camera vertex), sits where a camera path would have its
    /// first vertex.
    #[inline]
    pub fn weight_camera_connection(
        &self,
        light: (Partial, f64),
        camera_a: f32,
        light_rev: f32,
    ) -> f32 {
        let (light, vm) = light;
        let w_light = self.f(camera_a as f64 / self.light_paths)
            * (vm + light.dvcm + light.dvc * self.f(light_rev));
        (1.0 / (w_light + 1.0)) as f32
    }

    /// A merge at vertex x by the estimator whose Mis(eta_k(x)) is `own`, among all
    /// merges there summing to `all` (M(x)) ([TR] eqs. 38-39 with [UPBP]'s estimators).
    /// `light` and `camera` are both subpaths' partial weights at x; `camera_dir` is the
    /// camera side's density of the light's incoming direction, `camera_rev` the
    /// reverse one (with the light side's continuation probability).
    #[inline]
    pub fn weight_merge(
        &self,
        light: Partial,
        camera: Partial,
        (own, all): (f64, f64),
        camera_dir: f32,
        camera_rev: f32,
    ) -> f32 {
        let w_light = light.dvcm * self.vc + light.dvm * self.f(camera_dir);
        let w_camera = camera.dvcm * self.vc + camera.dvm * self.f(camera_rev);
        (own / (w_light + all + w_camera)) as f32
    }
}

#[cfg(test)]
mod tests;
