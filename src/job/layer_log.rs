//! layers.csv: per snapshot, the error of each radius layer (`radii`) against the
//! job's reference, one row per layer. A radius layer is a whole image, as a job with
//! that radius renders it, so its error reads like log.csv's; technique layers are
//! parts of the image and have none. Cut back to the checkpoint on resume, as the log.

use super::store::{append_csv, read_csv, write_csv, JobDir};
use super::JobError;

pub const LAYER_HEADER: &str = "iteration,layer,radius,medium_radius,rmse,rel_mse";

/// One layer at one snapshot. `medium_radius` is None where the layer takes the job's
/// (or the scene's derived) medium radius; `rmse` and `rel_mse` without a reference.
#[derive(
    Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize, utoipa::ToSchema,
)]
pub struct LayerRow {
    pub iteration: u64,
    pub layer: String,
    /// The layer's initial merge radius.
    pub radius: f64,
    pub medium_radius: Option<f64>,
    pub rmse: Option<f64>,
    pub rel_mse: Option<f64>,
}

impl LayerRow {
    pub fn csv(&self) -> String {
        let opt = |v: Option<f64>| v.map(|x| format!("{x:.6e}")).unwrap_or_default();
        format!(
            "{},{},{:.6e},{},{},{}",
            self.iteration,
            self.layer,
            self.radius,
            opt(self.medium_radius),
            opt(self.rmse),
            opt(self.rel_mse)
        )
    }

    pub fn parse(line: &str) -> Option<LayerRow> {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != LAYER_HEADER.split(',').count() {
            return None;
        }
        let opt = |s: &str| -> Option<Option<f64>> {
            match s {
                "" => Some(None),
                s => s.parse().ok().map(Some),
            }
        };
        Some(LayerRow {
            iteration: f[0].parse().ok()?,
            layer: f[1].to_string(),
            radius: f[2].parse().ok()?,
            medium_radius: opt(f[3])?,
            rmse: opt(f[4])?,
            rel_mse: opt(f[5])?,
        })
    }
}

/// Appends one snapshot's rows (none: nothing is written).
pub fn append_layer_rows(dir: &JobDir, rows: &[LayerRow]) -> Result<(), JobError> {
    if rows.is_empty() {
        return Ok(());
    }
    append_csv(
        &dir.layers_csv(),
        LAYER_HEADER,
        rows.iter().map(LayerRow::csv),
    )
}

pub fn read_layer_log(dir: &JobDir) -> Vec<LayerRow> {
    read_csv(&dir.layers_csv(), LayerRow::parse)
}

/// Keeps only rows up to `iteration`, rewriting the file whole (see
/// [`super::store::truncate_log`]); a job without the file gets none.
pub fn truncate_layer_log(dir: &JobDir, iteration: u64) -> Result<(), JobError> {
    if !dir.layers_csv().exists() {
        return Ok(());
    }
    let rows = read_layer_log(dir)
        .into_iter()
        .filter(|r| r.iteration <= iteration);
    write_csv(&dir.layers_csv(), LAYER_HEADER, rows.map(|r| r.csv()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn row(iteration: u64, layer: &str, rmse: Option<f64>) -> LayerRow {
        LayerRow {
            iteration,
            layer: layer.into(),
            radius: 0.025,
            medium_radius: (layer == "radius1").then_some(0.5),
            rmse,
            rel_mse: rmse.map(|r| r * 2.0),
        }
    }

    #[test]
    fn rows_round_trip_and_truncate_to_the_checkpoint() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = JobDir::new(tmp.path(), "j");
        dir.create().unwrap();
        append_layer_rows(&dir, &[]).unwrap();
        assert!(!dir.layers_csv().exists(), "no layers, no file");
        for it in [4, 8, 12] {
            let rows = [
                row(it, "radius0", Some(0.5 / it as f64)),
                row(it, "radius1", None),
            ];
            append_layer_rows(&dir, &rows).unwrap();
        }
        let read = read_layer_log(&dir);
        assert_eq!(read.len(), 6);
        assert_eq!(read[2], row(8, "radius0", Some(0.5 / 8.0)));
        assert_eq!(read[5], row(12, "radius1", None));
        // A half-written last line (a crash mid-append) is dropped with the rows past
        // the checkpoint.
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(dir.layers_csv())
            .unwrap();
        f.write_all(b"16,radius0,2.5e-2").unwrap();
        truncate_layer_log(&dir, 8).unwrap();
        let kept = read_layer_log(&dir);
        assert_eq!(kept.len(), 4);
        assert!(kept.iter().all(|r| r.iteration <= 8));
        append_layer_rows(&dir, &[row(12, "radius0", Some(0.1))]).unwrap();
        let text = std::fs::read_to_string(dir.layers_csv()).unwrap();
        assert_eq!(text.lines().next(), Some(LAYER_HEADER));
        assert_eq!(text.lines().count(), 6, "{text}");
    }
}
