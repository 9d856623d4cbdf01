use crate::math::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::math::{Rgb, Vec2, Vec3, INV_PI};

use super::BsdfSample;

/// Lambertian reflection, one-sided: zero unless both directions are above the surface.
#[derive(Clone, Debug, PartialEq)]
pub struct Diffuse {
    pub reflectance: Rgb,
    pub two_sided: bool,
}

impl Diffuse {
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.reflectance * (INV_PI * wi.z)
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        cosine_hemisphere_pdf(wi.z)
    }

    // Forced: left out of line, it is compiled for baseline x86 and called from the
    // AVX2 kernels.
    #[inline(always)]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = square_to_cosine_hemisphere(u);
        if wi.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi: wi.into(),
            weight: self.reflectance.into(),
            pdf: cosine_hemisphere_pdf(wi.z),
            delta: false,
        })
    }
}
