//! A bounded single-producer single-consumer ring: how the real-time thread hands log events
//! and per-tick records to ordinary threads, and takes commands (a new scene, parameters)
//! from them, without locks or allocation. When full, pushes fail rather than block, and hand
//! the value back, so the real-time thread never frees one by accident.

use std::cell::UnsafeCell;
use std::mem::MaybeUninit;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

struct Ring<T> {
    slots: Box<[UnsafeCell<MaybeUninit<T>>]>,
    /// Next slot to read; written by the consumer only.
    head: AtomicUsize,
    /// Next slot to write; written by the producer only.
    tail: AtomicUsize,
}

// SAFETY: slots are only written by the single producer before publishing `tail`, and only
// read by the single consumer after observing it; T is Send.
unsafe impl<T: Send> Sync for Ring<T> {}

impl<T> Drop for Ring<T> {
    fn drop(&mut self) {
        let (mut head, tail) = (*self.head.get_mut(), *self.tail.get_mut());
        while head != tail {
            // SAFETY: slots from head to tail were written and never read.
            unsafe { self.slots[head].get_mut().assume_init_drop() };
            head = (head + 1) % self.slots.len();
        }
    }
}

/// The writing end.
pub struct Producer<T> {
    ring: Arc<Ring<T>>,
}

/// The reading end.
pub struct Consumer<T> {
    ring: Arc<Ring<T>>,
}

/// A ring holding up to `capacity` values (allocated here, never again).
///
/// ```
/// use hapticd_core::sync::spsc;
///
/// let (mut commands, mut taken) = spsc::channel(2);
/// assert!(commands.push(1));
/// assert!(commands.push(2));
/// // Full: the value is handed back, nothing waits.
/// assert_eq!(commands.try_push(3), Err(3));
/// assert_eq!(taken.pop(), Some(1));
/// assert_eq!(taken.pop(), Some(2));
/// assert_eq!(taken.pop(), None);
/// ```
pub fn channel<T: Send>(capacity: usize) -> (Producer<T>, Consumer<T>) {
    let slots = (0..capacity + 1)
        .map(|_| UnsafeCell::new(MaybeUninit::uninit()))
        .collect();
    let ring = Arc::new(Ring {
        slots,
        head: AtomicUsize::new(0),
        tail: AtomicUsize::new(0),
    });
    (Producer { ring: ring.clone() }, Consumer { ring })
}

impl<T: Send> Producer<T> {
    /// [rt] Append `value`; returns false (dropping it) when the ring is full.
    pub fn push(&mut self, value: T) -> bool {
        self.try_push(value).is_ok()
    }

    /// Whether a push would succeed now; it still will later, since only this end fills
    /// the ring.
    pub fn has_room(&self) -> bool {
        let ring = &*self.ring;
        let next = (ring.tail.load(Ordering::Relaxed) + 1) % ring.slots.len();
        next != ring.head.load(Ordering::Acquire)
    }

    /// [rt] Append `value`, or hand it back when the ring is full.
    pub fn try_push(&mut self, value: T) -> Result<(), T> {
        let ring = &*self.ring;
        let tail = ring.tail.load(Ordering::Relaxed);
        let next = (tail + 1) % ring.slots.len();
        if next == ring.head.load(Ordering::Acquire) {
            return Err(value);
        }
        // SAFETY: the slot at `tail` is not visible to the consumer until `tail` advances.
        unsafe { (*ring.slots[tail].get()).write(value) };
        ring.tail.store(next, Ordering::Release);
        Ok(())
    }
}

impl<T: Send> Consumer<T> {
    /// Take the oldest value, if any.
    pub fn pop(&mut self) -> Option<T> {
        let ring = &*self.ring;
        let head = ring.head.load(Ordering::Relaxed);
        if head == ring.tail.load(Ordering::Acquire) {
            return None;
        }
        // SAFETY: the producer initialised this slot before publishing `tail` past it.
        let value = unsafe { (*ring.slots[head].get()).assume_init_read() };
        ring.head
            .store((head + 1) % ring.slots.len(), Ordering::Release);
        Some(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_arrive_in_order_across_threads() {
        let (mut tx, mut rx) = channel::<u64>(64);
        let writer = std::thread::spawn(move || {
            let mut sent = 0;
            while sent < 100_000 {
                if tx.push(sent) {
                    sent += 1;
                }
            }
        });
        let mut expected = 0;
        while expected < 100_000 {
            if let Some(v) = rx.pop() {
                assert_eq!(v, expected);
                expected += 1;
            }
        }
        writer.join().unwrap();
    }

    #[test]
    fn a_full_ring_refuses_instead_of_blocking() {
        let (mut tx, mut rx) = channel::<u8>(2);
        assert!(tx.push(1) && tx.has_room() && tx.push(2));
        assert!(!tx.has_room() && !tx.push(3));
        assert_eq!(rx.pop(), Some(1));
        assert!(tx.has_room());
        assert_eq!((rx.pop(), rx.pop()), (Some(2), None));
    }

    #[test]
    fn owned_values_come_back_when_full_and_are_dropped_with_the_ring() {
        let value = std::sync::Arc::new(());
        let (mut tx, mut rx) = channel(1);
        assert!(tx.try_push(value.clone()).is_ok());
        let refused = tx.try_push(value.clone()).unwrap_err();
        assert_eq!(std::sync::Arc::strong_count(&value), 3);
        drop(refused);
        assert!(rx.pop().is_some());
        tx.push(value.clone());
        drop((tx, rx));
        assert_eq!(
            std::sync::Arc::strong_count(&value),
            1,
            "unread value leaked"
        );
    }
}
