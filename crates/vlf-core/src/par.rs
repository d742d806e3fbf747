//! Deterministic data parallelism, the one place vlf-core starts worker threads. Plain data
//! parallelism ([`map`], [`map_ranges`], [`pool`]) runs on rayon: work cut into chunks whose
//! results come back in index order, so the output never depends on the thread count or on
//! scheduling. [`ordered`] is written by hand because rayon has no bounded, index-ordered fold:
//! the propagation sums each direction's contribution into the iteration in direction order
//! (the file's bits must not depend on the schedule) while holding at most a window of
//! directions' results in memory; rayon's ordered `collect` would hold them all, its `reduce`
//! would combine them in a tree whose shape depends on the split.

use std::collections::HashMap;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, OnceLock, mpsc};

use rayon::prelude::*;

/// Worker threads for a request: `0` means every available core.
pub fn threads(requested: usize) -> usize {
    if requested == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        requested
    }
}

/// The rayon pool of `threads` workers (0 = all cores; `--threads`), built on first use and
/// kept for the process (one per thread count asked for).
pub fn pool(threads: usize) -> Arc<rayon::ThreadPool> {
    static POOLS: OnceLock<Mutex<HashMap<usize, Arc<rayon::ThreadPool>>>> = OnceLock::new();
    let n = self::threads(threads);
    let mut pools = POOLS
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|p| p.into_inner());
    pools
        .entry(n)
        .or_insert_with(|| {
            Arc::new(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .thread_name(move |i| format!("vlf-{n}-{i}"))
                    .build()
                    .unwrap_or_else(|e| panic!("cannot start {n} worker threads: {e}")),
            )
        })
        .clone()
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
/// returning one item per index, concatenated in order. A panic in `f` is re-raised.
pub fn map_ranges<T: Send>(
    n: usize,
    threads: usize,
    chunk: usize,
    f: impl Fn(Range<usize>) -> Vec<T> + Sync,
) -> Vec<T> {
    let chunk = chunk.max(1);
    let chunks = n.div_ceil(chunk);
    if self::threads(threads).min(chunks) <= 1 {
        return f(0..n);
    }
    let parts: Vec<Vec<T>> = pool(threads).install(|| {
        (0..chunks)
            .into_par_iter()
            .map(|c| f(c * chunk..((c + 1) * chunk).min(n)))
            .collect()
    });
    let mut out = Vec::with_capacity(n);
    for p in parts {
        out.extend(p);
    }
    out
}

/// `produce(i)` for every `i` in `0..n` on `threads` workers (0 = all cores), each result
/// handed to `consume(i, result)` on the calling thread in index order: a fold whose order of
/// operations, and so whose result, never depends on the thread count or on scheduling. At
/// most `window` results (at least one per worker) are computed ahead of the one being
/// consumed, which bounds the memory they hold. One worker (or one index) runs everything on
/// the calling thread. A panic in `produce` or `consume` stops the workers and is re-raised.
pub fn ordered<T: Send>(
    n: usize,
    threads: usize,
    window: usize,
    produce: impl Fn(usize) -> T + Sync,
    mut consume: impl FnMut(usize, T),
) {
    let workers = self::threads(threads).min(n);
    if workers <= 1 {
        for i in 0..n {
            consume(i, produce(i));
        }
        return;
    }
    let window = window.max(workers);
    let gate = Gate {
        consumed: Mutex::new(0),
        moved: Condvar::new(),
        abort: AtomicBool::new(false),
    };
    let claim = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<(usize, T)>();
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                let tx = tx.clone();
                let (gate, claim, produce) = (&gate, &claim, &produce);
                s.spawn(move || {
                    let _stop = StopOnPanic(gate);
                    loop {
                        let i = claim.fetch_add(1, Ordering::Relaxed);
                        if i >= n || !gate.wait_until_below(i, window) {
                            break;
                        }
                        if tx.send((i, produce(i))).is_err() {
                            break;
                        }
                    }
                })
            })
            .collect();
        drop(tx);
        {
            let _stop = StopOnPanic(&gate);
            // Results in flight have indices in next..next + window: a ring of `window` slots.
            let mut waiting: Vec<Option<T>> = (0..window).map(|_| None).collect();
            let mut next = 0;
            while next < n {
                // Every sender gone before the end: a worker panicked (re-raised below).
                let Ok((i, r)) = rx.recv() else { break };
                waiting[i % window] = Some(r);
                while next < n {
                    let Some(r) = waiting[next % window].take() else {
                        break;
                    };
                    consume(next, r);
                    next += 1;
                    gate.advance(next);
                }
            }
        }
        for h in handles {
            h.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
        }
    });
}

/// How far [`ordered`] has consumed, for the workers that may not run ahead of it.
struct Gate {
    consumed: Mutex<usize>,
    moved: Condvar,
    abort: AtomicBool,
}

impl Gate {
    /// Waits until `i < consumed + window`; false when the fold is being abandoned.
    fn wait_until_below(&self, i: usize, window: usize) -> bool {
        let mut c = self.consumed.lock().unwrap_or_else(|p| p.into_inner());
        while i >= *c + window {
            if self.abort.load(Ordering::Relaxed) {
                return false;
            }
            c = self.moved.wait(c).unwrap_or_else(|p| p.into_inner());
        }
        !self.abort.load(Ordering::Relaxed)
    }

    fn advance(&self, consumed: usize) {
        *self.consumed.lock().unwrap_or_else(|p| p.into_inner()) = consumed;
        self.moved.notify_all();
    }
}

/// Abandons the fold when its thread unwinds, so that no worker waits for ever.
struct StopOnPanic<'a>(&'a Gate);

impl Drop for StopOnPanic<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            let _guard = self.0.consumed.lock().unwrap_or_else(|p| p.into_inner());
            self.0.abort.store(true, Ordering::Relaxed);
            self.0.moved.notify_all();
        }
    }
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

    /// A float sum in index order, with uneven work per index: the same bits for every thread
    /// count and window, and never more than `window` results waiting.
    #[test]
    fn ordered_folds_in_index_order() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        let term = |i: usize| {
            // Uneven work, so that later indices often finish first.
            let spin = (i * 7919) % 13 * 2000;
            let mut x = 1.0f32 / (i as f32 + 1.0);
            for k in 0..spin {
                x = std::hint::black_box(x + (k as f32) * 0.0);
            }
            x
        };
        let fold = |threads: usize, window: usize| {
            let mut sum = 0f32;
            let mut order = Vec::new();
            let ahead = AtomicUsize::new(0);
            let peak = AtomicUsize::new(0);
            let consumed = AtomicUsize::new(0);
            super::ordered(
                500,
                threads,
                window,
                |i| {
                    let a = ahead.fetch_add(1, Ordering::SeqCst) + 1;
                    peak.fetch_max(a, Ordering::SeqCst);
                    assert!(i < consumed.load(Ordering::SeqCst) + window.max(threads));
                    term(i)
                },
                |i, x| {
                    ahead.fetch_sub(1, Ordering::SeqCst);
                    consumed.store(i + 1, Ordering::SeqCst);
                    order.push(i);
                    sum += x;
                },
            );
            assert_eq!(order, (0..500).collect::<Vec<_>>());
            assert!(peak.load(Ordering::SeqCst) <= window.max(threads));
            sum.to_bits()
        };
        let one = fold(1, 1);
        for (t, w) in [(2, 2), (3, 4), (4, 16), (8, 3)] {
            assert_eq!(fold(t, w), one, "{t} threads, window {w}");
        }
        let mut none = 0;
        super::ordered(0, 4, 4, |i| i, |_, _| none += 1);
        assert_eq!(none, 0);
    }

    #[test]
    fn ordered_re_raises_a_worker_panic() {
        let r = std::panic::catch_unwind(|| {
            super::ordered(100, 3, 4, |i| assert!(i != 37, "boom"), |_, ()| {})
        });
        assert!(r.is_err());
    }
}
