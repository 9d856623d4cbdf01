//! `caustic render`, `reference` and `diff`: local renders with a progress bar, and
//! image comparison.

use super::args::{ReferenceArgs, RenderArgs};
use anyhow::{bail, Context, Result};
use caustic::client::parse_params;
use caustic::film::{self, Image};
use caustic::integrator::drive::{self, Halt};
use caustic::integrator::Settings;
use caustic::scene::Scene;
use caustic::tev::TevClient;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::Path;
use std::time::{Duration, Instant};

pub fn load_scene(path: &Path) -> Result<Scene> {
    Ok(load_scene_and_spp(path)?.0)
}

/// Loads a JSON or Mitsuba XML scene (printing the import's warnings), with the XML
/// sampler's sample count.
pub fn load_scene_and_spp(path: &Path) -> Result<(Scene, Option<u32>)> {
    let t = Instant::now();
    let (scene, spp) = if caustic::scene::mitsuba::is_xml_path(path) {
        let import = super::import::import_xml(path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        let scene = Scene::compile(&import.scene, Some(base))
            .map_err(|e| anyhow::anyhow!("{} (imported): {e}", path.display()))?;
        (scene, import.spp)
    } else {
        let scene = Scene::load(path).map_err(|e| scene_error(path, e))?;
        (scene, None)
    };
    Settings::for_scene_defaults(&scene).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let s = &scene.stats;
    eprintln!(
        "scene: {} triangles ({} pairs as parallelograms), {} spheres, {} disks, {} lights; BVH {:.1} ms, {:.1} KiB; loaded in {:.1} ms",
        s.triangles,
        s.quads,
        s.spheres,
        s.disks,
        scene.lights.len(),
        s.bvh_build.as_secs_f64() * 1e3,
        s.bvh_bytes as f64 / 1024.0,
        t.elapsed().as_secs_f64() * 1e3
    );
    if s.degenerate_dropped > 0 {
        eprintln!(
            "warning: {} degenerate triangles dropped",
            s.degenerate_dropped
        );
    }
    Ok((scene, spp))
}

/// A scene file's error, naming the file once (errors reading the file name it by
/// its file name already).
fn scene_error(path: &Path, e: caustic::scene::SceneError) -> anyhow::Error {
    let named = path.file_name().is_some_and(|n| *n == *e.path);
    let shown = if named { &e.message } else { &e.to_string() };
    anyhow::anyhow!("{}: {shown}", path.display())
}

pub fn render(a: &RenderArgs) -> Result<()> {
    let (scene, scene_spp) = load_scene_and_spp(&a.scene)?;
    let settings = Settings::for_scene(a.algorithm.as_deref(), &scene, &parse_params(&a.params)?)?;
    let halt = match (a.spp, a.time, a.noise) {
        // An XML scene's sample count, else 16.
        (None, None, None) => Halt {
            iterations: Some(scene_spp.map_or(16, u64::from)),
            ..Halt::default()
        },
        (spp, time, noise) => Halt {
            iterations: spp,
            time: time.map(Duration::from_secs_f64),
            noise,
        },
    };
    if a.noise.is_some() && settings.build().chained() {
        bail!(
            "--noise: {} carries its statistics from one iteration to the next, so its \
             noise cannot be estimated from its iterations; give --spp or --time",
            settings.name()
        );
    }
    let tev = match &a.tev {
        Some(addr) => Some(TevClient::connect(addr, &tev_name(&a.scene))?),
        None => None,
    };
    let out = render_streamed(&scene, &settings, a.seed, halt, "", tev.as_ref());
    let image = out.image();
    if let Some(t) = &tev {
        t.show(image.clone());
    }
    write_outputs(a, &scene, &image, &out.film.layer_images())?;
    if let Some(t) = tev {
        t.finish();
    }
    print_summary(settings.name(), &out);
    Ok(())
}

/// A progress bar over iterations, or over milliseconds for a time budget, with an
/// optional label in front.
pub fn progress_bar(halt: Halt, label: &str) -> ProgressBar {
    let (len, unit) = match (halt.iterations, halt.time) {
        (Some(n), _) => (n, "it"),
        (None, Some(t)) => (t.as_millis() as u64, "ms"),
        _ => (1, "it"),
    };
    let bar = ProgressBar::new(len);
    let style =
        format!("{{prefix}}{{bar:40}} {{pos}}/{{len}} {unit} {{msg}} [{{elapsed}} < {{eta}}]");
    bar.set_style(ProgressStyle::with_template(&style).expect("template"));
    if !label.is_empty() {
        bar.set_prefix(format!("{label} "));
    }
    bar
}

/// Advances `bar` after `i` iterations and `elapsed` time.
pub fn show_progress(bar: &ProgressBar, by_count: bool, i: u64, elapsed: Duration) {
    if by_count {
        bar.set_position(i);
    } else {
        bar.set_position(elapsed.as_millis() as u64);
    }
    bar.set_message(format!("{i} it"));
}

/// `drive::render` with a progress bar on stderr.
pub fn render_with_progress(
    scene: &Scene,
    settings: &Settings,
    seed: u64,
    halt: Halt,
    label: &str,
) -> drive::RenderOutcome {
    render_streamed(scene, settings, seed, halt, label, None)
}

/// How often `render --tev` sends the image so far.
const TEV_EVERY: Duration = Duration::from_millis(500);

/// [`render_with_progress`] that also shows the image so far in tev after the first
/// iteration and then every [`TEV_EVERY`] (the final image is the caller's to send).
fn render_streamed(
    scene: &Scene,
    settings: &Settings,
    seed: u64,
    halt: Halt,
    label: &str,
    tev: Option<&TevClient>,
) -> drive::RenderOutcome {
    let integrator = settings.build();
    let bar = progress_bar(halt, label);
    let by_count = halt.iterations.is_some();
    let mut sent: Option<Duration> = None;
    let out = drive::render_observed(scene, integrator.as_ref(), seed, halt, |p| {
        show_progress(&bar, by_count, p.iterations, p.elapsed);
        if let Some(t) = tev {
            if sent.is_none_or(|s| p.elapsed >= s + TEV_EVERY) {
                t.show(p.image());
                sent = Some(p.elapsed);
            }
        }
    });
    bar.finish_and_clear();
    out
}

/// The image name in tev: the scene file's name.
fn tev_name(scene: &Path) -> String {
    scene
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| scene.display().to_string())
}

pub fn reference(a: &ReferenceArgs) -> Result<()> {
    let scene = load_scene(&a.scene)?;
    let settings = Settings::for_scene(a.algorithm.as_deref(), &scene, &parse_params(&a.params)?)?;
    let halt = Halt {
        iterations: a.spp,
        time: a.time.map(Duration::from_secs_f64),
        ..Halt::default()
    };
    let out = render_with_progress(&scene, &settings, a.seed, halt, "");
    let image = out.image();
    match out.noise.as_ref().filter(|_| a.variance_layer) {
        Some(noise) => {
            film::write_exr_layers(&a.output, &image, &[("variance", &noise.variance_image())])?
        }
        None => film::write_exr(&a.output, &image)?,
    }
    if a.variance_layer && out.noise.is_none() {
        eprintln!(
            "warning: {} carries statistics from one iteration to the next: no variance layer",
            settings.name()
        );
    }
    eprintln!("wrote {}", a.output.display());
    if let Some(p) = &a.png {
        film::write_png(p, &image, 0.0)?;
        eprintln!("wrote {}", p.display());
    }
    print_summary(settings.name(), &out);
    Ok(())
}

/// Writes the image, with the integrator's own layers (technique or strategy parts)
/// and, with `--exr-layers`, albedo and normal layers.
fn write_outputs(
    a: &RenderArgs,
    scene: &Scene,
    image: &Image,
    own: &[(String, Image)],
) -> Result<()> {
    let mut layers: Vec<(&str, &Image)> = own.iter().map(|(n, i)| (n.as_str(), i)).collect();
    let aovs;
    if a.exr_layers {
        let aov = |s: Settings| {
            drive::render(
                scene,
                s.build().as_ref(),
                a.seed,
                Halt {
                    iterations: Some(4),
                    ..Halt::default()
                },
                |_, _| {},
            )
            .image()
        };
        aovs = [aov(Settings::Albedo {}), aov(Settings::Normals {})];
        layers.push(("albedo", &aovs[0]));
        layers.push(("normal", &aovs[1]));
    }
    if layers.is_empty() {
        film::write_exr(&a.output, image)?;
    } else {
        film::write_exr_layers(&a.output, image, &layers)?;
    }
    eprintln!("wrote {}", a.output.display());
    if let Some(p) = &a.png {
        film::write_png(p, image, a.exposure)?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

fn print_summary(alg: &str, out: &drive::RenderOutcome) {
    let (iterations, s, dropped) = (out.iterations, &out.stats, out.film.dropped());
    let secs = out.elapsed.as_secs_f64().max(1e-9);
    println!(
        "{alg}: {iterations} iterations in {secs:.3} s ({:.2} ms/iteration), {:.3} M samples/s, {:.2} M rays/s ({} closest + {} shadow), {dropped} dropped samples",
        secs * 1e3 / iterations.max(1) as f64,
        s.samples as f64 / secs / 1e6,
        (s.rays + s.shadow_rays) as f64 / secs / 1e6,
        s.rays,
        s.shadow_rays,
    );
    if s.light_vertices > 0 || s.merges > 0 || s.connections > 0 {
        let n = iterations.max(1) as f64;
        println!(
            "  per iteration: {:.0} light vertices stored ({:.1} MiB of vertex storage), {:.0} connections, {:.0} merges; last merge radius {:.3e}",
            s.light_vertices as f64 / n,
            s.vertex_bytes as f64 / 1048576.0,
            s.connections as f64 / n,
            s.merges as f64 / n,
            s.merge_radius,
        );
    }
    if let Some(n) = &out.noise {
        println!(
            "  estimated from its own iterations: relative error {:.3e}, RMSE {:.3e} (variance only: a consistent method's bias is not in it)",
            n.rel_error(),
            n.rmse()
        );
    }
}

pub fn diff(a: &Path, b: &Path, png: Option<&Path>) -> Result<()> {
    let ia = film::read_image(a)?;
    let ib = film::read_image(b)?;
    let m = film::compare(&ia, &ib)?;
    println!("rmse {:.6e}\nrel_mse {:.6e}", m.rmse, m.rel_mse);
    let (ma, mb) = (ia.mean(), ib.mean());
    println!(
        "mean_a {:.6} {:.6} {:.6}\nmean_b {:.6} {:.6} {:.6}",
        ma.x, ma.y, ma.z, mb.x, mb.y, mb.z
    );
    if let Some(p) = png {
        let d = film::false_colour_diff(&ia, &ib)?;
        film::write_png(p, &d, 0.0).with_context(|| format!("writing {}", p.display()))?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}
