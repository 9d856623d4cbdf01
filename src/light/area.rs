use super::emitting::{grid, Emitting};
use super::{Distribution1D, LightSample};
use crate::geometry::{Interaction, Prim, TexCoords};
use crate::material::texture::Texture;
use crate::math::warp::{sin_cos_2pi, square_to_disk, square_to_triangle};
use crate::math::{safe_sqrt, Frame, Rgb, Vec2, Vec3, PI};

/// Lambertian emission from a shape, on the side its (possibly flipped) normal points
/// to, or both sides when `two_sided`.
///
/// The radiance is one colour, or a texture over the shape's (u, v) (`textured`).
/// Every read of it goes through one branch on `textured`, so constant lights cost
/// what they did before textures existed; the lookup itself is out of line.
#[derive(Clone, Debug)]
pub struct AreaLight {
    pub shape: u32,
    /// The radiance; for a textured light, its mean over the surface (an estimate,
    /// for the light's power).
    pub radiance: Rgb,
    pub two_sided: bool,
    /// Radiance that varies over the surface, with the shape's texture coordinates.
    textured: Option<Box<Emitting>>,
    /// World-space primitives of the shape.
    prims: Vec<Prim>,
    /// -1 when the shape's normals are flipped.
    normal_sign: f32,
    /// Front normals of flat primitives (flip applied), so sampling need not
    /// normalise a cross product per sample.
    normals: Vec<Vec3>,
    by_area: Distribution1D,
    area: f32,
}

impl AreaLight {
    pub fn new(shape: u32, prims: Vec<Prim>, flip: bool, radiance: Rgb, two_sided: bool) -> Self {
        let areas: Vec<f32> = prims.iter().map(Prim::area).collect();
        let area = areas.iter().sum();
        let normal_sign = if flip { -1.0 } else { 1.0 };
        AreaLight {
            normals: prims
                .iter()
                .map(|p| Vec3::from(p.flat_normal()) * normal_sign)
                .collect(),
            shape,
            radiance,
            two_sided,
            by_area: Distribution1D::new(&areas),
            prims,
            normal_sign,
            area,
            textured: None,
        }
    }

    /// The light with radiance `texture` over the shape's texture coordinates `uvs`
    /// (computed for the same primitives, in the same order). Its `radiance` becomes
    /// the texture's mean over the surface, estimated on a grid of samples uniform by
    /// area, for the power that light selection weighs.
    pub fn with_texture(mut self, texture: Texture, uvs: TexCoords) -> Self {
        let t = Emitting { texture, uvs };
        const SIDE: u32 = 64;
        let sum: glam::DVec3 = grid(SIDE)
            .map(|u| {
                let (i, _, ux) = self.by_area.sample_discrete(u.x);
                let u = Vec2::new(ux, u.y);
                let (p, _) = self.point_on(i, u);
                t.at_sample(&self.prims[i], i, u, p).as_dvec3()
            })
            .sum();
        self.radiance = (sum / f64::from(SIDE * SIDE)).as_vec3();
        self.textured = Some(Box::new(t));
        self
    }

    pub fn area(&self) -> f32 {
        self.area
    }

    /// Whether the light emits from a point with front normal `n` towards `w`.
    #[inline(always)]
    fn emits(&self, n: Vec3, w: Vec3) -> bool {
        self.two_sided || n.dot(w) > 0.0
    }

    /// Radiance leaving the light towards `w` at `it`, a hit on its shape.
    #[inline]
    pub fn le(&self, it: &Interaction, w: Vec3) -> Rgb {
        if !self.emits(it.ng, w) {
            return Rgb::ZERO;
        }
        match &self.textured {
            None => self.radiance,
            Some(t) => t.at_hit(*it),
        }
    }

    /// Radiance leaving towards `w` the point `es` (from [`AreaLight::sample_le`])
    /// started a light path from.
    #[inline]
    pub fn le_sampled(&self, es: &super::EmissionSample, w: Vec3) -> Rgb {
        if self.emits(es.n, w) {
            es.le
        } else {
            Rgb::ZERO
        }
    }

    /// Radiance at the point `point_on(i, u)` placed at `p`.
    #[inline(always)]
    fn radiance_on(&self, i: usize, u: Vec2, p: Vec3) -> Rgb {
        match &self.textured {
            None => self.radiance,
            Some(t) => t.at_sample(&self.prims[i], i, u, p),
        }
    }

    /// Emitted power. For a textured light, its mean radiance (estimated over the
    /// surface) stands in for the radiance, as Mitsuba's area emitter takes its
    /// texture's mean; a light whose estimate came out black is kept selectable.
    pub fn power(&self) -> Rgb {
        let sides = if self.two_sided { 2.0 } else { 1.0 };
        let radiance = match &self.textured {
            None => self.radiance,
            Some(t) => self.radiance.max(Rgb::splat(1e-3 * t.texture.max_value())),
        };
        radiance * (PI * self.area * sides)
    }

    /// The analytic sphere to sample by solid angle, when the light is one and `p` is
    /// outside it.
    #[inline(always)]
    fn visible_sphere(&self, p: Vec3) -> Option<(Vec3, f32)> {
        match self.prims.as_slice() {
            [Prim::Sphere { c, r }] if (p - Vec3::from(*c)).length_squared() > r * r * 1.0001 => {
                Some(((*c).into(), *r))
            }
            _ => None,
        }
    }

    /// A uniformly distributed point on the light: (point, front normal).
    #[inline]
    pub fn sample_area(&self, u_prim: f32, u: Vec2) -> (Vec3, Vec3) {
        let (i, _, _) = self.by_area.sample_discrete(u_prim);
        self.point_on(i, u)
    }

    /// A bound on the rounding error of `point_on(i, u)` per component: each is a
    /// sum of three products, c + a s + b t, whose rounding is below gamma(3) times the
    /// sum of the terms' magnitudes (pbrt-v4 sec. 6.8.5); gamma(5) also covers the
    /// edge vectors' own rounding at build time. A bound proportional to |p| alone
    /// would be zero where the terms cancel (a point near a coordinate plane on a
    /// light far from it) and let rays leaving the light hit it again.
    fn point_error(&self, i: usize, u: Vec2) -> Vec3 {
        use crate::math::gamma;
        let terms = match self.prims[i] {
            Prim::Tri { p0, e1, e2 } => {
                let b = square_to_triangle(u);
                p0.abs() + (e1 * b.x).abs() + (e2 * b.y).abs()
            }
            Prim::Quad { p0, e1, e2 } => p0.abs() + (e1 * u.x).abs() + (e2 * u.y).abs(),
            Prim::Sphere { c, r } => c.abs() + glam::Vec3A::splat(r),
            Prim::Disk { c, u: du, v: dv } => {
                let q = square_to_disk(u);
                c.abs() + (du * q.x).abs() + (dv * q.y).abs()
            }
        };
        Vec3::from(terms) * gamma(5)
    }

    // Forced: out of line it is a baseline-x86 call from the AVX2 kernels (seen once
    // its sphere arm grew).
    #[inline(always)]
    fn point_on(&self, i: usize, u: Vec2) -> (Vec3, Vec3) {
        match self.prims[i] {
            Prim::Tri { p0, e1, e2 } => {
                let b = square_to_triangle(u);
                ((p0 + e1 * b.x + e2 * b.y).into(), self.normals[i])
            }
            Prim::Quad { p0, e1, e2 } => ((p0 + e1 * u.x + e2 * u.y).into(), self.normals[i]),
            Prim::Sphere { c, r } => {
                let d = crate::math::warp::square_to_uniform_sphere(u);
                ((c + r * glam::Vec3A::from(d)).into(), d * self.normal_sign)
            }
            Prim::Disk { c, u: du, v: dv } => {
                let q = square_to_disk(u);
                ((c + du * q.x + dv * q.y).into(), self.normals[i])
            }
        }
    }

    // Forced: callers in the AVX2 kernels otherwise get a baseline-x86 copy.
    #[inline(always)]
    pub fn sample_li(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        if let Some((c, r)) = self.visible_sphere(p) {
            return self.sample_sphere_cone(p, c, r, u);
        }
        // Reuse the first dimension to pick the primitive, remapped, so each sample
        // costs two random numbers.
        let (i, _, ux) = self.by_area.sample_discrete(u.x);
        let (pl, n) = self.point_on(i, Vec2::new(ux, u.y));
        let d = pl - p;
        let dist2 = d.length_squared();
        let dist = dist2.sqrt();
        if dist <= 0.0 {
            return None;
        }
        let wi = d / dist;
        let cos_l = n.dot(-wi);
        let li = if self.emits(n, -wi) {
            self.radiance_on(i, Vec2::new(ux, u.y), pl)
        } else {
            Rgb::ZERO
        };
        if cos_l.abs() <= 0.0 || li == Rgb::ZERO {
            return None;
        }
        Some(LightSample::new(
            pl,
            n,
            wi,
            dist,
            li,
            dist2 / (cos_l.abs() * self.area),
            false,
        ))
    }

    /// Uniform sampling of the cone the sphere subtends (pbrt-v4, sec. 6.2.4, with its
    /// small-angle series for distant spheres).
    fn sample_sphere_cone(&self, p: Vec3, c: Vec3, r: f32, u: Vec2) -> Option<LightSample> {
        let to_c = c - p;
        let dc = to_c.length();
        let sin_max = r / dc;
        let sin2_max = sin_max * sin_max;
        let cos_max = safe_sqrt(1.0 - sin2_max);
        let mut one_minus_cos_max = 1.0 - cos_max;
        let mut cos_t = (cos_max - 1.0) * u.x + 1.0;
        let mut sin2_t = 1.0 - cos_t * cos_t;
        if sin2_max < 0.000_685_23 {
            // sin^2(1.5 deg): below it, 1 - cos loses every digit.
            sin2_t = sin2_max * u.x;
            cos_t = (1.0 - sin2_t).sqrt();
            one_minus_cos_max = sin2_max / 2.0;
        }
        // Angle alpha at the sphere's centre between the axis and the sampled point.
        let cos_a = sin2_t / sin_max + cos_t * safe_sqrt(1.0 - sin2_t / sin2_max);
        let sin_a = safe_sqrt(1.0 - cos_a * cos_a);
        let (sin_phi, cos_phi) = sin_cos_2pi(u.y);
        let frame = Frame::from_normal(to_c / dc);
        let w = Vec3::new(sin_a * cos_phi, sin_a * sin_phi, cos_a);
        let n_out = frame.to_world(-w);
        let pl = c + r * n_out;
        let d = pl - p;
        let dist = d.length();
        let wi = d / dist;
        let n = n_out * self.normal_sign;
        let li = if self.emits(n, -wi) {
            self.radiance_on(0, Vec2::ZERO, pl)
        } else {
            Rgb::ZERO
        };
        if li == Rgb::ZERO {
            return None;
        }
        Some(LightSample::new(
            pl,
            n,
            wi,
            dist,
            li,
            1.0 / (2.0 * PI * one_minus_cos_max),
            false,
        ))
    }

    /// Solid-angle density of reaching `pl` (front normal `n`) from `p` (inlined, as
    /// `Light::pdf_li`).
    #[inline(always)]
    pub fn pdf_li(&self, p: Vec3, pl: Vec3, n: Vec3) -> f32 {
        if let Some((c, r)) = self.visible_sphere(p) {
            let sin2_max = r * r / (c - p).length_squared();
            let one_minus_cos_max = if sin2_max < 0.000_685_23 {
                sin2_max / 2.0
            } else {
                1.0 - safe_sqrt(1.0 - sin2_max)
            };
            return 1.0 / (2.0 * PI * one_minus_cos_max);
        }
        let d = pl - p;
        let dist2 = d.length_squared();
        let cos_l = n.dot(d).abs() / dist2.sqrt();
        if cos_l <= 0.0 {
            return 0.0;
        }
        dist2 / (cos_l * self.area)
    }
}

impl AreaLight {
    /// Emission sampling for light paths: a uniform point on the light, then a
    /// cosine-distributed direction on its emitting side (either side with probability
    /// 1/2 when two-sided).
    #[inline]
    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2) -> Option<super::EmissionSample> {
        let (i, _, ux) = self.by_area.sample_discrete(u_pos.x);
        let u_point = Vec2::new(ux, u_pos.y);
        let (p, n) = self.point_on(i, u_point);
        let (mut u, mut side) = (u_dir, 1.0);
        if self.two_sided {
            // Reuse the first dimension to pick the side.
            if u.x < 0.5 {
                u.x *= 2.0;
            } else {
                u.x = 2.0 * u.x - 1.0;
                side = -1.0;
            }
        }
        let local = crate::math::warp::square_to_cosine_hemisphere(u);
        if local.z <= 0.0 {
            return None;
        }
        let le = self.radiance_on(i, u_point, p);
        if le == Rgb::ZERO {
            return None;
        }
        let d = Frame::from_normal(n * side).to_world(local);
        let (pdf_pos, pdf_dir) = self.pdf_le(n, d);
        Some(super::EmissionSample {
            p,
            n,
            p_err: self.point_error(i, u_point),
            d,
            le,
            pdf_pos,
            pdf_dir,
            cos: local.z,
        })
    }

    /// Densities of `sample_le` emitting from a point with front normal `n` in direction
    /// `d`: (area density of the point, solid-angle density of the direction).
    #[inline]
    pub fn pdf_le(&self, n: Vec3, d: Vec3) -> (f32, f32) {
        let cos = n.dot(d);
        let pdf_dir = if self.two_sided {
            0.5 * cos.abs() * crate::math::INV_PI
        } else {
            cos.max(0.0) * crate::math::INV_PI
        };
        (1.0 / self.area, pdf_dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;
    use glam::{DVec3, Vec3A};

    /// `point_error` bounds the distance between the f32 point and the same point
    /// computed in f64 from the stored primitive, per component, on lights far from
    /// the origin whose coordinates cancel (where a bound proportional to |p| fails).
    #[test]
    fn point_error_bounds_the_rounding_of_sampled_points() {
        let far = Vec3A::new(-3.0e4, 7.0e3, 1.0e4);
        let prims = vec![
            Prim::Tri {
                p0: far,
                e1: Vec3A::new(6.0e4, 1.0, -2.0e4),
                e2: Vec3A::new(3.0e4, -1.4e4, 0.5),
            },
            Prim::Quad {
                p0: far,
                e1: Vec3A::new(6.0e4, 3.0, 0.25),
                e2: Vec3A::new(0.5, -1.4e4, 2.0e4),
            },
            Prim::Sphere {
                c: Vec3A::new(1.0e4, -1.0e4, 3.0),
                r: 1.0e4,
            },
            Prim::Disk {
                c: far,
                u: Vec3A::new(3.0e4, 0.0, 1.0e4),
                v: Vec3A::new(0.0, 3.0e4, 0.0),
            },
        ];
        let light = AreaLight::new(0, prims.clone(), false, Rgb::splat(1.0), false);
        let mut rng = Rng::new(1, 2, 3);
        let mut old_fails = 0;
        let d = |v: Vec3A| DVec3::new(v.x as f64, v.y as f64, v.z as f64);
        for (i, prim) in prims.iter().enumerate() {
            for _ in 0..2000 {
                let u = rng.next_2d();
                let (p, _) = light.point_on(i, u);
                let exact = match *prim {
                    Prim::Tri { p0, e1, e2 } => {
                        let b = square_to_triangle(u);
                        d(p0) + d(e1) * b.x as f64 + d(e2) * b.y as f64
                    }
                    Prim::Quad { p0, e1, e2 } => d(p0) + d(e1) * u.x as f64 + d(e2) * u.y as f64,
                    Prim::Sphere { c, r } => {
                        let dir = crate::math::warp::square_to_uniform_sphere(u);
                        d(c) + d(Vec3A::from(dir)) * r as f64
                    }
                    Prim::Disk { c, u: du, v: dv } => {
                        let q = square_to_disk(u);
                        d(c) + d(du) * q.x as f64 + d(dv) * q.y as f64
                    }
                };
                let err = (d(p.into()) - exact).abs();
                let bound = d(light.point_error(i, u).into());
                assert!(
                    err.cmple(bound).all(),
                    "prim {i}: error {err:?} above bound {bound:?} at {p:?}"
                );
                // Where terms cancel, gamma(6) |p| (the rule light subpaths used
                // before) is below the error.
                let old = d(p.abs().into()) * crate::math::gamma(6) as f64;
                old_fails += err.cmpgt(old).any() as u32;
            }
        }
        assert!(old_fails > 0, "the test points never cancel");
    }
}
