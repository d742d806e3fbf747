//! Bulk radiance work (reading and verifying sections, encoding, decoding, checksums) split
//! over threads in runs of whole checksum blocks, so that every thread hashes the blocks it
//! reads and block hashes come back in order. Runs on `par`'s rayon pool.

use std::ops::Range;

use rayon::prelude::*;

/// Work of at least this many bytes is spread over several threads.
pub(crate) const PARALLEL_MIN_BYTES: usize = 4 << 20;

/// Threads worth using for `bytes` of work (1 below [`PARALLEL_MIN_BYTES`], at most 8).
pub(crate) fn threads_for(bytes: usize) -> usize {
    if bytes < PARALLEL_MIN_BYTES {
        1
    } else {
        crate::par::threads(0).min(8)
    }
}

/// Runs `work(first_block, chunk)` over `items` split into per-thread runs of whole blocks of
/// `per_block` items, on as many threads as pay off for `bytes`; results in order.
pub(crate) fn blocks_mut<T: Send, R: Send>(
    items: &mut [T],
    per_block: usize,
    bytes: usize,
    work: impl Fn(usize, &mut [T]) -> R + Sync,
) -> Vec<R> {
    let blocks = items.len().div_ceil(per_block).max(1);
    let threads = threads_for(bytes).min(blocks);
    if threads <= 1 {
        return vec![work(0, items)];
    }
    let blocks_per_thread = blocks.div_ceil(threads);
    let chunk = blocks_per_thread * per_block;
    crate::par::pool(threads).install(|| {
        items
            .par_chunks_mut(chunk)
            .enumerate()
            .map(|(t, c)| work(t * blocks_per_thread, c))
            .collect()
    })
}

/// Runs `work(blocks)` over `0..blocks` split into per-thread runs, on as many threads as pay
/// off for `bytes`; results in order (none for no blocks).
pub(crate) fn block_ranges<R: Send>(
    blocks: usize,
    bytes: usize,
    work: impl Fn(Range<usize>) -> R + Sync,
) -> Vec<R> {
    if blocks == 0 {
        return Vec::new();
    }
    let threads = threads_for(bytes).min(blocks);
    if threads <= 1 {
        return vec![work(0..blocks)];
    }
    let per_thread = blocks.div_ceil(threads);
    crate::par::pool(threads).install(|| {
        (0..blocks.div_ceil(per_thread))
            .into_par_iter()
            .map(|k| work(k * per_thread..((k + 1) * per_thread).min(blocks)))
            .collect()
    })
}

/// [`crate::hash::section_checksum`] of `data`, blocks hashed on several threads when large.
pub(crate) fn section_checksum(data: &[u8]) -> u64 {
    use crate::hash::{BLOCK, block_hash, combine};
    let blocks = data.len().div_ceil(BLOCK);
    let hashes: Vec<u64> = block_ranges(blocks, data.len(), |r| {
        r.map(|b| block_hash(&data[b * BLOCK..((b + 1) * BLOCK).min(data.len())], b))
            .collect::<Vec<_>>()
    })
    .into_iter()
    .flatten()
    .collect();
    combine(&hashes, data.len() as u64)
}
