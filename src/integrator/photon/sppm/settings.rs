//! The parameters `ppm` and `sppm` take, their checks and their memory estimate.

use super::*;

/// Photon mapping parameters (`ppm` and `sppm` take the same ones).
///
/// | field | default | meaning |
/// |---|---|---|
/// | `max_depth` | 64 | longest path, in Mitsuba's sense (1 = emitters seen directly), counted over the camera and photon halves together |
/// | `light_paths` | 1.0 | photon paths per pass, as a multiple of the pixel count |
/// | `radius` | none | initial gather radius, in scene units; overrides `radius_factor` |
/// | `radius_factor` | 0.01 | initial radius as a fraction of the scene's bounding-sphere radius (about 1.5 pixels on the 256 x 256 Cornell box) |
/// | `alpha` | 0.7 | fraction of new photons kept per pass (the papers' alpha, in (0, 1]; 1 never shrinks the radius) |
/// | `rr_depth` | 1 | photon scattering events before Russian roulette starts (it keeps photon power near constant: survival = new / old throughput) |
/// | `medium_radius` | none | media: first radius of the beam radiance estimate in scene units; overrides `medium_radius_factor` |
/// | `medium_radius_factor` | 0.03 | media: the same as a fraction of the scene's bounding-sphere radius (`vpm`'s default) |
/// | `medium_alpha` | 2/3 | media: r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1) (Knaus and Zwicker; 2/3 balances variance and squared bias in 2D) |
/// | `max_photon_mib` | 1024 | media: budget for the medium photons of one wave of photon paths |
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct SppmSettings {
    pub max_depth: u32,
    pub light_paths: f32,
    pub radius: Option<f32>,
    pub radius_factor: f32,
    pub alpha: f32,
    pub rr_depth: u32,
    pub medium_radius: Option<f32>,
    pub medium_radius_factor: f32,
    pub medium_alpha: f32,
    pub max_photon_mib: f32,
}

impl Default for SppmSettings {
    fn default() -> Self {
        SppmSettings {
            max_depth: 64,
            light_paths: 1.0,
            radius: None,
            radius_factor: 0.01,
            alpha: 0.7,
            rr_depth: 1,
            medium_radius: None,
            medium_radius_factor: 0.03,
            medium_alpha: 2.0 / 3.0,
            max_photon_mib: 1024.0,
        }
    }
}

impl SppmSettings {
    pub fn validate(&self) -> Result<(), ParamError> {
        check_photon_params(
            self.max_depth,
            self.light_paths,
            self.radius,
            self.radius_factor,
        )?;
        check_alpha(self.alpha)?;
        check_radius(self.medium_radius, self.medium_radius_factor)
            .map_err(|e| e.prefixed("medium_"))?;
        check_alpha(self.medium_alpha).map_err(|e| e.prefixed("medium_"))?;
        if !(self.max_photon_mib.is_finite() && self.max_photon_mib > 0.0) {
            return Err(ParamError::new(
                "max_photon_mib",
                format!(
                    "max_photon_mib must be positive, got {}",
                    self.max_photon_mib
                ),
            ));
        }
        Ok(())
    }

    /// A job's memory (module `memory`): per pixel, the statistics and their
    /// checkpoint copy, and the camera pass's results, held twice while they are
    /// gathered into one array, then with the gathered flux and the film each pass
    /// rebuilds; for one wave of photon paths, its chunks' photons and the map's with
    /// its grid (in media, the medium photons and their BVH too).
    pub fn memory(&self, facts: &Facts) -> Memory {
        let mut e = Memory::default();
        let scene = facts.scene;
        let px = facts.pixels();
        let camera = array::<CameraResult>(px);
        let gathered = array::<Gathered>(px) + array::<[f64; 3]>(px);
        let mut per_pixel =
            array::<PixelStat>(px) + px * state::PIXEL_BYTES as f64 + camera + camera.max(gathered);
        if scene.has_media {
            // A camera path that meets a medium records its segments: the first push
            // makes room for four.
            per_pixel += px * array::<CameraSegment>(4.0);
        }
        e.add("per-pixel statistics", facts.film(), per_pixel);
        if scene.lights.is_empty() {
            return e;
        }
        let paths = photon_paths(self.light_paths, px);
        let wave = paths.min(WAVE);
        let driver = paths_driver(Some(self.light_paths), paths, facts);
        let walk = crate::integrator::pilot::walk(facts, self.max_depth, true);
        let chunks = wave.div_ceil(PATHS_PER_TASK);
        let per_chunk = wave as f64 / chunks as f64;
        let surface = per_chunk * (walk.surface - walk.direct);
        let point = std::mem::size_of::<Vec3>() + std::mem::size_of::<SurfacePhoton>();
        let n = surface * chunks as f64;
        // Each wave's chunks are new; the map's arrays are refilled.
        let mut photons = (chunks as f64 * pushed(surface, 0.0) + refilled(n, 0.0)) * point as f64;
        let mut index = HashGrid::bytes_for(n);
        let mut driver = driver;
        if scene.has_media {
            let budget = photon_budget(self.max_photon_mib, chunks) as f64;
            let wanted = per_chunk * walk.medium;
            let medium = wanted.min(budget);
            let m = medium * chunks as f64;
            photons += chunks as f64 * array::<Photon>(pushed(medium, 0.0))
                + array::<Photon>(refilled(m, 0.0));
            index += PointBvh::<Photon>::bytes_for(m);
            driver = capped(
                &driver,
                wanted > budget,
                "max_photon_mib",
                self.max_photon_mib,
            );
        }
        e.add("photons", &driver, photons);
        e.add("photon index", &driver, index);
        e
    }

    /// The radius of the media's beam radiance estimate in `iteration`.
    pub(super) fn medium_radius_at(&self, scene: &Scene, iteration: u64) -> f32 {
        let r1 = self
            .medium_radius
            .unwrap_or(self.medium_radius_factor * scene.sphere.radius);
        radius_schedule(r1, self.medium_alpha, 2, iteration)
    }

    /// Initial radius for `scene`.
    pub fn initial_radius(&self, scene: &Scene) -> f32 {
        self.radius
            .unwrap_or(self.radius_factor * scene.sphere.radius)
    }
}
