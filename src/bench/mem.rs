//! Peak resident memory, so that benchmarks measure memory as they measure time.
//!
//! Linux keeps the high-water mark of a process's resident set (`VmHWM` in
//! /proc/self/status) and lets the process reset it (writing 5 to
//! /proc/self/clear_refs), so one process can measure the peak of each algorithm in
//! turn. Elsewhere the figures are absent.

/// Resets the peak to the current resident set; false where that is not possible
/// (then [`peak_rss_bytes`] reports the peak since the process started).
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", b"5").is_ok()
}

/// The peak resident set since the process started or the last [`reset_peak_rss`].
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    Some(proc_kib(&status, "VmHWM:")? * 1024)
}

/// The figure of the line that starts with `key` in a /proc file whose figures are in
/// KiB (`status`, `meminfo`): `VmHWM:    1234 kB`.
pub fn proc_kib(text: &str, key: &str) -> Option<u64> {
    text.lines()
        .find_map(|l| l.strip_prefix(key))?
        .trim()
        .strip_suffix("kB")?
        .trim()
        .parse()
        .ok()
}

/// `peak_rss_bytes` in MiB for a table, or "-".
pub fn peak_rss_mib() -> String {
    peak_rss_bytes().map_or_else(|| "-".into(), |b| format!("{:.1}", b as f64 / 1048576.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_peak_follows_an_allocation_and_resets() {
        // Where the peak cannot be reset there is nothing to measure against.
        if !reset_peak_rss() {
            return;
        }
        // Large against what other tests running alongside allocate or free.
        let before = peak_rss_bytes().unwrap();
        let big = vec![1u8; 256 << 20];
        std::hint::black_box(&big);
        let during = peak_rss_bytes().unwrap();
        assert!(during >= before + (200 << 20), "{before} -> {during}");
        drop(big);
        assert!(reset_peak_rss());
        let after = peak_rss_bytes().unwrap();
        assert!(after + (128 << 20) < during, "{during} -> {after}");
    }
}
