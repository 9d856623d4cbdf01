//! Where every random sequence of an iteration comes from. A sequence is named by its
//! stream, the job's seed, the iteration and an index (a pixel, or a light path), so
//! an iteration is a pure function of (scene, settings, seed, iteration) and runs the
//! same on any number of threads; streams keep the sequences of different passes of
//! one iteration apart. The constants are fixed: changing one changes every image of
//! the algorithms that use it.

use crate::math::rng::mix64;
use crate::math::Rng;

/// Light paths per parallel task of a light pass: fixed, so the split never depends on
/// the number of threads.
pub const PATHS_PER_TASK: usize = 1024;

/// The random streams.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stream {
    /// Camera paths of the tile loop (one per pixel and iteration).
    Pixels,
    /// Light subpaths of the bidirectional core.
    LightSubpaths,
    /// sppm's camera paths to their visible points.
    SppmCamera,
    /// sppm's next-event estimation at visible points.
    SppmDirect,
    /// sppm's photon paths.
    SppmPhotons,
    /// sppm's transmittance estimates and beam radiance estimates in media.
    SppmMedium,
    /// vpm's photon paths.
    VpmPhotons,
    /// The many-light methods' per-light draws (truncation of unbounded ray lights,
    /// beam offsets), one sequence per virtual light.
    VirtualLights,
    /// Photon beams' cuts, one sequence per beam.
    PhotonBeams,
}

impl Stream {
    /// The generator seed of this stream for a job seed.
    #[inline]
    pub fn seed(self, seed: u64) -> u64 {
        match self {
            Stream::Pixels => seed,
            Stream::LightSubpaths => seed ^ 0x5DEE_CE66_D1CE_4E5B,
            Stream::SppmCamera => mix64(seed ^ 0x5350_504D_4341_4D31),
            Stream::SppmDirect => mix64(seed ^ 0x5350_504D_4E45_4531),
            Stream::SppmPhotons => mix64(seed ^ 0x5350_504D_5048_4F31),
            Stream::SppmMedium => mix64(seed ^ 0x5350_504D_4D45_4431),
            Stream::VpmPhotons => mix64(seed ^ 0x5650_4D50_484F_5431),
            Stream::VirtualLights => mix64(seed ^ 0x5649_5254_4C49_4731),
            Stream::PhotonBeams => mix64(seed ^ 0x5048_4F54_4245_4131),
        }
    }

    /// The sequence of `index` (pixel or path) in `iteration`.
    #[inline]
    pub fn rng(self, seed: u64, iteration: u64, index: u64) -> Rng {
        Rng::new(self.seed(seed), iteration, index)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_distinct_for_one_seed() {
        let all = [
            Stream::Pixels,
            Stream::LightSubpaths,
            Stream::SppmCamera,
            Stream::SppmDirect,
            Stream::SppmPhotons,
            Stream::SppmMedium,
            Stream::VpmPhotons,
            Stream::VirtualLights,
            Stream::PhotonBeams,
        ];
        for seed in [0u64, 1, 11, u64::MAX] {
            let mut seeds: Vec<u64> = all.iter().map(|s| s.seed(seed)).collect();
            seeds.sort_unstable();
            seeds.dedup();
            assert_eq!(seeds.len(), all.len(), "seed {seed}");
        }
    }
}
