use super::{Distribution2D, LightSample};
use crate::math::{Mat3, Rgb, Vec2, Vec3, PI};

/// Latitude-longitude parameterisation: with the identity rotation +y is up, u runs
/// across the image, v down it, and the image centre (0.5, 0.5) looks along -z.
#[derive(Clone, Copy, Debug)]
pub struct LatLong;

impl LatLong {
    #[inline]
    pub fn to_dir(uv: Vec2) -> Vec3 {
        let theta = uv.y * PI;
        let phi = 2.0 * PI * (uv.x - 0.5);
        let (st, ct) = theta.sin_cos();
        Vec3::new(st * phi.sin(), ct, -st * phi.cos())
    }

    #[inline]
    pub fn to_uv(d: Vec3) -> Vec2 {
        let u = d.x.atan2(-d.z) * (0.5 / PI) + 0.5;
        let v = d.y.clamp(-1.0, 1.0).acos() / PI;
        Vec2::new(
            u.clamp(0.0, 1.0 - f32::EPSILON),
            v.clamp(0.0, 1.0 - f32::EPSILON),
        )
    }
}

/// Environment map, importance sampled by luminance times sin(theta) per texel; lookups
/// are nearest-texel so that the sampling density matches the radiance exactly.
#[derive(Clone, Debug)]
pub struct EnvMap {
    width: usize,
    height: usize,
    texels: Vec<Rgb>,
    dist: Distribution2D,
    /// World-from-map rotation and its inverse.
    to_world: Mat3,
    to_local: Mat3,
    mean: Rgb,
}

impl EnvMap {
    pub fn new(width: usize, height: usize, texels: Vec<Rgb>, to_world: Mat3) -> Self {
        let weights: Vec<f32> = (0..height)
            .flat_map(|y| {
                let sin_t = ((y as f32 + 0.5) / height as f32 * PI).sin();
                let row = &texels[y * width..(y + 1) * width];
                row.iter()
                    .map(move |c| crate::math::luminance(*c).max(0.0) * sin_t)
                    .collect::<Vec<_>>()
            })
            .collect();
        // Mean radiance over the sphere: sum of L times each texel's exact solid angle,
        // (2 pi / width) (cos theta_0 - cos theta_1), over 4 pi. (The midpoint rule,
        // sin(theta_mid) d theta, is 0.6% low on an 8-row map.)
        let mut mean = Rgb::ZERO;
        for y in 0..height {
            let (t0, t1) = (y as f64 / height as f64, (y + 1) as f64 / height as f64);
            let band =
                ((t0 * std::f64::consts::PI).cos() - (t1 * std::f64::consts::PI).cos()) as f32;
            let mut row = Rgb::ZERO;
            for x in 0..width {
                row += texels[y * width + x];
            }
            mean += row * band;
        }
        let mean = mean * (2.0 * PI / width as f32) / (4.0 * PI);
        EnvMap {
            width,
            height,
            dist: Distribution2D::new(&weights, width, height),
            texels,
            to_local: to_world.transpose(),
            to_world,
            mean,
        }
    }

    pub fn mean_radiance(&self) -> Rgb {
        self.mean
    }

    #[inline]
    fn texel(&self, uv: Vec2) -> Rgb {
        let x = ((uv.x * self.width as f32) as usize).min(self.width - 1);
        let y = ((uv.y * self.height as f32) as usize).min(self.height - 1);
        self.texels[y * self.width + x]
    }

    #[inline]
    pub fn eval(&self, d: Vec3) -> Rgb {
        self.texel(LatLong::to_uv(self.to_local * d))
    }

    #[inline]
    pub fn sample_li(&self, u: Vec2) -> Option<LightSample> {
        let (uv, pdf_uv) = self.dist.sample(u);
        let local = LatLong::to_dir(uv);
        let sin_t = safe_sin_theta(local);
        if pdf_uv <= 0.0 || sin_t <= 0.0 {
            return None;
        }
        // dA(uv) = 2 pi^2 sin(theta) dw.
        let pdf = pdf_uv / (2.0 * PI * PI * sin_t);
        let wi = self.to_world * local;
        Some(LightSample::new(
            Vec3::ZERO,
            Vec3::ZERO,
            wi,
            f32::INFINITY,
            self.texel(uv),
            pdf,
            false,
        ))
    }

    #[inline]
    pub fn pdf_li(&self, wi: Vec3) -> f32 {
        let local = self.to_local * wi;
        let sin_t = safe_sin_theta(local);
        if sin_t <= 0.0 {
            return 0.0;
        }
        self.dist.pdf(LatLong::to_uv(local)) / (2.0 * PI * PI * sin_t)
    }
}

#[inline]
fn safe_sin_theta(d: Vec3) -> f32 {
    crate::math::safe_sqrt(d.x * d.x + d.z * d.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn latlong_round_trip_and_centre_looks_down_minus_z() {
        assert!((LatLong::to_dir(Vec2::new(0.5, 0.5)) - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        for &(u, v) in &[(0.1f32, 0.2f32), (0.7, 0.9), (0.5, 0.01)] {
            let uv = LatLong::to_uv(LatLong::to_dir(Vec2::new(u, v)));
            assert!((uv - Vec2::new(u, v)).length() < 1e-4);
        }
    }
}
