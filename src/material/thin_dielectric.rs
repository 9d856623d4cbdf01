use crate::math::{Rgb, Vec3, Vec3A};

use super::{fresnel, BsdfSample};

/// Thin dielectric sheet (a window pane), as Mitsuba 3's `thindielectric`: light
/// reflects off, or passes straight through, a slab whose two faces bounce it back and
/// forth. Summing the bounces, R' = R + T^2 R / (1 - R^2) with R the Fresnel reflectance
/// at the incidence angle and T = 1 - R, and T' = 1 - R'. Both lobes are deltas; the
/// transmitted ray keeps its direction, so neither mode scales it.
#[derive(Clone, Debug, PartialEq)]
pub struct ThinDielectric {
    /// interior IOR / exterior IOR.
    pub eta: f32,
    pub specular_reflectance: Rgb,
    pub specular_transmittance: Rgb,
}

impl ThinDielectric {
    /// R' for a direction of cosine `cos` (either side: the slab is symmetric).
    #[inline]
    pub fn reflectance(&self, cos: f32) -> f32 {
        let r = fresnel::dielectric(cos.abs(), self.eta).0;
        let t = 1.0 - r;
        if r >= 1.0 {
            return 1.0;
        }
        r + t * t * r / (1.0 - r * r)
    }

    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let r = self.reflectance(wo.z);
        let s = if u_lobe < r {
            BsdfSample {
                wi: Vec3A::new(-wo.x, -wo.y, wo.z),
                weight: self.specular_reflectance.into(),
                pdf: r,
                delta: true,
            }
        } else {
            BsdfSample {
                wi: Vec3A::new(-wo.x, -wo.y, -wo.z),
                weight: self.specular_transmittance.into(),
                pdf: 1.0 - r,
                delta: true,
            }
        };
        Some(s)
    }
}
