//! The light-path loop: an iteration's light (or photon) paths in fixed chunks of
//! [`PATHS_PER_TASK`] traced in parallel, each chunk into a buffer of its own that the
//! caller reads in chunk order, so what is stored never depends on the thread count.
//! Chunks are compiled twice, as the camera tiles are ([`super::pixels`]): for AVX2 +
//! FMA processors (chosen at run time) and for baseline x86-64.

use crate::integrator::transport::PATHS_PER_TASK;
use rayon::prelude::*;
use std::ops::Range;

/// A tracer of one kind of light path into per-chunk buffers.
pub(crate) trait ChunkTracer: Sync {
    type Chunk: Default + Send;

    /// Empties `chunk` for this iteration, keeping what its buffers hold for reuse.
    fn clear(&self, chunk: &mut Self::Chunk);

    /// Light path `index` of the iteration into `chunk`. Implementations are
    /// `#[inline(always)]`, so that the path's code is compiled for the chunk's
    /// instruction set.
    fn trace(&self, index: u64, chunk: &mut Self::Chunk);
}

/// Chunks that `paths` fills.
pub(crate) fn chunk_count(paths: &Range<u64>) -> usize {
    (paths.end.saturating_sub(paths.start) as usize).div_ceil(PATHS_PER_TASK)
}

/// Items of type `T` one of `chunks` chunks may store: its share of a budget of
/// `mib` MiB.
pub(crate) fn chunk_share<T>(mib: f32, chunks: usize) -> usize {
    (mib as f64 * 1048576.0 / std::mem::size_of::<T>() as f64 / chunks.max(1) as f64) as usize
}

/// Traces `paths` with `tracer`, chunk `c` holding paths `start + c PATHS_PER_TASK`
/// onwards; `chunks` keeps one buffer per chunk (grown or cut to the count).
pub(crate) fn trace_chunks<T: ChunkTracer>(
    tracer: &T,
    chunks: &mut Vec<T::Chunk>,
    paths: Range<u64>,
) {
    let n = chunk_count(&paths);
    chunks.resize_with(n, T::Chunk::default);
    chunks.truncate(n);
    chunks.par_iter_mut().enumerate().for_each(|(c, chunk)| {
        let start = paths.start + (c * PATHS_PER_TASK) as u64;
        let range = start..(start + PATHS_PER_TASK as u64).min(paths.end);
        tracer.clear(chunk);
        trace_chunk(tracer, range, chunk);
    });
}

fn trace_chunk<T: ChunkTracer>(tracer: &T, paths: Range<u64>, chunk: &mut T::Chunk) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            // SAFETY: the features were detected on this processor just above.
            return unsafe { trace_chunk_avx2(tracer, paths, chunk) };
        }
    }
    trace_chunk_body(tracer, paths, chunk)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
unsafe fn trace_chunk_avx2<T: ChunkTracer>(tracer: &T, paths: Range<u64>, chunk: &mut T::Chunk) {
    trace_chunk_body(tracer, paths, chunk)
}

#[inline(always)]
fn trace_chunk_body<T: ChunkTracer>(tracer: &T, paths: Range<u64>, chunk: &mut T::Chunk) {
    for i in paths {
        tracer.trace(i, chunk);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records which paths each chunk traced.
    struct Indices;

    impl ChunkTracer for Indices {
        type Chunk = Vec<u64>;
        fn clear(&self, chunk: &mut Vec<u64>) {
            chunk.clear();
        }
        fn trace(&self, index: u64, chunk: &mut Vec<u64>) {
            chunk.push(index);
        }
    }

    #[test]
    fn chunks_cover_the_range_in_order_and_reuse_their_buffers() {
        let per = PATHS_PER_TASK as u64;
        let mut chunks = vec![vec![7u64; 3]; 5];
        let paths = 10..10 + 2 * per + 3;
        trace_chunks(&Indices, &mut chunks, paths.clone());
        assert_eq!(chunks.len(), 3);
        assert_eq!(chunks[1].first(), Some(&(10 + per)));
        assert_eq!(chunks[2].len(), 3);
        let all: Vec<u64> = chunks.concat();
        assert_eq!(all, paths.collect::<Vec<_>>());
        trace_chunks(&Indices, &mut chunks, 0..0);
        assert!(chunks.is_empty());
        assert_eq!(chunk_count(&(5..5)), 0);
    }
}
