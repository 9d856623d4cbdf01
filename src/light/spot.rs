use super::LightSample;
use crate::math::{Frame, Rgb, Vec3, PI};

/// Spot light with Mitsuba 3's falloff: intensity I inside the beam width, falling
/// linearly in angle to zero at the cutoff angle.
#[derive(Clone, Debug)]
pub struct SpotLight {
    pub position: Vec3,
    pub frame: Frame,
    pub intensity: Rgb,
    pub cutoff: f32,
    pub beam: f32,
    cos_cutoff: f32,
    cos_beam: f32,
}

impl SpotLight {
    /// Angles in radians; `beam` is clamped to at most `cutoff`.
    pub fn new(position: Vec3, axis: Vec3, intensity: Rgb, cutoff: f32, beam: f32) -> Self {
        let beam = beam.min(cutoff);
        SpotLight {
            position,
            frame: Frame::from_normal(axis.normalize()),
            intensity,
            cutoff,
            beam,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam.cos(),
        }
    }

    /// Angular falloff for a unit direction leaving the light, in world space.
    #[inline]
    pub fn falloff(&self, w: Vec3) -> f32 {
        let cos = w.dot(self.frame.n);
        if cos <= self.cos_cutoff {
            0.0
        } else if cos >= self.cos_beam {
            1.0
        } else {
            ((self.cutoff - cos.clamp(-1.0, 1.0).acos()) / (self.cutoff - self.beam))
                .clamp(0.0, 1.0)
        }
    }

    #[inline]
    pub fn sample_li(&self, p: Vec3) -> Option<LightSample> {
        let d = self.position - p;
        let dist2 = d.length_squared();
        if dist2 <= 0.0 {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        let f = self.falloff(-wi);
        if f <= 0.0 {
            return None;
        }
        Some(LightSample::new(
            self.position,
            Vec3::ZERO,
            wi,
            dist,
            self.intensity * (f / dist2),
            1.0,
            true,
        ))
    }

    /// Exact integral of the falloff over the sphere times I: 2 pi I [ (1 - cos b) +
    /// int_b^c (c - t)/(c - b) sin t dt ].
    pub fn power(&self) -> Rgb {
        let (b, c) = (self.beam, self.cutoff);
        let ramp = if c > b {
            // int_b^c (c - t) sin t dt = (c - b) cos b - (sin c - sin b)
            ((c - b) * b.cos() - (c.sin() - b.sin())) / (c - b)
        } else {
            0.0
        };
        self.intensity * (2.0 * PI * ((1.0 - b.cos()) + ramp))
    }
}
