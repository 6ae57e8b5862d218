//! A wait-free triple buffer: one writer publishes values, one reader always gets the latest
//! complete one, and neither ever waits for the other.
//!
//! Why a triple buffer between the haptic thread and the viewer: the haptic loop must never
//! block (a 1 kHz loop that waits for a 60 Hz renderer to release a lock would miss ticks and
//! buzz), and the viewer only ever needs the newest state, never a queue of old ones. With
//! three slots the writer always has a free slot to fill and the reader always has a complete
//! one to read; publishing and fetching are a single atomic swap each. A mutex could block the
//! haptic thread behind a descheduled reader; a seqlock makes the reader retry and needs the
//! value read with racy copies; a queue grows or drops. The triple buffer has none of these.
//!
//! Invariant: the writer's slot, the reader's slot and the "back" slot held in the atomic are
//! always three different slots, so the two sides never touch the same memory.

use std::cell::UnsafeCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

const INDEX_MASK: u8 = 0b011;
const FRESH: u8 = 0b100;

struct Shared<T> {
    slots: [UnsafeCell<T>; 3],
    /// The back slot's index, with [`FRESH`] set when it holds a value the reader has not seen.
    back: AtomicU8,
}

// SAFETY: the writer and the reader only access the slot whose index they own, and ownership
// of slots is exchanged only through the atomic swap on `back` (AcqRel), which orders the
// previous owner's accesses before the next owner's. `T: Send` because values cross threads.
unsafe impl<T: Send> Sync for Shared<T> {}

/// The writing end.
pub struct Writer<T> {
    shared: Arc<Shared<T>>,
    index: u8,
}

/// The reading end.
pub struct Reader<T> {
    shared: Arc<Shared<T>>,
    index: u8,
}

impl<T> std::fmt::Debug for Writer<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("triple_buffer::Writer").finish_non_exhaustive()
    }
}

impl<T> std::fmt::Debug for Reader<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("triple_buffer::Reader").finish_non_exhaustive()
    }
}

/// A triple buffer whose reader sees `initial` until the first write.
pub fn triple_buffer<T: Copy + Send>(initial: T) -> (Writer<T>, Reader<T>) {
    let shared = Arc::new(Shared {
        slots: [UnsafeCell::new(initial), UnsafeCell::new(initial), UnsafeCell::new(initial)],
        back: AtomicU8::new(2),
    });
    (Writer { shared: Arc::clone(&shared), index: 0 }, Reader { shared, index: 1 })
}

impl<T: Copy + Send> Writer<T> {
    /// Publishes `value`. Never blocks.
    pub fn write(&mut self, value: T) {
        // SAFETY: slot `self.index` is owned by the writer (see the module invariant).
        unsafe { *self.shared.slots[self.index as usize].get() = value };
        let previous = self.shared.back.swap(self.index | FRESH, Ordering::AcqRel);
        self.index = previous & INDEX_MASK;
    }
}

impl<T: Copy + Send> Reader<T> {
    /// The most recently published value. Never blocks.
    pub fn read(&mut self) -> T {
        if self.shared.back.load(Ordering::Acquire) & FRESH != 0 {
            let previous = self.shared.back.swap(self.index, Ordering::AcqRel);
            self.index = previous & INDEX_MASK;
        }
        // SAFETY: slot `self.index` is owned by the reader (see the module invariant).
        unsafe { *self.shared.slots[self.index as usize].get() }
    }

    /// True when a value was published since the last [`Reader::read`].
    pub fn has_update(&self) -> bool {
        self.shared.back.load(Ordering::Acquire) & FRESH != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reader_sees_latest() {
        let (mut w, mut r) = triple_buffer(0u64);
        assert_eq!(r.read(), 0);
        assert!(!r.has_update());
        w.write(1);
        w.write(2);
        assert!(r.has_update());
        assert_eq!(r.read(), 2);
        assert_eq!(r.read(), 2);
        w.write(3);
        assert_eq!(r.read(), 3);
    }

    #[test]
    fn concurrent_values_are_never_torn_and_never_go_back() {
        // Each value is four copies of one counter: a torn read would mix counters.
        let (mut w, mut r) = triple_buffer([0u64; 4]);
        let writer = std::thread::spawn(move || {
            for i in 1..=200_000u64 {
                w.write([i; 4]);
            }
        });
        let mut last = 0;
        loop {
            let v = r.read();
            assert!(v.iter().all(|&x| x == v[0]), "torn read {v:?}");
            assert!(v[0] >= last, "went back from {last} to {}", v[0]);
            last = v[0];
            if last == 200_000 {
                break;
            }
            if writer.is_finished() && !r.has_update() && last != 200_000 {
                assert_eq!(r.read()[0], 200_000);
                break;
            }
        }
        writer.join().unwrap();
    }
}
