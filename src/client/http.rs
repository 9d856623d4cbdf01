//! The HTTP transport: one connection to a server, its requests, and the server's
//! error bodies as [`ClientError`]s.

use super::sse::SseReader;
use super::{ClientError, Result};
use crate::api::{JobView, SweepTable};
use crate::job::spec::JobSpec;
use crate::job::sweep::SweepSpec;
use serde::de::DeserializeOwned;
use serde::Serialize;
use serde_json::Value;
use std::io::{BufReader, Read};
use std::time::Duration;

/// A connection to one server: base URL plus optional bearer token.
pub struct Client {
    base: String,
    token: Option<String>,
    agent: ureq::Agent,
}

/// Percent-encodes one path segment (job and sweep ids come from the user).
pub(super) fn segment(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

impl Client {
    /// `server` is a base URL (`http://host:port`); a bare `host:port` gets `http://`.
    pub fn new(server: &str, token: Option<String>) -> Client {
        let server = server.trim().trim_end_matches('/');
        let base = if server.contains("://") {
            server.to_string()
        } else {
            format!("http://{server}")
        };
        let agent = ureq::AgentBuilder::new()
            .timeout_connect(Duration::from_secs(10))
            // Longer than the SSE keep-alive interval (15 s), so idle streams live on.
            .timeout_read(Duration::from_secs(120))
            .user_agent(concat!("caustic/", env!("CARGO_PKG_VERSION")))
            .build();
        Client {
            base,
            token: token.filter(|t| !t.is_empty()),
            agent,
        }
    }

    pub fn base_url(&self) -> &str {
        &self.base
    }

    fn request(&self, method: &str, path: &str) -> ureq::Request {
        let req = self.agent.request(method, &format!("{}{path}", self.base));
        match &self.token {
            Some(t) => req.set("authorization", &format!("Bearer {t}")),
            None => req,
        }
    }

    /// Sends a request, turning error statuses into `ClientError::Server`.
    fn send(
        &self,
        result: std::result::Result<ureq::Response, ureq::Error>,
    ) -> Result<ureq::Response> {
        match result {
            Ok(r) => Ok(r),
            Err(ureq::Error::Status(status, resp)) => Err(server_error(status, resp)),
            Err(ureq::Error::Transport(t)) => Err(ClientError::Transport(t.to_string())),
        }
    }

    fn json<T: DeserializeOwned>(&self, resp: ureq::Response) -> Result<T> {
        let url = resp.get_url().to_string();
        let mut body = Vec::new();
        resp.into_reader()
            .read_to_end(&mut body)
            .map_err(|e| ClientError::Transport(format!("{url}: {e}")))?;
        serde_json::from_slice(&body).map_err(|e| ClientError::Protocol {
            url,
            message: e.to_string(),
        })
    }

    fn get<T: DeserializeOwned>(&self, path: &str, query: &[(&str, &str)]) -> Result<T> {
        let mut req = self.request("GET", path);
        for (k, v) in query {
            req = req.query(k, v);
        }
        let resp = self.send(req.call())?;
        self.json(resp)
    }

    fn post<T: DeserializeOwned>(&self, path: &str, body: &impl Serialize) -> Result<T> {
        let resp = self.send(self.request("POST", path).send_json(body))?;
        self.json(resp)
    }

    /// Uploads a scene document or bundle; returns the scene id.
    pub fn upload_scene(&self, bytes: &[u8], content_type: &str) -> Result<String> {
        self.upload("/v1/scenes", bytes, content_type)
    }

    /// Uploads a reference EXR (`POST /v1/references`); returns its id.
    pub fn upload_reference(&self, bytes: &[u8]) -> Result<String> {
        self.upload("/v1/references", bytes, "application/octet-stream")
    }

    /// POSTs an upload; returns the `id` the server gives it.
    fn upload(&self, path: &str, bytes: &[u8], content_type: &str) -> Result<String> {
        let resp = self.send(
            self.request("POST", path)
                .set("content-type", content_type)
                .send_bytes(bytes),
        )?;
        let info: Value = self.json(resp)?;
        info["id"]
            .as_str()
            .map(String::from)
            .ok_or_else(|| ClientError::Protocol {
                url: format!("{}{path}", self.base),
                message: "no id in the answer".into(),
            })
    }

    /// `POST /v1/jobs/{id}/{action}` (cancel, pause, resume, retry): the job after it.
    pub fn job_action(&self, id: &str, action: &str) -> Result<JobView> {
        let path = format!("/v1/jobs/{}/{action}", segment(id));
        let resp = self.send(self.request("POST", &path).call())?;
        self.json(resp)
    }

    /// `DELETE /v1/jobs/{id}`.
    pub fn delete_job(&self, id: &str) -> Result<()> {
        let path = format!("/v1/jobs/{}", segment(id));
        self.send(self.request("DELETE", &path).call())?;
        Ok(())
    }

    pub fn submit(&self, spec: &JobSpec) -> Result<JobView> {
        self.post("/v1/jobs", spec)
    }

    pub fn job(&self, id: &str) -> Result<JobView> {
        self.get(&format!("/v1/jobs/{}", segment(id)), &[])
    }

    pub fn jobs(
        &self,
        state: Option<&str>,
        tag: Option<&str>,
        sweep: Option<&str>,
    ) -> Result<Vec<JobView>> {
        let q: Vec<(&str, &str)> = [("state", state), ("tag", tag), ("sweep", sweep)]
            .into_iter()
            .filter_map(|(k, v)| v.map(|v| (k, v)))
            .collect();
        self.get("/v1/jobs", &q)
    }

    pub fn create_sweep(&self, spec: &SweepSpec) -> Result<SweepTable> {
        self.post("/v1/sweeps", spec)
    }

    pub fn sweep(&self, id: &str) -> Result<SweepTable> {
        self.get(&format!("/v1/sweeps/{}", segment(id)), &[])
    }

    pub fn sweep_csv(&self, id: &str) -> Result<String> {
        let resp = self.send(
            self.request("GET", &format!("/v1/sweeps/{}", segment(id)))
                .query("format", "csv")
                .call(),
        )?;
        resp.into_string()
            .map_err(|e| ClientError::Transport(e.to_string()))
    }

    /// The job's latest image as EXR bytes (`GET /v1/jobs/{id}/image.exr`).
    pub fn image_exr(&self, id: &str) -> Result<Vec<u8>> {
        let url = format!("/v1/jobs/{}/image.exr", segment(id));
        let resp = self.send(self.request("GET", &url).call())?;
        let mut body = Vec::new();
        resp.into_reader()
            .read_to_end(&mut body)
            .map_err(|e| ClientError::Transport(format!("{}{url}: {e}", self.base)))?;
        Ok(body)
    }

    /// Opens a job's event stream.
    pub fn events(&self, id: &str) -> Result<SseReader<BufReader<Box<dyn Read + Send + Sync>>>> {
        let resp = self.send(
            self.request("GET", &format!("/v1/jobs/{}/events", segment(id)))
                .set("accept", "text/event-stream")
                .call(),
        )?;
        Ok(SseReader::new(BufReader::new(resp.into_reader())))
    }
}

/// The server's `{"error": {"code", "message"}}` body, or the raw text when it is not.
fn server_error(status: u16, resp: ureq::Response) -> ClientError {
    let status_text = resp.status_text().to_string();
    let body = resp.into_string().unwrap_or_default();
    let parsed: Option<(String, String)> =
        serde_json::from_str::<Value>(&body).ok().and_then(|v| {
            let e = v.get("error")?;
            Some((e["code"].as_str()?.into(), e["message"].as_str()?.into()))
        });
    match parsed {
        Some((code, message)) => ClientError::Server {
            status,
            code,
            message,
        },
        None => ClientError::Server {
            status,
            code: status_text.to_lowercase().replace(' ', "_"),
            message: body.trim().to_string(),
        },
    }
}
