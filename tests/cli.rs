//! The README's commands, run as a newcomer would (paths moved to a temp folder).

use std::process::Command;

fn caustic() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_caustic"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
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
    let rmse: f64 = text
        .lines()
        .find_map(|l| l.strip_prefix("rmse "))
        .unwrap()
        .parse()
        .unwrap();
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
