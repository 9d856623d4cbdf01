//! Command-line job options, `--param` and `--grid` values.

use super::{ClientError, Result};
use crate::job::spec::{JobSpec, ReferenceSpec, SnapshotEvery};
use serde_json::Value;
use std::collections::BTreeMap;

/// The job settings `submit` and `sweep` share; unset fields keep the server's default
/// (or, for a sweep file, the file's value).
#[derive(Clone, Debug, Default)]
pub struct JobOptions {
    pub algorithm: Option<String>,
    pub spp: Option<u64>,
    pub time_s: Option<f64>,
    pub iterations: Option<u64>,
    pub target_rmse: Option<f64>,
    /// `halt.noise`: the estimated relative error to stop at.
    pub noise: Option<f64>,
    /// `variance_layer`: a per-pixel variance layer in the EXRs.
    pub variance_layer: bool,
    pub reference_job: Option<String>,
    /// `--reference`: a local EXR, `job:ID`, `upload:ID` or an id (see
    /// [`super::reference_spec`]); resolved by the command, which may upload.
    pub reference: Option<String>,
    pub seed: Option<u64>,
    /// `KEY=VALUE`; values parse as JSON when they can, else as strings.
    pub params: Vec<String>,
    pub priority: Option<i32>,
    pub snapshot_every_iterations: Option<u64>,
    pub snapshot_every_seconds: Option<f64>,
    pub name: Option<String>,
    pub tags: Vec<String>,
}

/// A command-line value: JSON when it parses (numbers, booleans, arrays), else a
/// string; a number too large for any field is refused, named as written.
fn parse_value(v: &str) -> Result<Value> {
    match serde_json::from_str(v) {
        Ok(value) => Ok(value),
        Err(e) if e.to_string().contains("number out of range") => {
            let named = crate::json_numbers::name_out_of_range(&e.to_string(), v);
            // A one-line value needs no position.
            let named = named.rsplit_once(" at line ").map_or(&*named, |(m, _)| m);
            Err(ClientError::Input(named.to_string()))
        }
        Err(_) => Ok(Value::String(v.to_string())),
    }
}

/// `key=value` pairs into a parameter map.
pub fn parse_params(params: &[String]) -> Result<serde_json::Map<String, Value>> {
    let mut m = serde_json::Map::new();
    for p in params {
        let Some((k, v)) = p.split_once('=') else {
            return Err(ClientError::Input(format!(
                "--param {p}: expected KEY=VALUE"
            )));
        };
        let value = parse_value(v).map_err(|e| ClientError::Input(format!("--param {p}: {e}")))?;
        m.insert(k.trim().to_string(), value);
    }
    Ok(m)
}

impl JobOptions {
    /// Overrides the fields of `spec` that were given.
    pub fn apply(&self, spec: &mut JobSpec) -> Result<()> {
        if let Some(a) = &self.algorithm {
            spec.algorithm = Some(a.clone());
        }
        if let Some(n) = self.spp {
            spec.halt.spp = Some(n);
        }
        if let Some(n) = self.iterations {
            spec.halt.iterations = Some(n);
        }
        if let Some(t) = self.time_s {
            spec.halt.time_s = Some(t);
        }
        if let Some(r) = self.target_rmse {
            spec.halt.target_rmse = Some(r);
        }
        if let Some(n) = self.noise {
            spec.halt.noise = Some(n);
        }
        spec.variance_layer |= self.variance_layer;
        if let Some(j) = &self.reference_job {
            spec.reference = Some(ReferenceSpec::Job(j.clone()));
        }
        if let Some(s) = self.seed {
            spec.seed = s;
        }
        spec.params.extend(parse_params(&self.params)?);
        if let Some(p) = self.priority {
            spec.priority = p;
        }
        if let Some(n) = self.snapshot_every_iterations {
            spec.snapshot_every = SnapshotEvery::Iterations(n);
        }
        if let Some(s) = self.snapshot_every_seconds {
            spec.snapshot_every = SnapshotEvery::Seconds(s);
        }
        if let Some(n) = &self.name {
            spec.name = Some(n.clone());
        }
        for t in &self.tags {
            if !spec.tags.contains(t) {
                spec.tags.push(t.clone());
            }
        }
        Ok(())
    }

    /// A job spec for `scene` with these options over the server's defaults.
    pub fn spec(&self, scene: &str) -> Result<JobSpec> {
        let mut spec: JobSpec =
            serde_json::from_value(serde_json::json!({"scene": scene, "halt": {}}))
                .map_err(|e| ClientError::Input(e.to_string()))?;
        self.apply(&mut spec)?;
        Ok(spec)
    }
}

/// Refuses a job without a halting rule, naming the command-line flags that set one
/// (the server's message names the API's fields).
pub fn require_halt(spec: &JobSpec) -> Result<()> {
    let h = &spec.halt;
    let by_error = h.target_rmse.is_some() || h.noise.is_some();
    if h.spp.is_none() && h.iterations.is_none() && h.time_s.is_none() && !by_error {
        return Err(ClientError::Input(
            "the job needs a halting rule: give --spp N, --iterations N, --time SECONDS, \
             --noise X, or --target-rmse X with --reference"
                .into(),
        ));
    }
    Ok(())
}

/// Short grid keys for the halting rule.
fn grid_key(k: &str) -> String {
    match k {
        "spp" => "halt.spp".into(),
        "iterations" => "halt.iterations".into(),
        "time" | "time_s" => "halt.time_s".into(),
        "target_rmse" => "halt.target_rmse".into(),
        "noise" => "halt.noise".into(),
        k => k.into(),
    }
}

/// `KEY=V1,V2,...` (or `KEY=[JSON array]`) into a sweep grid. Values parse as JSON
/// when they can (numbers), else as strings; a key given twice gets both lists.
pub fn parse_grid(items: &[String]) -> Result<BTreeMap<String, Vec<Value>>> {
    let mut grid: BTreeMap<String, Vec<Value>> = BTreeMap::new();
    for item in items {
        let bad = || ClientError::Input(format!("--grid {item}: expected KEY=V1,V2,..."));
        let (k, v) = item.split_once('=').ok_or_else(bad)?;
        let k = k.trim();
        if k.is_empty() {
            return Err(bad());
        }
        let values = match serde_json::from_str::<Value>(v.trim()) {
            Ok(Value::Array(a)) => a,
            _ => v
                .split(',')
                .map(|s| {
                    let s = s.trim();
                    if s.is_empty() {
                        Err(ClientError::Input(format!("--grid {item}: empty value")))
                    } else {
                        parse_value(s)
                            .map_err(|e| ClientError::Input(format!("--grid {item}: {e}")))
                    }
                })
                .collect::<Result<Vec<_>>>()?,
        };
        grid.entry(grid_key(k)).or_default().extend(values);
    }
    Ok(grid)
}
