use crate::math::{Rgb, Vec3, Vec3A};

use super::BsdfSample;

/// Perfect specular reflection.
#[derive(Clone, Debug, PartialEq)]
pub struct Mirror {
    pub reflectance: Rgb,
    pub two_sided: bool,
}

impl Mirror {
    #[inline]
    pub fn sample(&self, wo: Vec3) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi: Vec3A::new(-wo.x, -wo.y, wo.z),
            weight: self.reflectance.into(),
            pdf: 1.0,
            delta: true,
        })
    }
}
