//! Large per-iteration buffers on 2 MiB pages.
//!
//! Merging and connections read light vertices in an order unrelated to where they
//! are stored, so with 4 KiB pages nearly every such read also misses the TLB. Linux
//! backs anonymous memory with huge pages where the process asks for them
//! (`transparent_hugepage` = `madvise`, the common default), if asked before the
//! memory is first touched.

/// Smallest buffer worth the advice.
const MIN_BYTES: usize = 4 << 20;

/// Makes `v` (which must be empty) able to hold `len` elements without growing. A new
/// allocation is advised onto huge pages before anything is written to it.
pub(crate) fn reserve<T>(v: &mut Vec<T>, len: usize) {
    debug_assert!(v.is_empty());
    if v.capacity() >= len {
        return;
    }
    // A fresh allocation rather than `reserve`, whose realloc could move already
    // touched (small-page) memory into the new buffer.
    *v = Vec::with_capacity(reserved(len));
    advise(v);
}

/// The capacity [`reserve`] gives for `len` elements: room to grow by an eighth
/// before the next iteration needs a new buffer.
pub(crate) fn reserved(len: usize) -> usize {
    len + len / 8
}

#[cfg(target_os = "linux")]
fn advise<T>(v: &Vec<T>) {
    const HUGE: usize = 2 << 20;
    let bytes = v.capacity() * std::mem::size_of::<T>();
    if bytes < MIN_BYTES {
        return;
    }
    let start = v.as_ptr() as usize;
    let lo = start.next_multiple_of(HUGE);
    let hi = (start + bytes) / HUGE * HUGE;
    if hi > lo {
        // SAFETY: [lo, hi) lies inside the allocation `v` owns; madvise only changes
        // how the kernel backs those pages, never their contents. A failure (for
        // example transparent huge pages switched off) leaves small pages.
        unsafe {
            libc::madvise(lo as *mut libc::c_void, hi - lo, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise<T>(_: &Vec<T>) {}

#[cfg(test)]
mod tests {
    #[test]
    fn reserve_gives_room_and_keeps_a_large_enough_buffer() {
        let mut v: Vec<u64> = Vec::new();
        super::reserve(&mut v, 1 << 20);
        assert!(v.capacity() >= 1 << 20);
        let p = v.as_ptr();
        v.extend(0..1 << 20);
        assert_eq!(v[12345], 12345);
        v.clear();
        super::reserve(&mut v, 1000);
        assert_eq!(v.as_ptr(), p, "a buffer that is large enough is kept");
    }
}
