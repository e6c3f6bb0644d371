//! A counting global allocator and heap marks, to measure each phase of a
//! run's heap peak: the bytes allocated less the bytes freed (a
//! `realloc` counted by its difference), and the highest that sum reached.
//! A mark ([`mark`]) prints the heap now and its peak since the last mark,
//! then sets the peak to the heap now.
//!
//! Only built where asked: `cargo build --release -p dexcut-cli --features
//! heap-marks` installs [`Counting`] as the `dexcut` binary's allocator and
//! turns dexcut's marks on (without the feature they are empty functions).
//! It agrees with heaptrack's peak where both measure the same run
//! (BENCHMARKS.md).
//!
//! Not a stage of the pipeline: a measuring tool beside it, for the phases of
//! the `dexcut` library's commands. It depends on no other crate.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

/// Bytes live on the heap and the highest they reached since the last mark.
pub struct Counter {
    now: AtomicUsize,
    peak: AtomicUsize,
}

impl Counter {
    /// Nothing allocated.
    pub const fn new() -> Counter {
        Counter {
            now: AtomicUsize::new(0),
            peak: AtomicUsize::new(0),
        }
    }

    /// `bytes` more are live.
    pub fn grew(&self, bytes: usize) {
        let now = self.now.fetch_add(bytes, Relaxed) + bytes;
        self.peak.fetch_max(now, Relaxed);
    }

    /// `bytes` fewer are live.
    pub fn shrank(&self, bytes: usize) {
        self.now.fetch_sub(bytes, Relaxed);
    }

    /// A block of `old` bytes became one of `new` bytes.
    pub fn resized(&self, old: usize, new: usize) {
        if new >= old {
            self.grew(new - old);
        } else {
            self.shrank(old - new);
        }
    }

    /// The bytes live now and the most live since the last mark (or since
    /// the start); the peak is set to the bytes live now.
    pub fn mark(&self) -> (usize, usize) {
        let now = self.now.load(Relaxed);
        let peak = self.peak.swap(now, Relaxed).max(now);
        (now, peak)
    }
}

impl Default for Counter {
    fn default() -> Counter {
        Counter::new()
    }
}

/// What [`Counting`] counts.
static HEAP: Counter = Counter::new();

/// The system allocator, counted in [`HEAP`]: set as a binary's
/// `#[global_allocator]`.
pub struct Counting;

// SAFETY: every call is the system allocator's with the caller's arguments;
// the counting only reads the sizes, and counts a block only where the
// system allocator returned one.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc(layout);
        if !p.is_null() {
            HEAP.grew(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc_zeroed(layout);
        if !p.is_null() {
            HEAP.grew(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout);
        HEAP.shrank(layout.size());
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = System.realloc(ptr, layout, new_size);
        if !p.is_null() {
            HEAP.resized(layout.size(), new_size);
        }
        p
    }
}

/// Prints (to stderr) the heap now and its peak since the last mark, in MB
/// (10^6 bytes, as heaptrack's), after the phase that ends here; the peak
/// starts again from the heap now. Zeros unless [`Counting`] is the
/// allocator.
pub fn mark(phase: &str) {
    let (now, peak) = HEAP.mark();
    eprintln!(
        "heap mark: {phase}: peak {:.1} MB, now {:.1} MB",
        peak as f64 / 1e6,
        now as f64 / 1e6
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The counter follows blocks made, grown, shrunk and freed: the live
    /// bytes, the highest since the last mark, then from the mark on.
    #[test]
    fn a_mark_gives_the_heap_now_and_its_peak_since_the_last_mark() {
        let c = Counter::new();
        c.grew(100);
        c.grew(50);
        c.shrank(120);
        c.resized(30, 80);
        assert_eq!(c.mark(), (80, 150));
        // The peak starts again from the heap now.
        c.resized(80, 10);
        assert_eq!(c.mark(), (10, 80));
        c.grew(5);
        c.shrank(15);
        assert_eq!(c.mark(), (0, 15));
        assert_eq!(c.mark(), (0, 0));
    }
}
