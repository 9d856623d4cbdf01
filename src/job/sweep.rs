//! Sweeps: a base job and a grid of parameter values expand into one job per grid
//! point, tagged with the sweep's id; the sweep's table summarises their results.
//! The types only: the service creates, stores and tabulates sweeps
//! (`service/sweeps.rs`), so this module imports nothing above the job's spec.

use super::spec::{JobSpec, JobState};
use super::JobError;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// `grid` keys: `algorithm`, `seed`, `priority`, `halt.spp`, `halt.iterations`,
/// `halt.time_s`, `halt.target_rmse`, `halt.noise`, or `params.<name>` for an
/// algorithm parameter.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, utoipa::ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    #[serde(deserialize_with = "crate::job::spec::de_object")]
    pub base: JobSpec,
    #[schema(value_type = Object)]
    pub grid: BTreeMap<String, Vec<serde_json::Value>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Whether grid points that differ only in `params.radius` render as the radius
    /// layers (`radii`) of one job, where the algorithm has them and the halt is by
    /// count (see [`SweepSpec::radius_groups`]). True unless set false.
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub radius_layers: bool,
}

fn yes() -> bool {
    true
}

fn is_true(b: &bool) -> bool {
    *b
}

/// A grid point: the value of every grid key.
pub type Point = BTreeMap<String, serde_json::Value>;

/// Largest number of jobs one sweep may create.
pub const MAX_SWEEP_JOBS: usize = 1000;

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Sweep {
    pub id: String,
    pub spec: SweepSpec,
    /// Each grid point (key -> value) with the job that renders it.
    pub jobs: Vec<(Point, String)>,
    /// Per entry of `jobs`, the job's radius layer that renders the point; None (and
    /// an empty list, as sweeps stored before layers have) for the main image.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub layers: Vec<Option<String>>,
}

impl Sweep {
    /// Entry `i`'s radius layer, None for the job's main image.
    pub fn layer(&self, i: usize) -> Option<&str> {
        self.layers.get(i).and_then(|l| l.as_deref())
    }
}

fn set(spec: &mut JobSpec, key: &str, v: &serde_json::Value) -> Result<(), JobError> {
    let bad = |what: &str| JobError::BadRequest(format!("grid.{key}: {what}"));
    let num = || v.as_f64().ok_or_else(|| bad("expected a number"));
    let int = || {
        v.as_u64()
            .ok_or_else(|| bad("expected a non-negative integer"))
    };
    match key {
        "algorithm" => {
            spec.algorithm = Some(v.as_str().ok_or_else(|| bad("expected a name"))?.into())
        }
        "seed" => spec.seed = int()?,
        "priority" => {
            spec.priority = v
                .as_i64()
                .and_then(|p| i32::try_from(p).ok())
                .ok_or_else(|| bad("expected an integer that fits in 32 bits"))?
        }
        "halt.spp" => spec.halt.spp = Some(int()?),
        "halt.iterations" => spec.halt.iterations = Some(int()?),
        "halt.time_s" => spec.halt.time_s = Some(num()?),
        "halt.target_rmse" => spec.halt.target_rmse = Some(num()?),
        "halt.noise" => spec.halt.noise = Some(num()?),
        k => match k.strip_prefix("params.") {
            Some(p) if !p.is_empty() => {
                spec.params.insert(p.into(), v.clone());
            }
            _ => {
                return Err(bad(
                    "unknown key (algorithm, seed, priority, halt.*, params.<name>)",
                ))
            }
        },
    }
    Ok(())
}

impl SweepSpec {
    /// Every grid point as a job, in row-major order of the (sorted) keys.
    pub fn expand(&self, sweep_id: &str) -> Result<Vec<(Point, JobSpec)>, JobError> {
        if self.grid.is_empty() {
            return Err(JobError::BadRequest("grid is empty".into()));
        }
        let mut total = 1usize;
        for (k, vals) in &self.grid {
            if vals.is_empty() {
                return Err(JobError::BadRequest(format!("grid.{k} has no values")));
            }
            total = total.saturating_mul(vals.len());
        }
        if total > MAX_SWEEP_JOBS {
            return Err(JobError::BadRequest(format!(
                "grid expands to {total} jobs, above the limit of {MAX_SWEEP_JOBS}"
            )));
        }
        let keys: Vec<&String> = self.grid.keys().collect();
        let mut out = Vec::with_capacity(total);
        for mut n in 0..total {
            let mut spec = self.base.clone();
            let mut point = BTreeMap::new();
            for k in keys.iter().rev() {
                let vals = &self.grid[*k];
                let v = &vals[n % vals.len()];
                n /= vals.len();
                set(&mut spec, k, v)?;
                point.insert((*k).clone(), v.clone());
            }
            spec.sweep = Some(sweep_id.into());
            if !spec.tags.iter().any(|t| t == sweep_id) {
                spec.tags.push(sweep_id.into());
            }
            out.push((point, spec));
        }
        Ok(out)
    }
}

/// The radius parameters whose sweeps may share a job, each with the list that
/// takes its other values as radius layers.
const RADIUS_PARAMS: [(&str, &str); 4] = [
    ("radius", "radii"),
    ("medium_radius", "medium_radii"),
    ("pb2d_radius", "pb2d_radii"),
    ("bb1d_radius", "bb1d_radii"),
];

/// A swept radius parameter and its list (one of [`RADIUS_PARAMS`]).
pub type SweptRadius = (&'static str, &'static str);

impl SweepSpec {
    /// The one radius parameter the grid sweeps over several values, if there is
    /// exactly one.
    pub fn swept_radius(&self) -> Option<SweptRadius> {
        let swept = |(p, _): &&SweptRadius| {
            let key = format!("params.{p}");
            self.grid.get(&key).is_some_and(|v| v.len() > 1)
        };
        let mut all = RADIUS_PARAMS.iter().filter(swept);
        let one = *all.next()?;
        all.next().is_none().then_some(one)
    }

    /// The expanded points (`expand`'s output) in groups that one job renders: points
    /// that differ only in the swept radius parameter share a job whose main image
    /// takes the first value and whose radius layers the others (`radii`, and for a
    /// volume radius its list with `radii` repeating the job's `radius`), as separate
    /// jobs with those radii and the same seed would render them
    /// (tests/radius_sweeps.rs). Only where the halt is a count: under `halt.time_s` a
    /// job with layers runs fewer iterations than each separate job would, and
    /// `halt.target_rmse` and `halt.noise` watch the main image alone. Every other point is a group
    /// of its own. The service still falls back to separate jobs where the algorithm
    /// has no radius layers.
    pub fn radius_groups(&self, expanded: &[(Point, JobSpec)]) -> Vec<Vec<usize>> {
        let mut groups: Vec<(Option<String>, Vec<usize>)> = Vec::new();
        let listed = RADIUS_PARAMS
            .iter()
            .any(|(_, list)| self.base.params.contains_key(*list));
        let swept = self
            .swept_radius()
            .filter(|_| self.radius_layers && !listed);
        for (i, (_, spec)) in expanded.iter().enumerate() {
            let key = swept.and_then(|(param, _)| radius_free_key(spec, param));
            match groups.iter_mut().find(|(k, _)| key.is_some() && *k == key) {
                Some((_, g)) => g.push(i),
                None => groups.push((key, vec![i])),
            }
        }
        groups.into_iter().map(|(_, g)| g).collect()
    }
}

/// What a job is apart from its radius parameter `param`, as text; None where the job
/// may not share: a halt by time or error, a value that is not a positive number, or
/// for a volume radius a `radius` that is not one (the layers repeat it).
fn radius_free_key(spec: &JobSpec, param: &str) -> Option<String> {
    let h = &spec.halt;
    if h.time_s.is_some() || h.target_rmse.is_some() || h.noise.is_some() {
        return None;
    }
    let positive = |key: &str| {
        let r = spec.params.get(key).and_then(|v| v.as_f64());
        r.is_some_and(|r| r.is_finite() && r > 0.0)
    };
    if !positive(param) || !positive("radius") {
        return None;
    }
    let mut rest = spec.clone();
    rest.params.remove(param);
    serde_json::to_string(&rest).ok()
}

/// The one job of a group of `radius_groups` over `(param, list)`: the first spec,
/// with the others' values of `param` as `list` (and `radii` repeating its `radius`
/// where the swept parameter is a volume radius).
pub fn layered_spec(specs: &[&JobSpec], (param, list): SweptRadius) -> JobSpec {
    let mut job = specs[0].clone();
    let values: Vec<serde_json::Value> =
        specs[1..].iter().map(|s| s.params[param].clone()).collect();
    if param != "radius" {
        let radius = job.params["radius"].clone();
        job.params
            .insert("radii".into(), vec![radius; values.len()].into());
    }
    job.params.insert(list.into(), values.into());
    job
}

/// One row per job of a sweep.
#[derive(Serialize, Deserialize, Debug, Clone, utoipa::ToSchema)]
pub struct SweepRow {
    pub job: String,
    #[schema(value_type = Object)]
    pub point: std::collections::BTreeMap<String, serde_json::Value>,
    pub state: JobState,
    pub iterations: u64,
    pub time_s: f64,
    pub rmse: Option<f64>,
    /// The radius layer of the job that renders this point (`rmse` is the layer's,
    /// from the job's layers.csv); absent for the job's main image.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layer: Option<String>,
}

// A sweep's summary, one row per job in grid order (no doc comment: it would change
// the OpenAPI schema's description).
#[derive(Serialize, Deserialize, Debug, Clone, utoipa::ToSchema)]
pub struct SweepTable {
    pub id: String,
    pub name: Option<String>,
    pub rows: Vec<SweepRow>,
}

impl SweepTable {
    pub fn csv(&self) -> String {
        let keys: Vec<&String> = self
            .rows
            .first()
            .map(|r| r.point.keys().collect())
            .unwrap_or_default();
        let mut out = String::from("job");
        for k in &keys {
            out.push(',');
            out.push_str(k);
        }
        out.push_str(",state,iterations,time_s,rmse,layer\n");
        for r in &self.rows {
            out.push_str(&r.job);
            for k in &keys {
                out.push(',');
                let v = &r.point[*k];
                out.push_str(
                    &v.as_str()
                        .map(String::from)
                        .unwrap_or_else(|| v.to_string()),
                );
            }
            let rmse = r.rmse.map(|x| format!("{x:.6e}")).unwrap_or_default();
            out.push_str(&format!(
                ",{},{},{:.3},{rmse},{}\n",
                r.state.as_str(),
                r.iterations,
                r.time_s,
                r.layer.as_deref().unwrap_or_default()
            ));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn grid_expands_to_the_cartesian_product() {
        let spec: SweepSpec = serde_json::from_value(json!({
            "base": {"scene": "cornell-box", "halt": {"spp": 4}},
            "grid": {"algorithm": ["pt", "normals"], "halt.time_s": [1, 2, 3]}
        }))
        .unwrap();
        let jobs = spec.expand("s1").unwrap();
        assert_eq!(jobs.len(), 6);
        assert!(jobs.iter().all(|(_, j)| j.sweep.as_deref() == Some("s1")));
        let pts: Vec<_> = jobs
            .iter()
            .map(|(p, _)| (p["algorithm"].clone(), p["halt.time_s"].clone()))
            .collect();
        assert_eq!(
            pts.iter().collect::<std::collections::HashSet<_>>().len(),
            6
        );
        let bad: SweepSpec = serde_json::from_value(json!({
            "base": {"scene": "x", "halt": {"spp": 1}}, "grid": {"radius": [1]}
        }))
        .unwrap();
        assert!(bad.expand("s").is_err());
    }

    fn groups(spec: serde_json::Value) -> Vec<Vec<usize>> {
        let spec: SweepSpec = serde_json::from_value(spec).unwrap();
        spec.radius_groups(&spec.expand("s").unwrap())
    }

    #[test]
    fn points_that_differ_only_in_radius_share_a_job() {
        let base = json!({"scene": "x", "halt": {"spp": 4}});
        // Row-major over sorted keys: algorithm varies slowest.
        let grid = json!({"algorithm": ["vcm", "bpm"], "params.radius": [0.1, 0.2, 0.3]});
        let g = groups(json!({"base": base, "grid": grid}));
        assert_eq!(g, vec![vec![0, 1, 2], vec![3, 4, 5]]);
        // The radius not the fastest key: the groups still gather by everything else.
        let grid = json!({"params.radius": [0.1, 0.2], "seed": [1, 2]});
        let g = groups(json!({"base": base, "grid": grid}));
        assert_eq!(g, vec![vec![0, 2], vec![1, 3]]);
        let single = |g: Vec<Vec<usize>>| g.iter().all(|g| g.len() == 1);
        let grid = json!({"params.radius": [0.1, 0.2]});
        assert!(single(groups(
            json!({"base": base, "grid": grid, "radius_layers": false})
        )));
        let timed = json!({"scene": "x", "halt": {"time_s": 4}});
        assert!(single(groups(json!({"base": timed, "grid": grid}))));
        let listed = json!({"scene": "x", "halt": {"spp": 4}, "params": {"radii": [0.5]}});
        assert!(single(groups(json!({"base": listed, "grid": grid}))));
        let odd = json!({"params.radius": [0.1, "auto"]});
        assert!(single(groups(json!({"base": base, "grid": odd}))));
        let spec: SweepSpec = serde_json::from_value(json!({"base": base, "grid": grid})).unwrap();
        let expanded = spec.expand("s").unwrap();
        let job = layered_spec(&[&expanded[0].1, &expanded[1].1], ("radius", "radii"));
        assert_eq!(job.params["radius"], json!(0.1));
        assert_eq!(job.params["radii"], json!([0.2]));
        // A volume radius: the layers repeat the job's radius, which must be set.
        let fixed = json!({"scene": "x", "halt": {"spp": 4}, "params": {"radius": 0.05}});
        let grid = json!({"params.pb2d_radius": [0.1, 0.2, 0.3]});
        let spec = json!({"base": fixed, "grid": grid});
        assert_eq!(groups(spec.clone()), vec![vec![0, 1, 2]]);
        let spec: SweepSpec = serde_json::from_value(spec).unwrap();
        assert_eq!(spec.swept_radius(), Some(("pb2d_radius", "pb2d_radii")));
        let expanded = spec.expand("s").unwrap();
        let specs: Vec<&JobSpec> = expanded.iter().map(|(_, j)| j).collect();
        let job = layered_spec(&specs, ("pb2d_radius", "pb2d_radii"));
        assert_eq!(job.params["radii"], json!([0.05, 0.05]));
        assert_eq!(job.params["pb2d_radii"], json!([0.2, 0.3]));
        assert!(single(groups(json!({"base": base, "grid": grid}))));
        // Two radius parameters swept at once: no sharing.
        let two = json!({"params.radius": [0.1, 0.2], "params.bb1d_radius": [0.1, 0.2]});
        assert!(single(groups(json!({"base": base, "grid": two}))));
    }
}
