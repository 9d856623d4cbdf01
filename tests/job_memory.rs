//! Issue 36: a job's memory estimate against what the job allocates at its peak: the
//! integrator's (`Settings::memory`) for every algorithm, on a scene without media and
//! on one with fog, and the whole job's (`job::memory::estimate`) for jobs run by the
//! service, checkpoints and snapshots included. This test binary counts every
//! allocation (its own global allocator), so the figures are exact rather than a
//! noisy resident-set size; its tests take turns.
//!
//! The estimate must lie within [LOW, HIGH] times the measured peak: not below it by
//! more than the pilot's sampling error and the Vec growth it cannot foresee, and not
//! so far above that it refuses jobs that fit. It counts buffers that are refilled
//! every iteration at the twice-the-count they can grow to over a long job, so it
//! stands above a short render's peak.

mod common;

use caustic::integrator::drive::{self, Halt};
use caustic::integrator::memory::{human, Estimate};
use caustic::integrator::Settings;
use caustic::job::{JobSpec, Service, ServiceConfig};
use caustic::scene::Scene;
use common::{settings, shipped_media};
use serde_json::{json, Value};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// The factor the estimate may be off by, each way (module notes).
const LOW: f64 = 0.8;
const HIGH: f64 = 3.0;

/// Measurements take turns: the allocator's counters are the process's.
static SERIAL: Mutex<()> = Mutex::new(());

/// The system allocator, counting the bytes held now and at the peak.
struct Counting;

static NOW: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grew(by: usize) {
    let now = NOW.fetch_add(by, Ordering::Relaxed) + by;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

// SAFETY: every call is passed to the system allocator unchanged; the counters only
// observe the sizes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        NOW.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            if new_size >= layout.size() {
                grew(new_size - layout.size());
            } else {
                NOW.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
            }
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Starts a measurement: the peak is reset to what is allocated now, which is returned.
fn begin() -> usize {
    let before = NOW.load(Ordering::Relaxed);
    PEAK.store(before, Ordering::Relaxed);
    before
}

/// Bytes allocated at the peak since `begin` returned `before`, above it.
fn peak_since(before: usize) -> u64 {
    PEAK.load(Ordering::Relaxed).saturating_sub(before) as u64
}

/// Bytes allocated at the peak of `iterations` iterations of `s` on `scene`, above
/// what was allocated before (the scene).
fn render_peak(scene: &Scene, s: &Settings, iterations: u64) -> u64 {
    let before = begin();
    let integrator = s.build();
    let out = drive::render(
        scene,
        integrator.as_ref(),
        1,
        Halt {
            iterations: Some(iterations),
            ..Halt::default()
        },
        |_, _| {},
    );
    drop((out, integrator));
    peak_since(before)
}

/// The Cornell box at `size` x `size`.
fn cornell(size: u32) -> Scene {
    cornell_with(size, json!("box"))
}

/// The Cornell box at `size` x `size` with pixel filter `filter` (a wider one adds
/// summed weights, splat images and tile borders).
fn cornell_with(size: u32, filter: Value) -> Scene {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box.json"
    ))
    .unwrap();
    let mut v: Value = serde_json::from_str(&text).unwrap();
    v["film"] = json!({"width": size, "height": size, "filter": filter});
    common::compile(v)
}

/// `estimate` against `measured`: the ratio, or a line saying what is wrong.
fn compare(what: &str, e: &Estimate, measured: u64) -> Result<f64, String> {
    let ratio = e.total() as f64 / measured as f64;
    let line = format!(
        "{what}: estimate {} ({}), measured {}, ratio {ratio:.2}",
        human(e.total()),
        e.by_size()
            .iter()
            .map(|p| format!("{} {}", p.what, human(p.bytes)))
            .collect::<Vec<_>>()
            .join(", "),
        human(measured)
    );
    eprintln!("{line}");
    if (LOW..=HIGH).contains(&ratio) {
        Ok(ratio)
    } else {
        Err(line)
    }
}

/// Every algorithm, with light paths enough that its stores outweigh the film: the
/// estimate of its settings against a render of four iterations.
#[test]
fn every_algorithm_estimates_what_its_render_allocates() {
    let _turn = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let plain = cornell(64);
    let fog = shipped_media("fog-cornell", 64, 64);
    let filtered = cornell_with(64, json!("lanczos"));
    // The thread pool's own allocations are not the job's: made before measuring.
    render_peak(&plain, &settings("pt", json!({})), 1);
    let cases: Vec<(&Scene, &str, Value)> = vec![
        (&plain, "pt", json!({})),
        (&plain, "normals", json!({})),
        (&plain, "lt", json!({"light_paths": 4})),
        (&plain, "bpt", json!({"light_paths": 4})),
        (&plain, "bpm", json!({"light_paths": 4})),
        (&plain, "vcm", json!({"light_paths": 4})),
        (
            &plain,
            "vcm",
            json!({"light_paths": 4, "merge_depth": "all", "correlation_aware": true}),
        ),
        (
            &plain,
            "vcm",
            json!({"light_paths": 1, "strategy_images": 3}),
        ),
        (&plain, "sppm", json!({"light_paths": 4})),
        (&plain, "ppm", json!({"light_paths": 4})),
        (&plain, "vpl", json!({"light_paths": {"count": 65536}})),
        (
            &plain,
            "vpl",
            json!({"light_paths": {"count": 65536}, "max_vertex_mib": 2}),
        ),
        (&filtered, "pt", json!({})),
        (&filtered, "lt", json!({"light_paths": 1})),
        (
            &filtered,
            "vcm",
            json!({"light_paths": 1, "strategy_images": 3}),
        ),
        (&fog, "volpath", json!({})),
        (&fog, "vcm", json!({"light_paths": 4})),
        (&fog, "upbp", json!({"light_paths": 4})),
        (
            &fog,
            "upbp",
            json!({"light_paths": 4, "merge_depth": "all", "correlation_aware": true}),
        ),
        (
            &fog,
            "upbp",
            json!({"light_paths": 4, "selection": "adaptive"}),
        ),
        (&fog, "sppm", json!({"light_paths": 4})),
        (&fog, "vpm", json!({"light_paths": 4})),
        (&fog, "vpm", json!({"light_paths": 4, "estimate": "point"})),
        (&fog, "ppb", json!({"light_paths": {"count": 8192}})),
        (&fog, "vpl", json!({"light_paths": {"count": 32768}})),
        (&fog, "vrl", json!({"light_paths": {"count": 8192}})),
        (&fog, "vbl", json!({"light_paths": {"count": 8192}})),
    ];
    let mut wrong = Vec::new();
    for (scene, alg, params) in cases {
        let s = settings(alg, params.clone());
        let measured = render_peak(scene, &s, 4);
        if let Err(line) = compare(&format!("{alg} {params}"), &s.memory(scene), measured) {
            wrong.push(line);
        }
    }
    assert!(
        wrong.is_empty(),
        "estimates outside [{LOW}, {HIGH}] x measured:\n{}",
        wrong.join("\n")
    );
}

/// A scene uploaded to the service: 256 x 256, a sphere on a floor under a point light.
fn served_scene() -> Value {
    json!({"format": 1,
        "camera": {"look_at": {"origin": [0, 1, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 45},
        "film": {"width": 256, "height": 256},
        "materials": {"m": {"type": "diffuse", "reflectance": [0.6, 0.5, 0.4]}},
        "shapes": [
            {"type": "sphere", "radius": 0.8, "material": "m"},
            {"type": "rectangle", "material": "m", "transform": {"translate": [0, -0.8, 0],
             "rotate": [{"axis": [1, 0, 0], "angle": -90}], "scale": 5}}
        ],
        "lights": [{"type": "point", "position": [1, 3, 2], "intensity": [8, 8, 8]}]})
}

/// Whole jobs run by the service, with a snapshot and checkpoint after every
/// iteration: their estimate (film, stores, and what writing checkpoints and images
/// holds) against the peak over the job, from submit (scene compilation included) to
/// completion.
#[test]
fn served_jobs_allocate_about_their_estimate() {
    let _turn = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let svc = Service::start(ServiceConfig::for_tests(dir.path())).unwrap();
    let text = served_scene().to_string();
    let scene_id = svc.upload_scene(text.as_bytes()).unwrap().id;
    let scene = common::compile(served_scene());
    let jobs = [
        ("pt", json!({})),
        ("vcm", json!({"strategy_images": 2})),
        ("sppm", json!({})),
        ("vpl", json!({"light_paths": {"count": 262144}})),
    ];
    let mut wrong = Vec::new();
    for (alg, params) in jobs {
        let spec: JobSpec = serde_json::from_value(json!({"scene": scene_id, "algorithm": alg,
            "params": params, "halt": {"spp": 3}, "snapshot_every": {"iterations": 1}}))
        .unwrap();
        let settings = Settings::for_scene(Some(alg), &scene, &spec.params).unwrap();
        let e = caustic::job::memory::estimate(&settings, &scene, &spec);
        let before = begin();
        let id = svc.submit(spec).unwrap().id;
        let start = std::time::Instant::now();
        while !svc.get_job(&id).unwrap().state.is_terminal() {
            assert!(start.elapsed().as_secs() < 120, "job {alg} did not finish");
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        let measured = peak_since(before);
        assert_eq!(svc.get_job(&id).unwrap().state.as_str(), "completed");
        if let Err(line) = compare(&format!("served {alg} {params}"), &e, measured) {
            wrong.push(line);
        }
    }
    svc.shutdown();
    assert!(
        wrong.is_empty(),
        "estimates outside [{LOW}, {HIGH}] x measured:\n{}",
        wrong.join("\n")
    );
}
