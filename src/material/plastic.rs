use crate::math::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::math::{Rgb, Vec2, Vec3, Vec3A, INV_PI};

use super::coating::Coating;
use super::{fresnel, BsdfSample};

/// Smooth plastic, as Mitsuba 3's `plastic`: a delta reflection off the coating with
/// Fresnel weight F(cos_o), and a diffuse lobe for the light that enters, scatters off
/// the base and leaves,
/// f cos_i = base (1 - F(cos_o)) (1 - F(cos_i)) cos_i / (pi eta^2),
/// with base = rho / (1 - Fdr_int) (or its `nonlinear` form) and Fdr_int the diffuse
/// Fresnel reflectance of the coating's underside. One-sided.
#[derive(Clone, Debug, PartialEq)]
pub struct Plastic {
    pub coating: Coating,
    pub two_sided: bool,
}

impl Plastic {
    #[inline]
    fn fresnel(&self, cos: f32) -> f32 {
        fresnel::dielectric(cos, self.coating.eta).0
    }

    /// Fdr_int: Mitsuba's fit where it holds (Egan and Hilgeman's, to 0.6 % up to a
    /// relative IOR of 2); beyond, where that fit grows past 1 (near 3.8) and the base
    /// term would turn negative, the exact relation to the external reflectance,
    /// 1 - Fdr_int = (1 - Fdr_ext) / eta^2, with d'Eon and Irving's fit of Fdr_ext
    /// (accurate to 0.2 % up to 10). The two agree to 1e-3 at 2.
    #[inline]
    fn internal(&self) -> f32 {
        let eta = self.coating.eta;
        if eta <= 2.0 {
            fresnel::diffuse_reflectance(1.0 / eta)
        } else {
            1.0 - (1.0 - fresnel::diffuse_reflectance(eta)) / (eta * eta)
        }
    }

    #[inline(never)]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let c = &self.coating;
        let t = (1.0 - self.fresnel(wo.z)) * (1.0 - self.fresnel(wi.z));
        c.base(self.internal()) * (t * c.inv_eta2() * INV_PI * wi.z)
    }

    /// The diffuse lobe's density (the delta lobe has none).
    #[inline(never)]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let p = self.coating.prob_specular(self.fresnel(wo.z));
        (1.0 - p) * cosine_hemisphere_pdf(wi.z)
    }

    /// Probability that `sample` picks the delta lobe from `wo`.
    #[inline]
    pub fn delta_probability(&self, wo: Vec3) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        self.coating.prob_specular(self.fresnel(wo.z))
    }

    #[inline(never)]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let c = &self.coating;
        let f_o = self.fresnel(wo.z);
        let p = c.prob_specular(f_o);
        if u_lobe < p {
            return Some(BsdfSample {
                wi: Vec3A::new(-wo.x, -wo.y, wo.z),
                weight: (c.specular_reflectance * (f_o / p)).into(),
                pdf: p,
                delta: true,
            });
        }
        let wi = square_to_cosine_hemisphere(u);
        if wi.z <= 0.0 {
            return None;
        }
        let t = (1.0 - f_o) * (1.0 - self.fresnel(wi.z));
        Some(BsdfSample {
            wi: wi.into(),
            weight: (c.base(self.internal()) * (t * c.inv_eta2() / (1.0 - p))).into(),
            pdf: (1.0 - p) * cosine_hemisphere_pdf(wi.z),
            delta: false,
        })
    }
}
