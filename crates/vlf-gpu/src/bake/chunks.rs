//! Chunks of transport directions: the buffers that hold something for *every* direction
//! (tile bins, their tile starts, reflect items) are split into several buffers, each holding
//! whole directions and at most one storage binding (`max_storage_buffer_binding_size`), so
//! their total size is bounded by memory and not by the binding limit. A scene with a few
//! thousand triangles at 606 directions bins ~160 MiB of triangle entries at any resolution,
//! more than lavapipe's 128 MiB binding (and real GPUs have a limit too).
//!
//! The split is greedy, in direction order, and made once by the bake's plan
//! ([`super::BakePlan`]), which the propagator allocates from and `vlf-bake`'s memory budget
//! reads, so both see the same chunks.

use std::ops::Range;

/// Default cap on one chunk buffer: 128 MiB, or the adapter's binding limit when that is
/// smaller. A larger cap saves nothing (one bind group per chunk is cheap) while a buffer
/// near a multi-GiB binding limit can be hard for the driver to place.
pub const DEFAULT_MAX_CHUNK_BYTES: u64 = 128 << 20;

/// The chunk cap for an adapter whose binding limit is `limit` bytes: `max_chunk_bytes`
/// (default [`DEFAULT_MAX_CHUNK_BYTES`]) or the limit, whichever is smaller (and below 4 GiB,
/// so that offsets in a chunk fit the shaders' u32 indices).
pub fn chunk_cap(limit: u64, max_chunk_bytes: Option<u64>) -> u64 {
    max_chunk_bytes
        .unwrap_or(DEFAULT_MAX_CHUNK_BYTES)
        .min(limit)
        .min(u64::from(u32::MAX))
        .max(1)
}

/// Bytes in each chunked buffer (of one direction, or of a chunk).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ChunkBytes {
    /// `Bake::bin_start`: (tiles² + 1) u32 per direction.
    pub bin_start: u64,
    /// `Bake::bin_tris`: one u32 per binned triangle entry.
    pub bin_tris: u64,
    /// `Bake::reflect_items`: one `ReflectItem` (32 B) per item.
    pub reflect_items: u64,
}

impl ChunkBytes {
    /// The largest of the buffers.
    pub fn largest(&self) -> u64 {
        self.bin_start.max(self.bin_tris).max(self.reflect_items)
    }

    /// The sum of the buffers.
    pub fn sum(&self) -> u64 {
        self.bin_start + self.bin_tris + self.reflect_items
    }

    fn plus(self, o: ChunkBytes) -> ChunkBytes {
        ChunkBytes {
            bin_start: self.bin_start + o.bin_start,
            bin_tris: self.bin_tris + o.bin_tris,
            reflect_items: self.reflect_items + o.reflect_items,
        }
    }

    fn max(self, o: ChunkBytes) -> ChunkBytes {
        ChunkBytes {
            bin_start: self.bin_start.max(o.bin_start),
            bin_tris: self.bin_tris.max(o.bin_tris),
            reflect_items: self.reflect_items.max(o.reflect_items),
        }
    }
}

/// One chunk: a range of transport directions and the bytes of its buffers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Chunk {
    pub directions: Range<usize>,
    pub bytes: ChunkBytes,
}

/// Greedy split of the transport directions, fed one at a time in order: a direction joins
/// the current chunk while every buffer of the chunk stays within the cap, and opens a new
/// chunk otherwise. A direction larger than the cap on its own gets a chunk of its own (then
/// larger than the cap: the caller checks chunks against the adapter's binding limit).
#[derive(Clone, Debug)]
pub struct Chunker {
    cap: u64,
    chunks: Vec<Chunk>,
}

impl Chunker {
    pub fn new(cap: u64) -> Chunker {
        Chunker {
            cap: cap.max(1),
            chunks: Vec::new(),
        }
    }

    /// Adds the next direction; `true` when it opened a new chunk (the previous one, if any,
    /// is then complete).
    pub fn push(&mut self, d: ChunkBytes) -> bool {
        let next = self.chunks.last().map_or(0, |c| c.directions.end);
        if let Some(c) = self.chunks.last_mut() {
            let joined = c.bytes.plus(d);
            if joined.largest() <= self.cap {
                c.directions.end += 1;
                c.bytes = joined;
                return false;
            }
        }
        self.chunks.push(Chunk {
            directions: next..next + 1,
            bytes: d,
        });
        true
    }

    pub fn cap(&self) -> u64 {
        self.cap
    }

    pub fn chunks(&self) -> &[Chunk] {
        &self.chunks
    }

    /// Per buffer, its largest chunk (each ≤ the cap unless one direction alone is larger).
    pub fn largest(&self) -> ChunkBytes {
        self.chunks
            .iter()
            .fold(ChunkBytes::default(), |a, c| a.max(c.bytes))
    }

    /// Per buffer, all chunks together.
    pub fn total(&self) -> ChunkBytes {
        self.chunks
            .iter()
            .fold(ChunkBytes::default(), |a, c| a.plus(c.bytes))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(bin_tris: u64) -> ChunkBytes {
        ChunkBytes {
            bin_start: 8,
            bin_tris,
            reflect_items: 0,
        }
    }

    #[test]
    fn greedy_whole_directions_within_the_cap() {
        let mut c = Chunker::new(100);
        let opened: Vec<bool> = [40, 40, 30, 100, 10, 150, 5]
            .into_iter()
            .map(|b| c.push(dir(b)))
            .collect();
        assert_eq!(opened, [true, false, true, true, true, true, true]);
        let ranges: Vec<_> = c.chunks().iter().map(|c| c.directions.clone()).collect();
        assert_eq!(ranges, [0..2, 2..3, 3..4, 4..5, 5..6, 6..7]);
        assert_eq!(
            c.chunks()[0].bytes,
            ChunkBytes {
                bin_start: 16,
                bin_tris: 80,
                reflect_items: 0
            }
        );
        // The 150-byte direction is alone, over the cap; every other chunk is within it.
        assert_eq!(c.largest().bin_tris, 150);
        assert!(
            c.chunks()
                .iter()
                .all(|k| k.bytes.largest() <= 100 || k.directions.len() == 1)
        );
        assert_eq!(c.total().bin_tris, 375);
        assert_eq!(c.total().bin_start, 56);
    }

    #[test]
    fn every_buffer_counts_against_the_cap() {
        let mut c = Chunker::new(64);
        for _ in 0..4 {
            c.push(ChunkBytes {
                bin_start: 4,
                bin_tris: 4,
                reflect_items: 32,
            });
        }
        // Two reflect-item sets per chunk.
        assert_eq!(c.chunks().len(), 2);
        assert_eq!(c.largest().reflect_items, 64);
    }

    #[test]
    fn the_cap_is_the_smaller_of_option_and_limit() {
        assert_eq!(chunk_cap(128 << 20, None), 128 << 20);
        assert_eq!(chunk_cap(2 << 30, None), DEFAULT_MAX_CHUNK_BYTES);
        assert_eq!(chunk_cap(1 << 20, Some(4 << 20)), 1 << 20);
        assert_eq!(chunk_cap(1 << 30, Some(4096)), 4096);
        assert_eq!(chunk_cap(1 << 30, Some(0)), 1);
        assert_eq!(chunk_cap(u64::MAX, Some(u64::MAX)), u64::from(u32::MAX));
    }
}
