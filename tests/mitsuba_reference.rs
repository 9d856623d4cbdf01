//! caustic against Mitsuba 3 itself: each scene in tests/data/mitsuba_refs (one per
//! material, texture and pixel filter) is imported from its XML, rendered with `pt`,
//! and compared with Mitsuba 3.9.1's image of the same XML (`<name>.exr`, rendered by
//! deploy/scripts/mitsuba_references.py at 16384 spp; its spp and the standard error
//! of its mean are in references.json).
//!
//! The noise is measured, not guessed: caustic renders `BATCHES` independent seeds, and
//! the spread of their means gives the standard error of the image mean and of each
//! 8 x 8 block. Mitsuba's own standard errors: the image mean's from the script's
//! passes; a block's, caustic's scaled by sqrt(caustic spp / Mitsuba spp) (the same
//! estimator, so about the same variance per sample; at 16384 against 256 spp it adds
//! 1.6 % to the variance).
//!
//! Checks: (1) each channel's image mean within 0.5 % of Mitsuba's plus four standard
//! errors; (2) every block within 0.5 % plus `Z_MAX` standard errors (a block's error
//! is t-distributed with BATCHES - 1 degrees of freedom: with 32 batches,
//! P(|t| > 6) ~ 1e-6, so ~3000 blocks give a false failure once in ~300 runs);
//! (3) the mean squared z-score of the blocks at most `Z2_MEAN_MAX` (1.07 expected
//! for t with 31 degrees of freedom, sd ~0.13 over 144 values), so a bias spread over
//! many blocks fails even when no single block stands out.

mod common;

use caustic::film::{read_exr, Image};
use caustic::scene::mitsuba::import_file;
use caustic::scene::Scene;
use std::path::{Path, PathBuf};

const BATCHES: u64 = 32;
const BLOCK: u32 = 8;
const Z_MAX: f64 = 6.0;
const Z2_MEAN_MAX: f64 = 1.7;
/// The bias allowed between the two renderers (issue 37: "same image within 0.5 %").
const BIAS: f64 = 0.005;
/// The reference is stored as half floats: a relative rounding of up to 2^-11 per
/// pixel, far below the bias allowed; this keeps a noiseless block (inside an
/// emitter) from dividing by zero.
const HALF_ROUNDING: f64 = 4.9e-4;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitsuba_refs")
}

/// Mitsuba's spp and the standard errors of its image's channel means.
fn reference_noise(name: &str) -> (u64, [f64; 3]) {
    let text = std::fs::read_to_string(dir().join("references.json")).unwrap();
    let all: serde_json::Value = serde_json::from_str(&text).unwrap();
    let r = &all[name];
    let se = |c: usize| r["mean_se"][c].as_f64().unwrap_or(0.0);
    (
        r["spp"].as_u64().expect("references.json names the scene"),
        [se(0), se(1), se(2)],
    )
}

fn import(name: &str) -> Scene {
    let import =
        import_file(&dir().join(format!("{name}.xml"))).unwrap_or_else(|e| panic!("{name}: {e}"));
    for w in &import.warnings {
        eprintln!("{name}: import warning: {w}");
    }
    Scene::compile(&import.scene, Some(&dir())).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// caustic's image of `batches` x `spp` samples per pixel, and each batch's image.
fn render(scene: &Scene, batches: u64, spp: u64) -> (Image, Vec<Image>) {
    let s = caustic::integrator::Settings::for_scene(None, scene, &Default::default())
        .expect("settings");
    assert_eq!(s.name(), "pt", "Mitsuba's path integrator imports as pt");
    let mut images = Vec::new();
    let mut total: Option<caustic::film::Film> = None;
    for seed in 0..batches {
        let (film, n) = common::render(scene, &s, 100 + seed, spp);
        assert_eq!((n, film.dropped()), (spp, 0));
        images.push(film.to_image(1.0 / spp as f64));
        match &mut total {
            Some(t) => t.merge(&film),
            None => total = Some(film),
        }
    }
    let image = total.unwrap().to_image(1.0 / (batches * spp) as f64);
    (image, images)
}

/// The mean of channel `c` over the pixels of `img` in block (bx, by); a block at the
/// right or bottom edge is cut by the image.
fn block_mean(img: &Image, bx: u32, by: u32, c: usize) -> f64 {
    let (x1, y1) = (
        ((bx + 1) * BLOCK).min(img.width()),
        ((by + 1) * BLOCK).min(img.height()),
    );
    let mut sum = 0.0;
    for y in by * BLOCK..y1 {
        for x in bx * BLOCK..x1 {
            sum += f64::from(img.get(x, y)[c]);
        }
    }
    sum / f64::from((x1 - bx * BLOCK) * (y1 - by * BLOCK))
}

/// The value of `f` on caustic's image, and its standard error from the batches.
fn with_se(image: &Image, batches: &[Image], f: impl Fn(&Image) -> f64) -> (f64, f64) {
    let values: Vec<f64> = batches.iter().map(&f).collect();
    (f(image), common::mean_se(&values).1)
}

/// Renders `name` and checks it against Mitsuba's image (see the module comment).
fn check(name: &str, batches: u64, spp: u64) {
    let scene = import(name);
    let reference = read_exr(dir().join(format!("{name}.exr"))).unwrap();
    let (ref_spp, ref_mean_se) = reference_noise(name);
    let (image, batch_images) = render(&scene, batches, spp);
    assert_eq!(image.size(), reference.size(), "{name}: image size");
    // A block's reference noise, relative to caustic's (the same estimator).
    let ref_ratio = (batches * spp) as f64 / ref_spp as f64;
    let mut failures: Vec<String> = (ref_mean_se.iter().enumerate())
        .filter_map(|(c, &ref_se)| mean_failure(name, c, &image, &batch_images, &reference, ref_se))
        .collect();
    failures.extend(block_failures(
        name,
        &image,
        &batch_images,
        &reference,
        ref_ratio,
    ));
    assert!(
        failures.is_empty(),
        "{name} against Mitsuba 3:\n{}",
        failures.join("\n")
    );
}

/// Channel `c`'s image mean against Mitsuba's: within 0.5 % plus four standard
/// errors (caustic's from the batches, Mitsuba's `ref_se` from its passes).
fn mean_failure(
    name: &str,
    c: usize,
    image: &Image,
    batches: &[Image],
    reference: &Image,
    ref_se: f64,
) -> Option<String> {
    let mean = |img: &Image| f64::from(img.mean()[c]);
    let (m, se) = with_se(image, batches, mean);
    let r = mean(reference);
    let allowed = BIAS * r.abs() + 4.0 * (se * se + ref_se * ref_se).sqrt();
    eprintln!(
        "{name} channel {c}: mean {m:.6} vs Mitsuba {r:.6} (se {se:.2e}, allowed {allowed:.2e})"
    );
    ((m - r).abs() > allowed).then(|| {
        format!(
            "channel {c}: mean {m} vs Mitsuba's {r}: differs by {:.3} %, allowed {:.3} % \
             (0.5 % + 4 standard errors, caustic's {se:.2e})",
            100.0 * (m - r) / r,
            100.0 * allowed / r
        )
    })
}

/// The blocks that differ from the reference by more than noise (and the overall
/// mean squared z-score, if it is too large).
fn block_failures(
    name: &str,
    image: &Image,
    batches: &[Image],
    reference: &Image,
    ref_ratio: f64,
) -> Vec<String> {
    let (bw, bh) = (
        image.width().div_ceil(BLOCK),
        image.height().div_ceil(BLOCK),
    );
    let mut failures = Vec::new();
    let mut z2 = Vec::new();
    for by in 0..bh {
        for bx in 0..bw {
            for c in 0..3 {
                let (x, se) = with_se(image, batches, |img| block_mean(img, bx, by, c));
                let r = block_mean(reference, bx, by, c);
                let sigma = (se * se * (1.0 + ref_ratio) + (HALF_ROUNDING * r).powi(2)).sqrt();
                let excess = ((x - r).abs() - BIAS * r.abs()).max(0.0);
                z2.push(((x - r) / sigma).powi(2));
                if excess > Z_MAX * sigma {
                    failures.push(format!(
                        "block ({bx}, {by}) channel {c}: {x:.5} vs Mitsuba's {r:.5} \
                         ({:.1} standard errors of {sigma:.2e} beyond 0.5 %)",
                        excess / sigma
                    ));
                }
            }
        }
    }
    let z2_mean = z2.iter().sum::<f64>() / z2.len() as f64;
    eprintln!("{name}: blocks' mean squared z {z2_mean:.3}");
    if z2_mean > Z2_MEAN_MAX {
        failures.push(format!(
            "blocks' mean squared z-score {z2_mean:.3} > {Z2_MEAN_MAX} (1.07 expected)"
        ));
    }
    failures
}

/// One test per scene: `BATCHES` seeds of `$spp` samples per pixel; the dense
/// variant (ignored: minutes) takes 8 times as many.
macro_rules! against_mitsuba {
    ($($(#[$attr:meta])* $test:ident, $dense:ident: $name:literal, $spp:literal;)*) => {
        $(
            $(#[$attr])*
            #[test]
            fn $test() {
                check($name, BATCHES, $spp);
            }

            #[test]
            #[ignore = "dense: minutes"]
            fn $dense() {
                check($name, BATCHES, 8 * $spp);
            }
        )*
    };
}

against_mitsuba! {
    diffuse, diffuse_dense: "bsdf-diffuse", 8;
    plastic, plastic_dense: "bsdf-plastic", 8;
    roughplastic, roughplastic_dense: "bsdf-roughplastic", 8;
    roughconductor_ggx, roughconductor_ggx_dense: "bsdf-roughconductor-ggx", 8;
    roughconductor_beckmann, roughconductor_beckmann_dense: "bsdf-roughconductor-beckmann", 8;
    roughconductor_anisotropic, roughconductor_anisotropic_dense:
        "bsdf-roughconductor-anisotropic", 8;
    roughdielectric, roughdielectric_dense: "bsdf-roughdielectric", 8;
    dielectric, dielectric_dense: "bsdf-dielectric", 8;
    thindielectric, thindielectric_dense: "bsdf-thindielectric", 8;
    conductor, conductor_dense: "bsdf-conductor", 8;
    conductor_named, conductor_named_dense: "bsdf-conductor-named", 8;
    mask, mask_dense: "bsdf-mask", 8;
    blend, blend_dense: "bsdf-blend", 8;
    normalmap, normalmap_dense: "bsdf-normalmap", 8;
    bumpmap, bumpmap_dense: "bsdf-bumpmap", 8;
    /// Mitsuba 3.9.1's checkerboard disagrees with itself: its scalar lookup
    /// (`eval_1`, which the mask's opacity uses) swaps color0 and color1 against its
    /// colour lookup; the importer follows it (`mitsuba::texture::scalar`).
    mask_checkerboard, mask_checkerboard_dense: "bsdf-mask-checkerboard", 8;
    texture_bitmap, texture_bitmap_dense: "texture-bitmap", 8;
    texture_raw, texture_raw_dense: "texture-raw", 8;
    texture_checkerboard, texture_checkerboard_dense: "texture-checkerboard", 8;
    texture_scale, texture_scale_dense: "texture-scale", 8;
    texture_to_uv, texture_to_uv_dense: "texture-to-uv", 8;
    texture_obj, texture_obj_dense: "texture-obj", 8;
    /// caustic drops a BSDF sample whose direction lies on the other side of the
    /// geometric surface than of the shading one (src/integrator/common/camera.rs,
    /// `sample_lobe`: pbrt's rule against light leaks); Mitsuba's path integrator keeps
    /// it and traces the ray on through the surface (src/integrators/path.cpp,
    /// `si.spawn_ray(si.to_world(bsdf_sample.wo))`, no geometric test). Where vertex
    /// normals lean away from the faces' (the strip's crease), caustic is 1-1.5 %
    /// darker: 12-24 standard errors at 2048 spp; the 256 spp check cannot see it. The
    /// same mesh flat-shaded (texture-obj) agrees.
    #[ignore = "shading normals: caustic drops samples below the geometric surface, Mitsuba keeps them"]
    obj_normals, obj_normals_dense: "shape-obj-normals", 8;
    emitter_area_textured, emitter_area_textured_dense: "emitter-area-textured", 8;
    filter_box, filter_box_dense: "filter-box", 8;
    filter_tent, filter_tent_dense: "filter-tent", 8;
    filter_gaussian, filter_gaussian_dense: "filter-gaussian", 8;
    filter_mitchell, filter_mitchell_dense: "filter-mitchell", 8;
    filter_lanczos, filter_lanczos_dense: "filter-lanczos", 8;
}

/// Every scene in the folder has a test (a scene added without one would not be
/// checked) and a reference.
#[test]
fn every_scene_has_a_test_and_a_reference() {
    let listed = include_str!("mitsuba_reference.rs");
    for entry in std::fs::read_dir(dir()).unwrap() {
        let file = entry.unwrap().file_name().into_string().unwrap();
        let Some(name) = file.strip_suffix(".xml") else {
            continue;
        };
        if name.starts_with('_') || name.ends_with(".mitsuba") {
            continue;
        }
        assert!(
            listed.contains(&format!("\"{name}\", ")),
            "{name}.xml has no test"
        );
        assert!(
            dir().join(format!("{name}.exr")).exists(),
            "{name}.exr missing"
        );
        reference_noise(name);
    }
}
