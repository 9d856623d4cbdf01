//! The RMSE-vs-time plot of a convergence benchmark: log-log, one line per algorithm,
//! drawn with plotters' bitmap backend and an embedded font (no system fonts).

use super::{BenchError, ConvergenceRun};
use crate::film::write_bytes_atomic;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// Plot size in pixels.
const SIZE: (u32, u32) = (960, 640);

/// Registers the embedded DejaVu Sans as plotters' "sans-serif" (once per process).
fn register_font() -> Result<(), BenchError> {
    static LOADED: OnceLock<bool> = OnceLock::new();
    let ok = *LOADED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(BenchError::Invalid("the embedded font did not load".into()))
    }
}

/// Writes a log-log plot of RMSE against render time, one line (with a marker per
/// measured point) per run, as an sRGB PNG. Points with zero error or zero time cannot
/// be shown on log axes and are left out.
pub fn plot_rmse_vs_time(
    path: &Path,
    title: &str,
    runs: &[ConvergenceRun],
) -> Result<(), BenchError> {
    register_font()?;
    let err = |e: &dyn std::fmt::Display| BenchError::Plot {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    let series: Vec<(&str, Vec<(f64, f64)>)> = runs
        .iter()
        .map(|r| {
            let pts = r
                .points
                .iter()
                .filter(|p| p.elapsed_s > 0.0 && p.rmse > 0.0 && p.rmse.is_finite())
                .map(|p| (p.elapsed_s, p.rmse))
                .collect();
            (r.label.as_str(), pts)
        })
        .collect();
    let all = || series.iter().flat_map(|(_, p)| p.iter().copied());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in all() {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if x0 > x1 {
        // Nothing to show: a placeholder range so the axes still draw.
        (x0, x1, y0, y1) = (0.01, 1.0, 0.01, 1.0);
    }
    // Whole decades: plotters labels a log axis from its first power of ten on. The
    // ends are widened by a hair, so that rounding in its log10 cannot skip one.
    let ((x0, x1, x_decades), (y0, y1, y_decades)) = (decades(x0, x1), decades(y0, y1));
    let (x0, x1, y0, y1) = (x0 * 0.999, x1 * 1.001, y0 * 0.999, y1 * 1.001);

    let (w, h) = SIZE;
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 24))
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(90)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("render time (s)")
            .y_desc("RMSE")
            .x_labels(label_count(x_decades))
            .y_labels(label_count(y_decades))
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            // Grid lines at the labels only: plotters' finer ones crowd into grey bands.
            .light_line_style(TRANSPARENT)
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 18))
            .draw()
            .map_err(|e| err(&e))?;
        for (i, (label, pts)) in series.iter().enumerate() {
            let colour = Palette99::pick(i).to_rgba();
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), colour.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(*label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .map_err(|e| err(&e))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(("sans-serif", 16))
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    let png = encode_rgb8_png(w, h, &rgb).map_err(|e| err(&e))?;
    write_bytes_atomic(path, &png)?;
    Ok(())
}

/// The powers of ten around [lo, hi] (lo > 0), and the number of decades between them.
fn decades(lo: f64, hi: f64) -> (f64, f64, u32) {
    let a = lo.log10().floor();
    let b = hi.log10().ceil().max(a + 1.0);
    (10f64.powf(a), 10f64.powf(b), (b - a) as u32)
}

/// Labels to ask plotters for: 1, 2, ..., 9 in every decade when there are at most two
/// (it gives all nine or none), else only the powers of ten, which would crowd less.
fn label_count(decades: u32) -> usize {
    if decades <= 2 {
        10 * decades as usize + 1
    } else {
        decades as usize + 1
    }
}

/// A tick label: three significant digits, in plain notation from 0.001 to 99999, else
/// in scientific notation.
fn tick(v: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return format!("{v}");
    }
    // Round to three significant digits with exact decimal steps, so that the shortest
    // representation is the one printed (0.05, not 0.05000000000000001).
    let e = v.log10().floor() as i32 - 2;
    let r = if e >= 0 {
        (v / 10f64.powi(e)).round() * 10f64.powi(e)
    } else {
        (v * 10f64.powi(-e)).round() / 10f64.powi(-e)
    };
    if (1e-3..1e5).contains(&r) {
        format!("{r}")
    } else {
        format!("{r:e}")
    }
}

fn encode_rgb8_png(w: u32, h: u32, rgb: &[u8]) -> Result<Vec<u8>, png::EncodingError> {
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = enc.write_header()?;
    writer.write_image_data(rgb)?;
    writer.finish()?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::tick;

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick(0.05), "0.05");
        assert_eq!(tick(0.1), "0.1");
        assert_eq!(tick(0.30000000000000004), "0.3");
        assert_eq!(tick(2.0), "2");
        assert_eq!(tick(1234.5), "1230");
        assert_eq!(tick(0.0001234), "1.23e-4");
        assert_eq!(tick(2e6), "2e6");
    }

    #[test]
    fn ranges_extend_to_whole_decades() {
        assert_eq!(super::decades(0.028, 0.28), (0.01, 1.0, 2));
        assert_eq!(super::decades(0.5, 0.6), (0.1, 1.0, 1));
        let (lo, hi, n) = super::decades(0.1, 60.0);
        assert!((lo - 0.1).abs() < 1e-15 && hi == 100.0 && n == 3);
    }
}
