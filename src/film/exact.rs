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
/// weights and splats; both are read.
const MAGIC: &[u8; 8] = b"CAUSTEX2";
const MAGIC_V1: &[u8; 8] = b"CAUSTEX1";

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
        }
    }

    /// Bytes the sums of a `width` x `height` film with `layers` layers hold.
    pub fn bytes_for(width: u32, height: u32, layers: usize) -> u64 {
        let per_image = pixel_count(width, height) * std::mem::size_of::<[i128; 3]>();
        (per_image * (1 + layers)) as u64
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

    /// Adds another set of exact sums (e.g. a worker's range): exact, so the order of
    /// merges never shows in the result.
    pub fn merge(&mut self, other: &ExactSums) -> Result<(), ExactError> {
        self.check_size(other.width, other.height)?;
        self.dropped += other.dropped;
        add_exact(&mut self.sums, &other.sums);
        add_exact(&mut self.weights, &other.weights);
        add_exact(&mut self.splats, &other.splats);
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
    /// (0 absent, 1 present) and then the values.
    pub fn encode(&self) -> Vec<u8> {
        let v2 = self.is_filtered();
        let mut out = Vec::with_capacity(32 + 48 * self.sums.len() * (1 + self.layers.len()));
        out.extend_from_slice(if v2 { MAGIC } else { MAGIC_V1 });
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
        out
    }

    fn is_filtered(&self) -> bool {
        !self.weights.is_empty()
            || !self.splats.is_empty()
            || self.layers.iter().any(|l| !l.splats.is_empty())
    }

    /// Reads what [`ExactSums::encode`] wrote; any truncation or excess is an error.
    pub fn decode(bytes: &[u8]) -> Result<ExactSums, ExactError> {
        let mut r = Reader(bytes);
        let v2 = match r.take(8)? {
            m if m == MAGIC => true,
            m if m == MAGIC_V1 => false,
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
            let name = std::str::from_utf8(r.take(len)?)
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
        if !r.0.is_empty() {
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
fn to_fixed(x: f64) -> Option<i128> {
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
    let unit = 2f64.powi(-FRAC_BITS);
    sums.iter().map(|s| s.map(|c| c as f64 * unit)).collect()
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

struct Reader<'a>(&'a [u8]);

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], ExactError> {
        if self.0.len() < n {
            return Err(ExactError::Malformed("truncated"));
        }
        let (head, rest) = self.0.split_at(n);
        self.0 = rest;
        Ok(head)
    }

    fn u32(&mut self) -> Result<u32, ExactError> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap()))
    }

    fn u64(&mut self) -> Result<u64, ExactError> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }

    fn sums<const N: usize>(&mut self, n: usize) -> Result<Vec<[i128; N]>, ExactError> {
        let bytes = self.take(
            n.checked_mul(16 * N)
                .ok_or(ExactError::Malformed("too large"))?,
        )?;
        Ok(bytes
            .chunks_exact(16 * N)
            .map(|c| {
                std::array::from_fn(|k| {
                    i128::from_le_bytes(c[16 * k..16 * k + 16].try_into().unwrap())
                })
            })
            .collect())
    }

    /// What [`put_optional`] wrote.
    fn optional<const N: usize>(&mut self, n: usize) -> Result<Vec<[i128; N]>, ExactError> {
        match self.take(1)?[0] {
            0 => Ok(Vec::new()),
            1 => self.sums(n),
            _ => Err(ExactError::Malformed("bad flag")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3 as Rgb;

    /// A film of one "iteration": values spread over many binades, as radiance is.
    fn iteration(seed: u64, layer: bool) -> Film {
        let mut film = Film::new(5, 4);
        let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for i in 0..20 {
            let e = (next() * 40.0 - 20.0) as i32;
            let v = next() as f32 * 2f32.powi(e);
            film.add_index(i, Rgb::new(v, v * 0.3, next() as f32));
            if layer {
                let k = film.begin_layer("bpt");
                film.add_layer_index(k, i, Rgb::splat(v));
            }
        }
        film
    }

    #[test]
    fn any_grouping_and_order_gives_the_same_bits() {
        let films: Vec<Film> = (0..12).map(|i| iteration(i, i % 3 != 0)).collect();
        let mut sequential = ExactSums::new(5, 4);
        for f in &films {
            sequential.add_film(f).unwrap();
        }
        // Ranges [0, 5), [5, 7), [7, 12), merged last to first.
        let mut merged = ExactSums::new(5, 4);
        for range in [7..12, 5..7, 0..5] {
            let mut part = ExactSums::new(5, 4);
            for f in &films[range] {
                part.add_film(f).unwrap();
            }
            merged.merge(&part).unwrap();
        }
        assert_eq!(merged, sequential);
        // The plain f64 way does depend on the grouping here (why this module exists).
        let mut a = films[0].clone();
        for f in &films[1..] {
            a.merge(f);
        }
        let mut b = films[11].clone();
        for f in films[..11].iter().rev() {
            b.merge(f);
        }
        assert_ne!(a.sums(), b.sums());
    }

    #[test]
    fn the_film_it_gives_matches_the_f64_sums_to_rounding() {
        let films: Vec<Film> = (0..6).map(|i| iteration(i, true)).collect();
        let mut exact = ExactSums::new(5, 4);
        let mut plain = films[0].clone();
        exact.add_film(&films[0]).unwrap();
        for f in &films[1..] {
            exact.add_film(f).unwrap();
            plain.merge(f);
        }
        let film = exact.to_film();
        for (x, y) in film.sums().iter().zip(plain.sums()) {
            for c in 0..3 {
                let tol = 1e-15 * y[c].abs() + 6.0 * 2f64.powi(-65);
                assert!((x[c] - y[c]).abs() <= tol, "{} vs {}", x[c], y[c]);
            }
        }
        let (layers, plain_layers) = (film.layer_images(), plain.layer_images());
        assert_eq!(layers.len(), 1);
        assert_eq!(layers[0].0, plain_layers[0].0);
        let (m, p) = (layers[0].1.mean(), plain_layers[0].1.mean());
        assert!((m - p).abs().max_element() <= 1e-6 * p.abs().max_element());
        assert_eq!(film.dropped(), plain.dropped());
    }

    #[test]
    fn fixed_point_from_the_bits_is_the_rounded_product() {
        let reference = |x: f64| (x * 2f64.powi(FRAC_BITS)).round() as i128;
        let mut values = vec![0.0, -0.0, 1.0, -1.5, 2f64.powi(-65), 2f64.powi(-66), 3e-20];
        values.extend([LIMIT * 0.999_999, -LIMIT * 0.5, 1e-300, f64::MIN_POSITIVE]);
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..100_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            // Random bits over every binade from 2^-80 to 2^61, either sign.
            let e = (s % 142) as i32 - 80;
            let m = 1.0 + (s >> 12) as f64 / (1u64 << 52) as f64;
            values.push(if s & 1 == 1 { -m } else { m } * 2f64.powi(e));
        }
        // Exact halves of one unit round away from zero.
        values.extend([2.5 * 2f64.powi(-64), -2.5 * 2f64.powi(-64)]);
        for x in values {
            assert_eq!(to_fixed(x), Some(reference(x)), "{x:e}");
        }
        for x in [LIMIT, -LIMIT, f64::INFINITY, f64::NAN] {
            assert_eq!(to_fixed(x), None);
        }
    }

    #[test]
    fn values_beyond_the_limit_are_dropped_and_counted() {
        let mut film = Film::new(2, 1);
        film.add_index(0, Rgb::new(1e19, 1.0, 0.0));
        film.add_index(1, Rgb::new(3.0e-20, 2.0e-20, 0.0));
        let mut exact = ExactSums::new(2, 1);
        exact.add_film(&film).unwrap();
        assert_eq!(exact.dropped(), 1);
        let back = exact.to_film();
        assert_eq!(back.sums()[0], [0.0, 1.0, 0.0]);
        // 3e-20 is just over one unit of 2^-64 (5.4e-20) / 2: rounds to one unit;
        // 2e-20 to zero.
        assert_eq!(back.sums()[1], [2f64.powi(-64), 0.0, 0.0]);
    }

    #[test]
    fn bytes_round_trip_and_reject_damage() {
        let mut exact = ExactSums::new(5, 4);
        exact.add_film(&iteration(3, true)).unwrap();
        exact.add_film(&iteration(4, false)).unwrap();
        let bytes = exact.encode();
        assert_eq!(ExactSums::decode(&bytes).unwrap(), exact);
        for cut in [0, 7, 30, bytes.len() - 1] {
            assert!(ExactSums::decode(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        let mut long = bytes.clone();
        long.push(0);
        assert!(ExactSums::decode(&long).is_err());
        let mut huge = bytes.clone();
        huge[8..16].copy_from_slice(&[0xff; 8]);
        assert!(ExactSums::decode(&huge).is_err());
    }

    /// A filtered film of one "iteration": camera samples spread by a Gaussian (with
    /// summed weights), splats, and a layer with both.
    fn filtered_iteration(seed: u64) -> Film {
        use crate::film::{Filter, PixelFilter, TileBuffer};
        use glam::Vec2;
        let filter = PixelFilter::new(Filter::Gaussian { stddev: 0.5 });
        let mut film = iteration(seed, false);
        film.clear();
        let k = film.begin_layer("s2_t1");
        let mut s = seed | 1;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        for t in crate::film::tiles(5, 4, 2) {
            let mut buf = TileBuffer::for_filter(t, &filter, 5, 4);
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    let p = Vec2::new(x as f32 + next(), y as f32 + next());
                    let v = Rgb::new(next(), next() * 1e-3, next() * 1e3);
                    buf.add_sample(&filter, (x, y, p), v);
                    film.add_layer_sample(&filter, k, (x, y, p), v * 0.5);
                }
            }
            film.add_tile_buffer(&buf);
        }
        for _ in 0..30 {
            let p = Vec2::new(next() * 5.0, next() * 4.0);
            film.add_splat(&filter, p, Rgb::splat(next()), Some(k));
        }
        film
    }

    #[test]
    fn filter_weights_and_splats_sum_exactly_and_round_trip() {
        let films: Vec<Film> = (1..=9).map(filtered_iteration).collect();
        let mut sequential = ExactSums::new(5, 4);
        for f in &films {
            sequential.add_film(f).unwrap();
        }
        let mut merged = ExactSums::new(5, 4);
        for range in [6..9, 0..2, 2..6] {
            let mut part = ExactSums::new(5, 4);
            for f in &films[range] {
                part.add_film(f).unwrap();
            }
            merged.merge(&part).unwrap();
        }
        assert_eq!(merged, sequential);
        assert!(!sequential.weights.is_empty() && !sequential.splats.is_empty());
        assert!(!sequential.layers[0].splats.is_empty());
        // Its film develops as the f64 sums of the same films do, to rounding.
        let mut plain = films[0].clone();
        for f in &films[1..] {
            plain.merge(f);
        }
        let (a, b) = (
            sequential.to_film().to_image(1.0 / 9.0),
            plain.to_image(1.0 / 9.0),
        );
        assert!((a.mean() - b.mean()).abs().max_element() < 1e-6 * b.mean().max_element());
        let bytes = sequential.encode();
        assert_eq!(&bytes[..8], MAGIC);
        assert_eq!(ExactSums::decode(&bytes).unwrap(), sequential);
        for cut in [20, 40 + 48 * 20, bytes.len() - 1] {
            assert!(ExactSums::decode(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        // Magic, width, height, dropped and the layer count take 28 bytes.
        let mut flag = bytes.clone();
        assert_eq!(flag[28 + 48 * 20], 1, "the weights' flag");
        flag[28 + 48 * 20] = 2;
        assert!(ExactSums::decode(&flag).is_err(), "a weights flag of 2");
    }

    #[test]
    fn pixel_box_sums_are_written_as_version_1() {
        let mut exact = ExactSums::new(5, 4);
        exact.add_film(&iteration(3, true)).unwrap();
        assert_eq!(&exact.encode()[..8], MAGIC_V1);
    }

    #[test]
    fn films_of_another_size_are_refused() {
        let mut exact = ExactSums::new(5, 4);
        assert_eq!(
            exact.add_film(&Film::new(4, 5)),
            Err(ExactError::Size(5, 4, 4, 5))
        );
        assert!(exact.merge(&ExactSums::new(1, 1)).is_err());
    }
}
