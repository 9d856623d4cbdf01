//! `caustic bench`: the speed table, and the equal-time comparison (the
//! convergence runs themselves are [`caustic::bench`]).

use super::args::BenchArgs;
use super::render::{load_scene, progress_bar, render_with_progress, show_progress};
use anyhow::{bail, Context, Result};
use caustic::client::parse_params;
use caustic::film;
use caustic::integrator::drive::{self, Halt};
use caustic::integrator::Settings;
use caustic::scene::Scene;
use std::time::Duration;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The algorithms of `--algorithms`, each resolved against the scene, `--param` and
/// its own parameters (`vrl:sampler=uniform:vl_samples=4`), with its label: the entry
/// as written, so that variants of one algorithm are told apart.
fn bench_settings(a: &BenchArgs, scene: &Scene) -> Result<Vec<(String, Settings)>> {
    let shared = parse_params(&a.params)?;
    a.algorithms
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|entry| {
            let mut parts = entry.split(':');
            let alg = parts.next().unwrap_or_default();
            let own: Vec<String> = parts.map(str::to_string).collect();
            let mut params = shared.clone();
            params.extend(parse_params(&own).with_context(|| format!("--algorithms {entry}"))?);
            let settings = Settings::for_scene(Some(alg), scene, &params)
                .with_context(|| format!("--algorithms {entry}"))?;
            Ok((entry.to_string(), settings))
        })
        .collect()
}

/// Speed: per algorithm, one untimed warm-up iteration, then `--repeat` timed runs of
/// `--spp` iterations; medians of wall and process CPU time per iteration.
pub fn bench(a: &BenchArgs) -> Result<()> {
    let scene = load_scene(&a.scene)?;
    let all = bench_settings(a, &scene)?;
    println!(
        "{:<10} {:>12} {:>15} {:>14} {:>12} {:>10} {:>9}",
        "algorithm",
        "ms/iteration",
        "CPU s/iteration",
        "M samples/s",
        "M rays/s",
        "dropped",
        "peak MiB"
    );
    let iterations = |n| Halt {
        iterations: Some(n),
        ..Halt::default()
    };
    for (label, settings) in all {
        // Each algorithm's own peak: the scene, plus what its iterations allocate.
        caustic::bench::reset_peak_rss();
        drive::render(
            &scene,
            settings.build().as_ref(),
            1,
            iterations(1),
            |_, _| {},
        );
        let mut ms = Vec::new();
        let mut cpu = Vec::new();
        let mut sps = Vec::new();
        let mut rps = Vec::new();
        let mut dropped = 0;
        for r in 0..a.repeat.max(1) {
            // A fresh integrator per run: algorithms with state start over.
            let integrator = settings.build();
            let sw = caustic::bench::Stopwatch::start();
            let out = drive::render(
                &scene,
                integrator.as_ref(),
                r as u64,
                iterations(a.spp),
                |_, _| {},
            );
            let (_, cpu_time) = sw.elapsed();
            let secs = out.elapsed.as_secs_f64();
            let n = out.iterations.max(1) as f64;
            ms.push(secs * 1e3 / n);
            cpu.push(cpu_time.as_secs_f64() / n);
            sps.push(out.stats.samples as f64 / secs / 1e6);
            rps.push((out.stats.rays + out.stats.shadow_rays) as f64 / secs / 1e6);
            dropped += out.film.dropped();
        }
        println!(
            "{:<10} {:>12.2} {:>15.4} {:>14.3} {:>12.2} {:>10} {:>9}",
            label,
            median(ms),
            median(cpu),
            median(sps),
            median(rps),
            dropped,
            caustic::bench::peak_rss_mib()
        );
    }
    Ok(())
}

/// `ALG:SECONDS` of `--reference-from`.
fn parse_reference_from(s: &str) -> Result<(String, f64)> {
    let parsed = s
        .rsplit_once(':')
        .and_then(|(alg, t)| Some((alg.trim().to_string(), t.trim().parse::<f64>().ok()?)));
    match parsed {
        Some((alg, t)) if !alg.is_empty() && t > 0.0 && t.is_finite() => Ok((alg, t)),
        _ => bail!("--reference-from {s}: expected ALGORITHM:SECONDS, e.g. vcm:3600"),
    }
}

/// Equal time: every algorithm runs for `time` seconds of iterations; the error
/// against the reference is measured at log-spaced times (untimed).
pub fn bench_equal_time(a: &BenchArgs, time: f64) -> Result<()> {
    if !(time > 0.0 && time.is_finite()) {
        bail!("--time {time}: expected a positive number of seconds");
    }
    let scene = load_scene(&a.scene)?;
    let all = bench_settings(a, &scene)?;
    std::fs::create_dir_all(&a.output)
        .with_context(|| format!("creating {}", a.output.display()))?;
    let reference = match (&a.reference, &a.reference_from) {
        (Some(path), _) => film::read_image(path)?,
        (None, Some(spec)) => {
            let (alg, secs) = parse_reference_from(spec)?;
            let params = parse_params(&a.params)?;
            let settings = Settings::for_scene(Some(&alg), &scene, &params)?;
            let halt = Halt {
                time: Some(Duration::from_secs_f64(secs)),
                ..Halt::default()
            };
            let seed = a.seed.wrapping_add(1);
            let out = render_with_progress(&scene, &settings, seed, halt, "reference");
            let image = out.image();
            let path = a.output.join("reference.exr");
            film::write_exr(&path, &image)?;
            eprintln!(
                "reference: {alg}, {} iterations in {:.1} s, wrote {}",
                out.iterations,
                out.elapsed.as_secs_f64(),
                path.display()
            );
            image
        }
        (None, None) => {
            bail!("--time needs a reference: --reference EXR or --reference-from ALG:SECONDS")
        }
    };
    let plan = caustic::bench::Plan {
        seed: a.seed,
        budget: Duration::from_secs_f64(time),
        points: a.points,
    };
    let halt = Halt {
        time: Some(plan.budget),
        ..Halt::default()
    };
    let mut runs = Vec::new();
    let mut peaks = Vec::new();
    for (entry, settings) in &all {
        let label = unique_label(&file_label(entry), &runs);
        caustic::bench::reset_peak_rss();
        let integrator = settings.build();
        let bar = progress_bar(halt, &label);
        let run = caustic::bench::converge(
            &label,
            &scene,
            integrator.as_ref(),
            &reference,
            plan,
            |i, el| show_progress(&bar, false, i, el),
        )?;
        bar.finish_and_clear();
        peaks.push(caustic::bench::peak_rss_mib());
        let path = a.output.join(format!("{label}.exr"));
        film::write_exr(&path, &run.image())?;
        runs.push(run);
    }
    let csv = a.output.join("bench.csv");
    caustic::bench::write_csv(&csv, &runs)?;
    let png = a.output.join("rmse_vs_time.png");
    let title = format!(
        "{}: RMSE vs time",
        a.scene.file_stem().unwrap_or_default().to_string_lossy()
    );
    caustic::bench::plot_rmse_vs_time(&png, &title, &runs)?;
    eprintln!(
        "wrote {}, {} and the final images in {}",
        csv.display(),
        png.display(),
        a.output.display()
    );
    println!(
        "{:<10} {:>10} {:>9} {:>9} {:>12} {:>12} {:>10} {:>8} {:>9}",
        "algorithm",
        "iterations",
        "time s",
        "CPU s",
        "RMSE",
        "rel MSE",
        "M rays/s",
        "dropped",
        "peak MiB"
    );
    for (run, peak) in runs.iter().zip(&peaks) {
        let p = run.last();
        println!(
            "{:<10} {:>10} {:>9.2} {:>9.2} {:>12.4e} {:>12.4e} {:>10.2} {:>8} {:>9}",
            run.label,
            p.iteration,
            p.elapsed_s,
            p.cpu_s,
            p.rmse,
            p.rel_mse,
            p.rays_per_s() / 1e6,
            p.dropped,
            peak
        );
    }
    Ok(())
}

/// `name`, or `name-2`, `name-3`, ... when earlier runs already use it.
/// An `--algorithms` entry as a file name: `vrl:sampler=uniform` -> `vrl-sampler-uniform`.
fn file_label(entry: &str) -> String {
    entry
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .collect()
}

fn unique_label(name: &str, runs: &[caustic::bench::ConvergenceRun]) -> String {
    let taken = |l: &str| runs.iter().any(|r| r.label == l);
    if !taken(name) {
        return name.to_string();
    }
    (2..)
        .map(|k| format!("{name}-{k}"))
        .find(|l| !taken(l))
        .expect("a free label")
}
