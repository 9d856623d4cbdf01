//! `render --tev` and `watch --tev` against a stand-in for the tev viewer: a TCP
//! listener that decodes the packets (pbrt-v4's form of tev's protocol) and rebuilds
//! the image from them.

mod server_common;
use serde_json::json;
use server_common::*;
use std::io::Read;
use std::net::{TcpListener, TcpStream};
use std::process::{Command, Output};
use std::thread::JoinHandle;

#[derive(Debug)]
enum Packet {
    Create {
        name: String,
        width: i32,
        height: i32,
        channels: Vec<String>,
    },
    Update {
        name: String,
        channel: String,
        rect: [i32; 4],
        values: Vec<f32>,
    },
}

/// Reads little-endian fields from one packet's payload.
struct Fields<'a>(&'a [u8]);

impl Fields<'_> {
    fn u8(&mut self) -> u8 {
        let v = self.0[0];
        self.0 = &self.0[1..];
        v
    }
    fn i32(&mut self) -> i32 {
        let (v, rest) = self.0.split_at(4);
        self.0 = rest;
        i32::from_le_bytes(v.try_into().unwrap())
    }
    fn str(&mut self) -> String {
        let end = self.0.iter().position(|&b| b == 0).expect("nul-terminated");
        let s = String::from_utf8(self.0[..end].to_vec()).unwrap();
        self.0 = &self.0[end + 1..];
        s
    }
}

/// Packets until the sender closes the connection.
fn decode_stream(mut s: TcpStream) -> Vec<Packet> {
    let mut packets = Vec::new();
    loop {
        let mut len = [0u8; 4];
        if s.read_exact(&mut len).is_err() {
            return packets;
        }
        let len = u32::from_le_bytes(len) as usize;
        assert!(len >= 5, "packet length {len}");
        let mut body = vec![0u8; len - 4];
        s.read_exact(&mut body).expect("a whole packet");
        let mut f = Fields(&body[1..]);
        let packet = match body[0] {
            4 => {
                assert_eq!(f.u8(), 1, "CreateImage grabs focus");
                let name = f.str();
                let (width, height, n) = (f.i32(), f.i32(), f.i32());
                let channels = (0..n).map(|_| f.str()).collect();
                Packet::Create {
                    name,
                    width,
                    height,
                    channels,
                }
            }
            3 => {
                assert_eq!(f.u8(), 0, "UpdateImage leaves focus alone");
                let (name, channel) = (f.str(), f.str());
                let rect = [f.i32(), f.i32(), f.i32(), f.i32()];
                let values =
                    f.0.chunks_exact(4)
                        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
                        .collect::<Vec<_>>();
                assert_eq!(values.len(), (rect[2] * rect[3]) as usize, "{rect:?}");
                f.0 = &[];
                Packet::Update {
                    name,
                    channel,
                    rect,
                    values,
                }
            }
            t => panic!("unexpected packet type {t}"),
        };
        assert!(f.0.is_empty(), "trailing bytes in {packet:?}");
        packets.push(packet);
    }
}

/// A pretend tev: accepts one connection and decodes it until it closes.
struct FakeTev {
    addr: String,
    thread: JoinHandle<Vec<Packet>>,
}

impl FakeTev {
    fn listen() -> FakeTev {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = l.local_addr().unwrap().to_string();
        let thread = std::thread::spawn(move || decode_stream(l.accept().unwrap().0));
        FakeTev { addr, thread }
    }

    fn packets(self) -> Vec<Packet> {
        self.thread.join().unwrap()
    }
}

/// What the viewer shows after all packets, and how many full frames it received;
/// checks that the image is created first, once, with R, G, B, and that every update
/// names it and lies inside it.
fn replay(packets: &[Packet], want_name: &str, size: (u32, u32)) -> (caustic::film::Image, usize) {
    let Some(Packet::Create {
        name,
        width,
        height,
        channels,
    }) = packets.first()
    else {
        panic!("first packet is not CreateImage: {:?}", packets.first());
    };
    assert_eq!(name, want_name);
    assert_eq!((*width as u32, *height as u32), size);
    assert_eq!(channels, &["R", "G", "B"]);
    let (w, h) = (size.0 as usize, size.1 as usize);
    let mut planes = vec![vec![f32::NAN; w * h]; 3];
    // Per channel, how many times each pixel was written.
    let mut writes = vec![vec![0usize; w * h]; 3];
    for p in &packets[1..] {
        let Packet::Update {
            name,
            channel,
            rect,
            values,
        } = p
        else {
            panic!("a second CreateImage: {p:?}");
        };
        assert_eq!(name, want_name);
        let c = ["R", "G", "B"].iter().position(|n| n == channel).unwrap();
        let [x0, y0, tw, th] = rect.map(|v| v as usize);
        assert!(
            tw <= 128 && th <= 128 && x0 + tw <= w && y0 + th <= h,
            "{rect:?}"
        );
        for y in 0..th {
            for x in 0..tw {
                let i = (y0 + y) * w + x0 + x;
                planes[c][i] = values[y * tw + x];
                writes[c][i] += 1;
            }
        }
    }
    // Every frame covers every pixel of every channel exactly once.
    let frames = writes[0][0];
    assert!(frames >= 1, "no updates");
    for plane in &writes {
        assert!(plane.iter().all(|&n| n == frames), "tiles overlap or miss");
    }
    let pixels = (0..w * h)
        .map(|i| glam::Vec3::new(planes[0][i], planes[1][i], planes[2][i]))
        .collect();
    (
        caustic::film::Image::from_pixels(size.0, size.1, pixels),
        frames,
    )
}

fn assert_bit_identical(a: &caustic::film::Image, b: &caustic::film::Image) {
    assert_eq!(a.size(), b.size());
    for (i, (p, q)) in a.pixels().iter().zip(b.pixels()).enumerate() {
        for c in 0..3 {
            assert_eq!(p[c].to_bits(), q[c].to_bits(), "pixel {i} channel {c}");
        }
    }
}

fn caustic() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_caustic"));
    c.env_remove("CAUSTIC_SERVER").env_remove("CAUSTIC_TOKEN");
    c
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A 200 × 150 scene file (tiles of 128 leave partial ones on both edges).
fn scene_file(dir: &std::path::Path) -> std::path::PathBuf {
    let mut scene = tiny_scene(0);
    scene["film"] = json!({"width": 200, "height": 150});
    let path = dir.join("tiny.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    path
}

/// A port nothing listens on (bound, then released).
fn closed_port() -> String {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    l.local_addr().unwrap().to_string()
}

#[test]
fn render_streams_the_image_and_ends_with_the_written_exr() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_file(dir.path());
    let exr = dir.path().join("out.exr");
    let tev = FakeTev::listen();
    let out = caustic()
        .arg("render")
        .arg(&scene)
        .args(["--spp", "8", "--tev", &tev.addr, "-o"])
        .arg(&exr)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out));
    let packets = tev.packets();
    let (shown, frames) = replay(&packets, "tiny.json", (200, 150));
    // The first iteration at once, then the final image.
    assert!(frames >= 2, "{frames} frames");
    assert_bit_identical(&shown, &caustic::film::read_exr(&exr).unwrap());
}

#[test]
fn watch_shows_the_jobs_final_image() {
    let s = TestServer::start(None);
    let (_, info) = s.post_bytes("/v1/scenes", tiny_scene(40).to_string().as_bytes());
    let (code, job) = s.post_json(
        "/v1/jobs",
        &json!({"scene": info["id"], "halt": {"spp": 32},
                "snapshot_every": {"iterations": 4}}),
    );
    assert_eq!(code, 201, "{job}");
    let id = job["id"].as_str().unwrap();
    let tev = FakeTev::listen();
    let out = caustic()
        .args(["watch", id, "--tev", &tev.addr, "--server", &s.url])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out));
    let packets = tev.packets();
    let (shown, _) = replay(&packets, id, (40, 40));
    let (code, bytes) = s.get(&format!("/v1/jobs/{id}/image.exr"));
    assert_eq!(code, 200);
    assert_bit_identical(&shown, &caustic::film::decode_exr(&bytes).unwrap());
}

/// An address where tev is not listening is an error before any work, naming it.
#[test]
fn unreachable_tev_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_file(dir.path());
    let addr = closed_port();
    let out = caustic()
        .arg("render")
        .arg(&scene)
        .args(["--spp", "1", "--tev", &addr, "-o"])
        .arg(dir.path().join("out.exr"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let t = text(&out);
    assert!(
        t.contains(&format!("cannot connect to tev at {addr}")),
        "{t}"
    );
    assert!(!dir.path().join("out.exr").exists());

    let out = caustic()
        .args(["watch", "any", "--tev", &addr])
        .args(["--server", "http://127.0.0.1:9"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains(&format!("cannot connect to tev at {addr}")));

    let out = caustic()
        .arg("render")
        .arg(&scene)
        .args(["--spp", "1", "--tev", "no-port"])
        .output()
        .unwrap();
    assert!(
        text(&out).contains("--tev no-port: expected host:port"),
        "{}",
        text(&out)
    );
}

/// A viewer that goes away costs one warning; the render finishes and writes its file.
#[test]
fn tev_going_away_never_fails_the_render() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_file(dir.path());
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = l.local_addr().unwrap().to_string();
    let closer = std::thread::spawn(move || drop(l.accept().unwrap()));
    let exr = dir.path().join("out.exr");
    let out = caustic()
        .arg("render")
        .arg(&scene)
        .args(["--time", "1.2", "--tev", &addr, "-o"])
        .arg(&exr)
        .output()
        .unwrap();
    closer.join().unwrap();
    let t = text(&out);
    assert!(out.status.success(), "{t}");
    assert!(exr.exists());
    assert_eq!(t.matches("no further images are sent").count(), 1, "{t}");
}
