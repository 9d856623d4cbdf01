//! Mitsuba 3's `normalmap` and `bumpmap` wrappers. They change the frame a nested
//! BSDF is evaluated in, not the BSDF: at a hit the scene replaces the shading normal
//! with the perturbed one ([`Perturb::normal`]), so every integrator builds its frame
//! from it, stores it with light vertices, visible points and virtual lights, and
//! applies its usual rule to it (a direction whose side of the geometric normal
//! differs from its side of the shading normal carries nothing). What remains of the
//! wrappers is a factor of the BSDF, Estevez et al.'s shadowing term ([`Shadowed`]).
//!
//! Conventions (Mitsuba 3.9 `normalmap.cpp`, `bumpmap.cpp`):
//! - normalmap: n = 2 rgb - 1 in the unperturbed shading frame, whose x axis is dp/du
//!   made orthogonal to the shading normal. The texture is read as any other (8-bit
//!   images sRGB-decoded unless `raw`, which Mitsuba's documentation asks for).
//! - bumpmap: the surface p + h n with h = scale * texture (luminance), h's gradient
//!   in (u, v) from the texture; the normal dp/du' x dp/dv' with dp/du' = dp/du +
//!   n (dh/du - n.dp/du) (likewise for v), turned to the geometric normal's side.
//! - flip_invalid_normals: a perturbed normal on the other side of the incoming
//!   direction than the unperturbed one has its tangential part negated (mirrored
//!   about the unperturbed normal).
//! - use_shadowing_function: f is scaled by G(w) = 2 / (1 + sqrt(1 + a^2 tan^2 w)),
//!   a^2 = min(tan^2(n') / 8, 1), with w the direction towards the light (Mitsuba
//!   applies it to the sampled direction, which is the light's on camera paths; on
//!   light paths caustic keeps the same function, so light tracing estimates what
//!   path tracing does). Angles are measured from the geometric normal, which is
//!   Mitsuba's unperturbed normal on every shape without vertex normals.
//!
//! A perturbed normal that is not a unit vector after normalising (a map value of
//! (0.5, 0.5, 0.5), degenerate tangents) leaves the unperturbed normal in place, so no
//! NaN reaches the film (Mitsuba renders NaN there).

use super::texture::Texture;
use super::{BsdfSample, Material, Mode};
use crate::math::{Frame, Rgb, Vec2, Vec3};

/// Where the perturbed normal comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum NormalSource {
    /// A tangent-space normal map, 2 rgb - 1.
    Map(Texture),
    /// A height field `scale` times the texture's luminance.
    Bump { height: Texture, scale: f32 },
}

/// The normal perturbation of one material.
#[derive(Clone, Debug, PartialEq)]
pub struct Perturb {
    pub source: NormalSource,
    pub flip_invalid_normals: bool,
    pub use_shadowing_function: bool,
}

/// The unperturbed surface at a hit: shading and geometric normals and tangents.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceFrame {
    pub ns: Vec3,
    pub ng: Vec3,
    pub dpdu: Vec3,
    pub dpdv: Vec3,
}

impl Perturb {
    /// The perturbed shading normal at texture coordinates `uv`, for light arriving
    /// from `wo` (world, pointing away from the surface).
    pub fn normal(&self, uv: Vec2, s: &SurfaceFrame, wo: Vec3) -> Vec3 {
        let n = match &self.source {
            NormalSource::Map(t) => {
                let c = t.eval(uv) * 2.0 - Rgb::ONE;
                let f = tangent_frame(s.ns, s.dpdu);
                f.s * c.x + f.t * c.y + f.n * c.z
            }
            NormalSource::Bump { height, scale } => {
                let g = height.grad(uv) * *scale;
                let du = s.dpdu + s.ns * (g.x - s.ns.dot(s.dpdu));
                let dv = s.dpdv + s.ns * (g.y - s.ns.dot(s.dpdv));
                let n = du.cross(dv);
                if n.dot(s.ng) < 0.0 {
                    -n
                } else {
                    n
                }
            }
        };
        let n = if self.flip_invalid_normals && wo.dot(s.ns) * wo.dot(n) <= 0.0 {
            s.ns * (2.0 * n.dot(s.ns)) - n
        } else {
            n
        };
        let n = n.normalize_or_zero();
        if n == Vec3::ZERO || !n.is_finite() {
            s.ns
        } else {
            n
        }
    }
}

/// The shading frame of normal `ns` on a surface with tangent `dpdu`: x along dp/du
/// made orthogonal to the normal (Mitsuba's `initialize_sh_frame`), an arbitrary
/// basis where dp/du is degenerate. Inlined: a frame returned from a call goes
/// through the caller's memory.
#[inline(always)]
pub fn tangent_frame(ns: Vec3, dpdu: Vec3) -> Frame {
    let t = (dpdu - ns * ns.dot(dpdu)).normalize_or_zero();
    if t == Vec3::ZERO || !t.is_finite() {
        return Frame::from_normal(ns);
    }
    Frame {
        s: t,
        t: ns.cross(t),
        n: ns,
    }
}

/// A BSDF under a perturbed normal, with Estevez et al.'s shadowing term ("A
/// Microfacet-Based Shadowing Function to Solve the Bump Terminator Problem", Ray
/// Tracing Gems 2019). Built at each hit, in the local frame of the perturbed normal.
#[derive(Clone, Debug, PartialEq)]
pub struct Shadowed {
    pub nested: Material,
    /// The geometric normal in the local frame.
    pub reference: Vec3,
    /// min(tan^2 / 8, 1) of the perturbed normal's angle to the reference.
    pub alpha2: f32,
}

impl Shadowed {
    /// `nested` at a hit whose geometric normal is `ng`, evaluated in `frame` (the
    /// integrators' local frame, about the perturbed shading normal).
    pub fn new(nested: Material, ng: Vec3, frame: &Frame) -> Shadowed {
        let reference = frame.to_local(ng);
        Shadowed {
            nested,
            reference,
            alpha2: (0.125 * tan2(reference.z)).min(1.0),
        }
    }

    /// G of the direction towards the light: `wi` on camera paths, `wo` on light paths.
    #[inline]
    fn g(&self, wo: Vec3, wi: Vec3, mode: Mode) -> f32 {
        if self.alpha2 <= 0.0 {
            return 1.0;
        }
        let w = if mode == Mode::Radiance { wi } else { wo };
        2.0 / (1.0 + (1.0 + self.alpha2 * tan2(w.dot(self.reference))).sqrt())
    }

    #[inline(never)]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: Mode) -> Rgb {
        self.nested.eval(wo, wi, mode) * self.g(wo, wi, mode)
    }

    #[inline(never)]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: Mode) -> Option<BsdfSample> {
        let s = self.nested.sample(wo, u_lobe, u, mode)?;
        Some(self.shadow(wo, s, mode))
    }

    // The nested material's queries, out of line like the rest: a call back into
    // `Material` from one of its own arms would make its methods recursive, and the
    // kernels would then call them instead of inlining them.
    #[inline(never)]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.nested.pdf(wo, wi)
    }

    #[inline(never)]
    pub fn is_delta(&self) -> bool {
        self.nested.is_delta()
    }

    #[inline(never)]
    pub fn delta_probability(&self, wo: Vec3) -> f32 {
        self.nested.delta_probability(wo)
    }

    #[inline(never)]
    pub fn is_black_from(&self, wo: Vec3) -> bool {
        self.nested.is_black_from(wo)
    }

    #[inline(never)]
    pub fn albedo(&self) -> Rgb {
        self.nested.albedo()
    }

    /// [`Material::sample_delta`] of the nested BSDF, with the shadowing term.
    #[inline(never)]
    pub fn sample_delta(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: Mode) -> Option<BsdfSample> {
        let s = self.nested.sample_delta(wo, u_lobe, u, mode)?;
        Some(self.shadow(wo, s, mode))
    }

    fn shadow(&self, wo: Vec3, mut s: BsdfSample, mode: Mode) -> BsdfSample {
        s.weight *= self.g(wo, s.wi.into(), mode);
        s
    }
}

/// tan^2 of the angle whose cosine is `c` (infinite at grazing angles: G is 0 there).
#[inline]
fn tan2(c: f32) -> f32 {
    let c2 = c * c;
    ((1.0 - c2).max(0.0) / c2).min(f32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Diffuse;

    fn flat() -> SurfaceFrame {
        SurfaceFrame {
            ns: Vec3::Z,
            ng: Vec3::Z,
            dpdu: Vec3::X * 2.0,
            dpdv: Vec3::Y * 2.0,
        }
    }

    fn map(c: [f32; 3], flip: bool) -> Perturb {
        Perturb {
            source: NormalSource::Map(Texture::Constant(Rgb::from(c))),
            flip_invalid_normals: flip,
            use_shadowing_function: true,
        }
    }

    #[test]
    fn normal_maps_read_2rgb_minus_1_along_dpdu() {
        let up = Vec3::Z;
        assert_eq!(
            map([0.5, 0.5, 1.0], true).normal(Vec2::ZERO, &flat(), up),
            up
        );
        let n = map([1.0, 0.5, 0.5], false).normal(Vec2::ZERO, &flat(), up);
        assert!((n - Vec3::X).length() < 1e-6, "{n}");
        // dp/du along +y: the map's x follows it.
        let turned = SurfaceFrame {
            dpdu: Vec3::Y,
            dpdv: -Vec3::X,
            ..flat()
        };
        let n = map([0.75, 0.5, 1.0], false).normal(Vec2::ZERO, &turned, up);
        assert!(
            (n - Vec3::new(0.0, 0.5, 1.0).normalize()).length() < 1e-6,
            "{n}"
        );
        // No normal at all: the unperturbed one stays.
        assert_eq!(
            map([0.5, 0.5, 0.5], true).normal(Vec2::ZERO, &flat(), up),
            up
        );
    }

    #[test]
    fn invalid_normals_are_mirrored_about_the_shading_normal() {
        // Tilted 60 degrees towards +x, seen from far on the -x side.
        let c = [0.5 + 0.5 * 0.866, 0.5, 0.75];
        let wo = Vec3::new(-0.95, 0.0, 0.1).normalize();
        let kept = map(c, false).normal(Vec2::ZERO, &flat(), wo);
        let flipped = map(c, true).normal(Vec2::ZERO, &flat(), wo);
        assert!(kept.x > 0.8 && flipped.x < -0.8, "{kept} {flipped}");
        assert!((kept.z - flipped.z).abs() < 1e-6);
        // Seen from above it stays.
        let n = map(c, true).normal(Vec2::ZERO, &flat(), Vec3::Z);
        assert!(n.x > 0.8, "{n}");
    }

    #[test]
    fn constant_bumps_change_nothing() {
        let p = Perturb {
            source: NormalSource::Bump {
                height: Texture::Constant(Rgb::ONE),
                scale: 1.0,
            },
            flip_invalid_normals: true,
            use_shadowing_function: false,
        };
        assert_eq!(p.normal(Vec2::ZERO, &flat(), Vec3::Z), Vec3::Z);
    }

    #[test]
    fn shadowing_term_is_estevez() {
        let d = Material::Diffuse(Diffuse {
            reflectance: Rgb::splat(0.5),
            two_sided: false,
        });
        let n = Vec3::new(0.5, 0.0, 1.0).normalize();
        let f = Frame::from_normal(n);
        let s = Shadowed::new(d.clone(), Vec3::Z, &f);
        // tan^2 of the normal's tilt is 1/4: a^2 = 1/32.
        assert!((s.alpha2 - 1.0 / 32.0).abs() < 1e-6);
        let wo = f.to_local(Vec3::Z);
        let light = Vec3::new(0.6, 0.0, 0.8);
        let wi = f.to_local(light);
        let g = 2.0 / (1.0 + (1.0f32 + (0.36 / 0.64) / 32.0).sqrt());
        let want = d.eval(wo, wi, Mode::Radiance) * g;
        assert!((s.eval(wo, wi, Mode::Radiance) - want).length() < 1e-6);
        // On a light path the light is behind wo.
        let want = d.eval(wi, wo, Mode::Importance) * g;
        assert!((s.eval(wi, wo, Mode::Importance) - want).length() < 1e-6);
    }
}
