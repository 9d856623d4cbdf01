//! A job's memory against the server's budget (`caustic serve --max-job-mib`).
//!
//! The estimate is the integrator's ([`Settings::memory`]: its stores, film and exact
//! sums) plus what the job layer holds besides: the reference image, and the copies
//! that writing a checkpoint or the images makes, whichever is larger. A job above
//! the budget is refused when it is submitted (REST, gRPC, every job of a sweep), with
//! the figure and the parameter that drives it; and checked again when it starts, so
//! that a job stored before the budget was lowered fails with the same message
//! instead of running.

use super::spec::JobSpec;
use super::JobError;
use crate::film::{ExactSums, Film, Image};
use crate::integrator::memory::Estimate;
use crate::integrator::Settings;
use crate::scene::Scene;

/// The budget when the machine's memory cannot be read.
const FALLBACK_BUDGET: u64 = 4 << 30;

/// The default budget per job: the memory this process may use (the machine's, or its
/// control group's limit when lower), shared by the `active_jobs` jobs held in memory
/// at once, so that they fit together.
pub fn default_budget(active_jobs: usize) -> u64 {
    machine_memory().map_or(FALLBACK_BUDGET, |m| m / active_jobs.max(1) as u64)
}

/// Physical memory, or the control group's memory limit when it is lower (a container).
fn machine_memory() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib = crate::bench::mem::proc_kib(&meminfo, "MemTotal:")?;
    let limits = [
        "/sys/fs/cgroup/memory.max",
        "/sys/fs/cgroup/memory/memory.limit_in_bytes",
    ];
    let cgroup = limits
        .iter()
        .filter_map(|p| std::fs::read_to_string(p).ok()?.trim().parse::<u64>().ok())
        .min();
    Some(cgroup.map_or(kib << 10, |c| c.min(kib << 10)))
}

/// The peak memory of the job `spec` with `settings` on `scene`, by part.
pub fn estimate(settings: &Settings, scene: &Scene, spec: &JobSpec) -> Estimate {
    let mut e = settings.memory(scene);
    let (w, h) = (scene.width(), scene.height());
    let film = format!("film {w}x{h}");
    if spec.reference.is_some() {
        e.add("reference image", &film, Image::bytes_for(w, h) as f64);
    }
    let layers = settings.layers();
    // A filter's weights and splats are copied and encoded with the sums.
    let filtered = 2 * settings.filter_bytes(scene);
    let writing = checkpoint_bytes(w, h, layers).max(images_bytes(w, h, layers)) + filtered;
    e.add("checkpoint and snapshots", film, writing as f64);
    e
}

/// What writing a checkpoint holds at once (`store::Checkpoint`): the film and exact
/// sums it copies, the exact sums encoded, and the file's bytes (the film's sums and
/// the encoded exact sums, in a buffer that may have doubled to take them).
fn checkpoint_bytes(w: u32, h: u32, layers: usize) -> u64 {
    let exact = ExactSums::bytes_for(w, h, layers);
    let file = Film::bytes_for(w, h, 0) + exact;
    Film::bytes_for(w, h, layers) + 2 * exact + 2 * file
}

/// What writing the images holds at once: the mean as a film and as an image per
/// layer, and the EXR and PNG being encoded (two images' worth).
fn images_bytes(w: u32, h: u32, layers: usize) -> u64 {
    Film::bytes_for(w, h, layers) + Image::bytes_for(w, h) * (layers as u64 + 3)
}

/// Refuses a job whose estimate exceeds `budget` bytes, naming the figure, its largest
/// parts and the parameter behind the largest.
pub fn check(
    settings: &Settings,
    scene: &Scene,
    spec: &JobSpec,
    budget: u64,
) -> Result<(), JobError> {
    let e = estimate(settings, scene, spec);
    if e.total() <= budget {
        return Ok(());
    }
    let driver = e
        .by_size()
        .first()
        .map_or(String::new(), |p| p.driver.clone());
    Err(JobError::BadRequest(format!(
        "{}: {driver} needs {}; this server's limit is {} MiB per job (--max-job-mib)",
        settings.name(),
        e.summary(),
        budget >> 20
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(size: u32) -> Scene {
        let json = format!(
            r#"{{"format": 1,
            "camera": {{"look_at": {{"origin": [0, 0, 3], "target": [0, 0, 0], "up": [0, 1, 0]}}, "fov": 40}},
            "film": {{"width": {size}, "height": {size}}},
            "materials": {{"m": {{"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}}}},
            "shapes": [{{"type": "sphere", "radius": 1, "material": "m"}}],
            "lights": [{{"type": "point", "position": [0, 2, 2], "intensity": [1, 1, 1]}}]}}"#
        );
        let file = crate::scene::load::parse_scene(&json).unwrap();
        Scene::compile(&file, None).unwrap()
    }

    fn spec(v: serde_json::Value) -> JobSpec {
        serde_json::from_value(v).unwrap()
    }

    /// A film-bound job: the message names the film as what drives it, and the checkpoint
    /// copies, at about 600 bytes a pixel (360 before the noise estimate's second
    /// moments joined the exact sums), dominate `pt`'s estimate.
    #[test]
    fn a_film_bound_job_names_the_film() {
        let scene = scene(1024);
        let pt = Settings::resolve(Some("pt"), None, &serde_json::Map::new()).unwrap();
        let job = spec(serde_json::json!({"scene": "s", "halt": {"spp": 1}}));
        let e = estimate(&pt, &scene, &job);
        let per_pixel = e.total() as f64 / (1024.0 * 1024.0);
        assert!(
            (500.0..700.0).contains(&per_pixel),
            "{per_pixel} bytes a pixel: {e:?}"
        );
        assert!(check(&pt, &scene, &job, e.total()).is_ok());
        let err = check(&pt, &scene, &job, 100 << 20).unwrap_err().to_string();
        assert!(
            err.starts_with("pt: film 1024x1024 needs about 6") && err.contains("100 MiB per job"),
            "{err}"
        );
        // A reference image is held too.
        let with_ref = spec(serde_json::json!({"scene": "s", "halt": {"spp": 1},
            "reference": {"upload": "0123456789abcdef"}}));
        let more = estimate(&pt, &scene, &with_ref).total() - e.total();
        assert_eq!(more, Image::bytes_for(1024, 1024));
    }

    #[test]
    fn the_default_budget_shares_the_machine() {
        let one = default_budget(1);
        assert!(one >= 256 << 20, "{one}");
        assert!(default_budget(4) <= one / 4 + 1);
    }
}
