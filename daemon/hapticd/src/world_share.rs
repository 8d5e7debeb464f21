//! The shared world's memory: a sealed memfd the haptic thread writes the world's picture
//! into ([`hapticd_core::world_state`]) and the renderer maps read-only. hapticd hands out
//! the descriptor (`OpenWorld` on the bus); its seals let no one else write, grow or shrink
//! it, so a reader can neither disturb the haptic thread nor fault on a vanished page.

use std::ffi::c_void;
use std::io;
use std::os::fd::{AsFd, AsRawFd, FromRawFd, OwnedFd};

use hapticd_core::world_state::{
    SHARED_SIZE, SharedWorld, WorldFrame, WorldReader, WorldWriter,
};

/// A mapping, unmapped when dropped.
struct Mapping {
    address: *mut c_void,
    len: usize,
}

// SAFETY: a mapping is plain memory; who reads or writes it is up to its owner.
unsafe impl Send for Mapping {}

impl Mapping {
    fn new(fd: &OwnedFd, len: usize, protection: libc::c_int) -> io::Result<Self> {
        // SAFETY: a fresh shared mapping of an open descriptor; the kernel checks the rest.
        let address = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                len,
                protection,
                libc::MAP_SHARED,
                fd.as_raw_fd(),
                0,
            )
        };
        if address == libc::MAP_FAILED {
            return Err(io::Error::last_os_error());
        }
        Ok(Self { address, len })
    }
}

impl Drop for Mapping {
    fn drop(&mut self) {
        // SAFETY: mapped in `new` and not used past the owner's life.
        unsafe { libc::munmap(self.address, self.len) };
    }
}

/// The daemon's side of one device's shared world.
pub struct SharedWorldFile {
    fd: OwnedFd,
}

impl SharedWorldFile {
    /// A new shared world and its one writer. The writer's mapping is never unmapped: the
    /// haptic thread may write to its last tick, whatever is dropped first (a few hundred
    /// kilobytes per device, for the life of the process).
    pub fn create() -> io::Result<(Self, WorldWriter)> {
        // SAFETY: a NUL-terminated name and known flags.
        let raw = unsafe {
            libc::memfd_create(
                c"hapticd-world".as_ptr(),
                libc::MFD_CLOEXEC | libc::MFD_ALLOW_SEALING,
            )
        };
        if raw < 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: memfd_create returned a descriptor this process now owns.
        let fd = unsafe { OwnedFd::from_raw_fd(raw) };
        // SAFETY: resizing a descriptor this process owns.
        if unsafe { libc::ftruncate(fd.as_raw_fd(), SHARED_SIZE as libc::off_t) } != 0 {
            return Err(io::Error::last_os_error());
        }
        let mapping = Mapping::new(&fd, SHARED_SIZE, libc::PROT_READ | libc::PROT_WRITE)?;
        // SAFETY: the mapping is SHARED_SIZE bytes, page-aligned, only this writer writes
        // it, and it is never unmapped.
        let writer = unsafe { WorldWriter::new(mapping.address.cast::<SharedWorld>()) };
        std::mem::forget(mapping);
        // The mapping made above stays writable; from now on no one can map or write it
        // writable again, or change its size.
        let seals =
            libc::F_SEAL_SHRINK | libc::F_SEAL_GROW | libc::F_SEAL_FUTURE_WRITE | libc::F_SEAL_SEAL;
        // SAFETY: fcntl on a descriptor this process owns.
        if unsafe { libc::fcntl(fd.as_raw_fd(), libc::F_ADD_SEALS, seals) } != 0 {
            return Err(io::Error::last_os_error());
        }
        Ok((Self { fd }, writer))
    }

    /// A new descriptor of the file, to hand to a reader.
    pub fn share(&self) -> io::Result<OwnedFd> {
        self.fd.as_fd().try_clone_to_owned()
    }
}

/// A reader's view of a shared world it was handed.
pub struct MappedWorld {
    reader: WorldReader,
    _mapping: Mapping,
}

impl MappedWorld {
    /// Map `fd` read-only and check it holds a shared world of this layout.
    pub fn open(fd: &OwnedFd) -> Result<Self, String> {
        // SAFETY: fstat writes one stat to a valid pointer.
        let mut stat: libc::stat = unsafe { std::mem::zeroed() };
        // SAFETY: as above, on a descriptor the caller owns.
        if unsafe { libc::fstat(fd.as_raw_fd(), &mut stat) } != 0 {
            return Err(format!("fstat: {}", io::Error::last_os_error()));
        }
        let len = stat.st_size as usize;
        if len < SHARED_SIZE {
            return Err(format!(
                "{len} bytes, a shared world has {SHARED_SIZE}"
            ));
        }
        let mapping = Mapping::new(fd, len, libc::PROT_READ)
            .map_err(|e| format!("cannot map the shared world: {e}"))?;
        // SAFETY: the mapping holds `len` bytes, page-aligned, for the reader's life (both
        // live in this struct and the reader is dropped first).
        let reader = unsafe { WorldReader::new(mapping.address.cast::<SharedWorld>(), len) }
            .map_err(|e| e.to_string())?;
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

    #[test]
    fn a_reader_maps_what_the_writer_writes_and_cannot_write_it() {
        let (file, mut writer) = SharedWorldFile::create().unwrap();
        let shared = file.share().unwrap();
        let world = MappedWorld::open(&shared).unwrap();
        writer.write(|f| f.body_count = 7);
        let mut frame = Box::new(WorldFrame::empty());
        assert_eq!(world.read(&mut frame), Some(2));
        assert_eq!(frame.body_count, 7);
        // Sealed: a writable mapping and a resize are refused.
        assert!(Mapping::new(&shared, SHARED_SIZE, libc::PROT_READ | libc::PROT_WRITE).is_err());
        // SAFETY: resizing a descriptor the test owns (the seal refuses it).
        assert_ne!(unsafe { libc::ftruncate(shared.as_raw_fd(), 0) }, 0);
        let written = std::fs::File::from(shared.try_clone().unwrap());
        assert!(std::io::Write::write_all(&mut &written, b"x").is_err());
    }

    #[test]
    fn a_file_too_small_is_not_a_world() {
        // SAFETY: a NUL-terminated name and known flags.
        let raw = unsafe { libc::memfd_create(c"small".as_ptr(), libc::MFD_CLOEXEC) };
        // SAFETY: memfd_create returned a descriptor the test now owns.
        let fd = unsafe { OwnedFd::from_raw_fd(raw) };
        let error = MappedWorld::open(&fd).err().unwrap();
        assert!(error.contains("bytes"), "{error}");
    }
}
