//! The texels of a bitmap texture, stored as compactly as their file allows.
//!
//! An 8-bit image keeps its bytes and a 256-entry table that makes them linear (the
//! sRGB decoding, or /255 for `raw` data): looking a byte up gives exactly the value a
//! float image converted at load would hold, at a quarter of the memory. Everything
//! else (16-bit PNG, EXR, Radiance HDR) is stored as linear f32.

use crate::math::Rgb;
use std::sync::OnceLock;

#[derive(Debug)]
enum Samples {
    Bytes {
        data: Vec<u8>,
        linear: &'static [f32; 256],
    },
    Floats(Vec<f32>),
}

/// A grey (one channel) or RGB image, row 0 at the top.
#[derive(Debug)]
pub struct Texels {
    width: u32,
    height: u32,
    channels: usize,
    samples: Samples,
}

impl Texels {
    /// 8-bit samples, `channels` (1 or 3) per texel; `srgb` says they are sRGB-encoded.
    pub fn from_bytes(width: u32, height: u32, channels: usize, data: Vec<u8>, srgb: bool) -> Self {
        debug_assert_eq!(data.len(), width as usize * height as usize * channels);
        let linear = if srgb { srgb_table() } else { unit_table() };
        Texels {
            width,
            height,
            channels,
            samples: Samples::Bytes { data, linear },
        }
    }

    /// Linear float samples, `channels` (1 or 3) per texel.
    pub fn from_floats(width: u32, height: u32, channels: usize, data: Vec<f32>) -> Self {
        debug_assert_eq!(data.len(), width as usize * height as usize * channels);
        Texels {
            width,
            height,
            channels,
            samples: Samples::Floats(data),
        }
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// True for one-channel (grey) images.
    pub fn is_grey(&self) -> bool {
        self.channels == 1
    }

    /// Bytes held by the samples.
    pub fn bytes(&self) -> usize {
        match &self.samples {
            Samples::Bytes { data, .. } => data.len(),
            Samples::Floats(data) => data.len() * 4,
        }
    }

    /// Whether every sample is finite and not negative (8-bit samples always are),
    /// as radiance must be.
    pub fn is_valid_radiance(&self) -> bool {
        match &self.samples {
            Samples::Bytes { .. } => true,
            Samples::Floats(data) => data.iter().all(|x| x.is_finite() && *x >= 0.0),
        }
    }

    /// The largest sample, over every channel.
    pub fn max_value(&self) -> f32 {
        match &self.samples {
            Samples::Bytes { data, linear } => {
                data.iter().map(|&b| linear[b as usize]).fold(0.0, f32::max)
            }
            Samples::Floats(data) => data.iter().copied().fold(0.0, f32::max),
        }
    }

    /// The texel at column `x`, row `y` (both in range), grey replicated to RGB.
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> Rgb {
        let i = (y as usize * self.width as usize + x as usize) * self.channels;
        let c = |k: usize| match &self.samples {
            Samples::Bytes { data, linear } => linear[data[i + k] as usize],
            Samples::Floats(data) => data[i + k],
        };
        if self.channels == 1 {
            Rgb::splat(c(0))
        } else {
            Rgb::new(c(0), c(1), c(2))
        }
    }
}

/// sRGB byte -> linear value.
fn srgb_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| crate::film::srgb_eotf(i as f32 / 255.0)))
}

/// Byte -> byte / 255, for raw data (normal maps, masks marked `raw`).
fn unit_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| i as f32 / 255.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_decode_as_srgb_or_raw_and_grey_is_replicated() {
        let srgb = Texels::from_bytes(2, 1, 1, vec![0, 255], true);
        assert_eq!(srgb.get(0, 0), Rgb::ZERO);
        assert_eq!(srgb.get(1, 0), Rgb::ONE);
        let mid = Texels::from_bytes(1, 1, 3, vec![188, 128, 0], true);
        // sRGB 188/255 is linear 0.5029 (IEC 61966-2-1).
        assert!(
            (mid.get(0, 0).x - 0.5029).abs() < 1e-3,
            "{:?}",
            mid.get(0, 0)
        );
        let raw = Texels::from_bytes(1, 1, 3, vec![188, 128, 0], false);
        assert_eq!(raw.get(0, 0), Rgb::new(188.0 / 255.0, 128.0 / 255.0, 0.0));
        assert_eq!(raw.bytes(), 3);
        let floats = Texels::from_floats(1, 2, 3, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(floats.get(0, 1), Rgb::new(4.0, 5.0, 6.0));
        assert_eq!(floats.bytes(), 24);
    }
}
