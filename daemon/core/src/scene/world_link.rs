//! The memory between a device's remote scene and the network bridge that carries its world
//! ([`remote`](super::remote)): the daemon makes it, one per device, and hands it to the
//! bridge (`Device.OpenWorldLink`), so the haptic process never touches the network.
//!
//! Two ways through it, each message a run of bytes under its own sequence lock:
//! - the **inbox**, bridge → daemon: the latest world update (a newer one replaces it: only
//!   the last step matters);
//! - the **outbox**, daemon → bridge: a ring of host messages, numbered, read in order (each
//!   carries hand-backs the world must not lose; a bridge that falls a whole ring behind
//!   knows how many it missed).
//!
//! The bytes are words of atomics, so neither side can tear the other's reads into
//! undefined behaviour; what the inbox holds is checked where it is decoded.

use std::sync::atomic::{AtomicU64, Ordering, fence};

use crate::scene::remote::{MAX_HOST_BYTES, MAX_WORLD_BYTES};
use crate::shared_header::{Header, WrongLayout};

/// First bytes of a world link.
pub const MAGIC: [u8; 8] = *b"hapticdL";

/// Layout version of [`SharedWorldLink`].
pub const VERSION: u32 = 1;

/// Messages the outbox holds.
pub const OUTBOX_SLOTS: usize = 32;

const INBOX_WORDS: usize = MAX_WORLD_BYTES.div_ceil(8);
const OUTBOX_WORDS: usize = MAX_HOST_BYTES.div_ceil(8);

/// Attempts at a slot being written before a read gives up for now.
const READ_ATTEMPTS: usize = 8;

/// One message: its sequence lock (odd while written), its length and its bytes.
#[repr(C)]
struct Slot<const WORDS: usize> {
    sequence: AtomicU64,
    len: AtomicU64,
    words: [AtomicU64; WORDS],
}

impl<const WORDS: usize> Slot<WORDS> {
    /// Write `bytes` (at most `WORDS * 8`; longer is cut, never written past) as message
    /// number `number` (the sequence ends at `2 * number`).
    fn write(&self, number: u64, bytes: &[u8]) {
        let bytes = &bytes[..bytes.len().min(WORDS * 8)];
        self.sequence.store(2 * number - 1, Ordering::Relaxed);
        fence(Ordering::Release);
        self.len.store(bytes.len() as u64, Ordering::Relaxed);
        for (word, chunk) in self.words.iter().zip(bytes.chunks(8)) {
            let mut w = [0; 8];
            w[..chunk.len()].copy_from_slice(chunk);
            word.store(u64::from_le_bytes(w), Ordering::Relaxed);
        }
        self.sequence.store(2 * number, Ordering::Release);
    }

    /// The number of the message here and its bytes into `out`, or None while one is
    /// being written (or was never written).
    fn read(&self, out: &mut Vec<u8>) -> Option<u64> {
        for _ in 0..READ_ATTEMPTS {
            let before = self.sequence.load(Ordering::Acquire);
            if before == 0 || before & 1 == 1 {
                std::hint::spin_loop();
                continue;
            }
            let len = (self.len.load(Ordering::Relaxed) as usize).min(WORDS * 8);
            out.clear();
            for word in &self.words[..len.div_ceil(8)] {
                out.extend_from_slice(&word.load(Ordering::Relaxed).to_le_bytes());
            }
            out.truncate(len);
            fence(Ordering::Acquire);
            if self.sequence.load(Ordering::Relaxed) == before {
                return Some(before / 2);
            }
        }
        None
    }
}

/// The shared block.
#[repr(C)]
pub struct SharedWorldLink {
    header: Header,
    inbox: Slot<INBOX_WORDS>,
    /// Host messages written so far; message `k` (from 1) is in slot `k % OUTBOX_SLOTS`.
    sent: AtomicU64,
    outbox: [Slot<OUTBOX_WORDS>; OUTBOX_SLOTS],
}

/// Bytes of a world link.
pub const SHARED_SIZE: usize = std::mem::size_of::<SharedWorldLink>();

impl SharedWorldLink {
    /// Initialise the block at `block`: its header, nothing in either direction.
    ///
    /// # Safety
    /// `block` is valid for writes of [`SHARED_SIZE`] bytes and aligned.
    pub unsafe fn init(block: *mut SharedWorldLink) {
        // SAFETY: as the caller promises; the block holds only plain integers.
        unsafe {
            block.write_bytes(0, 1);
            std::ptr::addr_of_mut!((*block).header).write(Header::new(MAGIC, VERSION, SHARED_SIZE));
        }
    }

    /// The block at `block` of `len` bytes, checked to be a world link of this layout.
    ///
    /// # Safety
    /// `block` is valid for reads of `len` bytes, aligned, and stays mapped while the
    /// reference is used.
    pub unsafe fn at<'a>(
        block: *const SharedWorldLink,
        len: usize,
    ) -> Result<&'a SharedWorldLink, WrongLayout> {
        // SAFETY: as the caller promises.
        unsafe {
            Header::new(MAGIC, VERSION, SHARED_SIZE).check(
                block.cast::<Header>(),
                len,
                "a world link",
            )?;
            Ok(&*block)
        }
    }

    /// [bridge] Put world update number `number` (from 1, increasing) in the inbox.
    pub fn deliver(&self, number: u64, update: &[u8]) {
        self.inbox.write(number.max(1), update);
    }

    /// [daemon] The number of the latest world update and its bytes into `out`; None before
    /// the first, or while one is being delivered.
    pub fn latest(&self, out: &mut Vec<u8>) -> Option<u64> {
        self.inbox.read(out)
    }

    /// [daemon] Put a host message in the outbox.
    pub fn send(&self, message: &[u8]) {
        let number = self.sent.load(Ordering::Relaxed) + 1;
        self.outbox[number as usize % OUTBOX_SLOTS].write(number, message);
        self.sent.store(number, Ordering::Release);
    }

    /// [bridge] Host messages sent so far.
    pub fn sent(&self) -> u64 {
        self.sent.load(Ordering::Acquire)
    }

    /// [bridge] Host message `number` into `out`, if the outbox still holds it whole.
    pub fn message(&self, number: u64, out: &mut Vec<u8>) -> bool {
        let slot = &self.outbox[number as usize % OUTBOX_SLOTS];
        slot.read(out) == Some(number)
    }
}

/// [bridge] A reader of a link's outbox that takes every host message once, in order.
#[derive(Debug)]
pub struct Outbox {
    next: u64,
    missed: u64,
}

impl Outbox {
    /// A reader of `link` from its next message on.
    pub fn after(link: &SharedWorldLink) -> Self {
        Self {
            next: link.sent() + 1,
            missed: 0,
        }
    }

    /// Hand `each` every message sent since the last call (through `scratch`), in order.
    /// A reader a whole ring behind starts again from the oldest message the ring holds;
    /// returns how many were lost so far when that happened.
    pub fn read(
        &mut self,
        link: &SharedWorldLink,
        scratch: &mut Vec<u8>,
        mut each: impl FnMut(&[u8]),
    ) -> Option<u64> {
        let sent = link.sent();
        let oldest = sent.saturating_sub(OUTBOX_SLOTS as u64 - 1).max(1);
        let lost = (self.next < oldest).then(|| {
            self.missed += oldest - self.next;
            self.next = oldest;
            self.missed
        });
        while self.next <= sent {
            if link.message(self.next, scratch) {
                each(scratch);
            }
            self.next += 1;
        }
        lost
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block() -> Box<SharedWorldLink> {
        let mut memory = Box::<SharedWorldLink>::new_uninit();
        // SAFETY: a fresh, aligned allocation of the block's size.
        unsafe {
            SharedWorldLink::init(memory.as_mut_ptr());
            memory.assume_init()
        }
    }

    #[test]
    fn the_inbox_keeps_the_latest_update_whole() {
        let link = block();
        let mut out = Vec::new();
        assert_eq!(link.latest(&mut out), None, "nothing delivered yet");
        link.deliver(1, b"first update");
        link.deliver(2, b"the second, longer, update");
        assert_eq!(link.latest(&mut out), Some(2));
        assert_eq!(out, b"the second, longer, update");
        link.deliver(3, b"short");
        assert_eq!(link.latest(&mut out), Some(3));
        assert_eq!(out, b"short", "no bytes of the longer one left over");
        // What no update could be is cut to the inbox, never written past it.
        link.deliver(4, &vec![7; MAX_WORLD_BYTES + 100]);
        assert_eq!(link.latest(&mut out), Some(4));
        assert_eq!(out.len(), INBOX_WORDS * 8);
    }

    #[test]
    fn the_outbox_is_read_in_order_until_a_whole_ring_overtakes_its_reader() {
        let link = block();
        let mut out = Vec::new();
        for k in 1..=5u8 {
            link.send(&[k; 3]);
        }
        assert_eq!(link.sent(), 5);
        for k in 1..=5u8 {
            assert!(link.message(k as u64, &mut out));
            assert_eq!(out, [k; 3]);
        }
        for k in 6..=(5 + OUTBOX_SLOTS as u64) {
            link.send(&k.to_le_bytes());
        }
        assert!(!link.message(5, &mut out), "overwritten by message 37");
        assert!(link.message(6, &mut out));
        assert_eq!(out, 6u64.to_le_bytes());
    }

    #[test]
    fn a_block_of_another_layout_is_refused() {
        let link = block();
        let ptr: *const SharedWorldLink = &*link;
        // SAFETY: the block is SHARED_SIZE bytes.
        assert!(unsafe { SharedWorldLink::at(ptr, SHARED_SIZE) }.is_ok());
        // SAFETY: as above; fewer bytes claimed.
        assert!(unsafe { SharedWorldLink::at(ptr, SHARED_SIZE - 8) }.is_err());
    }
}
