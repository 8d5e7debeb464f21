//! Memory shared with other processes by handing them a descriptor over the bus: a memfd
//! sealed once its owner has mapped it writable, so that whoever is handed it can map it
//! read-only and nothing else: neither write it, nor grow or shrink it under its owner.

use std::ffi::c_void;
use std::io;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};

/// Why a descriptor that was handed out cannot be read as what it should hold.
#[derive(Debug)]
pub enum MapError {
    /// It could not be mapped (`what` it should hold, and why not).
    Map {
        /// What the descriptor should hold.
        what: &'static str,
        /// Why it could not be mapped.
        error: io::Error,
    },
    /// It is mapped but does not hold the layout this crate reads: another version, or
    /// another kind of file.
    Layout(String),
}

impl std::fmt::Display for MapError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MapError::Map { what, error } => write!(f, "cannot map {what}: {error}"),
            MapError::Layout(why) => f.write_str(why),
        }
    }
}

impl std::error::Error for MapError {}

/// A shared mapping of a file, unmapped when dropped.
pub struct Mapping {
    address: *mut c_void,
    len: usize,
}

// SAFETY: a mapping is plain memory; who reads or writes it is up to its owner.
unsafe impl Send for Mapping {}

impl Mapping {
    fn new(fd: &OwnedFd, len: usize, protection: libc::c_int) -> io::Result<Self> {
        if len == 0 {
            return Err(io::Error::new(io::ErrorKind::InvalidData, "an empty file"));
        }
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

    /// All of `fd`, mapped read-only.
    pub fn read_only(fd: &OwnedFd) -> io::Result<Self> {
        Self::new(fd, file_size(fd)?, libc::PROT_READ)
    }

    /// All of `fd`, mapped to read and write.
    pub fn read_write(fd: &OwnedFd) -> io::Result<Self> {
        Self::new(fd, file_size(fd)?, libc::PROT_READ | libc::PROT_WRITE)
    }

    /// The first byte, page-aligned.
    pub fn address(&self) -> *mut c_void {
        self.address
    }

    /// Bytes mapped.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing is mapped (never so: an empty file is refused).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// The size of the file `fd` is open on.
fn file_size(fd: &OwnedFd) -> io::Result<usize> {
    // SAFETY: fstat writes one stat to a valid pointer.
    let mut stat: libc::stat = unsafe { std::mem::zeroed() };
    // SAFETY: as above, on a descriptor the caller owns.
    if unsafe { libc::fstat(fd.as_raw_fd(), &mut stat) } != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(stat.st_size as usize)
}

impl Drop for Mapping {
    fn drop(&mut self) {
        // SAFETY: mapped in `new` and not used past the owner's life.
        unsafe { libc::munmap(self.address, self.len) };
    }
}

/// A new memfd of `len` zero bytes called `name`, and its owner's writable mapping. The
/// file is sealed: the mapping returned stays writable, but no one can map or write it
/// writable again, nor change its size.
pub fn sealed(name: &str, len: usize) -> io::Result<(OwnedFd, Mapping)> {
    memfd(name, len, libc::F_SEAL_FUTURE_WRITE)
}

/// A descriptor of `fd`'s memory open for reading alone, for whoever may only read it: the
/// seals already refuse writes, and the descriptor says so too (a duplicate would be open to
/// read and write, as the owner's is).
pub fn read_only_descriptor(fd: &OwnedFd) -> io::Result<OwnedFd> {
    use std::os::unix::fs::OpenOptionsExt;
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_CLOEXEC)
        .open(format!("/proc/self/fd/{}", fd.as_raw_fd()))?;
    Ok(file.into())
}

/// A new memfd of `len` zero bytes called `name` that others may write as well, and its
/// owner's mapping: sealed against growing and shrinking, so that no writer can take the
/// memory from under its owner (a shrunk file would fault its reader).
pub fn shared_writable(name: &str, len: usize) -> io::Result<(OwnedFd, Mapping)> {
    memfd(name, len, 0)
}

/// A memfd of `len` bytes mapped writable, its size sealed, with `seals` besides.
fn memfd(name: &str, len: usize, seals: libc::c_int) -> io::Result<(OwnedFd, Mapping)> {
    let name = std::ffi::CString::new(name)
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "a name with NUL"))?;
    // SAFETY: a NUL-terminated name and known flags.
    let raw =
        unsafe { libc::memfd_create(name.as_ptr(), libc::MFD_CLOEXEC | libc::MFD_ALLOW_SEALING) };
    if raw < 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: memfd_create returned a descriptor this process now owns.
    let fd = unsafe { OwnedFd::from_raw_fd(raw) };
    let size = libc::off_t::try_from(len)
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "too large"))?;
    // SAFETY: resizing a descriptor this process owns.
    if unsafe { libc::ftruncate(fd.as_raw_fd(), size) } != 0 {
        return Err(io::Error::last_os_error());
    }
    let mapping = Mapping::new(&fd, len, libc::PROT_READ | libc::PROT_WRITE)?;
    let seals = libc::F_SEAL_SHRINK | libc::F_SEAL_GROW | libc::F_SEAL_SEAL | seals;
    // SAFETY: fcntl on a descriptor this process owns.
    if unsafe { libc::fcntl(fd.as_raw_fd(), libc::F_ADD_SEALS, seals) } != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok((fd, mapping))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn a_read_only_descriptor_is_open_for_reading_alone_on_the_same_memory() {
        let (fd, mapping) = sealed("read-only", 4096).unwrap();
        // SAFETY: the mapping is 4096 writable bytes of the owner's.
        unsafe { mapping.address().cast::<u8>().write(42) };
        let reader = read_only_descriptor(&fd).unwrap();
        // SAFETY: fcntl on a descriptor the test owns.
        let flags = unsafe { libc::fcntl(reader.as_raw_fd(), libc::F_GETFL) };
        assert_eq!(flags & libc::O_ACCMODE, libc::O_RDONLY);
        let seen = Mapping::read_only(&reader).unwrap();
        // SAFETY: as above, mapped for reading.
        assert_eq!(unsafe { seen.address().cast::<u8>().read() }, 42);
        assert_sealed(&reader);
    }

    /// `fd` can be neither mapped writable, resized, written nor sealed otherwise.
    pub(crate) fn assert_sealed(fd: &OwnedFd) {
        // SAFETY: a pure query of a descriptor the test owns.
        let size = unsafe { libc::lseek(fd.as_raw_fd(), 0, libc::SEEK_END) } as usize;
        assert!(Mapping::new(fd, size, libc::PROT_READ | libc::PROT_WRITE).is_err());
        // SAFETY: resizing a descriptor the test owns (the seal refuses it).
        assert_ne!(unsafe { libc::ftruncate(fd.as_raw_fd(), 0) }, 0);
        let written = std::fs::File::from(fd.try_clone().unwrap());
        assert!(std::io::Write::write_all(&mut &written, b"x").is_err());
        // SAFETY: fcntl on a descriptor the test owns (F_SEAL_SEAL refuses more seals).
        let resealed =
            unsafe { libc::fcntl(fd.as_raw_fd(), libc::F_ADD_SEALS, libc::F_SEAL_WRITE) };
        assert_ne!(resealed, 0);
    }

    #[test]
    fn the_owner_writes_what_a_reader_maps_and_no_one_else_can() {
        let (fd, mapping) = sealed("test", 8192).unwrap();
        // SAFETY: the mapping holds 8192 writable bytes.
        unsafe { mapping.address().cast::<u8>().add(100).write(42) };
        let reader = Mapping::read_only(&fd).unwrap();
        assert_eq!(reader.len(), 8192);
        // SAFETY: within the 8192 bytes mapped.
        assert_eq!(unsafe { reader.address().cast::<u8>().add(100).read() }, 42);
        assert_sealed(&fd);
    }

    #[test]
    fn a_shared_writable_file_is_written_by_both_and_keeps_its_size() {
        let (fd, owner) = shared_writable("test", 4096).unwrap();
        let other = Mapping::read_write(&fd).unwrap();
        // SAFETY: both map the same 4096 writable bytes.
        unsafe { other.address().cast::<u8>().add(7).write(9) };
        // SAFETY: as above.
        assert_eq!(unsafe { owner.address().cast::<u8>().add(7).read() }, 9);
        for size in [0, 8192] {
            // SAFETY: resizing a descriptor the test owns (the seals refuse it).
            assert_ne!(unsafe { libc::ftruncate(fd.as_raw_fd(), size) }, 0);
        }
    }
}
