//! Crash points for the crash-consistency tests: the process aborts, as under
//! `kill -9`, just before a chosen write of a job's files.
//!
//! `CAUSTIC_FAILPOINT=<point>@<iteration>` arms one point: the server aborts when the
//! scheduler is about to make that write for a job at that iteration (`@` and the
//! iteration may be left out: the first time the point is reached). Points, in the
//! order a job's last snapshot writes them: `snapshot-exr`, `snapshot-png`,
//! `latest-exr`, `latest-png`, `log`, `checkpoint`, `final-exr`, `final-png`,
//! `status`; and in `caustic worker`, `unit` (iteration = the unit's first), just
//! before a work unit renders. The variable is read once; without it every check is
//! one load of a static.

use std::sync::OnceLock;

struct Armed {
    point: String,
    iteration: Option<u64>,
}

fn armed() -> Option<&'static Armed> {
    static ARMED: OnceLock<Option<Armed>> = OnceLock::new();
    ARMED
        .get_or_init(|| {
            let v = std::env::var("CAUSTIC_FAILPOINT").ok()?;
            let (point, iteration) = match v.split_once('@') {
                Some((p, i)) => (p.to_string(), Some(i.trim().parse().ok()?)),
                None => (v, None),
            };
            Some(Armed { point, iteration })
        })
        .as_ref()
}

/// Aborts the process if `point` is armed for `iteration`.
pub fn hit(point: &str, iteration: u64) {
    if let Some(a) = armed() {
        if a.point == point && a.iteration.is_none_or(|i| i == iteration) {
            eprintln!("failpoint {point}@{iteration}: aborting");
            std::process::abort();
        }
    }
}
