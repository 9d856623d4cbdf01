//! Exact sums on the wire between a pool's workers and its coordinator (issue 40): a
//! range's sums are mostly zero high bytes (an i128 holds values of 2^-64 units, and a
//! pixel's sum rarely passes 2^20), so the encoding is split into byte planes (the
//! k-th byte of every 16-byte value together), which turns those bytes into long runs,
//! and then LZ4-compressed. Lossless: the unpacked bytes are the encoding itself, so
//! the image stays the same bit for bit.
//!
//! The header keeps the film size and the unpacked length outside the compressed
//! part, so a reader checks them against what it expects before it allocates.

use super::reader::{Reader, STRIDE};
use super::{ExactError, ExactSums};

const MAGIC: &[u8; 8] = b"CAUSTEXZ";
/// Magic, width, height, unpacked length.
const HEADER: usize = 8 + 4 + 4 + 8;

impl ExactSums {
    /// [`ExactSums::encode`], byte-plane shuffled and LZ4-compressed.
    pub fn encode_packed(&self) -> Vec<u8> {
        let raw = self.encode();
        let packed = lz4_flex::compress(&shuffle(&raw));
        let mut out = Vec::with_capacity(HEADER + packed.len());
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&self.width.to_le_bytes());
        out.extend_from_slice(&self.height.to_le_bytes());
        out.extend_from_slice(&(raw.len() as u64).to_le_bytes());
        out.extend_from_slice(&packed);
        out
    }

    /// Reads what [`ExactSums::encode_packed`] or [`ExactSums::encode`] wrote, for a
    /// film of `size` whose sums hold at most `images` images of sums per pixel
    /// (main, layers, moments, weights and splats counted as whole images): anything
    /// else is refused before it is unpacked.
    pub fn decode_expected(
        bytes: &[u8],
        size: (u32, u32),
        images: usize,
    ) -> Result<ExactSums, ExactError> {
        let sums = match bytes.strip_prefix(MAGIC.as_slice()) {
            Some(rest) => ExactSums::read(Reader::planes(&unpack(rest, size, images)?))?,
            None => ExactSums::decode(bytes)?,
        };
        if sums.size() != size {
            return Err(ExactError::Size(size.0, size.1, sums.width, sums.height));
        }
        Ok(sums)
    }
}

/// The byte planes after the magic, if the header agrees with `size` and `images`.
fn unpack(rest: &[u8], size: (u32, u32), images: usize) -> Result<Vec<u8>, ExactError> {
    let field = |at: usize, n: usize| -> Result<&[u8], ExactError> {
        rest.get(at..at + n)
            .ok_or(ExactError::Malformed("truncated packed header"))
    };
    let width = u32::from_le_bytes(field(0, 4)?.try_into().unwrap());
    let height = u32::from_le_bytes(field(4, 4)?.try_into().unwrap());
    let len = u64::from_le_bytes(field(8, 8)?.try_into().unwrap());
    if (width, height) != size {
        return Err(ExactError::Size(size.0, size.1, width, height));
    }
    // Each image is 48 bytes a pixel at most; names and flags take a little more.
    let pixels = width as u64 * height as u64;
    let most = (48 * pixels + 4096) * images.max(1) as u64 + 64;
    if len > most {
        return Err(ExactError::Malformed(
            "packed sums claim more bytes than the film holds",
        ));
    }
    let planes = lz4_flex::decompress(&rest[16..], len as usize)
        .map_err(|_| ExactError::Malformed("packed sums do not decompress"))?;
    if planes.len() as u64 != len {
        return Err(ExactError::Malformed("packed sums have the wrong length"));
    }
    Ok(planes)
}

/// Values per block of [`shuffle`]: the block's 16 planes and its
/// values both stay in the core's cache while bytes move between them.
const BLOCK: usize = 4096;

/// Byte k of every whole 16-byte value, for k = 0..16, then the bytes left over.
fn shuffle(raw: &[u8]) -> Vec<u8> {
    let n = raw.len() / STRIDE;
    let mut out = vec![0u8; raw.len()];
    for start in (0..n).step_by(BLOCK) {
        let values = &raw[start * STRIDE..(start + BLOCK).min(n) * STRIDE];
        for k in 0..STRIDE {
            let plane = &mut out[k * n + start..];
            for (b, value) in plane.iter_mut().zip(values.chunks_exact(STRIDE)) {
                *b = value[k];
            }
        }
    }
    out[n * STRIDE..].copy_from_slice(&raw[n * STRIDE..]);
    out
}

/// What [`shuffle`] undoes (decoding reads the planes in place: `reader`).
#[cfg(test)]
fn unshuffle(planes: &[u8]) -> Vec<u8> {
    let n = planes.len() / STRIDE;
    let mut out = vec![0u8; planes.len()];
    for start in (0..n).step_by(BLOCK) {
        let len = BLOCK.min(n - start);
        let values = &mut out[start * STRIDE..(start + len) * STRIDE];
        for k in 0..STRIDE {
            let plane = &planes[k * n + start..k * n + start + len];
            for (value, &b) in values.chunks_exact_mut(STRIDE).zip(plane) {
                value[k] = b;
            }
        }
    }
    out[n * STRIDE..].copy_from_slice(&planes[n * STRIDE..]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Film;

    fn sums(size: (u32, u32), iterations: u64) -> ExactSums {
        let mut sums = ExactSums::new(size.0, size.1);
        for i in 0..iterations {
            let mut film = Film::new(size.0, size.1);
            for (p, v) in film.sums_mut().iter_mut().enumerate() {
                let x = ((p as u64 * 2654435761 + i * 97) % 1000) as f64 / 250.0;
                *v = [x, 0.5 * x, if p % 7 == 0 { 0.0 } else { x * x }];
            }
            sums.add_iteration(&film).unwrap();
        }
        sums
    }

    #[test]
    fn packing_is_lossless_and_much_smaller() {
        let s = sums((64, 48), 5);
        let packed = s.encode_packed();
        assert_eq!(ExactSums::decode_expected(&packed, (64, 48), 2).unwrap(), s);
        // The plain encoding is read too.
        assert_eq!(
            ExactSums::decode_expected(&s.encode(), (64, 48), 2).unwrap(),
            s
        );
        let ratio = s.encode().len() as f64 / packed.len() as f64;
        assert!(
            ratio > 2.5,
            "packed {} of {} bytes",
            packed.len(),
            s.encode().len()
        );
        for odd in [0, 1, 15, 17, 33] {
            let raw: Vec<u8> = (0..odd as u8).collect();
            assert_eq!(unshuffle(&shuffle(&raw)), raw);
        }
    }

    #[test]
    fn blocked_shuffles_agree_with_the_plain_definition_across_blocks() {
        let len = (2 * BLOCK + 3) * STRIDE + 5;
        let raw: Vec<u8> = (0..len as u64)
            .map(|i| (i.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 56) as u8)
            .collect();
        let n = len / STRIDE;
        let mut plain = vec![0u8; len];
        for i in 0..n {
            for k in 0..STRIDE {
                plain[k * n + i] = raw[i * STRIDE + k];
            }
        }
        plain[n * STRIDE..].copy_from_slice(&raw[n * STRIDE..]);
        assert_eq!(shuffle(&raw), plain);
        assert_eq!(unshuffle(&plain), raw);
    }

    #[test]
    fn damaged_or_oversized_packs_are_refused_before_they_are_unpacked() {
        let s = sums((16, 8), 2);
        let packed = s.encode_packed();
        assert!(
            ExactSums::decode_expected(&packed, (8, 16), 2).is_err(),
            "wrong size"
        );
        // A claimed length beyond what two images of 16 x 8 pixels can take.
        let mut huge = packed.clone();
        huge[16..24].copy_from_slice(&(1u64 << 40).to_le_bytes());
        assert!(ExactSums::decode_expected(&huge, (16, 8), 2).is_err());
        for cut in [3, 20, packed.len() - 1] {
            assert!(
                ExactSums::decode_expected(&packed[..cut], (16, 8), 2).is_err(),
                "{cut}"
            );
        }
        let mut flipped = packed.clone();
        let mid = HEADER + (packed.len() - HEADER) / 2;
        flipped[mid] ^= 0xff;
        // A flipped byte either fails to decompress or decodes to other sums; never a panic.
        if let Ok(other) = ExactSums::decode_expected(&flipped, (16, 8), 2) {
            assert_ne!(other, s);
        }
    }
}
