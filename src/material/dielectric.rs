use crate::math::{Rgb, Vec3, Vec3A};

use super::{fresnel, BsdfSample, Mode};

/// Smooth dielectric: Fresnel-weighted choice between reflection and refraction.
#[derive(Clone, Debug, PartialEq)]
pub struct Dielectric {
    /// interior IOR / exterior IOR.
    pub eta: f32,
    pub specular_reflectance: Rgb,
    pub specular_transmittance: Rgb,
}

impl Dielectric {
    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, mode: Mode) -> Option<BsdfSample> {
        let (r, cos_t, eta_ti) = fresnel::dielectric(wo.z, self.eta);
        if u_lobe < r {
            return Some(BsdfSample {
                wi: Vec3A::new(-wo.x, -wo.y, wo.z),
                weight: self.specular_reflectance.into(),
                pdf: r,
                delta: true,
            });
        }
        let wi = Vec3::new(-eta_ti * wo.x, -eta_ti * wo.y, cos_t);
        // Radiance is compressed into a narrower cone when it enters a denser medium,
        // L_t = L_i (n_t / n_i)^2; importance is not (Veach 1997, sec. 5.2).
        let scale = match mode {
            Mode::Radiance => eta_ti * eta_ti,
            Mode::Importance => 1.0,
        };
        Some(BsdfSample {
            wi: wi.into(),
            weight: (self.specular_transmittance * scale).into(),
            pdf: 1.0 - r,
            delta: true,
        })
    }
}
