//! A raw HTTP/1.1 client over a TcpStream, for requests a well-behaved client library
//! will not send: any method, a request target as raw bytes (`..`, `%00`, non-UTF-8
//! percent sequences, no normalisation), lying or absent Content-Length, chunked
//! bodies, bodies the server refuses before reading them.
//!
//! The body is written on its own thread while this one reads, so that an answer the
//! server sends before the body is done (413 on a declared length) is read before the
//! connection is reset.

use serde_json::Value;
use std::io::{Read, Write};
use std::net::{Shutdown, TcpStream};
use std::time::{Duration, Instant};

#[derive(Clone, Debug)]
pub enum Body {
    None,
    /// The bytes, with a matching Content-Length.
    Full(Vec<u8>),
    /// The bytes as `Transfer-Encoding: chunked`, in chunks of 64 KiB.
    Chunked(Vec<u8>),
    /// Content-Length says `declared` (any text); only `sent` is sent, then silence.
    Declared {
        declared: String,
        sent: Vec<u8>,
    },
    /// Written as given after the head: the caller frames it (bad chunking...).
    Raw(Vec<u8>),
}

#[derive(Clone, Debug)]
pub struct Req {
    pub method: String,
    pub target: Vec<u8>,
    pub headers: Vec<(String, Vec<u8>)>,
    pub body: Body,
}

impl Req {
    pub fn new(method: &str, target: impl AsRef<[u8]>) -> Req {
        Req {
            method: method.to_string(),
            target: target.as_ref().to_vec(),
            headers: Vec::new(),
            body: Body::None,
        }
    }

    pub fn get(target: impl AsRef<[u8]>) -> Req {
        Req::new("GET", target)
    }

    pub fn post(target: impl AsRef<[u8]>) -> Req {
        Req::new("POST", target)
    }

    pub fn header(mut self, name: &str, value: impl AsRef<[u8]>) -> Req {
        self.headers
            .push((name.to_string(), value.as_ref().to_vec()));
        self
    }

    /// A body with `content-type: application/json`.
    pub fn json(self, body: impl AsRef<[u8]>) -> Req {
        self.header("content-type", "application/json").bytes(body)
    }

    pub fn bytes(mut self, body: impl AsRef<[u8]>) -> Req {
        self.body = Body::Full(body.as_ref().to_vec());
        self
    }

    pub fn chunked(mut self, body: impl AsRef<[u8]>) -> Req {
        self.body = Body::Chunked(body.as_ref().to_vec());
        self
    }

    pub fn declared(mut self, declared: impl Into<String>, sent: impl AsRef<[u8]>) -> Req {
        self.body = Body::Declared {
            declared: declared.into(),
            sent: sent.as_ref().to_vec(),
        };
        self
    }

    pub fn raw_body(mut self, bytes: impl AsRef<[u8]>) -> Req {
        self.body = Body::Raw(bytes.as_ref().to_vec());
        self
    }

    /// The request line and head, with Host and `Connection: close` added.
    pub fn head(&self, host: &str) -> Vec<u8> {
        let mut h = Vec::new();
        h.extend_from_slice(self.method.as_bytes());
        h.push(b' ');
        h.extend_from_slice(&self.target);
        h.extend_from_slice(b" HTTP/1.1\r\n");
        let has = |n: &str| self.headers.iter().any(|(k, _)| k.eq_ignore_ascii_case(n));
        if !has("host") {
            h.extend_from_slice(format!("Host: {host}\r\n").as_bytes());
        }
        if !has("connection") {
            h.extend_from_slice(b"Connection: close\r\n");
        }
        for (k, v) in &self.headers {
            h.extend_from_slice(k.as_bytes());
            h.extend_from_slice(b": ");
            h.extend_from_slice(v);
            h.extend_from_slice(b"\r\n");
        }
        match &self.body {
            Body::Full(b) if !has("content-length") => {
                h.extend_from_slice(format!("Content-Length: {}\r\n", b.len()).as_bytes())
            }
            Body::Chunked(_) => h.extend_from_slice(b"Transfer-Encoding: chunked\r\n"),
            Body::Declared { declared, .. } => {
                h.extend_from_slice(format!("Content-Length: {declared}\r\n").as_bytes())
            }
            _ => {}
        }
        h.extend_from_slice(b"\r\n");
        h
    }

    /// What follows the head on the wire.
    fn wire_body(&self) -> Vec<u8> {
        match &self.body {
            Body::None => Vec::new(),
            Body::Full(b) | Body::Raw(b) => b.clone(),
            Body::Declared { sent, .. } => sent.clone(),
            Body::Chunked(b) => {
                let mut out = Vec::with_capacity(b.len() + b.len() / 1000 + 16);
                for c in b.chunks(64 << 10) {
                    out.extend_from_slice(format!("{:x}\r\n", c.len()).as_bytes());
                    out.extend_from_slice(c);
                    out.extend_from_slice(b"\r\n");
                }
                out.extend_from_slice(b"0\r\n\r\n");
                out
            }
        }
    }

    /// A short description of the request for failure messages.
    pub fn describe(&self) -> String {
        let t: String = String::from_utf8_lossy(&self.target)
            .chars()
            .take(60)
            .flat_map(char::escape_debug)
            .collect();
        let t = if self.target.len() > 60 {
            format!("{t}...({} bytes)", self.target.len())
        } else {
            t
        };
        let body = match &self.body {
            Body::None => String::new(),
            Body::Full(b) => format!(" [{} body bytes]", b.len()),
            Body::Chunked(b) => format!(" [{} bytes chunked]", b.len()),
            Body::Declared { declared, sent } => {
                format!(" [Content-Length {declared}, {} bytes sent]", sent.len())
            }
            Body::Raw(b) => format!(" [{} raw bytes]", b.len()),
        };
        format!("{} {t}{body}", self.method)
    }
}

#[derive(Clone, Debug)]
pub struct Resp {
    pub status: u16,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
    /// From the first byte written to the complete answer.
    pub elapsed: Duration,
}

impl Resp {
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    pub fn json(&self) -> Option<Value> {
        serde_json::from_slice(&self.body).ok()
    }

    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }
}

#[derive(Debug)]
pub enum Outcome {
    Answered(Resp),
    /// The server closed (or reset) the connection without a complete answer.
    Closed {
        elapsed: Duration,
        partial: Vec<u8>,
    },
    /// No complete answer within the client's timeout; the connection was open.
    TimedOut {
        elapsed: Duration,
        partial: Vec<u8>,
    },
    /// Could not connect.
    Failed(String),
}

impl Outcome {
    pub fn describe(&self) -> String {
        match self {
            Outcome::Answered(r) => format!("{} {}", r.status, clip(&r.text(), 400)),
            Outcome::Closed { elapsed, partial } => format!(
                "connection closed after {elapsed:.1?} without an answer ({} bytes: {:?})",
                partial.len(),
                clip(&String::from_utf8_lossy(partial), 200)
            ),
            Outcome::TimedOut { elapsed, partial } => format!(
                "no answer within {elapsed:.1?} ({} bytes: {:?})",
                partial.len(),
                clip(&String::from_utf8_lossy(partial), 200)
            ),
            Outcome::Failed(e) => format!("could not connect: {e}"),
        }
    }
}

pub fn clip(s: &str, n: usize) -> String {
    if s.len() <= n {
        s.to_string()
    } else {
        format!("{}... ({} bytes)", &s[..s.floor_char_boundary(n)], s.len())
    }
}

/// `http://127.0.0.1:port` -> `127.0.0.1:port`.
pub fn addr_of(url: &str) -> &str {
    url.trim_start_matches("http://").trim_end_matches('/')
}

/// Sends `req` and waits at most `timeout` for a complete answer.
pub fn send(url: &str, req: &Req, timeout: Duration) -> Outcome {
    let addr = addr_of(url);
    let stream = match TcpStream::connect(addr) {
        Ok(s) => s,
        Err(e) => return Outcome::Failed(e.to_string()),
    };
    let _ = stream.set_nodelay(true);
    let mut wire = req.head(addr);
    wire.extend_from_slice(&req.wire_body());
    exchange(stream, wire, timeout)
}

/// Writes `wire` on a thread and reads the answer on this one.
pub fn exchange(stream: TcpStream, wire: Vec<u8>, timeout: Duration) -> Outcome {
    let start = Instant::now();
    let mut writer = stream.try_clone().expect("clone stream");
    let w = std::thread::spawn(move || {
        // The server may answer and close before the body is sent: that is allowed.
        for piece in wire.chunks(64 << 10) {
            if writer.write_all(piece).is_err() {
                break;
            }
        }
    });
    let out = read_answer(&stream, start, timeout);
    // Wakes a writer blocked on a server that no longer reads.
    let _ = stream.shutdown(Shutdown::Both);
    let _ = w.join();
    out
}

/// Reads until a complete answer, EOF, an error or the deadline.
pub fn read_answer(mut stream: &TcpStream, start: Instant, timeout: Duration) -> Outcome {
    let mut buf = Vec::new();
    let mut chunk = vec![0u8; 64 << 10];
    loop {
        let left = timeout.saturating_sub(start.elapsed());
        if left.is_zero() {
            return Outcome::TimedOut {
                elapsed: start.elapsed(),
                partial: buf,
            };
        }
        let _ = stream.set_read_timeout(Some(left));
        match stream.read(&mut chunk) {
            Ok(0) => {
                return match parse(&buf, true) {
                    Some(mut r) => {
                        r.elapsed = start.elapsed();
                        Outcome::Answered(r)
                    }
                    None => Outcome::Closed {
                        elapsed: start.elapsed(),
                        partial: buf,
                    },
                }
            }
            Ok(n) => {
                buf.extend_from_slice(&chunk[..n]);
                if let Some(mut r) = parse(&buf, false) {
                    r.elapsed = start.elapsed();
                    return Outcome::Answered(r);
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                continue
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(_) => {
                return match parse(&buf, true) {
                    Some(mut r) => {
                        r.elapsed = start.elapsed();
                        Outcome::Answered(r)
                    }
                    None => Outcome::Closed {
                        elapsed: start.elapsed(),
                        partial: buf,
                    },
                }
            }
        }
    }
}

/// A complete answer in `buf`, if there is one (`eof`: the connection has ended, so a
/// body without a length ends here). Interim 1xx answers are skipped.
fn parse(buf: &[u8], eof: bool) -> Option<Resp> {
    let mut buf = buf;
    loop {
        let end = buf.windows(4).position(|w| w == b"\r\n\r\n")?;
        let head = String::from_utf8_lossy(&buf[..end]).into_owned();
        let rest = &buf[end + 4..];
        let mut lines = head.split("\r\n");
        let status: u16 = lines.next()?.split_whitespace().nth(1)?.parse().ok()?;
        let headers: Vec<(String, String)> = lines
            .filter_map(|l| l.split_once(':'))
            .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
            .collect();
        if (100..200).contains(&status) {
            buf = rest;
            continue;
        }
        let get = |n: &str| {
            headers
                .iter()
                .find(|(k, _)| k.eq_ignore_ascii_case(n))
                .map(|(_, v)| v.clone())
        };
        let body = if let Some(n) = get("content-length").and_then(|v| v.parse::<usize>().ok()) {
            if rest.len() < n {
                return None;
            }
            rest[..n].to_vec()
        } else if get("transfer-encoding").is_some_and(|v| v.contains("chunked")) {
            dechunk(rest)?
        } else if eof {
            rest.to_vec()
        } else {
            return None;
        };
        return Some(Resp {
            status,
            headers,
            body,
            elapsed: Duration::ZERO,
        });
    }
}

fn dechunk(mut b: &[u8]) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    loop {
        let eol = b.windows(2).position(|w| w == b"\r\n")?;
        let size = std::str::from_utf8(&b[..eol]).ok()?;
        let size = usize::from_str_radix(size.split(';').next()?.trim(), 16).ok()?;
        b = &b[eol + 2..];
        if size == 0 {
            return Some(out);
        }
        if b.len() < size + 2 {
            return None;
        }
        out.extend_from_slice(&b[..size]);
        b = &b[size + 2..];
    }
}
