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
        let dist = dist2.sqrt();
        Some(LightSample::new(
            self.position,
            Vec3::ZERO,
            d / dist,
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
