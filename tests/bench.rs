//! `caustic bench` (speed and equal-time modes) and `caustic reference`, on a 32 x 32
//! scene so that they run in seconds.

use std::path::{Path, PathBuf};
use std::process::Command;

fn caustic() -> Command {
    Command::new(env!("CARGO_BIN_EXE_caustic"))
}

fn run(c: &mut Command) -> String {
    let out = c.output().expect("runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{c:?} failed:\n{text}");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// A small lit scene with an area light (so path tracing is noisy and converges).
fn tiny_scene(dir: &Path) -> PathBuf {
    let scene = serde_json::json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 1, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 45},
        "film": {"width": 32, "height": 32},
        "materials": {
            "m": {"type": "diffuse", "reflectance": [0.6, 0.5, 0.4]},
            "black": {"type": "diffuse", "reflectance": [0, 0, 0]}
        },
        "shapes": [
            {"type": "sphere", "radius": 0.8, "material": "m"},
            {"type": "rectangle", "material": "m", "transform": {"translate": [0, -0.8, 0], "rotate": [{"axis": [1, 0, 0], "angle": -90}], "scale": 5}},
            {"type": "rectangle", "material": "black", "emission": {"radiance": [6, 6, 6]},
             "transform": {"translate": [0, 2.5, 0], "rotate": [{"axis": [1, 0, 0], "angle": 90}], "scale": 0.5}}
        ]
    });
    let path = dir.join("tiny.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    path
}

#[test]
fn equal_time_bench_writes_a_falling_error_curve_a_plot_and_images() {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path());
    let out = dir.path().join("out");
    let stdout = run(caustic()
        .arg("bench")
        .arg(&scene)
        .args([
            "--algorithms",
            "pt",
            "--time",
            "2",
            "--reference-from",
            "pt:2",
            "-o",
        ])
        .arg(&out));

    let csv = std::fs::read_to_string(out.join("bench.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(
        header,
        caustic::bench::CSV_HEADER.split(',').collect::<Vec<_>>()
    );
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(rows.len() >= 5, "too few points:\n{csv}");
    assert!(
        rows.iter().all(|r| r[0] == "pt" && r.len() == header.len()),
        "{csv}"
    );
    let num = |r: &Vec<&str>, c: &str| r[col(c)].parse::<f64>().unwrap();
    let first = &rows[0];
    let last = rows.last().unwrap();
    assert_eq!(num(first, "iteration"), 1.0);
    assert!(num(last, "elapsed_s") >= 2.0, "{csv}");
    // Times and iterations increase; the error ends well below where it started.
    for w in rows.windows(2) {
        assert!(num(&w[1], "iteration") > num(&w[0], "iteration"), "{csv}");
        assert!(num(&w[1], "elapsed_s") > num(&w[0], "elapsed_s"), "{csv}");
    }
    assert!(num(last, "rmse") < 0.5 * num(first, "rmse"), "{csv}");
    assert!(num(last, "rmse") > 0.0 && num(last, "rays_per_s") > 0.0);
    assert!(num(last, "cpu_s") > 0.0, "{csv}");

    // The plot is a real picture, not a blank canvas.
    let png = std::fs::read(out.join("rmse_vs_time.png")).unwrap();
    let decoder = png::Decoder::new(std::io::Cursor::new(&png));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (960, 640));
    let pixels = &buf[..info.buffer_size()];
    let non_white = pixels.chunks(3).filter(|p| p != &[255, 255, 255]).count();
    assert!(non_white > 2000, "{non_white} drawn pixels");

    for f in ["reference.exr", "pt.exr"] {
        let img = caustic::film::read_exr(out.join(f)).unwrap();
        assert_eq!(img.size(), (32, 32), "{f}");
        assert!(img.mean().y > 0.0, "{f} is black");
    }
    let row = stdout
        .lines()
        .find(|l| l.starts_with("pt "))
        .expect("pt row");
    let iterations: u64 = row.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert_eq!(iterations as f64, num(last, "iteration"));
}

#[test]
fn equal_time_bench_needs_a_usable_reference() {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path());
    for (args, message) in [
        (vec!["--time", "1"], "needs a reference"),
        (
            vec!["--time", "1", "--reference-from", "pt"],
            "ALGORITHM:SECONDS",
        ),
        (
            vec!["--time", "1", "--reference-from", "vcmm:1"],
            "unknown algorithm",
        ),
    ] {
        let out = caustic()
            .arg("bench")
            .arg(&scene)
            .args(&args)
            .arg("-o")
            .arg(dir.path().join("o"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(message),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn reference_writes_an_exr() {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path());
    let exr = dir.path().join("ref.exr");
    let stdout = run(caustic()
        .arg("reference")
        .arg(&scene)
        .args([
            "--algorithm",
            "pt",
            "--time",
            "0.5",
            "--param",
            "max_depth=4",
            "-o",
        ])
        .arg(&exr));
    assert!(stdout.starts_with("pt: "), "{stdout}");
    let img = caustic::film::read_exr(&exr).unwrap();
    assert_eq!(img.size(), (32, 32));
    assert!(img.mean().y > 0.0);
}

/// `reference --variance-layer`: each pixel's estimated variance of its mean, which
/// must explain the squared difference of two references of other seeds:
/// E[(a - b)^2] = var_a + var_b per value, checked over all values within 4 standard
/// errors of their mean difference.
#[test]
fn a_reference_variance_layer_explains_the_difference_of_two_references() {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path());
    let render = |seed: &str| {
        let exr = dir.path().join(format!("ref{seed}.exr"));
        run(caustic()
            .arg("reference")
            .arg(&scene)
            .args(["-a", "pt", "--spp", "32", "--variance-layer"])
            .args(["--seed", seed])
            .args(["--param", "max_depth=4", "-o"])
            .arg(&exr));
        let image = caustic::film::read_exr(&exr).unwrap();
        let variance = caustic::film::read_exr_layer(&exr, "variance").unwrap();
        (image, variance)
    };
    let ((a, va), (b, vb)) = (render("1"), render("2"));
    let mut gaps = Vec::new();
    for i in 0..a.pixels().len() {
        let d = a.pixels()[i] - b.pixels()[i];
        let v = va.pixels()[i] + vb.pixels()[i];
        assert!(
            v.is_finite() && v.min_element() >= 0.0,
            "pixel {i}: variance {v:?}"
        );
        gaps.extend((d * d - v).to_array().map(f64::from));
    }
    let n = gaps.len() as f64;
    let mean = gaps.iter().sum::<f64>() / n;
    let var = gaps.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let scale = va.mean().y as f64;
    assert!(scale > 0.0, "no variance in the layer");
    let z = mean / (var / n).sqrt();
    eprintln!("mean (a - b)^2 - (var_a + var_b): {mean:.3e} ({z:.2} se); mean var {scale:.3e}");
    assert!(z.abs() < 4.0, "{z} standard errors");
}

#[test]
fn speed_bench_reports_wall_and_cpu_time_per_iteration() {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path());
    let stdout = run(caustic().arg("bench").arg(&scene).args([
        "--algorithms",
        "pt,albedo",
        "--spp",
        "4",
        "--repeat",
        "3",
    ]));
    assert!(stdout.contains("CPU s/iteration"), "{stdout}");
    for alg in ["pt", "albedo"] {
        let row = stdout
            .lines()
            .find(|l| l.starts_with(&format!("{alg} ")))
            .unwrap_or_else(|| panic!("no {alg} row:\n{stdout}"));
        let cols: Vec<f64> = row
            .split_whitespace()
            .skip(1)
            .map(|v| v.parse().unwrap())
            .collect();
        assert!(cols[0] > 0.0, "ms/iteration: {row}");
        assert!(
            cols[1] >= 0.0 && cols[1].is_finite(),
            "CPU s/iteration: {row}"
        );
    }
}

#[test]
fn bench_entries_carry_their_own_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path());
    // Two variants of one algorithm are two rows, each labelled by its entry (the bad
    // entry below shows that an entry's parameters reach the settings).
    let stdout = run(caustic().arg("bench").arg(&scene).args([
        "--algorithms",
        "pt:max_depth=1,pt:max_depth=12:rr_depth=12",
        "--spp",
        "4",
        "--repeat",
        "3",
    ]));
    let rays = |label: &str| -> f64 {
        let row = stdout
            .lines()
            .find(|l| l.starts_with(&format!("{label} ")))
            .unwrap_or_else(|| panic!("no {label} row:\n{stdout}"));
        row.split_whitespace().nth(4).unwrap().parse().unwrap()
    };
    let (short, long) = (rays("pt:max_depth=1"), rays("pt:max_depth=12:rr_depth=12"));
    assert!(short > 0.0 && long > 0.0, "{stdout}");
    // A bad entry is named.
    let out = caustic()
        .arg("bench")
        .arg(&scene)
        .args([
            "--algorithms",
            "pt,pt:max_dept=3",
            "--spp",
            "1",
            "--repeat",
            "1",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("pt:max_dept=3") && err.contains("max_dept"),
        "{err}"
    );
}
