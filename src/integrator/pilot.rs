//! The memory estimate's pilot (above the subpaths and the estimators it measures,
//! below the algorithms that estimate their memory with it): what a light path of a scene stores on average, at a
//! given `max_depth` and roulette ([`Walk`]), measured on 1024 paths of the light pass
//! with every vertex and segment kept, which every light-path algorithm's walk
//! matches in expectation (Russian roulette by albedo, or by the power a bounce keeps,
//! which is the albedo on average).

use crate::integrator::estimators::beams::{collect, BeamForm, PIECE};
use crate::integrator::memory::{Facts, Walk};
use crate::integrator::paths::light_pass::LightPass;
use crate::integrator::transport::light_paths::LightPaths;
use crate::scene::Scene;

/// Light paths of the pilot.
const PILOT_PATHS: usize = 1024;
/// The pilot's paths are at most this long; deeper jobs are extrapolated (see
/// [`pilot`]), so that a `max_depth` of 10^9 costs no more to estimate than 64.
const PILOT_DEPTH: u32 = 64;
const PILOT_SEED: u64 = 0x6d656d;

/// The pilot's store budget: the bidirectional family's default `max_vertex_mib`.
const PILOT_MIB: f32 = 2048.0;

/// What a light path of the scene of `facts` stores (the pilot's, run once per depth
/// and roulette).
pub(crate) fn walk(facts: &Facts, max_depth: u32, roulette: bool) -> Walk {
    facts.walk_or(max_depth, roulette, || {
        pilot(facts.scene, max_depth, roulette)
    })
}

/// Photon-beam pieces of `form` a light path makes (`estimators::beams::PIECE` long
/// at most).
pub(crate) fn pieces(w: &Walk, form: BeamForm) -> f64 {
    match form {
        BeamForm::Short => w.short_pieces,
        BeamForm::Long => w.long_pieces,
    }
}

/// The pilot (see [`Walk`]). Paths cut at PILOT_DEPTH when the job's are longer are
/// extended as if each stored a vertex (and a segment and piece) at every further
/// bounce, an upper bound: the share of pilot paths that reached the cut, times the
/// bounces beyond it.
fn pilot(scene: &Scene, max_depth: u32, roulette: bool) -> Walk {
    if scene.lights.is_empty() {
        return Walk::default();
    }
    let depth = max_depth.min(PILOT_DEPTH);
    let paths = LightPaths::Count {
        count: PILOT_PATHS as u32,
    };
    let pass = LightPass::new(depth, paths, PILOT_MIB)
        .with_roulette(roulette)
        .keeping_segments();
    let ((mut w, at_cut), _) = pass.run(scene, PILOT_SEED, 0, |store| {
        let mut w = Walk::default();
        let mut at_cut = 0.0;
        for v in store.vertices() {
            match v.scattering_medium() {
                Some(_) => w.medium += 1.0,
                None if v.len == 1 => (w.surface, w.direct) = (w.surface + 1.0, w.direct + 1.0),
                None => w.surface += 1.0,
            }
            if v.len + 1 >= depth {
                at_cut += 1.0;
            }
        }
        w.segments = store.segments().count() as f64;
        let piece = scene.sphere.radius * PIECE;
        let mut out = Vec::new();
        for form in [BeamForm::Short, BeamForm::Long] {
            let segments = store.segments().copied();
            collect(
                scene,
                segments,
                PILOT_PATHS,
                form,
                piece,
                PILOT_SEED,
                0,
                &mut out,
            );
            match form {
                BeamForm::Short => w.short_pieces = out.len() as f64,
                BeamForm::Long => w.long_pieces = out.len() as f64,
            }
        }
        (w, at_cut)
    });
    let n = PILOT_PATHS as f64;
    w = w.scaled(1.0 / n);
    let vertices = w.vertices();
    if max_depth > depth && vertices > 0.0 {
        let more = at_cut / n * (max_depth - depth) as f64;
        w = w.scaled((vertices + more) / vertices);
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point light inside a white two-sided sphere: without roulette every light
    /// path stores a vertex at every bounce, to `max_depth`.
    fn furnace() -> Scene {
        let json = r#"{"format": 1,
            "camera": {"look_at": {"origin": [0, 0, 0.5], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 40},
            "film": {"width": 4, "height": 4},
            "materials": {"white": {"type": "diffuse", "reflectance": [1, 1, 1], "two_sided": true}},
            "shapes": [{"type": "sphere", "radius": 1, "material": "white"}],
            "lights": [{"type": "point", "position": [0, 0, 0], "intensity": [1, 1, 1]}]}"#;
        let file = crate::scene::load::parse_scene(json).unwrap();
        Scene::compile(&file, None).unwrap()
    }

    #[test]
    fn the_pilot_counts_vertices_and_extends_paths_beyond_its_depth() {
        let scene = furnace();
        let facts = Facts::new(&scene);
        // Stored at lengths 1 to max_depth - 1; the first straight from the light.
        let short = walk(&facts, 8, false);
        assert!((short.surface - 7.0).abs() < 0.05, "{short:?}");
        assert!((short.direct - 1.0).abs() < 0.01, "{short:?}");
        assert_eq!(short.medium, 0.0);
        // Deeper than the pilot: extended, not cut at its depth.
        let deep = walk(&facts, 640, false);
        assert!(deep.surface > 600.0, "{deep:?}");
        // Russian roulette by albedo 1 keeps every path too.
        assert_eq!(walk(&facts, 8, true), short);
    }
}
