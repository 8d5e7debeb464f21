//! The memory of a device's world link (`hapticd_core::scene::world_link`): a memfd the daemon
//! makes for each device, through which its remote scene and the network bridge exchange
//! world updates and host messages. Its size is sealed, so the bridge can never take the
//! memory from under the daemon.

use std::io;
use std::ops::Deref;
use std::os::fd::OwnedFd;
use std::sync::Arc;

use hapticd_core::scene::world_link::{SHARED_SIZE, SharedWorldLink};

use crate::shared_memory::{MapError, Mapping, shared_writable};

/// A mapped world link: the daemon's, or the bridge's from the descriptor it was handed.
///
/// ```
/// use hapticd_ipc::world_link_share::WorldLink;
///
/// let (daemon, fd) = WorldLink::create()?;
/// let bridge = WorldLink::open(&fd)?;
/// bridge.deliver(1, b"an update");
/// let mut bytes = Vec::new();
/// assert_eq!(daemon.latest(&mut bytes), Some(1));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct WorldLink {
    mapping: Mapping,
}

// SAFETY: the block is atomics only, mapped for the life of the value.
unsafe impl Sync for WorldLink {}

impl std::fmt::Debug for WorldLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WorldLink")
            .field("sent", &self.sent())
            .finish_non_exhaustive()
    }
}

impl WorldLink {
    /// A new, empty link, and the descriptor to share it by.
    pub fn create() -> io::Result<(Self, OwnedFd)> {
        let (fd, mapping) = shared_writable("hapticd-world-link", SHARED_SIZE)?;
        // SAFETY: the mapping holds SHARED_SIZE writable, page-aligned bytes.
        unsafe { SharedWorldLink::init(mapping.address().cast()) };
        Ok((Self { mapping }, fd))
    }

    /// Map `fd` and check it holds a world link of this layout.
    pub fn open(fd: &OwnedFd) -> Result<Self, MapError> {
        let mapping = Mapping::read_write(fd).map_err(|error| MapError::Map {
            what: "the world link",
            error,
        })?;
        // SAFETY: the mapping holds `len` bytes, page-aligned, while self lives.
        unsafe { SharedWorldLink::at(mapping.address().cast(), mapping.len()) }
            .map_err(|e| MapError::Layout(e.to_string()))?;
        Ok(Self { mapping })
    }
}

impl Deref for WorldLink {
    type Target = SharedWorldLink;

    fn deref(&self) -> &SharedWorldLink {
        // SAFETY: initialised or checked when made; mapped while self lives.
        unsafe { &*self.mapping.address().cast::<SharedWorldLink>() }
    }
}

/// A device's world link as the daemon keeps it: the mapping its remote scenes use, and the
/// descriptor it hands the bridge.
pub struct WorldLinkFile {
    link: Arc<WorldLink>,
    fd: OwnedFd,
}

impl WorldLinkFile {
    /// A new, empty link.
    pub fn create() -> io::Result<Self> {
        let (link, fd) = WorldLink::create()?;
        Ok(Self {
            link: Arc::new(link),
            fd,
        })
    }

    /// The daemon's mapping.
    pub fn link(&self) -> &Arc<WorldLink> {
        &self.link
    }

    /// A descriptor of the link, to hand out (read and write).
    pub fn share(&self) -> io::Result<OwnedFd> {
        self.fd.try_clone()
    }
}
