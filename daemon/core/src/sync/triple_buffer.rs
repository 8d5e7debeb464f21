//! A triple buffer: the real-time thread publishes its latest state, other threads read the
//! latest complete one; neither waits for the other and nothing is allocated after creation.

use std::cell::UnsafeCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

/// Bit set in the shared index when the middle buffer holds a value not yet read.
const FRESH: u8 = 0b100;

struct Shared<T> {
    buffers: [UnsafeCell<T>; 3],
    /// Index of the middle buffer, plus [`FRESH`].
    middle: AtomicU8,
}

// SAFETY: each buffer is owned by exactly one of writer, reader and the middle slot at any
// time; ownership moves only through the atomic swap.
unsafe impl<T: Send> Sync for Shared<T> {}

/// The writing side.
pub struct Writer<T> {
    shared: Arc<Shared<T>>,
    back: u8,
}

/// The reading side.
pub struct Reader<T> {
    shared: Arc<Shared<T>>,
    front: u8,
}

/// A triple buffer whose three slots start as `initial`.
///
/// ```
/// use hapticd_core::sync::triple_buffer::triple_buffer;
///
/// let (mut frames, mut latest) = triple_buffer([0.0; 3]);
/// frames.publish(|f| f[0] = 1.0);
/// frames.publish(|f| f[0] = 2.0);
/// // A reader sees the last whole frame, never one half written.
/// assert_eq!(latest.latest()[0], 2.0);
/// ```
pub fn triple_buffer<T: Clone + Send>(initial: T) -> (Writer<T>, Reader<T>) {
    let shared = Arc::new(Shared {
        buffers: [
            UnsafeCell::new(initial.clone()),
            UnsafeCell::new(initial.clone()),
            UnsafeCell::new(initial),
        ],
        middle: AtomicU8::new(1),
    });
    (
        Writer {
            shared: shared.clone(),
            back: 0,
        },
        Reader { shared, front: 2 },
    )
}

impl<T: Send> Writer<T> {
    /// [rt] Fill the back buffer with `fill` and publish it.
    pub fn publish(&mut self, fill: impl FnOnce(&mut T)) {
        // SAFETY: the back buffer belongs to the writer alone.
        fill(unsafe { &mut *self.shared.buffers[self.back as usize].get() });
        let previous = self.shared.middle.swap(self.back | FRESH, Ordering::AcqRel);
        self.back = previous & !FRESH;
    }
}

impl<T: Send> Reader<T> {
    /// The latest published value (the same one again if nothing new was published).
    pub fn latest(&mut self) -> &T {
        if self.shared.middle.load(Ordering::Acquire) & FRESH != 0 {
            let previous = self.shared.middle.swap(self.front, Ordering::AcqRel);
            self.front = previous & !FRESH;
        }
        // SAFETY: the front buffer belongs to the reader alone.
        unsafe { &*self.shared.buffers[self.front as usize].get() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reader_sees_whole_values_and_never_goes_back() {
        let (mut w, mut r) = triple_buffer([0u64; 16]);
        let writer = std::thread::spawn(move || {
            for i in 1..=200_000u64 {
                w.publish(|v| v.fill(i));
            }
        });
        let mut last = 0;
        while last < 200_000 {
            let v = *r.latest();
            assert!(v.iter().all(|x| *x == v[0]), "torn value {v:?}");
            assert!(v[0] >= last);
            last = v[0];
        }
        writer.join().unwrap();
    }
}
