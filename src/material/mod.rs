//! BSDFs as one closed enum. Every routine works in the local shading frame (+z is the
//! surface normal on the shape's front side); `wo` points towards where the path came
//! from, `wi` towards where it goes next, both away from the surface. `eval` returns
//! f(wo, wi) |cos theta_i| (the cosine included, as in Mitsuba) and `sample` returns
//! that value divided by the pdf.
//!
//! The simple BSDFs are inlined into the integrators' kernels; the microfacet and
//! coated ones (`RoughDielectric`, `Plastic`, `RoughPlastic`) stay out of line: inlined
//! at every call site they grew the bidirectional kernel by a sixth and multiplied its
//! instruction-cache misses by five, slowing scenes that hold none of them. The
//! wrappers (`Mixture`, `Shadowed`) are out of line for a second reason: an arm that
//! calls back into `Material` inline makes its methods recursive, and recursive
//! methods are called, not inlined (bpt on the Cornell box: 27 % slower).

mod coating;
mod conductor;
mod dielectric;
mod diffuse;
pub mod fresnel;
pub mod microfacet;
mod mirror;
mod mixture;
pub mod normal_map;
mod phong;
mod plastic;
mod rough_dielectric;
mod rough_plastic;
pub mod texture;
pub mod textured;
mod thin_dielectric;

pub use coating::Coating;
pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use diffuse::Diffuse;
pub use mirror::Mirror;
pub use mixture::Mixture;
pub use phong::Phong;
pub use plastic::Plastic;
pub use rough_dielectric::RoughDielectric;
pub use rough_plastic::RoughPlastic;
pub use thin_dielectric::ThinDielectric;

use crate::math::{Rgb, Vec2, Vec3, Vec3A};

/// Which quantity flows along the path: radiance (camera paths) or importance (light
/// paths). Only non-symmetric BSDFs care (refraction scales radiance by 1/eta^2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Radiance,
    Importance,
}

#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled direction, local frame. Four lanes, so the sample is built and
    /// read as one vector: as three scalars, the integrators' loads of it stalled on
    /// store forwarding (perf, Cornell box).
    pub wi: Vec3A,
    /// f |cos theta_i| / pdf, in four lanes for the same reason as `wi`.
    pub weight: Vec3A,
    /// Solid-angle density of `wi` (for delta lobes, the discrete probability of the
    /// chosen lobe, which MIS never compares with a continuous pdf).
    pub pdf: f32,
    pub delta: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    Diffuse(Diffuse),
    Phong(Phong),
    Mirror(Mirror),
    Dielectric(Dielectric),
    Conductor(Conductor),
    RoughDielectric(RoughDielectric),
    Plastic(Plastic),
    RoughPlastic(RoughPlastic),
    ThinDielectric(ThinDielectric),
    /// A weighted sum of materials (`mixturebsdf`, `blendbsdf`), boxed so that the
    /// enum stays as small as before for every scene.
    Mixture(Box<Mixture>),
    /// Index-matched boundary: not a scattering event at all.
    Null,
    /// A BSDF under a normal or bump map, with its shadowing term (built per hit).
    Shadowed(Box<normal_map::Shadowed>),
}

/// Two-sided materials see the back face as a mirrored copy of the front.
#[inline]
fn orient(two_sided: bool, wo: Vec3, wi: Vec3) -> (Vec3, Vec3, bool) {
    if two_sided && wo.z < 0.0 {
        let m = Vec3::new(1.0, 1.0, -1.0);
        (wo * m, wi * m, true)
    } else {
        (wo, wi, false)
    }
}

impl Material {
    fn two_sided(&self) -> bool {
        match self {
            Material::Diffuse(m) => m.two_sided,
            Material::Phong(m) => m.two_sided,
            Material::Mirror(m) => m.two_sided,
            Material::Conductor(m) => m.two_sided,
            Material::Plastic(m) => m.two_sided,
            Material::RoughPlastic(m) => m.two_sided,
            Material::Dielectric(_)
            | Material::RoughDielectric(_)
            | Material::ThinDielectric(_)
            | Material::Mixture(_)
            | Material::Null
            | Material::Shadowed(_) => false,
        }
    }

    // Forced: callers in the AVX2 kernels otherwise get a baseline-x86 copy.
    #[inline(always)]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: Mode) -> Rgb {
        let (wo, wi, _) = orient(self.two_sided(), wo, wi);
        match self {
            Material::Diffuse(m) => m.eval(wo, wi),
            Material::Phong(m) => m.eval(wo, wi),
            Material::Conductor(m) => m.eval(wo, wi),
            Material::RoughDielectric(m) => m.eval(wo, wi, mode),
            Material::Plastic(m) => m.eval(wo, wi),
            Material::RoughPlastic(m) => m.eval(wo, wi),
            Material::Shadowed(m) => m.eval(wo, wi, mode),
            Material::Mixture(m) => m.eval(wo, wi, mode),
            Material::Dielectric(_)
            | Material::ThinDielectric(_)
            | Material::Mirror(_)
            | Material::Null => Rgb::ZERO,
        }
    }

    // Forced: callers in the AVX2 kernels otherwise get a baseline-x86 copy.
    #[inline(always)]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi, _) = orient(self.two_sided(), wo, wi);
        match self {
            Material::Diffuse(m) => m.pdf(wo, wi),
            Material::Phong(m) => m.pdf(wo, wi),
            Material::Conductor(m) => m.pdf(wo, wi),
            Material::RoughDielectric(m) => m.pdf(wo, wi),
            Material::Plastic(m) => m.pdf(wo, wi),
            Material::RoughPlastic(m) => m.pdf(wo, wi),
            Material::Shadowed(m) => m.pdf(wo, wi),
            Material::Mixture(m) => m.pdf(wo, wi),
            Material::Dielectric(_)
            | Material::ThinDielectric(_)
            | Material::Mirror(_)
            | Material::Null => 0.0,
        }
    }

    /// `(eval(wo, wi), pdf(wo, wi), pdf(wi, wo))` in one call, bit for bit: what a
    /// bidirectional connection needs, with the work the three share done once.
    #[inline(always)]
    pub fn eval_pdfs(&self, wo: Vec3, wi: Vec3, mode: Mode) -> (Rgb, f32, f32) {
        match self {
            // Phong is one-sided after orienting: where f is not zero, both directions
            // are on one side, so the three calls orient alike.
            Material::Phong(m) => {
                let (wo_o, wi_o, _) = orient(m.two_sided, wo, wi);
                let r = m.eval_pdfs(wo_o, wi_o);
                if r.0 == Rgb::ZERO {
                    (r.0, self.pdf(wo, wi), self.pdf(wi, wo))
                } else {
                    r
                }
            }
            // Diffuse scatters only between directions on one side, so orienting by
            // `wo` alone gives all three (both pdfs are zero otherwise). Its own arm
            // also keeps f out of the memory that `eval`'s match joins through.
            Material::Diffuse(m) => {
                let (wo_o, wi_o, _) = orient(m.two_sided, wo, wi);
                (m.eval(wo_o, wi_o), m.pdf(wo_o, wi_o), m.pdf(wi_o, wo_o))
            }
            _ => (self.eval(wo, wi, mode), self.pdf(wo, wi), self.pdf(wi, wo)),
        }
    }

    /// Samples `wi` given `wo`; `u_lobe` picks a lobe, `u` the direction within it.
    // Forced: callers in the AVX2 kernels otherwise get a baseline-x86 copy.
    #[inline(always)]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: Mode) -> Option<BsdfSample> {
        let (wo_o, _, flipped) = orient(self.two_sided(), wo, Vec3::Z);
        let mut s = match self {
            Material::Diffuse(m) => m.sample(wo_o, u),
            Material::Phong(m) => m.sample(wo_o, u_lobe, u),
            Material::Mirror(m) => m.sample(wo_o),
            Material::Conductor(m) => m.sample(wo_o, u),
            Material::Dielectric(m) => m.sample(wo_o, u_lobe, mode),
            Material::RoughDielectric(m) => m.sample(wo_o, u_lobe, u, mode),
            Material::Plastic(m) => m.sample(wo_o, u_lobe, u),
            Material::RoughPlastic(m) => m.sample(wo_o, u_lobe, u),
            Material::ThinDielectric(m) => m.sample(wo_o, u_lobe),
            Material::Shadowed(m) => m.sample(wo_o, u_lobe, u, mode),
            Material::Mixture(m) => m.sample(wo_o, u_lobe, u, mode),
            Material::Null => None,
        }?;
        if flipped {
            s.wi.z = -s.wi.z;
        }
        Some(s)
    }

    /// True when every lobe is a Dirac delta (no connection or merging possible).
    #[inline]
    pub fn is_delta(&self) -> bool {
        match self {
            Material::Mirror(_)
            | Material::Dielectric(_)
            | Material::ThinDielectric(_)
            | Material::Null => true,
            Material::Conductor(c) => c.is_smooth(),
            Material::Shadowed(m) => m.is_delta(),
            Material::Mixture(m) => m.is_delta(),
            // Plastic's specular lobe is a delta, its diffuse lobe is not: it is sampled
            // per lobe (`BsdfSample::delta`) and connects through the diffuse one.
            Material::Diffuse(_)
            | Material::Phong(_)
            | Material::RoughDielectric(_)
            | Material::Plastic(_)
            | Material::RoughPlastic(_) => false,
        }
    }

    /// Probability that `sample` picks a delta lobe from `wo`, for a BSDF that mixes
    /// one with continuous lobes (plastic's coating); 0 for every other BSDF. Sampling
    /// with `u_lobe` 0 picks that delta lobe where this is positive.
    #[inline]
    pub fn delta_probability(&self, wo: Vec3) -> f32 {
        match self {
            Material::Plastic(m) => m.delta_probability(orient(m.two_sided, wo, Vec3::Z).0),
            Material::Shadowed(m) => m.delta_probability(wo),
            Material::Mixture(m) => m.delta_probability(wo),
            _ => 0.0,
        }
    }

    /// Probability that `sample` picks a delta lobe from `wo`, for any BSDF: 1 for a
    /// delta one.
    #[inline]
    fn delta_share(&self, wo: Vec3) -> f32 {
        if self.is_delta() {
            1.0
        } else {
            self.delta_probability(wo)
        }
    }

    /// `sample` restricted to the delta lobes, where `delta_probability` (or
    /// `is_delta`) says there are some: the sample's weight is f over the lobe's
    /// probability under `sample`, as `sample` gives it. `u_lobe` picks among several
    /// delta lobes (plastic has one: it is what `sample` picks with `u_lobe` 0).
    #[inline]
    pub fn sample_delta(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: Mode) -> Option<BsdfSample> {
        match self {
            Material::Mixture(m) => m.sample_delta(wo, u_lobe, u, mode),
            Material::Shadowed(m) => m.sample_delta(wo, u_lobe, u, mode),
            m if m.is_delta() => m.sample(wo, u_lobe, u, mode),
            m => m.sample(wo, 0.0, u, mode),
        }
    }

    /// True when nothing arriving from `wo` (local frame) is scattered, whatever the
    /// outgoing direction: the back of a one-sided surface. Light vertices there add
    /// nothing to any technique.
    #[inline(always)]
    pub fn is_black_from(&self, wo: Vec3) -> bool {
        match self {
            Material::Diffuse(_)
            | Material::Phong(_)
            | Material::Conductor(_)
            | Material::Plastic(_)
            | Material::RoughPlastic(_) => orient(self.two_sided(), wo, Vec3::Z).0.z <= 0.0,
            Material::Shadowed(m) => m.is_black_from(wo),
            Material::Mixture(m) => m.is_black_from(wo),
            Material::Mirror(_)
            | Material::Dielectric(_)
            | Material::RoughDielectric(_)
            | Material::ThinDielectric(_)
            | Material::Null => false,
        }
    }

    /// Hemispherical reflectance estimate, for the albedo AOV and light power (and
    /// Russian roulette at every bidirectional vertex: inlined).
    #[inline]
    pub fn albedo(&self) -> Rgb {
        match self {
            Material::Diffuse(m) => m.reflectance,
            Material::Phong(m) => m.kd() + m.ks(),
            Material::Mirror(m) => m.reflectance,
            Material::Dielectric(m) => m.specular_transmittance,
            Material::RoughDielectric(m) => m.specular_transmittance,
            Material::ThinDielectric(m) => m.specular_transmittance,
            Material::Plastic(Plastic { coating, .. })
            | Material::RoughPlastic(RoughPlastic { coating, .. }) => coating.diffuse_reflectance,
            Material::Conductor(m) => m.normal_reflectance(),
            Material::Mixture(m) => m.albedo(),
            Material::Null => Rgb::ONE,
            Material::Shadowed(m) => m.albedo(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mixtures_leave_the_enum_size_alone() {
        // 64 bytes before mixtures: the largest variant is a microfacet material.
        eprintln!(
            "size_of::<Material>() = {}",
            std::mem::size_of::<Material>()
        );
        assert!(std::mem::size_of::<Material>() <= 64);
    }

    #[test]
    fn two_sided_back_face_mirrors_front() {
        let one = Material::Diffuse(Diffuse {
            reflectance: Rgb::splat(0.5),
            two_sided: false,
        });
        let two = Material::Diffuse(Diffuse {
            reflectance: Rgb::splat(0.5),
            two_sided: true,
        });
        let wo = Vec3::new(0.3, 0.0, -0.95).normalize();
        let wi = Vec3::new(-0.3, 0.2, -0.9).normalize();
        assert_eq!(one.eval(wo, wi, Mode::Radiance), Rgb::ZERO);
        assert!(two.eval(wo, wi, Mode::Radiance).x > 0.0);
        let s = two
            .sample(wo, 0.5, Vec2::new(0.3, 0.7), Mode::Radiance)
            .unwrap();
        assert!(s.wi.z < 0.0);
    }
}
