//! The extra images a pass splits its estimate into (by connection strategy, or by
//! technique), as both subpaths address them.

use super::partial::Merge;

/// Extra images a pass splits its estimate into.
#[derive(Clone, Debug, Default)]
pub(crate) struct Layers {
    pub names: Vec<String>,
    /// Split by connection strategy up to this path length (0: no).
    pub(crate) strategies: u32,
    /// Split by technique: connections in layer 0, merges from `merges[k]` on.
    pub(crate) techniques: bool,
    pub(crate) merges: [u8; Merge::COUNT],
    /// Layers per merge estimator, by the camera vertex or segment the merge sits at
    /// (1, 2, ..., `depths` or more); 1 when merges are not split by depth.
    pub(crate) depths: u32,
    /// The first `radii` layer (each a whole image under its radius), after the
    /// others.
    pub(crate) radii: usize,
}

impl Layers {
    /// The layer of a connection with `s` light and `t` camera vertices.
    #[inline]
    pub fn connection(&self, s: u32, t: u32) -> Option<usize> {
        if self.techniques {
            return Some(0);
        }
        let k = s + t - 1;
        (k >= 1 && k <= self.strategies).then(|| ((k - 1) * (k + 2) / 2 + s) as usize)
    }

    /// The layer of a merge by estimator `k` at camera vertex or segment
    /// `camera_len` (1: the first).
    #[inline]
    pub fn merge(&self, k: Merge, camera_len: u32) -> Option<usize> {
        let depth = camera_len.clamp(1, self.depths.max(1)) - 1;
        self.techniques
            .then_some(self.merges[k as usize] as usize + depth as usize)
    }
}
