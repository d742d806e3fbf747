//! Deterministic data parallelism over index ranges: the work is cut into chunks that worker
//! threads take in turn, and the results come back in index order, so the output never depends
//! on the thread count or on scheduling.

use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Worker threads for a request: `0` means every available core.
pub fn threads(requested: usize) -> usize {
    if requested == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        requested
    }
}

/// `f(i)` for every `i` in `0..n`, in order, computed on `threads` workers (0 = all cores) in
/// chunks of `chunk` indices.
pub fn map<T: Send>(
    n: usize,
    threads: usize,
    chunk: usize,
    f: impl Fn(usize) -> T + Sync,
) -> Vec<T> {
    map_ranges(n, threads, chunk, |r| r.map(&f).collect())
}

/// `f(range)` over consecutive ranges of at most `chunk` indices covering `0..n`, each
/// returning one item per index, concatenated in order.
pub fn map_ranges<T: Send>(
    n: usize,
    threads: usize,
    chunk: usize,
    f: impl Fn(Range<usize>) -> Vec<T> + Sync,
) -> Vec<T> {
    let chunk = chunk.max(1);
    let chunks = n.div_ceil(chunk);
    let workers = self::threads(threads).min(chunks);
    if workers <= 1 {
        return f(0..n);
    }
    let next = AtomicUsize::new(0);
    let mut parts: Vec<(usize, Vec<T>)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                s.spawn(|| {
                    let mut done = Vec::new();
                    loop {
                        let c = next.fetch_add(1, Ordering::Relaxed);
                        if c >= chunks {
                            break done;
                        }
                        let r = c * chunk..((c + 1) * chunk).min(n);
                        done.push((c, f(r)));
                    }
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .collect()
    });
    parts.sort_unstable_by_key(|p| p.0);
    let mut out = Vec::with_capacity(n);
    for (_, p) in parts {
        out.extend(p);
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn results_in_order_whatever_the_thread_count() {
        let one = super::map(1000, 1, 7, |i| i * i);
        for t in [2, 3, 8] {
            assert_eq!(super::map(1000, t, 7, |i| i * i), one);
        }
        assert!(super::map(0, 4, 7, |i| i).is_empty());
    }
}
