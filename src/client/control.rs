//! The commands that change a job on a server (`caustic cancel | pause | resume |
//! retry | delete JOB`) and `caustic reference upload`.

use super::{file_error, Client, ClientError, Result};
use crate::api::JobView;
use std::io::Write;
use std::path::Path;

/// What to do to a job.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JobAction {
    Cancel,
    Pause,
    Resume,
    Retry,
    Delete,
}

impl JobAction {
    fn name(self) -> &'static str {
        match self {
            JobAction::Cancel => "cancel",
            JobAction::Pause => "pause",
            JobAction::Resume => "resume",
            JobAction::Retry => "retry",
            JobAction::Delete => "delete",
        }
    }
}

/// Applies `action` to job `id` and prints the job as it is after it: `ID: STATE`
/// (with the iteration a retried job resumes from), or the job as JSON; `delete`
/// prints `ID: deleted`.
pub fn job_action(
    client: &Client,
    id: &str,
    action: JobAction,
    json: bool,
    out: &mut impl Write,
) -> Result<bool> {
    if action == JobAction::Delete {
        client.delete_job(id)?;
        if json {
            writeln!(out, "{}", serde_json::json!({"id": id, "deleted": true}))?;
        } else {
            writeln!(out, "{id}: deleted")?;
        }
        return Ok(true);
    }
    let job = client.job_action(id, action.name())?;
    if json {
        let text = serde_json::to_string_pretty(&job).expect("job serialises");
        writeln!(out, "{text}")?;
    } else {
        writeln!(out, "{}", action_line(&job, action))?;
    }
    Ok(true)
}

fn action_line(view: &JobView, action: JobAction) -> String {
    let j = &view.job;
    let mut line = format!("{}: {}", j.id, j.state.as_str());
    if action == JobAction::Retry {
        line.push_str(&match j.iteration {
            0 => " (starts over)".to_string(),
            n => format!(" (resumes from iteration {n})"),
        });
    }
    line
}

/// `caustic reference upload FILE.exr`: uploads the file as a reference image and
/// prints its id. A file that is not an EXR is refused here, saying what it is.
pub fn upload_reference(client: &Client, path: &Path, out: &mut impl Write) -> Result<bool> {
    let id = reference_id(client, path)?;
    writeln!(out, "{id}")?;
    Ok(true)
}

/// Uploads a local EXR as a reference; returns its id.
pub(super) fn reference_id(client: &Client, path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|e| file_error(path, e))?;
    if let Some(why) = crate::film::not_exr(&bytes) {
        return Err(file_error(path, why));
    }
    let id = client.upload_reference(&bytes)?;
    eprintln!(
        "uploaded {} as reference {id} ({:.1} KiB)",
        path.display(),
        bytes.len() as f64 / 1024.0
    );
    Ok(id)
}

/// A `--reference` value: a local EXR file (uploaded first), `job:ID` or `upload:ID`,
/// or a bare id: a reference upload's (16 hex digits, as `caustic reference upload`
/// prints) or else a job's.
pub fn reference_spec(client: &Client, value: &str) -> Result<crate::job::spec::ReferenceSpec> {
    use crate::job::spec::ReferenceSpec;
    let path = Path::new(value);
    if path.is_file() {
        return Ok(ReferenceSpec::Upload(reference_id(client, path)?));
    }
    if let Some(id) = value.strip_prefix("job:") {
        return Ok(ReferenceSpec::Job(id.to_string()));
    }
    if let Some(id) = value.strip_prefix("upload:") {
        return Ok(ReferenceSpec::Upload(id.to_string()));
    }
    if value.ends_with(".exr") || value.contains('/') {
        return Err(file_error(path, "no such reference file"));
    }
    if value.is_empty() {
        return Err(ClientError::Input("--reference: empty value".into()));
    }
    let upload = value.len() == 16 && value.bytes().all(|b| b.is_ascii_hexdigit());
    Ok(if upload {
        ReferenceSpec::Upload(value.to_string())
    } else {
        ReferenceSpec::Job(value.to_string())
    })
}
