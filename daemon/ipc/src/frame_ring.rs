//! A ring of rendered frames in shared memory, for viewers (`OpenFrameStream` of the
//! renderer): a header, then [`SLOTS`] slots of one RGBA frame each. The renderer writes
//! each frame into the next slot under that slot's sequence lock and then publishes its
//! number; a viewer copies the latest slot and throws the copy away if a write overlapped.
//! Neither ever waits for the other.

use std::io;
use std::os::fd::OwnedFd;
use std::sync::atomic::{AtomicU64, Ordering, fence};

use crate::shared_memory::{MapError, Mapping, sealed};

/// First bytes of a frame ring.
pub const MAGIC: [u8; 8] = *b"hapticdF";
/// Layout version.
pub const VERSION: u32 = 1;
/// Frames a ring holds: a viewer copying one while the next two are drawn still finishes.
pub const SLOTS: usize = 3;

/// The ring's header.
#[repr(C)]
struct Header {
    magic: [u8; 8],
    version: u32,
    slots: u32,
    width: u32,
    height: u32,
    /// Bytes from one slot's start to the next.
    stride: u64,
    /// Frames written; the latest is in slot `(frames - 1) % slots`. 0: none yet.
    frames: AtomicU64,
}

/// A slot's header, before its pixels.
#[repr(C)]
struct Slot {
    /// Even when whole, odd while written.
    sequence: AtomicU64,
    /// The frame's number (1 for the first).
    frame: u64,
}

/// Bytes before the first slot (a cache line's multiple).
const HEADER: usize = 64;
/// Bytes before a slot's pixels.
const SLOT_HEADER: usize = 64;

fn stride(width: u32, height: u32) -> usize {
    (SLOT_HEADER + width as usize * height as usize * 4).next_multiple_of(64)
}

/// The renderer's side of a ring.
pub struct FrameRingWriter {
    fd: OwnedFd,
    mapping: Mapping,
    width: u32,
    height: u32,
    frames: u64,
}

impl FrameRingWriter {
    /// A ring of `width × height` frames.
    pub fn create(width: u32, height: u32) -> io::Result<Self> {
        let len = HEADER + SLOTS * stride(width, height);
        let (fd, mapping) = sealed("hapticd-frames", len)?;
        // SAFETY: the mapping holds `len` zeroed, page-aligned bytes, the header first.
        unsafe {
            mapping.address().cast::<Header>().write(Header {
                magic: MAGIC,
                version: VERSION,
                slots: SLOTS as u32,
                width,
                height,
                stride: stride(width, height) as u64,
                frames: AtomicU64::new(0),
            })
        };
        Ok(Self {
            fd,
            mapping,
            width,
            height,
            frames: 0,
        })
    }

    /// A new descriptor of the ring, open for reading alone, to hand to a viewer.
    pub fn share(&self) -> io::Result<OwnedFd> {
        crate::shared_memory::read_only_descriptor(&self.fd)
    }

    /// The frames' size, pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Write the next frame (`rgba`: width × height × 4 bytes, rows top down); its number.
    pub fn write(&mut self, rgba: &[u8]) -> u64 {
        let stride = stride(self.width, self.height);
        let pixels = rgba.len().min(stride - SLOT_HEADER);
        let index = (self.frames % SLOTS as u64) as usize;
        let frame = self.frames + 1;
        // SAFETY: the header and slot `index` lie within the mapping (see `create`); only
        // this writer writes them.
        unsafe {
            let base = self.mapping.address().cast::<u8>();
            let slot = &mut *base.add(HEADER + index * stride).cast::<Slot>();
            let sequence = slot.sequence.load(Ordering::Relaxed);
            slot.sequence.store(sequence + 1, Ordering::Relaxed);
            fence(Ordering::Release);
            slot.frame = frame;
            std::ptr::copy_nonoverlapping(
                rgba.as_ptr(),
                base.add(HEADER + index * stride + SLOT_HEADER),
                pixels,
            );
            slot.sequence.store(sequence + 2, Ordering::Release);
            (*base.cast::<Header>())
                .frames
                .store(frame, Ordering::Release);
        }
        self.frames = frame;
        frame
    }
}

/// A viewer's side of a ring it was handed.
///
/// ```
/// use hapticd_ipc::frame_ring::{FrameRingReader, FrameRingWriter};
///
/// // The renderer's side: a ring of 2 × 1 pixel frames, RGBA.
/// let mut ring = FrameRingWriter::create(2, 1)?;
/// let viewer = FrameRingReader::open(&ring.share()?)?;
/// let mut rgba = Vec::new();
/// assert_eq!(viewer.read(&mut rgba), None); // nothing drawn yet
/// let frame = ring.write(&[255, 0, 0, 255, 0, 0, 255, 255]);
/// assert_eq!(viewer.read(&mut rgba), Some(frame));
/// assert_eq!(rgba[..4], [255, 0, 0, 255]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct FrameRingReader {
    mapping: Mapping,
    width: u32,
    height: u32,
    stride: usize,
    slots: usize,
}

impl FrameRingReader {
    /// Map `fd` read-only and check it is a frame ring of this layout.
    pub fn open(fd: &OwnedFd) -> Result<Self, MapError> {
        let mapping = Mapping::read_only(fd).map_err(|error| MapError::Map {
            what: "the frames",
            error,
        })?;
        if mapping.len() < HEADER {
            let why = format!("{} bytes: not a frame ring", mapping.len());
            return Err(MapError::Layout(why));
        }
        // SAFETY: the header lies within the mapping (checked above); its fields other
        // than `frames` are written once, before the descriptor was handed out.
        let header = unsafe { &*mapping.address().cast::<Header>() };
        let (width, height) = (header.width, header.height);
        let stride = stride(width, height);
        let slots = header.slots as usize;
        let fits = (slots as u64)
            .checked_mul(stride as u64)
            .is_some_and(|n| n + HEADER as u64 <= mapping.len() as u64);
        if header.magic != MAGIC
            || header.version != VERSION
            || header.stride != stride as u64
            || slots == 0
            || !fits
        {
            return Err(MapError::Layout(format!(
                "not a frame ring of layout {VERSION} (magic {:?}, layout {}, {} bytes)",
                header.magic,
                header.version,
                mapping.len()
            )));
        }
        Ok(Self {
            mapping,
            width,
            height,
            stride,
            slots,
        })
    }

    /// The frames' size, pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The number of the latest frame written (0: none yet).
    pub fn latest(&self) -> u64 {
        // SAFETY: the header lies within the mapping; `frames` is only used atomically.
        unsafe { &*self.mapping.address().cast::<Header>() }
            .frames
            .load(Ordering::Acquire)
    }

    /// Copy the latest frame into `rgba` (resized to width × height × 4); its number, or
    /// None when there is none yet or it was overwritten while copied.
    pub fn read(&self, rgba: &mut Vec<u8>) -> Option<u64> {
        let latest = self.latest();
        if latest == 0 {
            return None;
        }
        let index = ((latest - 1) % self.slots as u64) as usize;
        let pixels = self.width as usize * self.height as usize * 4;
        rgba.resize(pixels, 0);
        // SAFETY: slot `index` lies within the mapping (checked in `open`); the copy is kept
        // only if no write overlapped it.
        unsafe {
            let base = self.mapping.address().cast::<u8>();
            let slot = &*base.add(HEADER + index * self.stride).cast::<Slot>();
            let before = slot.sequence.load(Ordering::Acquire);
            if before % 2 == 1 {
                return None;
            }
            let frame = std::ptr::addr_of!(slot.frame).read_volatile();
            let source = base.add(HEADER + index * self.stride + SLOT_HEADER);
            std::ptr::copy_nonoverlapping(source, rgba.as_mut_ptr(), pixels);
            fence(Ordering::Acquire);
            (slot.sequence.load(Ordering::Relaxed) == before).then_some(frame)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_viewer_reads_the_latest_frame_written() {
        let mut ring = FrameRingWriter::create(3, 2).unwrap();
        let shared = ring.share().unwrap();
        let viewer = FrameRingReader::open(&shared).unwrap();
        assert_eq!(viewer.size(), (3, 2));
        let mut rgba = Vec::new();
        assert_eq!(viewer.read(&mut rgba), None);
        for n in 1..=5u8 {
            ring.write(&[n; 24]);
        }
        assert_eq!(viewer.read(&mut rgba), Some(5));
        assert_eq!(rgba, vec![5; 24]);
        crate::shared_memory::tests::assert_sealed(&shared);
    }

    #[test]
    fn a_world_is_not_a_frame_ring() {
        let (file, _writer) = crate::world_share::SharedWorldFile::create().unwrap();
        let error = FrameRingReader::open(&file.share().unwrap()).err().unwrap();
        assert!(matches!(&error, MapError::Layout(why) if why.contains("not a frame ring")));
    }
}
