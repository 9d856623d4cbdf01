//! Reading [`super::ExactSums::encode`]'s bytes, either as written or in the byte
//! planes of `packed` (the k-th byte of every 16-byte value together). Planes are read
//! in place: a value's bytes are gathered from the 16 planes straight into the sums,
//! with no unshuffled copy of the whole encoding in between (at 1080p that copy, 199
//! MB of fresh memory, cost more than the rest of decoding).

use super::ExactError;
use std::borrow::Cow;

/// The planes' stride: one i128.
pub(super) const STRIDE: usize = 16;

pub(super) struct Reader<'a> {
    bytes: &'a [u8],
    /// Whether `bytes` are byte planes of the encoding rather than the encoding.
    planes: bool,
    /// Offset in the encoding of the next byte to read.
    at: usize,
}

impl<'a> Reader<'a> {
    pub fn plain(bytes: &'a [u8]) -> Self {
        Reader {
            bytes,
            planes: false,
            at: 0,
        }
    }

    /// A reader of the encoding whose byte planes (`packed::shuffle`) are `planes`.
    pub fn planes(planes: &'a [u8]) -> Self {
        Reader {
            bytes: planes,
            planes: true,
            at: 0,
        }
    }

    pub fn at_end(&self) -> bool {
        self.at == self.bytes.len()
    }

    /// The next `n` bytes of the encoding.
    pub fn take(&mut self, n: usize) -> Result<Cow<'a, [u8]>, ExactError> {
        let start = self.advance(n)?;
        if !self.planes {
            return Ok(Cow::Borrowed(&self.bytes[start..start + n]));
        }
        Ok(Cow::Owned(
            (start..start + n).map(|j| self.byte(j)).collect(),
        ))
    }

    pub fn u32(&mut self) -> Result<u32, ExactError> {
        Ok(u32::from_le_bytes(
            self.take(4)?.as_ref().try_into().unwrap(),
        ))
    }

    pub fn u64(&mut self) -> Result<u64, ExactError> {
        Ok(u64::from_le_bytes(
            self.take(8)?.as_ref().try_into().unwrap(),
        ))
    }

    /// `n` pixels of `N` little-endian i128 each.
    pub fn sums<const N: usize>(&mut self, n: usize) -> Result<Vec<[i128; N]>, ExactError> {
        let len = n
            .checked_mul(STRIDE * N)
            .ok_or(ExactError::Malformed("too large"))?;
        let start = self.advance(len)?;
        if !self.planes {
            let bytes = &self.bytes[start..start + len];
            return Ok(bytes
                .chunks_exact(STRIDE * N)
                .map(|c| {
                    std::array::from_fn(|k| {
                        i128::from_le_bytes(c[STRIDE * k..STRIDE * (k + 1)].try_into().unwrap())
                    })
                })
                .collect());
        }
        let value = self.gather(start, n * N);
        Ok((0..n)
            .map(|p| std::array::from_fn(|c| value(p * N + c)))
            .collect())
    }

    /// What `put_optional` wrote.
    pub fn optional<const N: usize>(&mut self, n: usize) -> Result<Vec<[i128; N]>, ExactError> {
        match self.take(1)?[0] {
            0 => Ok(Vec::new()),
            1 => self.sums(n),
            _ => Err(ExactError::Malformed("bad flag")),
        }
    }

    /// Moves past `n` bytes, returning where they start.
    fn advance(&mut self, n: usize) -> Result<usize, ExactError> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or(ExactError::Malformed("truncated"))?;
        Ok(std::mem::replace(&mut self.at, end))
    }

    /// Byte `j` of the encoding, from the planes.
    fn byte(&self, j: usize) -> u8 {
        let n = self.bytes.len() / STRIDE;
        if j < n * STRIDE {
            self.bytes[(j % STRIDE) * n + j / STRIDE]
        } else {
            self.bytes[j]
        }
    }

    /// Value `v` of the `count` i128 values from byte `start` of the encoding, read
    /// from the planes.
    fn gather(&self, start: usize, count: usize) -> impl Fn(usize) -> i128 + '_ {
        // Value v starts at byte start + 16 v; its byte k lies in plane (r + k) % 16
        // at index q + v, or q + v + 1 once r + k passes 16 (q, r: start / 16, % 16).
        let n = self.bytes.len() / STRIDE;
        let (q, r) = (start / STRIDE, start % STRIDE);
        let offset: [usize; STRIDE] = std::array::from_fn(|k| {
            let (plane, carry) = ((r + k) % STRIDE, (r + k) / STRIDE);
            plane * n + q + carry
        });
        // The last values may reach the bytes after the planes: those go byte by byte.
        let fast = count.min((n - q).saturating_sub(1));
        move |v| {
            if v < fast {
                i128::from_le_bytes(std::array::from_fn(|k| self.bytes[offset[k] + v]))
            } else {
                let at = start + v * STRIDE;
                i128::from_le_bytes(std::array::from_fn(|k| self.byte(at + k)))
            }
        }
    }
}
