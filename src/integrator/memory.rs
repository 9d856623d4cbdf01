//! A job's memory, estimated from its settings before it runs, so that a server can
//! refuse a job that would not fit instead of finding out at its peak.
//!
//! Each algorithm's settings estimate their own stores (a `memory` function beside
//! `validate`, dispatched from [`super::Settings::memory`]), from the sizes of the
//! types those stores hold and the way they grow. This module has what they share:
//! the estimate and its parts, Vec growth as the standard library does it, and what a
//! light path of the scene stores on average ([`Walk`], measured by the pilot of
//! `paths::pilot`).
//!
//! Counted: per-pixel state (the film an iteration renders into, the exact sums,
//! layers, tile buffers, photon mapping's per-pixel statistics), the light pass's
//! stores (vertices, path ends, segments, splats, photons, beams, virtual lights) and
//! their accelerators (hash grids, BVHs, light trees), all as they stand at the peak of
//! an iteration (they are kept between iterations). Not counted: the compiled scene,
//! which every job on it shares and the upload limits bound, and per-thread scratch of
//! a few KiB. The job layer adds what writing snapshots and checkpoints needs.
//!
//! How honest: counts that follow from the settings (pixels, light paths, chunks,
//! reservations, budgets) are exact; counts that depend on where paths go (vertices,
//! segments and beam pieces per light path) are the pilot's means over 1024 paths.
//! `tests/job_memory.rs` holds the estimate to within a factor of the bytes a render
//! allocates at its peak, for every algorithm.

use crate::scene::Scene;
use std::cell::RefCell;

/// One part of an estimate: what it is, the setting that makes it large, its bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    pub what: &'static str,
    /// The parameter that scales it, as the client wrote it
    /// (`light_paths.count = 16777216`), or the film size.
    pub driver: String,
    pub bytes: u64,
}

/// A job's peak memory, by part.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Estimate {
    pub parts: Vec<Part>,
}

impl Estimate {
    /// Adds a part (parts of no bytes are left out).
    pub fn add(&mut self, what: &'static str, driver: impl Into<String>, bytes: f64) {
        if bytes >= 1.0 {
            self.parts.push(Part {
                what,
                driver: driver.into(),
                bytes: bytes.ceil() as u64,
            });
        }
    }

    pub fn total(&self) -> u64 {
        self.parts.iter().map(|p| p.bytes).sum()
    }

    /// The parts, largest first.
    pub fn by_size(&self) -> Vec<&Part> {
        let mut v: Vec<&Part> = self.parts.iter().collect();
        v.sort_by_key(|p| std::cmp::Reverse(p.bytes));
        v
    }

    /// `about 1.9 GiB (light vertices 1.6 GiB, film 3 MiB)`: the total and its three
    /// largest parts.
    pub fn summary(&self) -> String {
        let parts: Vec<String> = self
            .by_size()
            .iter()
            .take(3)
            .map(|p| format!("{} {}", p.what, human(p.bytes)))
            .collect();
        format!("about {} ({})", human(self.total()), parts.join(", "))
    }
}

/// Bytes in the largest binary unit that keeps the figure at least 1, to two
/// significant digits: `1.9 GiB`, `640 MiB`, `12 KiB`.
pub fn human(bytes: u64) -> String {
    let units = ["bytes", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < units.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 || v >= 10.0 {
        format!("{v:.0} {}", units[u])
    } else {
        format!("{v:.1} {}", units[u])
    }
}

/// Bytes of `n` values of `T`.
pub fn array<T>(n: f64) -> f64 {
    n * std::mem::size_of::<T>() as f64
}

/// The capacity of a Vec refilled to about `len` elements every iteration (cleared,
/// its buffer kept), from room for `reserved`: pushes and reservations double the
/// capacity whenever an iteration's count exceeds it, so over a long job it comes to
/// hold up to twice the count. Counted as that, or as the room while the count stays
/// a tenth or more below it.
pub fn refilled(len: f64, reserved: f64) -> f64 {
    if len < 0.9 * reserved {
        reserved
    } else {
        2.0 * len.max(reserved)
    }
}

/// [`refilled`] for a Vec that takes no more than `budget` elements: it never grows
/// past the first doubling that holds the budget.
pub fn budgeted(len: f64, reserved: f64, budget: f64) -> f64 {
    refilled(len, reserved).min(pushed(budget, reserved))
}

/// The capacity a new Vec reaches when `len` elements are pushed one at a time onto
/// room for `reserved`: the standard library doubles the capacity, from at least 4.
pub fn pushed(len: f64, reserved: f64) -> f64 {
    if len <= reserved {
        return reserved;
    }
    let start = reserved.max(4.0);
    start * (len / start).log2().ceil().exp2()
}

/// `driver`, with the budget that caps the part when it does (`over`).
pub fn capped(driver: &str, over: bool, field: &str, value: impl std::fmt::Display) -> String {
    match over {
        true => format!("{driver} (capped by {field} = {value})"),
        false => driver.to_string(),
    }
}

/// `light_paths`, as the client wrote it, and the count of paths it makes.
pub fn paths_driver(multiple: Option<f32>, paths: usize, facts: &Facts) -> String {
    match multiple {
        Some(m) => format!(
            "light_paths = {m} ({paths} paths on {}x{})",
            facts.scene.width(),
            facts.scene.height()
        ),
        None => format!("light_paths.count = {paths}"),
    }
}

/// What a light path of a scene stores, per path on average, at a given `max_depth`
/// and roulette: measured by a pilot of the bidirectional light pass (1024 paths,
/// every vertex and segment kept), which every light-path algorithm's walk matches in
/// expectation (Russian roulette by albedo, or by the power a bounce keeps, which is
/// the albedo on average).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Walk {
    /// Non-specular surface vertices.
    pub surface: f64,
    /// Those of them reached straight from the light (photon mapping stores none).
    pub direct: f64,
    /// Scattering points in media.
    pub medium: f64,
    /// Segments through media.
    pub segments: f64,
    /// Photon-beam pieces those segments make (`ppb::PIECE` long at most), as short and
    /// as long beams.
    pub short_pieces: f64,
    pub long_pieces: f64,
}

impl Walk {
    pub fn vertices(&self) -> f64 {
        self.surface + self.medium
    }

    pub(crate) fn scaled(self, k: f64) -> Walk {
        Walk {
            surface: self.surface * k,
            direct: self.direct * k,
            medium: self.medium * k,
            segments: self.segments * k,
            short_pieces: self.short_pieces * k,
            long_pieces: self.long_pieces * k,
        }
    }
}

/// What an estimate reads of the job's scene.
pub struct Facts<'a> {
    pub scene: &'a Scene,
    /// Pilots run so far, by (max_depth, roulette).
    walks: RefCell<Vec<((u32, bool), Walk)>>,
}

impl<'a> Facts<'a> {
    pub fn new(scene: &'a Scene) -> Self {
        Facts {
            scene,
            walks: RefCell::new(Vec::new()),
        }
    }

    pub fn pixels(&self) -> f64 {
        self.scene.width() as f64 * self.scene.height() as f64
    }

    /// `film 256x256`.
    pub fn film(&self) -> String {
        format!("film {}x{}", self.scene.width(), self.scene.height())
    }

    /// What a light path of this scene stores, at `max_depth` and with or without
    /// roulette: `pilot`'s figure, run once per depth and roulette.
    pub fn walk_or(&self, max_depth: u32, roulette: bool, pilot: impl FnOnce() -> Walk) -> Walk {
        let key = (max_depth, roulette);
        if let Some((_, w)) = self.walks.borrow().iter().find(|(k, _)| *k == key) {
            return *w;
        }
        let w = pilot();
        self.walks.borrow_mut().push((key, w));
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn human_figures() {
        assert_eq!(human(0), "0 bytes");
        assert_eq!(human(1000), "1000 bytes");
        assert_eq!(human(12 << 10), "12 KiB");
        assert_eq!(human(3 << 20), "3.0 MiB");
        assert_eq!(human(640 << 20), "640 MiB");
        assert_eq!(human((19 << 30) / 10), "1.9 GiB");
    }

    #[test]
    fn refilled_buffers_double_once_counts_reach_their_room() {
        assert_eq!(refilled(100.0, 3072.0), 3072.0);
        assert_eq!(refilled(3000.0, 3072.0), 6144.0);
        assert_eq!(refilled(5000.0, 0.0), 10000.0);
        assert_eq!(budgeted(341.0, 341.0, 341.0), 341.0);
        assert_eq!(budgeted(5000.0, 3072.0, 5000.0), 6144.0);
    }

    #[test]
    fn pushed_doubles_from_the_reservation() {
        assert_eq!(pushed(3.0, 0.0), 4.0);
        assert_eq!(pushed(5.0, 0.0), 8.0);
        assert_eq!(pushed(100.0, 3072.0), 3072.0);
        assert_eq!(pushed(3073.0, 3072.0), 6144.0);
        assert_eq!(pushed(1025.0, 1024.0), 2048.0);
    }
}
