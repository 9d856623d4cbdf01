//! Golden images: every algorithm on every shipped scene, a few iterations at a small
//! size, hashed bit for bit (the f64 pixel sums and the dropped-sample count). The
//! hashes in tests/data/golden.txt were recorded before the integrators were
//! reorganised; a change that should not alter any image must leave them all equal.
//!
//! Images are a pure function of (scene, settings, seed, iteration), whatever the
//! thread count (`caustic::integrator`), so the hashes are the same on every run of one build
//! target. To record them again after a deliberate change of images, run
//! `CAUSTIC_GOLDEN_WRITE=1 cargo test --release --test golden` and say in the commit
//! which images changed and why.

use caustic::integrator::drive::{self, Halt};
use caustic::integrator::{Settings, ALGORITHMS};
use caustic::scene::Scene;
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::path::Path;

/// Small enough for CI (about a hundred renders), large enough that every algorithm's
/// paths reach every kind of surface and medium.
const SIZE: u32 = 64;
const ITERATIONS: u64 = 3;
const SEED: u64 = 11;

const SCENES: &[&str] = &[
    "scenes/cornell-box.json",
    "scenes/smallvcm/gbs_s.json",
    "scenes/smallvcm/glm_c.json",
    "scenes/smallvcm/gbs_p.json",
    "scenes/smallvcm/gbs_b.json",
    "scenes/media/fog-cornell.json",
    "scenes/media/glass-sphere-fog.json",
    "scenes/media/procedural-noise.json",
    "scenes/media/smoke-room.json",
    "scenes/media/spot-shaft.json",
];

fn golden_path() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/golden.txt")
}

fn load(rel: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
    let text = std::fs::read_to_string(&path).unwrap();
    let mut file = caustic::scene::load::parse_scene(&text).unwrap();
    file.film.width = SIZE;
    file.film.height = SIZE;
    let dir = path.parent().unwrap();
    Scene::compile(&file, Some(dir)).unwrap()
}

/// `refused` when the algorithm does not take the scene, else the hash.
fn render(scene: &Scene, algorithm: &str) -> String {
    let settings = Settings::resolve(
        Some(algorithm),
        scene.integrator.as_ref(),
        &Default::default(),
    )
    .unwrap();
    if settings.check_scene(scene).is_err() {
        return "refused".into();
    }
    let halt = Halt {
        iterations: Some(ITERATIONS),
        ..Halt::default()
    };
    let out = drive::render(scene, settings.build().as_ref(), SEED, halt, |_, _| {});
    let mut h = Sha256::new();
    for p in out.film.sums() {
        for c in p {
            h.update(c.to_bits().to_le_bytes());
        }
    }
    h.update(out.film.dropped().to_le_bytes());
    h.finalize()[..12]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

fn current() -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for rel in SCENES {
        let scene = load(rel);
        for alg in ALGORITHMS {
            out.insert(format!("{rel} {alg}"), render(&scene, alg));
        }
    }
    out
}

#[test]
fn every_algorithm_on_every_shipped_scene_renders_the_recorded_image() {
    let now = current();
    if std::env::var_os("CAUSTIC_GOLDEN_WRITE").is_some() {
        let text: String = now.iter().map(|(k, v)| format!("{k} {v}\n")).collect();
        std::fs::write(golden_path(), text).unwrap();
        eprintln!("recorded {} golden images", now.len());
        return;
    }
    let text = std::fs::read_to_string(golden_path()).unwrap();
    let recorded: BTreeMap<String, String> = text
        .lines()
        .filter_map(|l| {
            let (key, hash) = l.rsplit_once(' ')?;
            Some((key.to_string(), hash.to_string()))
        })
        .collect();
    assert_eq!(
        recorded.keys().collect::<Vec<_>>(),
        now.keys().collect::<Vec<_>>(),
        "the scene and algorithm lists changed: record again (see the module notes)"
    );
    let changed: Vec<String> = now
        .iter()
        .filter(|(k, v)| recorded[*k] != **v)
        .map(|(k, v)| format!("{k}: recorded {}, now {v}", recorded[k]))
        .collect();
    assert!(
        changed.is_empty(),
        "images changed:\n{}",
        changed.join("\n")
    );
}
