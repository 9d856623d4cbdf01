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
    #[inline]
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
}
