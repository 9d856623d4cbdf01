//! Text tables: `caustic jobs` and the sweep table.

use super::{Client, Result};
use crate::api::SweepTable;
use serde_json::Value;
use std::io::Write;

pub struct JobsOptions {
    pub state: Option<String>,
    pub tag: Option<String>,
    pub sweep: Option<String>,
    pub json: bool,
}

/// `caustic jobs`: a table of jobs, or their JSON.
pub fn jobs(client: &Client, o: &JobsOptions, out: &mut impl Write) -> Result<bool> {
    let jobs = client.jobs(o.state.as_deref(), o.tag.as_deref(), o.sweep.as_deref())?;
    if o.json {
        writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&jobs).expect("jobs serialise")
        )?;
        return Ok(true);
    }
    let headers = [
        "id",
        "state",
        "algorithm",
        "iteration",
        "elapsed_s",
        "rmse",
        "noise",
        "name",
    ];
    let rows: Vec<Vec<String>> = jobs
        .iter()
        .map(|v| {
            let j = &v.job;
            let alg = j.settings["algorithm"]
                .as_str()
                .map(String::from)
                .or_else(|| j.spec.algorithm.clone())
                .unwrap_or_else(|| "-".into());
            vec![
                j.id.clone(),
                j.state.as_str().into(),
                alg,
                j.iteration.to_string(),
                format!("{:.2}", j.elapsed_s),
                j.last_rmse
                    .map(|r| format!("{r:.4e}"))
                    .unwrap_or("-".into()),
                j.noise
                    .map(|n| format!("{:.2}%", 100.0 * n))
                    .unwrap_or("-".into()),
                j.spec.name.clone().unwrap_or_default(),
            ]
        })
        .collect();
    let right = [false, false, false, true, true, true, true, false];
    out.write_all(table(&headers, &rows, &right).as_bytes())?;
    Ok(true)
}

/// Text columns separated by two spaces; `right` marks right-aligned columns.
pub(super) fn table(headers: &[&str], rows: &[Vec<String>], right: &[bool]) -> String {
    let mut widths: Vec<usize> = headers.iter().map(|h| h.chars().count()).collect();
    for r in rows {
        for (w, c) in widths.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let line = |cells: Vec<&str>| {
        let mut s = String::new();
        for (i, c) in cells.iter().enumerate() {
            if i > 0 {
                s.push_str("  ");
            }
            let pad = widths[i].saturating_sub(c.chars().count());
            if right.get(i).copied().unwrap_or(false) {
                s.push_str(&" ".repeat(pad));
                s.push_str(c);
            } else {
                s.push_str(c);
                if i + 1 < cells.len() {
                    s.push_str(&" ".repeat(pad));
                }
            }
        }
        s.truncate(s.trim_end().len());
        s.push('\n');
        s
    };
    let mut out = line(headers.to_vec());
    for r in rows {
        out.push_str(&line(r.iter().map(String::as_str).collect()));
    }
    out
}

/// The sweep table as text: the job, one column per grid key, then the results.
pub fn sweep_text(t: &SweepTable) -> String {
    let keys: Vec<&String> = t
        .rows
        .first()
        .map(|r| r.point.keys().collect())
        .unwrap_or_default();
    let mut headers: Vec<&str> = vec!["job"];
    headers.extend(keys.iter().map(|k| k.as_str()));
    headers.extend(["state", "iterations", "time_s", "rmse"]);
    let layered = t.rows.iter().any(|r| r.layer.is_some());
    if layered {
        headers.push("layer");
    }
    let rows: Vec<Vec<String>> = t
        .rows
        .iter()
        .map(|r| {
            let mut row = vec![r.job.clone()];
            for k in &keys {
                row.push(match r.point.get(*k) {
                    Some(Value::String(s)) => s.clone(),
                    Some(v) => v.to_string(),
                    None => "-".into(),
                });
            }
            row.push(r.state.as_str().into());
            row.push(r.iterations.to_string());
            row.push(format!("{:.2}", r.time_s));
            row.push(r.rmse.map(|x| format!("{x:.4e}")).unwrap_or("-".into()));
            if layered {
                row.push(r.layer.clone().unwrap_or("main".into()));
            }
            row
        })
        .collect();
    let mut right = vec![false; 1 + keys.len()];
    right.extend([false, true, true, true, false]);
    right.truncate(headers.len());
    table(&headers, &rows, &right)
}
