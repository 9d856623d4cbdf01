//! The README's commands, run as a newcomer would (paths moved to a temp folder).

use std::process::Command;

fn caustic() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_caustic"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

/// The `rmse` line of `caustic diff`'s output.
fn rmse_of(text: &str) -> f64 {
    text.lines()
        .find_map(|l| l.strip_prefix("rmse "))
        .unwrap_or_else(|| panic!("no rmse line in:\n{text}"))
        .parse()
        .unwrap()
}

fn run(c: &mut Command) -> String {
    let out = c.output().expect("runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{c:?} failed:\n{text}");
    text
}

#[test]
fn readme_render_command_writes_exr_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("cornell.exr");
    let png = dir.path().join("cornell.png");
    let text = run(caustic()
        .args(["render", "scenes/cornell-box.json", "--spp", "64", "-o"])
        .arg(&exr)
        .arg("--png")
        .arg(&png));
    assert!(text.contains("64 iterations"), "{text}");
    assert!(text.contains(" 0 dropped samples"), "{text}");
    let img = caustic::film::read_exr(&exr).unwrap();
    assert_eq!(img.size(), (256, 256));
    assert!(img.mean().y > 0.1, "image too dark: {:?}", img.mean());
    assert!(std::fs::metadata(&png).unwrap().len() > 1000);

    // diff against itself is zero; against a different seed it is not.
    let text = run(caustic().arg("diff").arg(&exr).arg(&exr));
    assert!(text.contains("rmse 0.000000e0"), "{text}");
    let other = dir.path().join("other.exr");
    run(caustic()
        .args([
            "render",
            "scenes/cornell-box.json",
            "--spp",
            "4",
            "--seed",
            "9",
            "-o",
        ])
        .arg(&other));
    let diff_png = dir.path().join("diff.png");
    let text = run(caustic()
        .arg("diff")
        .arg(&other)
        .arg(&exr)
        .arg("--png")
        .arg(&diff_png));
    let rmse = rmse_of(&text);
    assert!(rmse > 0.0 && rmse.is_finite());
    assert!(diff_png.exists());

    // Output into a pipe nobody reads (as `caustic diff a b | head -1` leaves it)
    // ends the command quietly rather than in a panic.
    let mut child = caustic()
        .arg("diff")
        .arg(&other)
        .arg(&exr)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bench_prints_a_table() {
    let text = run(caustic().args([
        "bench",
        "scenes/cornell-box.json",
        "--spp",
        "2",
        "--repeat",
        "1",
    ]));
    let row = text.lines().find(|l| l.starts_with("pt ")).expect("pt row");
    let ms: f64 = row.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!(ms > 0.0);
    // Memory is measured like time: the peak resident set, which holds at least the
    // film (and, on Linux, is there).
    let header = text.lines().find(|l| l.starts_with("algorithm")).unwrap();
    assert!(header.ends_with("peak MiB"), "{header}");
    let peak = row.split_whitespace().last().unwrap();
    if cfg!(target_os = "linux") {
        let mib: f64 = peak.parse().unwrap();
        assert!(mib > 1.0 && mib < 4096.0, "{row}");
    }
}

#[test]
fn bad_arguments_fail_with_a_message() {
    let out = caustic()
        .args(["render", "scenes/cornell-box.json", "--algorithm", "vcmm"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown algorithm \"vcmm\""));
    let out = caustic()
        .args(["render", "no/such/scene.json"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no/such/scene.json"));
}

/// A scene whose own integrator section no job could run with is refused at load,
/// naming the field in the scene (it used to fail later, naming no field).
#[test]
fn render_names_the_bad_field_of_a_scene_integrator() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.json"),
    )
    .unwrap();
    let bad = text.replace("\"max_depth\": 64", "\"max_depth\": 4294967296");
    assert_ne!(bad, text);
    let path = dir.path().join("deep.json");
    std::fs::write(&path, bad).unwrap();
    let out = caustic()
        .args(["render", path.to_str().unwrap(), "--spp", "1"])
        .arg("-o")
        .arg(dir.path().join("x.exr"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("deep.json: integrator settings: integrator.max_depth: invalid value"),
        "{stderr}"
    );
}

/// The README's `caustic diff` on a Radiance `.hdr` file (as SmallVCM writes it: flat
/// scan lines) against an EXR: the values are decoded at the middle of each RGBE step.
#[test]
fn diff_reads_radiance_hdr() {
    use caustic::film::{write_exr, Image};
    use glam::Vec3;
    let dir = tempfile::tempdir().unwrap();
    let hdr = dir.path().join("smallvcm.hdr");
    let mut bytes = b"#?RADIANCE\n# SmallVCM\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n".to_vec();
    // (128, 64, 0) and (200, 100, 50) under exponent bytes 129 and 127: steps of 1/128
    // and 1/512.
    bytes.extend_from_slice(&[128, 64, 0, 129, 200, 100, 50, 127]);
    std::fs::write(&hdr, &bytes).unwrap();
    let mid = |m: [f32; 3], step: f32| Vec3::new(m[0] + 0.5, m[1] + 0.5, m[2] + 0.5) * step;
    let exact = Image::from_pixels(
        2,
        1,
        vec![
            mid([128.0, 64.0, 0.0], 1.0 / 128.0),
            mid([200.0, 100.0, 50.0], 1.0 / 512.0),
        ],
    );
    let exr = dir.path().join("same.exr");
    write_exr(&exr, &exact).unwrap();
    let text = run(caustic().arg("diff").arg(&hdr).arg(&exr));
    assert!(text.contains("rmse 0.000000e0"), "{text}");

    // Half a step lower everywhere (the truncated values): the RMSE is the half step's.
    let low = Image::from_pixels(
        2,
        1,
        vec![
            Vec3::new(128.0, 64.0, 0.0) / 128.0,
            Vec3::new(200.0, 100.0, 50.0) / 512.0,
        ],
    );
    write_exr(&exr, &low).unwrap();
    let text = run(caustic().arg("diff").arg(&hdr).arg(&exr));
    let rmse = rmse_of(&text);
    let want = ((3.0 * (0.5f64 / 128.0).powi(2) + 3.0 * (0.5f64 / 512.0).powi(2)) / 6.0).sqrt();
    assert!(
        (rmse - want).abs() < 1e-6 * want,
        "rmse {rmse}, want {want}"
    );
}

/// A failed command prints one line, `error: ...`, that says each cause once and what
/// a misnamed file really is.
#[test]
fn errors_say_each_cause_once() {
    let dir = tempfile::tempdir().unwrap();
    let failing = |c: &mut Command| {
        let out = c.env("RUST_BACKTRACE", "1").output().expect("runs");
        assert_eq!(out.status.code(), Some(1), "{c:?}");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let missing = dir.path().join("missing.exr");
    let text = failing(caustic().arg("diff").arg(&missing).arg(&missing));
    assert_eq!(text.matches("No such file").count(), 1, "{text}");
    assert!(
        text.starts_with("error: ") && !text.contains("Caused by"),
        "{text}"
    );
    let text = failing(caustic().arg("render").arg(dir.path().join("nowhere.json")));
    assert_eq!(text.matches("nowhere.json").count(), 1, "{text}");

    let png = dir.path().join("image.exr");
    caustic::film::write_png(&png, &caustic::film::Image::new(4, 4), 0.0).unwrap();
    let text = failing(caustic().arg("diff").arg(&png).arg(&png));
    assert!(
        text.contains("image.exr: a PNG image, not an OpenEXR file"),
        "{text}"
    );
}
