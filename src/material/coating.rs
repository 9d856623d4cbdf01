//! What `plastic` and `roughplastic` share (Mitsuba 3's plugins of those names): a
//! dielectric coating of relative IOR `eta` over a Lambertian base, with light
//! bouncing between the base and the underside of the coating.

use crate::math::Rgb;

/// The coating's parameters, as plain values: a textured variant builds one of these
/// per shading point.
#[derive(Clone, Debug, PartialEq)]
pub struct Coating {
    pub diffuse_reflectance: Rgb,
    pub specular_reflectance: Rgb,
    /// interior IOR / exterior IOR.
    pub eta: f32,
    /// Mitsuba's `nonlinear`: the base's colour also tints the internal bounces.
    pub nonlinear: bool,
}

impl Coating {
    /// The share of lobe choices steered to the specular lobe before Fresnel: the
    /// specular reflectance's mean over both means (Mitsuba's
    /// `specular_sampling_weight`).
    #[inline]
    pub fn specular_weight(&self) -> f32 {
        let s = mean(self.specular_reflectance);
        let d = mean(self.diffuse_reflectance);
        if s + d > 0.0 {
            s / (s + d)
        } else {
            1.0
        }
    }

    /// Probability of choosing the specular lobe, given the weight `specular` that the
    /// interface gives it from this direction (Fresnel R, or one minus the rough
    /// transmittance) and `1 - specular` the diffuse one.
    #[inline]
    pub fn prob_specular(&self, specular: f32) -> f32 {
        let w = self.specular_weight();
        let (s, d) = (specular * w, (1.0 - specular) * (1.0 - w));
        if s + d > 0.0 {
            s / (s + d)
        } else {
            1.0
        }
    }

    /// The base's albedo after the geometric series of internal reflections with
    /// average reflectance `internal`: rho / (1 - internal), or rho / (1 - rho
    /// internal) when `nonlinear` (Mitsuba's plastic, after Weidlich and Wilkie 2007).
    #[inline]
    pub fn base(&self, internal: f32) -> Rgb {
        let rho = self.diffuse_reflectance;
        if self.nonlinear {
            rho / (Rgb::ONE - rho * internal)
        } else {
            rho / (1.0 - internal)
        }
    }

    #[inline]
    pub fn inv_eta2(&self) -> f32 {
        1.0 / (self.eta * self.eta)
    }
}

fn mean(c: Rgb) -> f32 {
    (c.x + c.y + c.z) / 3.0
}
