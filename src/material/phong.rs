use crate::math::warp::{
    cosine_hemisphere_pdf, cosine_power_pdf, square_to_cosine_hemisphere, square_to_cosine_power,
};
use crate::math::{luminance, pow_lobe, Frame, Rgb, Vec2, Vec3, INV_2PI, INV_PI};

use super::BsdfSample;

/// Energy-normalised modified Phong (Lafortune and Willems 1994), as in SmallVCM and the
/// VCM thesis: f = kd / pi + ks (n + 2) / (2 pi) max(0, R(wo) . wi)^n.
#[derive(Clone, Debug, PartialEq)]
pub struct Phong {
    kd: Rgb,
    ks: Rgb,
    exponent: f32,
    pub two_sided: bool,
    /// Probability of sampling the glossy lobe: its share of the luminance (fixed at
    /// construction, as it sits on the chain of every sample and density).
    p_glossy: f32,
}

#[inline]
fn mirror_local(w: Vec3) -> Vec3 {
    Vec3::new(-w.x, -w.y, w.z)
}

impl Phong {
    pub fn new(kd: Rgb, ks: Rgb, exponent: f32, two_sided: bool) -> Self {
        let (d, s) = (luminance(kd), luminance(ks));
        Phong {
            kd,
            ks,
            exponent,
            two_sided,
            p_glossy: if d + s > 0.0 { s / (d + s) } else { 0.0 },
        }
    }

    pub fn kd(&self) -> Rgb {
        self.kd
    }

    pub fn ks(&self) -> Rgb {
        self.ks
    }

    #[inline(always)]
    fn p_glossy(&self) -> f32 {
        self.p_glossy
    }

    #[inline(always)]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let cos_a = mirror_local(wo).dot(wi);
        let glossy = if cos_a > 0.0 {
            (self.exponent + 2.0) * INV_2PI * pow_lobe(cos_a, self.exponent)
        } else {
            0.0
        };
        (self.kd * INV_PI + self.ks * glossy) * wi.z
    }

    /// [`Phong::eval`] with [`Phong::pdf`] both ways, sharing the lobe's power (the
    /// mirror directions give the same cosine either way, to the bit).
    #[inline(always)]
    pub fn eval_pdfs(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Rgb::ZERO, 0.0, 0.0);
        }
        let cos_a = mirror_local(wo).dot(wi);
        let lobe = if cos_a > 0.0 {
            pow_lobe(cos_a, self.exponent)
        } else {
            0.0
        };
        let f = (self.kd * INV_PI + self.ks * ((self.exponent + 2.0) * INV_2PI * lobe)) * wi.z;
        let ps = self.p_glossy();
        let glossy_pdf = ps * ((self.exponent + 1.0) * INV_2PI * lobe);
        (
            f,
            (1.0 - ps) * cosine_hemisphere_pdf(wi.z) + glossy_pdf,
            (1.0 - ps) * cosine_hemisphere_pdf(wo.z) + glossy_pdf,
        )
    }

    #[inline(always)]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let ps = self.p_glossy();
        let cos_a = mirror_local(wo).dot(wi);
        (1.0 - ps) * cosine_hemisphere_pdf(wi.z) + ps * cosine_power_pdf(cos_a, self.exponent)
    }

    #[inline(always)]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.p_glossy() {
            let lobe = Frame::from_normal(mirror_local(wo));
            lobe.to_world(square_to_cosine_power(u, self.exponent))
        } else {
            square_to_cosine_hemisphere(u)
        };
        // Glossy samples may fall below the surface: the BSDF is zero there.
        let (f, pdf, _) = self.eval_pdfs(wo, wi);
        if wi.z <= 0.0 || pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi: wi.into(),
            weight: (f / pdf).into(),
            pdf,
            delta: false,
        })
    }
}
