//! The shared world's memory: a sealed memfd the haptic thread writes the world's picture
//! into ([`hapticd_core::world_state`]) and the renderer maps read-only. hapticd hands out
//! the descriptor (`OpenWorld` on the bus); its seals let no one else write, grow or shrink
//! it, so a reader can neither disturb the haptic thread nor fault on a vanished page.

use std::io;
use std::os::fd::OwnedFd;

use hapticd_core::world_state::{SHARED_SIZE, SharedWorld, WorldFrame, WorldReader, WorldWriter};

use crate::shared_memory::{MapError, Mapping, sealed};

/// The daemon's side of one device's shared world.
pub struct SharedWorldFile {
    fd: OwnedFd,
}

impl SharedWorldFile {
    /// A new shared world and its one writer. The writer's mapping is never unmapped: the
    /// haptic thread may write to its last tick, whatever is dropped first (a few hundred
    /// kilobytes per device, for the life of the process).
    pub fn create() -> io::Result<(Self, WorldWriter)> {
        let (fd, mapping) = sealed("hapticd-world", SHARED_SIZE)?;
        // SAFETY: the mapping is SHARED_SIZE bytes, page-aligned, only this writer writes
        // it, and it is never unmapped.
        let writer = unsafe { WorldWriter::new(mapping.address().cast::<SharedWorld>()) };
        std::mem::forget(mapping);
        Ok((Self { fd }, writer))
    }

    /// A new descriptor of the file, open for reading alone, to hand to a reader.
    pub fn share(&self) -> io::Result<OwnedFd> {
        crate::shared_memory::read_only_descriptor(&self.fd)
    }
}

/// A reader's view of a shared world it was handed.
///
/// ```
/// use hapticd_core::world_state::WorldFrame;
/// use hapticd_ipc::world_share::{MappedWorld, SharedWorldFile};
///
/// // The daemon's side: the file, and the haptic thread's writer.
/// let (file, mut writer) = SharedWorldFile::create()?;
/// writer.write(|frame| frame.body_count = 3);
/// // A reader's side: the descriptor the bus hands out, mapped read-only.
/// let world = MappedWorld::open(&file.share()?)?;
/// let mut frame = Box::new(WorldFrame::empty());
/// assert!(world.read(&mut frame).is_some());
/// assert_eq!(frame.body_count, 3);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct MappedWorld {
    reader: WorldReader,
    _mapping: Mapping,
}

impl MappedWorld {
    /// Map `fd` read-only and check it holds a shared world of this layout.
    pub fn open(fd: &OwnedFd) -> Result<Self, MapError> {
        let mapping = Mapping::read_only(fd).map_err(|error| MapError::Map {
            what: "the shared world",
            error,
        })?;
        // SAFETY: the mapping holds `len` bytes, page-aligned, for the reader's life (both
        // live in this struct and the reader is dropped first).
        let reader =
            unsafe { WorldReader::new(mapping.address().cast::<SharedWorld>(), mapping.len()) }
                .map_err(|e| MapError::Layout(e.to_string()))?;
        Ok(Self {
            reader,
            _mapping: mapping,
        })
    }

    /// Copy the latest whole frame into `out`; its sequence, or None if none could be read
    /// whole.
    pub fn read(&self, out: &mut WorldFrame) -> Option<u64> {
        self.reader.read(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::fd::{AsRawFd, FromRawFd};

    #[test]
    fn a_reader_maps_what_the_writer_writes_and_cannot_write_it() {
        let (file, mut writer) = SharedWorldFile::create().unwrap();
        let shared = file.share().unwrap();
        let world = MappedWorld::open(&shared).unwrap();
        writer.write(|f| f.body_count = 7);
        let mut frame = Box::new(WorldFrame::empty());
        assert_eq!(world.read(&mut frame), Some(2));
        assert_eq!(frame.body_count, 7);
        crate::shared_memory::tests::assert_sealed(&shared);
    }

    #[test]
    fn a_file_too_small_is_not_a_world() {
        // SAFETY: a NUL-terminated name and known flags.
        let raw = unsafe { libc::memfd_create(c"small".as_ptr(), libc::MFD_CLOEXEC) };
        // SAFETY: memfd_create returned a descriptor the test now owns.
        let fd = unsafe { OwnedFd::from_raw_fd(raw) };
        // SAFETY: resizing a descriptor the test owns.
        assert_eq!(unsafe { libc::ftruncate(fd.as_raw_fd(), 4096) }, 0);
        let error = MappedWorld::open(&fd).err().unwrap();
        assert!(
            matches!(&error, MapError::Layout(why) if why.contains("bytes")),
            "{error}"
        );
    }
}
