//! The memory estimate of a bidirectional job (module `memory`): what its settings
//! store per iteration.

use super::{BidirSettings, PixelSelection, Technique};
use crate::integrator::bidir::beams::BeamStore;
use crate::integrator::bidir::merge::MergeSet;
use crate::integrator::drive::pixels::tile_memory;
use crate::integrator::memory::{array, paths_driver, Estimate, Facts};
use crate::integrator::paths::partial::Merge;
use crate::integrator::paths::parts::Parts;
use crate::integrator::paths::store::{store_memory, StorePlan};
use std::sync::atomic::AtomicU32;

impl BidirSettings {
    /// A job's memory with these settings run as `technique` (module `memory`): the
    /// light store, the merge indices, `upbp`'s photon points and beams, the camera
    /// pass's tile buffers and per-pixel layer values.
    pub fn memory(&self, technique: Technique, facts: &Facts) -> Estimate {
        let mut e = Estimate::default();
        let has_media = facts.scene.has_media;
        let paths = crate::integrator::transport::light_paths::light_path_count(
            facts.pixels() as usize,
            self.light_paths,
        );
        let driver = paths_driver(Some(self.light_paths), paths, facts);
        let walk = crate::integrator::pilot::walk(facts, self.max_depth, self.russian_roulette);
        let plan = StorePlan {
            tracing: technique.tracing(),
            paths,
            walk,
            keep_segments: technique.uses(Merge::BeamBeam1d),
            max_vertex_mib: self.max_vertex_mib,
            driver: &driver,
            budget_field: "max_vertex_mib",
        };
        let stored = store_memory(&mut e, &plan, has_media);
        if technique.uses(Merge::Surface) {
            e.add("merge index", &driver, MergeSet::bytes_for(stored.surface));
        }
        if technique.uses(Merge::Point3d) && has_media {
            e.add(
                "medium merge index",
                &driver,
                MergeSet::bytes_for(stored.medium),
            );
        }
        if has_media {
            let points = match technique.uses(Merge::PointBeam2d) {
                true => stored.medium,
                false => 0.0,
            };
            let (mut segments, mut pieces) = (0.0, 0.0);
            if technique.uses(Merge::BeamBeam1d) {
                let beam_paths =
                    crate::integrator::bidir::beam_path_count(paths, self.beam_paths).min(paths);
                segments = stored.segments * beam_paths as f64 / paths as f64;
                if walk.segments > 0.0 {
                    pieces = segments * walk.short_pieces / walk.segments;
                }
            }
            let bytes = BeamStore::bytes_for(points, segments, pieces);
            e.add("photon points and beams", &driver, bytes);
        }
        let adaptive = self.selection_for(technique) == PixelSelection::Adaptive;
        if self.correlation_aware {
            // Each stored vertex's link, and in its merge set (or among the photon
            // points) where it sits; each kept segment's flight start, in the store
            // and at most once more in the beam store.
            use crate::integrator::paths::correlation::{FlightLinks, Link};
            let n = stored.surface + stored.medium;
            let mut bytes = n * (std::mem::size_of::<Link>() as f64 + 8.0);
            if has_media && technique.uses(Merge::PointBeam2d) {
                bytes += stored.medium * 8.0;
            }
            if has_media && technique.uses(Merge::BeamBeam1d) {
                let flight = std::mem::size_of::<FlightLinks>() as f64;
                bytes += stored.segments * (2.0 * flight + 4.0);
            }
            e.add("correlation links", &driver, bytes);
        }
        if !self.radii.is_empty() || adaptive || self.correlation_aware {
            // Each stored vertex's parts, in the store and again in its merge set;
            // the photon points' again in the beam store; each kept segment's two
            // (its own and pending), in the store and at most as many in the beam store.
            let mut n = 2.0 * (stored.surface + stored.medium);
            if has_media && technique.uses(Merge::PointBeam2d) {
                n += stored.medium;
            }
            if has_media && technique.uses(Merge::BeamBeam1d) {
                n += 4.0 * stored.segments;
            }
            let bytes = n * std::mem::size_of::<Parts>() as f64;
            e.add("radius-layer parts", &driver, bytes);
        }
        let mut layers = self.layer_count(technique) as f64;
        if adaptive {
            // A pilot's candidates (at most six) are layers too, with four merge
            // counts per pixel; the pilots' sums keep a second moment per candidate
            // and the merges per estimator, and one byte per pixel per choice made.
            let per_pixel = 6.0 * 8.0 + 4.0 * 8.0 + 4.0 * 4.0 + 32.0;
            e.add(
                "adaptive selection",
                facts.film(),
                per_pixel * facts.pixels(),
            );
            layers += 6.0;
        }
        let values = array::<AtomicU32>(3.0 * layers * facts.pixels());
        e.add("layer values", facts.film(), values);
        if technique != Technique::Lt {
            tile_memory(&mut e, facts);
        }
        e
    }
}
