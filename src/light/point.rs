use super::LightSample;
use crate::math::{Rgb, Vec3};

/// Isotropic point light with intensity I (W/sr): E = I cos / d^2.
#[derive(Clone, Debug)]
pub struct PointLight {
    pub position: Vec3,
    pub intensity: Rgb,
}

impl PointLight {
    #[inline]
    pub fn sample_li(&self, p: Vec3) -> Option<LightSample> {
        let d = self.position - p;
        let dist2 = d.length_squared();
        if dist2 <= 0.0 {
            return None;
        }
        // Beyond ~1.8e19 the squared distance overflows: normalise a scaled copy
        // instead, so the direction stays a unit vector (the light is still finite).
        let (wi, dist) = if dist2.is_finite() {
            let dist = dist2.sqrt();
            (d / dist, dist)
        } else {
            let m = d.abs().max_element();
            let unit = d / m;
            let len = unit.length();
            (unit / len, len * m)
        };
        Some(LightSample::new(
            self.position,
            Vec3::ZERO,
            wi,
            dist,
            self.intensity / dist2,
            1.0,
            true,
        ))
    }
}

/// Light from one direction at infinity; `direction` is where photons travel.
#[derive(Clone, Debug)]
pub struct DirectionalLight {
    pub direction: Vec3,
    pub irradiance: Rgb,
}

impl DirectionalLight {
    #[inline]
    pub fn sample_li(&self) -> Option<LightSample> {
        Some(LightSample::new(
            Vec3::ZERO,
            Vec3::ZERO,
            -self.direction,
            f32::INFINITY,
            self.irradiance,
            1.0,
            true,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 2e19 away the squared distance overflows f32; the sample must still point at
    /// the light with its true distance and no radiance, not be mistaken for a light
    /// at infinity with a zero direction (which gave NaN at medium vertices).
    #[test]
    fn a_point_light_beyond_f32_squares_keeps_a_unit_direction() {
        let light = PointLight {
            position: Vec3::new(0.0, 2e19, 0.0),
            intensity: Rgb::splat(1.0),
        };
        let s = light.sample_li(Vec3::new(1.0, 0.0, 0.0)).unwrap();
        assert!((s.wi().length() - 1.0).abs() < 1e-6, "{:?}", s.wi());
        assert!(s.wi().y > 0.999_999);
        assert!((s.dist / 2e19 - 1.0).abs() < 1e-6, "{}", s.dist);
        assert!(s.dist.is_finite());
        assert_eq!(s.li(), Rgb::splat(0.0));
    }
}
