use super::{Distribution1D, Light, SceneSphere};
use crate::math::luminance;
use serde::{Deserialize, Serialize};

/// How a light is picked (the scene file's `light_selection`).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum LightSelection {
    /// Proportional to each light's emitted power (luminance).
    #[default]
    Power,
    Uniform,
}

/// Picks one light per sample, proportionally to power (default) or uniformly.
#[derive(Clone, Debug)]
pub struct LightSampler {
    dist: Distribution1D,
}

impl LightSampler {
    pub fn new(lights: &[Light], mode: LightSelection, sphere: &SceneSphere) -> Self {
        let weights: Vec<f32> = match mode {
            LightSelection::Uniform => vec![1.0; lights.len()],
            LightSelection::Power => lights
                .iter()
                .map(|l| luminance(l.power(sphere)).max(0.0))
                .collect(),
        };
        LightSampler {
            dist: Distribution1D::new(&weights),
        }
    }

    /// (light index, selection probability, u remapped for reuse).
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        self.dist.sample_discrete(u)
    }

    #[inline]
    pub fn pmf(&self, light: usize) -> f32 {
        self.dist.pmf(light)
    }
}
