//! Bounds on the total work of one import. Depth limits alone let a small upload ask
//! for a great deal: 31 files of a few lines, each including the next twice, are 2^30
//! includes; a thousand shapes naming one serialized file decompress it a thousand
//! times. So every count is per use (per inclusion, per shape), not per distinct file,
//! and an import that passes a limit stops there with an error at the element where
//! it did. The limits are far above what large production scenes need (tens of
//! thousands of shapes, a few hundred thousand elements).

/// What an import spends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Work {
    /// Elements instantiated, includes expanded.
    Elements,
    /// `<include>`s followed.
    Includes,
    /// Bytes of XML parsed.
    XmlBytes,
    /// Shapes produced.
    Shapes,
    /// Bytes of `serialized` mesh data decompressed.
    MeshBytes,
}

const KINDS: usize = 5;

impl Work {
    /// The limit of one import.
    pub const fn limit(self) -> u64 {
        match self {
            Work::Elements => 1 << 20,
            Work::Includes => 1 << 14,
            Work::XmlBytes => 256 << 20,
            Work::Shapes => 1 << 18,
            Work::MeshBytes => 1 << 30,
        }
    }

    /// What is counted, as messages say it (with the limit).
    fn describe(self) -> String {
        let n = self.limit();
        match self {
            Work::Elements => format!("{n} elements (includes expanded)"),
            Work::Includes => format!("{n} <include>s (each inclusion counts, not each file)"),
            Work::XmlBytes => format!("{} MiB of XML (each inclusion counts)", n >> 20),
            Work::Shapes => format!("{n} shapes"),
            Work::MeshBytes => format!(
                "{} MiB of serialized mesh data decompressed (each shape counts)",
                n >> 20
            ),
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// What an import has spent so far.
#[derive(Debug, Default)]
pub struct Budget {
    used: [u64; KINDS],
}

impl Budget {
    /// Counts `n` more of `work`. Past the limit, the message for an error at the
    /// element that crossed it.
    pub fn spend(&mut self, work: Work, n: u64) -> Result<(), String> {
        let used = &mut self.used[work.index()];
        *used = used.saturating_add(n);
        if *used > work.limit() {
            return Err(format!(
                "the scene asks for more than {}, the limit of one import; a real scene needs \
                 far fewer (look for includes or references that multiply)",
                work.describe()
            ));
        }
        Ok(())
    }

    /// What is left of `work`'s limit.
    pub fn left(&self, work: Work) -> u64 {
        work.limit().saturating_sub(self.used[work.index()])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_stops_at_its_own_limit() {
        let mut b = Budget::default();
        let includes = Work::Includes.limit();
        assert!(b.spend(Work::Includes, includes).is_ok());
        assert_eq!(b.left(Work::Includes), 0);
        assert_eq!(b.left(Work::Elements), Work::Elements.limit());
        let e = b.spend(Work::Includes, 1).unwrap_err();
        assert!(
            e.contains(&format!("more than {includes} <include>s")),
            "{e}"
        );
        assert!(b.spend(Work::Elements, 1).is_ok());
        assert!(b.spend(Work::MeshBytes, u64::MAX).is_err());
    }
}
