//! Exact, order-free sums of iteration films, so that a job's image does not depend on
//! how its iterations were grouped or in which order the groups were added: the same
//! bits whether one process ran them in sequence or a pool of workers ran ranges of
//! them (issue 22, DESIGN.md "Scale-out").
//!
//! f64 addition is not associative, so (a + b) + c and a + (b + c) may differ in the
//! last bit. Each iteration's film (its own sums from zero, deterministic by the random
//! number rule) is therefore rounded once to fixed point, 2^-[`FRAC_BITS`] units in an
//! i128, and from then on only integers are added: exact, associative and commutative.
//! The rounding is the same wherever the iteration ran, so every grouping agrees.
//!
//! Range: magnitudes below 2^-65 (2.7e-20) round to zero, and an iteration's pixel sum
//! must stay below [`LIMIT`] (2^62, 4.6e18); a value beyond it is dropped and counted
//! like a non-finite sample. Totals have 2^127 of room: 2^65 such iterations.

use super::accum::Film;
use super::image::pixel_count;
use thiserror::Error;

/// Fraction bits of the fixed-point sums.
pub const FRAC_BITS: i32 = 64;
/// Largest magnitude one iteration may add to one pixel channel.
pub const LIMIT: f64 = 4.611_686_018_427_388e18; // 2^62

/// Exact per-pixel sums of whole iterations, with the layers they carry, and a
/// filtered film's summed weights and splats (see [`Film`]): every part of a film
/// that the image is made from, so that the image is the same wherever its
/// iterations ran.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExactSums {
    width: u32,
    height: u32,
    sums: Vec<[i128; 3]>,
    /// Empty unless a filtered film was added (as the film's).
    weights: Vec<[i128; 1]>,
    splats: Vec<[i128; 3]>,
    dropped: u64,
    layers: Vec<ExactLayer>,
    /// Per pixel, the sum over iterations of the square of each iteration's own pixel
    /// value (`film::noise`), and how many iterations it holds: empty and 0 unless
    /// iterations were added one by one ([`ExactSums::add_iteration`]).
    moments: Vec<[i128; 3]>,
    moment_iterations: u64,
}

#[derive(Clone, Debug, PartialEq, Eq)]
struct ExactLayer {
    name: String,
    iterations: u64,
    sums: Vec<[i128; 3]>,
    splats: Vec<[i128; 3]>,
}

/// Why bytes are not an [`ExactSums`].
#[derive(Debug, Error, PartialEq, Eq)]
pub enum ExactError {
    #[error("exact sums: {0}")]
    Malformed(&'static str),
    #[error("exact sums of a {0}x{1} film cannot take a {2}x{3} one")]
    Size(u32, u32, u32, u32),
}

/// Version 1 held the sums and layers only (pixel-box films), version 2 adds the
/// weights and splats, version 3 the second moments; all are read.
const MAGIC: &[u8; 8] = b"CAUSTEX2";
const MAGIC_V1: &[u8; 8] = b"CAUSTEX1";
const MAGIC_V3: &[u8; 8] = b"CAUSTEX3";

impl ExactSums {
    pub fn new(width: u32, height: u32) -> Self {
        ExactSums {
            width,
            height,
            sums: vec![[0; 3]; pixel_count(width, height)],
            weights: Vec::new(),
            splats: Vec::new(),
            dropped: 0,
            layers: Vec::new(),
            moments: Vec::new(),
            moment_iterations: 0,
        }
    }

    /// Bytes the sums of a `width` x `height` film with `layers` layers hold, with
    /// the second moments.
    pub fn bytes_for(width: u32, height: u32, layers: usize) -> u64 {
        let per_image = pixel_count(width, height) * std::mem::size_of::<[i128; 3]>();
        (per_image * (2 + layers)) as u64
    }

    /// Bytes a filter wider than the pixel box adds to [`ExactSums::bytes_for`]
    /// (twice [`Film::filter_bytes_for`]: i128 for f64).
    pub fn filter_bytes_for(width: u32, height: u32, layers: usize, splats: bool) -> u64 {
        2 * Film::filter_bytes_for(width, height, layers, splats)
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Samples dropped by the films added so far, and values beyond [`LIMIT`].
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Adds a film holding whole iterations: its sums are rounded to fixed point and
    /// its layers added by name with their iteration counts.
    pub fn add_film(&mut self, film: &Film) -> Result<(), ExactError> {
        self.check_size(film.width(), film.height())?;
        self.dropped += film.dropped();
        self.dropped += add_rounded(&mut self.sums, film.sums());
        if let Some(w) = film.weights() {
            self.dropped += add_rounded(&mut self.weights, w.as_chunks::<1>().0);
        }
        if let Some(s) = film.splats() {
            self.dropped += add_rounded(&mut self.splats, s);
        }
        for l in film.layers() {
            let k = self.layer(&l.name);
            let mine = &mut self.layers[k];
            mine.iterations += l.iterations;
            self.dropped += add_rounded(&mut mine.sums, l.sums());
            if let Some(s) = l.splats() {
                self.dropped += add_rounded(&mut mine.splats, s);
            }
        }
        Ok(())
    }

    /// Adds one iteration's film, as [`ExactSums::add_film`] does, and the squares of
    /// its pixel values to the second moments that the noise estimate reads
    /// (`film::noise`). A square beyond [`LIMIT`] / 2 (a pixel value above 1.5e9 in
    /// one iteration) is held there, and the moments' sums saturate rather than wrap:
    /// such a pixel's estimate is then low, never NaN.
    pub fn add_iteration(&mut self, film: &Film) -> Result<(), ExactError> {
        self.add_film(film)?;
        super::noise::add_squares(&mut self.moments, film);
        self.moment_iterations += 1;
        Ok(())
    }

    /// The second moments and the iterations they hold, if any were added.
    pub(super) fn moments(&self) -> Option<(&[[i128; 3]], u64)> {
        (self.moment_iterations > 0).then_some((&self.moments, self.moment_iterations))
    }

    /// Adds another set of exact sums (e.g. a worker's range): exact, so the order of
    /// merges never shows in the result.
    pub fn merge(&mut self, other: &ExactSums) -> Result<(), ExactError> {
        self.check_size(other.width, other.height)?;
        self.dropped += other.dropped;
        add_exact(&mut self.sums, &other.sums);
        add_exact(&mut self.weights, &other.weights);
        add_exact(&mut self.splats, &other.splats);
        super::noise::add_moments(&mut self.moments, &other.moments);
        self.moment_iterations += other.moment_iterations;
        for l in &other.layers {
            let k = self.layer(&l.name);
            let mine = &mut self.layers[k];
            mine.iterations += l.iterations;
            add_exact(&mut mine.sums, &l.sums);
            add_exact(&mut mine.splats, &l.splats);
        }
        Ok(())
    }

    /// The sums as a film (rounded to f64 once, here), layers included.
    pub fn to_film(&self) -> Film {
        let mut film = Film::from_parts(self.width, self.height, to_f64(&self.sums), self.dropped);
        let weights = to_f64(&self.weights).into_iter().map(|[w]| w).collect();
        film.set_filtered(weights, to_f64(&self.splats));
        for l in &self.layers {
            film.push_layer(&l.name, l.iterations, to_f64(&l.sums), to_f64(&l.splats));
        }
        film
    }

    /// Little-endian bytes: magic, size, dropped, sums, then each layer's name,
    /// iteration count and sums (version 1). Sums with filter weights or splats
    /// anywhere are written as version 2, where the sums are followed by the weights
    /// and the splats and each layer's sums by its splats, each of these a flag byte
    /// (0 absent, 1 present) and then the values. Sums with second moments are
    /// version 3: version 2 followed by the moments' iteration count and the moments.
    pub fn encode(&self) -> Vec<u8> {
        let v3 = self.moment_iterations > 0;
        let v2 = v3 || self.is_filtered();
        let mut out = Vec::with_capacity(32 + 48 * self.sums.len() * (2 + self.layers.len()));
        out.extend_from_slice(match (v3, v2) {
            (true, _) => MAGIC_V3,
            (false, true) => MAGIC,
            (false, false) => MAGIC_V1,
        });
        out.extend_from_slice(&self.width.to_le_bytes());
        out.extend_from_slice(&self.height.to_le_bytes());
        out.extend_from_slice(&self.dropped.to_le_bytes());
        out.extend_from_slice(&(self.layers.len() as u32).to_le_bytes());
        put_sums(&mut out, &self.sums);
        if v2 {
            put_optional(&mut out, &self.weights);
            put_optional(&mut out, &self.splats);
        }
        for l in &self.layers {
            out.extend_from_slice(&(l.name.len() as u32).to_le_bytes());
            out.extend_from_slice(l.name.as_bytes());
            out.extend_from_slice(&l.iterations.to_le_bytes());
            put_sums(&mut out, &l.sums);
            if v2 {
                put_optional(&mut out, &l.splats);
            }
        }
        if v3 {
            out.extend_from_slice(&self.moment_iterations.to_le_bytes());
            put_optional(&mut out, &self.moments);
        }
        out
    }

    fn is_filtered(&self) -> bool {
        !self.weights.is_empty()
            || !self.splats.is_empty()
            || self.layers.iter().any(|l| !l.splats.is_empty())
    }

    /// Reads what [`ExactSums::encode`] wrote; any truncation or excess is an error.
    pub fn decode(bytes: &[u8]) -> Result<ExactSums, ExactError> {
        ExactSums::read(Reader::plain(bytes))
    }

    /// What [`ExactSums::decode`] reads, from a reader of plain or shuffled bytes.
    fn read(mut r: Reader) -> Result<ExactSums, ExactError> {
        let (v2, v3) = match &*r.take(8)? {
            m if m == MAGIC_V3 => (true, true),
            m if m == MAGIC => (true, false),
            m if m == MAGIC_V1 => (false, false),
            _ => return Err(ExactError::Malformed("not exact sums (magic)")),
        };
        let (width, height) = (r.u32()?, r.u32()?);
        let n = (width as usize)
            .checked_mul(height as usize)
            .filter(|&n| n as u64 <= super::MAX_PIXELS)
            .ok_or(ExactError::Malformed("film size out of range"))?;
        let dropped = r.u64()?;
        let count = r.u32()?;
        let sums = r.sums(n)?;
        let (weights, splats) = match v2 {
            true => (r.optional(n)?, r.optional(n)?),
            false => (Vec::new(), Vec::new()),
        };
        let mut layers = Vec::new();
        for _ in 0..count {
            let len = r.u32()? as usize;
            let name = std::str::from_utf8(&r.take(len)?)
                .map_err(|_| ExactError::Malformed("layer name is not UTF-8"))?
                .to_string();
            let iterations = r.u64()?;
            let sums = r.sums(n)?;
            let splats = if v2 { r.optional(n)? } else { Vec::new() };
            layers.push(ExactLayer {
                name,
                iterations,
                sums,
                splats,
            });
        }
        let (moment_iterations, moments) = match v3 {
            true => (r.u64()?, r.optional(n)?),
            false => (0, Vec::new()),
        };
        if (moment_iterations > 0) == moments.is_empty() {
            return Err(ExactError::Malformed("moments without iterations"));
        }
        if !r.at_end() {
            return Err(ExactError::Malformed("bytes after the last layer"));
        }
        Ok(ExactSums {
            width,
            height,
            sums,
            weights,
            splats,
            dropped,
            layers,
            moments,
            moment_iterations,
        })
    }

    fn check_size(&self, w: u32, h: u32) -> Result<(), ExactError> {
        if (w, h) != (self.width, self.height) {
            return Err(ExactError::Size(self.width, self.height, w, h));
        }
        Ok(())
    }

    /// Index of layer `name`, created empty on first use.
    fn layer(&mut self, name: &str) -> usize {
        if let Some(k) = self.layers.iter().position(|l| l.name == name) {
            return k;
        }
        self.layers.push(ExactLayer {
            name: name.to_string(),
            iterations: 0,
            sums: vec![[0; 3]; self.sums.len()],
            splats: Vec::new(),
        });
        self.layers.len() - 1
    }
}

/// One value in fixed point, round(x 2^64) with halves away from zero, or None beyond
/// [`LIMIT`] (or not finite). From the bits: x = m 2^(e - 1075) with a 53-bit integer
/// m, so x 2^64 is m shifted, with no float-to-i128 cast (a slow library call, which
/// cost 11% of a 1-spp path-traced iteration).
#[inline]
pub(super) fn to_fixed(x: f64) -> Option<i128> {
    // NaN fails this too.
    if x.is_nan() || x.abs() >= LIMIT {
        return None;
    }
    let bits = x.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32;
    if exp == 0 {
        // Zero or subnormal: far below one unit.
        return Some(0);
    }
    let m = ((bits & ((1 << 52) - 1)) | (1 << 52)) as i128;
    let shift = exp - 1075 + FRAC_BITS;
    let magnitude = match shift {
        s if s >= 0 => m << s,
        s if s > -64 => (m + (1 << (-s - 1))) >> -s,
        _ => 0,
    };
    Some(if bits >> 63 == 1 {
        -magnitude
    } else {
        magnitude
    })
}

/// Pixels per parallel task when rounding a film in.
const CHUNK: usize = 1 << 14;

/// Adds rounded values (an empty `sums` first becomes zeros of their size), returning
/// how many were out of range (those pixels' channels are left as they were).
fn add_rounded<const N: usize>(sums: &mut Vec<[i128; N]>, values: &[[f64; N]]) -> u64 {
    use rayon::prelude::*;
    if sums.is_empty() {
        *sums = vec![[0; N]; values.len()];
    }
    sums.par_chunks_mut(CHUNK)
        .zip(values.par_chunks(CHUNK))
        .map(|(sums, values)| {
            let mut out = 0;
            for (s, v) in sums.iter_mut().zip(values) {
                for c in 0..N {
                    match to_fixed(v[c]) {
                        Some(q) => s[c] += q,
                        None => out += 1,
                    }
                }
            }
            out
        })
        .sum()
}

/// Adds `other` (nothing if it is empty; an empty `sums` takes it as it is).
fn add_exact<const N: usize>(sums: &mut Vec<[i128; N]>, other: &[[i128; N]]) {
    if sums.is_empty() {
        sums.extend_from_slice(other);
        return;
    }
    for (s, o) in sums.iter_mut().zip(other) {
        for c in 0..N {
            s[c] += o[c];
        }
    }
}

fn to_f64<const N: usize>(sums: &[[i128; N]]) -> Vec<[f64; N]> {
    sums.iter().map(|s| s.map(from_fixed)).collect()
}

/// A fixed-point value back in f64 (rounded once).
#[inline]
pub(super) fn from_fixed(c: i128) -> f64 {
    c as f64 * 2f64.powi(-FRAC_BITS)
}

fn put_sums<const N: usize>(out: &mut Vec<u8>, sums: &[[i128; N]]) {
    for s in sums {
        for c in s {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
}

/// A flag byte, then the values if there are any.
fn put_optional<const N: usize>(out: &mut Vec<u8>, sums: &[[i128; N]]) {
    out.push(!sums.is_empty() as u8);
    put_sums(out, sums);
}

mod packed;
mod reader;
use reader::Reader;

#[cfg(test)]
mod tests;
