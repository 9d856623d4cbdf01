//! The extra images a pass splits its estimate into (by connection strategy, or by
//! technique), as both subpaths address them.

use super::partial::Merge;

/// Extra images a pass splits its estimate into.
#[derive(Clone, Debug, Default)]
pub(crate) struct Layers {
    pub names: Vec<String>,
    /// Split by connection strategy up to this path length (0: no).
    pub(crate) strategies: u32,
    /// Split by technique: connections in layer 0, merges in `merges[k]`.
    pub(crate) techniques: bool,
    pub(crate) merges: [u8; Merge::COUNT],
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

    /// The layer of a merge by estimator `k`.
    #[inline]
    pub fn merge(&self, k: Merge) -> Option<usize> {
        self.techniques.then_some(self.merges[k as usize] as usize)
    }
}
