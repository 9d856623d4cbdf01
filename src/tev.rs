//! Streaming a progressive image to the [tev](https://github.com/Tom94/tev) HDR viewer
//! over its TCP protocol, with the packets pbrt-v4 sends (`src/pbrt/util/display.cpp`).
//!
//! Every packet is a little-endian `u32` total length (these 4 bytes included), a `u8`
//! type and a payload; strings are nul-terminated:
//!
//! | type | packet | payload |
//! |---|---|---|
//! | 4 | CreateImage | `u8` grab focus, image name, `i32` width, height, channel count, the channel names |
//! | 3 | UpdateImage | `u8` grab focus, image name, channel name, `i32` x, y, w, h, then w·h `f32` in rows |
//!
//! The image is created with channels R, G, B when the first frame arrives (again if a
//! frame has another size), then each frame goes as 128 × 128 tiles, one packet per
//! channel and tile. A background thread sends only the newest frame ([`TevClient::show`]
//! replaces a frame not yet sent), so a slow viewer never stalls a render; when tev goes
//! away the thread logs one warning and drops later frames.

use crate::film::Image;
use std::io::Write;
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// Tile edge in pixels, as pbrt-v4 sends them.
pub const TILE: u32 = 128;
/// Packet types (tev's `IpcPacket::EType`).
pub const UPDATE_IMAGE: u8 = 3;
pub const CREATE_IMAGE: u8 = 4;
/// The channels sent, in this order.
pub const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// How long connecting, and any one write, may take before tev counts as gone.
const TIMEOUT: Duration = Duration::from_secs(5);

#[derive(Debug, thiserror::Error)]
pub enum TevError {
    #[error("--tev {0}: expected host:port")]
    Address(String),
    #[error("cannot connect to tev at {addr}: {message} (start it with `tev --hostname {addr}`)")]
    Connect { addr: String, message: String },
}

/// The newest frame not yet sent, and whether the owner is done.
#[derive(Default)]
struct Slot {
    frame: Option<Image>,
    closing: bool,
}

type Shared = Arc<(Mutex<Slot>, Condvar)>;

/// A connection to tev showing one image, fed by [`TevClient::show`].
pub struct TevClient {
    shared: Shared,
    thread: Option<JoinHandle<()>>,
}

impl TevClient {
    /// Connects to tev at `addr` (`host:port`); frames will be shown as the image `name`.
    pub fn connect(addr: &str, name: &str) -> Result<TevClient, TevError> {
        let stream = open(addr)?;
        let _ = stream.set_nodelay(true);
        let _ = stream.set_write_timeout(Some(TIMEOUT));
        let shared: Shared = Arc::default();
        let (s, name, addr) = (shared.clone(), name.to_string(), addr.to_string());
        let thread = std::thread::Builder::new()
            .name("tev".into())
            .spawn(move || send_loop(stream, &s, &name, &addr))
            .expect("spawning the tev thread");
        Ok(TevClient {
            shared,
            thread: Some(thread),
        })
    }

    /// Queues `image` for display, replacing a frame that has not been sent yet.
    pub fn show(&self, image: Image) {
        let (lock, wake) = &*self.shared;
        lock.lock().expect("tev slot").frame = Some(image);
        wake.notify_one();
    }

    /// Sends the frame still queued (waiting at most the write timeout per packet if
    /// tev is slow) and closes the connection.
    pub fn finish(mut self) {
        self.close();
    }

    fn close(&mut self) {
        let (lock, wake) = &*self.shared;
        lock.lock().expect("tev slot").closing = true;
        wake.notify_one();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for TevClient {
    fn drop(&mut self) {
        self.close();
    }
}

fn open(addr: &str) -> Result<TcpStream, TevError> {
    let connect_error = |message: String| TevError::Connect {
        addr: addr.to_string(),
        message,
    };
    match addr.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && port.parse::<u16>().is_ok() => {}
        _ => return Err(TevError::Address(addr.to_string())),
    }
    let addrs = addr
        .to_socket_addrs()
        .map_err(|e| connect_error(e.to_string()))?;
    let mut last = "no address".to_string();
    for a in addrs {
        match TcpStream::connect_timeout(&a, TIMEOUT) {
            Ok(s) => return Ok(s),
            Err(e) => last = e.to_string(),
        }
    }
    Err(connect_error(last))
}

/// Sends the newest frame whenever there is one, until the owner closes; after a
/// failed write, warns once and only drains the slot.
fn send_loop(mut stream: TcpStream, shared: &Shared, name: &str, addr: &str) {
    let (lock, wake) = &**shared;
    let mut created: Option<(u32, u32)> = None;
    let mut alive = true;
    loop {
        let (frame, closing) = {
            let mut slot = lock.lock().expect("tev slot");
            while slot.frame.is_none() && !slot.closing {
                slot = wake.wait(slot).expect("tev slot");
            }
            (slot.frame.take(), slot.closing)
        };
        if let (Some(image), true) = (frame, alive) {
            if let Err(e) = send_frame(&mut stream, name, &image, &mut created) {
                tracing::warn!("tev at {addr}: {e}; no further images are sent");
                alive = false;
            }
        }
        if closing {
            return;
        }
    }
}

fn send_frame(
    stream: &mut TcpStream,
    name: &str,
    image: &Image,
    created: &mut Option<(u32, u32)>,
) -> std::io::Result<()> {
    let size = (image.width(), image.height());
    if *created != Some(size) {
        stream.write_all(&create_image(name, size.0, size.1))?;
        *created = Some(size);
    }
    for (x, y, w, h) in tiles(size.0, size.1) {
        for c in 0..CHANNELS.len() {
            stream.write_all(&update_image(name, image, c, (x, y, w, h)))?;
        }
    }
    stream.flush()
}

/// The tiles of a `width` × `height` image as `(x, y, w, h)`, rows of tiles top down.
pub fn tiles(width: u32, height: u32) -> impl Iterator<Item = (u32, u32, u32, u32)> {
    (0..height.div_ceil(TILE)).flat_map(move |ty| {
        (0..width.div_ceil(TILE)).map(move |tx| {
            let (x, y) = (tx * TILE, ty * TILE);
            (x, y, TILE.min(width - x), TILE.min(height - y))
        })
    })
}

/// A packet under construction: the length is patched in by [`Packet::finish`].
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8, capacity: usize) -> Packet {
        let mut b = Vec::with_capacity(capacity + 16);
        b.extend_from_slice(&[0; 4]);
        b.push(kind);
        Packet(b)
    }
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn i32(&mut self, v: u32) {
        self.0.extend_from_slice(&(v as i32).to_le_bytes());
    }
    fn str(&mut self, s: &str) {
        // A nul inside a name would end it early on tev's side.
        self.0.extend(s.bytes().filter(|&b| b != 0));
        self.0.push(0);
    }
    fn finish(mut self) -> Vec<u8> {
        let n = self.0.len() as u32;
        self.0[..4].copy_from_slice(&n.to_le_bytes());
        self.0
    }
}

/// CreateImage: `name` with `width` × `height` pixels and channels R, G, B; tev shows it.
pub fn create_image(name: &str, width: u32, height: u32) -> Vec<u8> {
    let mut p = Packet::new(CREATE_IMAGE, name.len() + 32);
    p.u8(1);
    p.str(name);
    p.i32(width);
    p.i32(height);
    p.i32(CHANNELS.len() as u32);
    for c in CHANNELS {
        p.str(c);
    }
    p.finish()
}

/// UpdateImage: channel `channel` (0 = R) of the tile `(x, y, w, h)` of `image`.
pub fn update_image(
    name: &str,
    image: &Image,
    channel: usize,
    tile: (u32, u32, u32, u32),
) -> Vec<u8> {
    let (x0, y0, w, h) = tile;
    let mut p = Packet::new(UPDATE_IMAGE, name.len() + 32 + 4 * (w * h) as usize);
    p.u8(0);
    p.str(name);
    p.str(CHANNELS[channel]);
    for v in [x0, y0, w, h] {
        p.i32(v);
    }
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            p.0.extend_from_slice(&image.get(x, y)[channel].to_le_bytes());
        }
    }
    p.finish()
}
