//! Pinhole and thin-lens camera. Raster (0,0) is the top-left corner of the image;
//! the ray through continuous film position (sx, sy) has direction
//! forward + (2 sx / W - 1) tx right + (1 - 2 sy / H) ty up, where tx or ty is
//! tan(fov / 2) along `fov_axis` and the other follows from the aspect ratio.

use crate::geometry::Ray;
use crate::math::warp::square_to_disk;
use crate::math::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Camera {
    pub origin: Vec3,
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub width: u32,
    pub height: u32,
    /// tan of the half field of view along x and y.
    pub tan_half: Vec2,
    pub aperture_radius: f32,
    pub focus_distance: f32,
}

impl Camera {
    /// `fov_deg` is measured across x when `fov_on_x`, else across y.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        origin: Vec3,
        target: Vec3,
        up: Vec3,
        fov_deg: f32,
        fov_on_x: bool,
        width: u32,
        height: u32,
        aperture_radius: f32,
        focus_distance: Option<f32>,
    ) -> Self {
        let forward = (target - origin).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        let t = (fov_deg.to_radians() * 0.5).tan();
        let aspect = width as f32 / height as f32;
        let tan_half = if fov_on_x {
            Vec2::new(t, t / aspect)
        } else {
            Vec2::new(t * aspect, t)
        };
        Camera {
            origin,
            forward,
            right,
            up,
            width,
            height,
            tan_half,
            aperture_radius,
            focus_distance: focus_distance.unwrap_or_else(|| (target - origin).length()),
        }
    }

    /// Unnormalised direction through film position `s` at unit distance.
    #[inline]
    fn film_dir(&self, s: Vec2) -> Vec3 {
        let nx = 2.0 * s.x / self.width as f32 - 1.0;
        let ny = 1.0 - 2.0 * s.y / self.height as f32;
        self.forward + self.right * (nx * self.tan_half.x) + self.up * (ny * self.tan_half.y)
    }

    /// Primary ray through film position `s`; `u_lens` is used only by a thin lens.
    #[inline(always)]
    pub fn generate_ray(&self, s: Vec2, u_lens: Vec2) -> Ray {
        let d = self.film_dir(s);
        if self.aperture_radius <= 0.0 {
            return Ray::new(self.origin, d.normalize());
        }
        // Points on the plane of focus are sharp: aim every lens sample at where the
        // pinhole ray meets that plane.
        let focus = self.origin + d * self.focus_distance;
        let lens = square_to_disk(u_lens) * self.aperture_radius;
        let o = self.origin + self.right * lens.x + self.up * lens.y;
        Ray::new(o, (focus - o).normalize())
    }
}

impl Camera {
    /// Distance from the lens of the image plane on which one pixel has unit area
    /// (SmallVCM's convention). A camera ray at angle theta to the view axis then has
    /// solid-angle density d^2 / cos^3(theta) per unit of pixel area.
    #[inline]
    pub fn image_plane_dist(&self) -> f32 {
        self.width as f32 / (2.0 * self.tan_half.x)
    }

    /// Solid-angle density of a camera ray along unit `d` per unit of pixel area.
    #[inline]
    pub fn pdf_dir(&self, d: Vec3) -> f32 {
        let cos = d.dot(self.forward);
        if cos <= 0.0 {
            return 0.0;
        }
        let dist = self.image_plane_dist() / cos;
        dist * dist / cos
    }

    /// A point on the lens (the pinhole itself without an aperture), sampled
    /// uniformly; every lens point sees the whole image, so light-tracing splats only
    /// need the point, not its density.
    #[inline]
    pub fn sample_lens(&self, u: Vec2) -> Vec3 {
        if self.aperture_radius <= 0.0 {
            return self.origin;
        }
        let l = square_to_disk(u) * self.aperture_radius;
        self.origin + self.right * l.x + self.up * l.y
    }

    /// Film position at which light from `p` arriving at lens point `lens` lands, when
    /// it is inside the image: the inverse of `generate_ray`.
    #[inline]
    pub fn raster(&self, p: Vec3, lens: Vec3) -> Option<Vec2> {
        let v = p - lens;
        let depth = v.dot(self.forward);
        if depth <= 0.0 {
            return None;
        }
        // Where the ray meets the plane of focus, seen from the pinhole at unit depth.
        let f = (lens - self.origin) / self.focus_distance + v / depth;
        let nx = f.dot(self.right) / self.tan_half.x;
        let ny = f.dot(self.up) / self.tan_half.y;
        let s = Vec2::new(
            (nx + 1.0) * 0.5 * self.width as f32,
            (1.0 - ny) * 0.5 * self.height as f32,
        );
        let inside =
            s.x >= 0.0 && s.y >= 0.0 && s.x < self.width as f32 && s.y < self.height as f32;
        inside.then_some(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cornell_box_corner_ray_matches_the_reference_formula() {
        let cam = Camera::new(
            Vec3::new(0.0, 0.0, 3.9),
            Vec3::ZERO,
            Vec3::Y,
            39.3077,
            true,
            256,
            256,
            0.0,
            None,
        );
        let r = cam.generate_ray(Vec2::new(0.0, 0.0), Vec2::ZERO);
        let t = 0.357143;
        let expect = Vec3::new(-t, t, -1.0).normalize();
        assert!((r.d - expect).length() < 1e-5, "{:?}", r.d);
    }

    #[test]
    fn raster_inverts_generate_ray_for_pinhole_and_thin_lens() {
        for aperture in [0.0, 0.2] {
            let cam = Camera::new(
                Vec3::new(0.3, -0.2, 3.9),
                Vec3::new(0.1, 0.2, 0.0),
                Vec3::Y,
                50.0,
                false,
                200,
                100,
                aperture,
                Some(3.0),
            );
            for &(s, u) in &[
                ((10.5, 20.25), (0.3, 0.8)),
                ((199.0, 0.5), (0.9, 0.1)),
                ((100.0, 50.0), (0.5, 0.5)),
            ] {
                let s = Vec2::new(s.0, s.1);
                let u = Vec2::new(u.0, u.1);
                let ray = cam.generate_ray(s, u);
                let lens = cam.sample_lens(u);
                assert!((lens - ray.o).length() < 1e-5);
                let p = ray.o + ray.d * 2.7;
                let back = cam.raster(p, lens).unwrap();
                assert!((back - s).length() < 2e-3, "{back:?} vs {s:?}");
            }
            assert!(cam.raster(cam.origin - cam.forward, cam.origin).is_none());
        }
    }
}
