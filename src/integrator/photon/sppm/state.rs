//! sppm's per-pixel statistics (photon count N, radius R, flux tau and the camera
//! pass's direct light) and their checkpoint form: they carry over from iteration to
//! iteration, so a resumed job must restore them bit for bit.

use super::Variant;

/// One pixel's progressive statistics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PixelStat {
    /// Accumulated photon count N.
    pub(super) n: f64,
    /// Gather radius R.
    pub(super) r: f64,
    /// Accumulated flux tau (camera throughput included).
    pub(super) tau: [f64; 3],
    /// Sum over passes of the camera-pass radiance (emission and NEE).
    pub(super) direct: [f64; 3],
}

#[derive(Clone, Debug, PartialEq)]
pub(super) struct State {
    pub(super) seed: u64,
    /// The iteration the state expects next.
    pub(super) next: u64,
    /// Passes accumulated since the statistics were initialised.
    pub(super) passes: u64,
    /// Photon paths emitted over those passes.
    pub(super) emitted: u64,
    pub(super) pixels: Vec<PixelStat>,
}

#[derive(Debug, thiserror::Error)]
pub enum StateError {
    #[error("not a photon-mapping state (bad magic)")]
    Magic,
    #[error("state was saved by {saved:?}, not {this:?}")]
    Variant { saved: Variant, this: Variant },
    #[error("state is truncated or has trailing bytes ({0} bytes)")]
    Length(usize),
    #[error("state holds a non-finite or negative statistic at pixel {0}")]
    Value(usize),
}

const STATE_MAGIC: &[u8; 8] = b"SPPMST01";
pub(super) const STATE_HEAD: usize = 8 + 1 + 4 * 8 + 8;
pub(super) const PIXEL_BYTES: usize = 8 * 8;

impl State {
    pub(super) fn new(seed: u64, iteration: u64, pixels: usize, r0: f32) -> State {
        State {
            seed,
            next: iteration,
            passes: 0,
            emitted: 0,
            pixels: vec![
                PixelStat {
                    n: 0.0,
                    r: r0 as f64,
                    tau: [0.0; 3],
                    direct: [0.0; 3],
                };
                pixels
            ],
        }
    }

    /// Little-endian: magic, variant, seed, next, passes, emitted, pixel count, then
    /// per pixel N, R, tau (3), direct (3) as f64.
    pub(super) fn encode(&self, variant: Variant) -> Vec<u8> {
        let mut out = Vec::with_capacity(STATE_HEAD + self.pixels.len() * PIXEL_BYTES);
        out.extend_from_slice(STATE_MAGIC);
        out.push(variant as u8);
        for v in [
            self.seed,
            self.next,
            self.passes,
            self.emitted,
            self.pixels.len() as u64,
        ] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for p in &self.pixels {
            for v in [p.n, p.r].iter().chain(p.tau.iter()).chain(p.direct.iter()) {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out
    }

    pub(super) fn decode(bytes: &[u8], variant: Variant) -> Result<State, StateError> {
        if bytes.len() < STATE_HEAD {
            return Err(StateError::Length(bytes.len()));
        }
        if &bytes[..8] != STATE_MAGIC {
            return Err(StateError::Magic);
        }
        let saved = match bytes[8] {
            0 => Variant::Ppm,
            1 => Variant::Sppm,
            _ => return Err(StateError::Magic),
        };
        if saved != variant {
            return Err(StateError::Variant {
                saved,
                this: variant,
            });
        }
        let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().unwrap());
        let count = u64_at(9 + 32) as usize;
        if count
            .checked_mul(PIXEL_BYTES)
            .and_then(|b| b.checked_add(STATE_HEAD))
            != Some(bytes.len())
        {
            return Err(StateError::Length(bytes.len()));
        }
        let mut pixels = Vec::with_capacity(count);
        for (i, c) in bytes[STATE_HEAD..].chunks_exact(PIXEL_BYTES).enumerate() {
            let f = |k: usize| f64::from_le_bytes(c[k * 8..k * 8 + 8].try_into().unwrap());
            let p = PixelStat {
                n: f(0),
                r: f(1),
                tau: [f(2), f(3), f(4)],
                direct: [f(5), f(6), f(7)],
            };
            let ok = (0..8).all(|k| f(k).is_finite() && f(k) >= 0.0) && p.r > 0.0;
            if !ok {
                return Err(StateError::Value(i));
            }
            pixels.push(p);
        }
        Ok(State {
            seed: u64_at(9),
            next: u64_at(17),
            passes: u64_at(25),
            emitted: u64_at(33),
            pixels,
        })
    }
}
