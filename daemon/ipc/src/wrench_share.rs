//! The memory of a device's commanded wrench (`hapticd_core::haptics::wrench_command`): a
//! memfd the daemon makes when a privileged caller asks (`Device.OpenWrenchInput`), reads at
//! every haptic tick, and hands out to be written. Its size is sealed, so a writer can never
//! take the memory from under the haptic thread; what it writes is checked there.

use std::io;
use std::os::fd::OwnedFd;

use hapticd_core::haptics::wrench_command::{SHARED_SIZE, SharedWrenchCommand, WrenchSource};
use hapticd_core::kinematics::Wrench;

use crate::shared_memory::{MapError, Mapping, shared_writable};

/// The daemon's side of a command block: the mapping the haptic thread reads.
pub struct WrenchInputFile {
    mapping: Mapping,
}

impl WrenchSource for WrenchInputFile {
    fn block(&self) -> &SharedWrenchCommand {
        // SAFETY: initialised in `create`, SHARED_SIZE bytes mapped for the life of self.
        unsafe { &*self.mapping.address().cast::<SharedWrenchCommand>() }
    }
}

impl WrenchInputFile {
    /// A new block, and the descriptor to hand its writer.
    pub fn create() -> io::Result<(Self, OwnedFd)> {
        let (fd, mapping) = shared_writable("hapticd-wrench-command", SHARED_SIZE)?;
        // SAFETY: the mapping holds SHARED_SIZE writable, page-aligned bytes.
        unsafe { SharedWrenchCommand::init(mapping.address().cast()) };
        Ok((Self { mapping }, fd))
    }
}

/// A writer's view of a command block it was handed.
///
/// ```
/// use hapticd_core::haptics::wrench_command::WrenchSource;
/// use hapticd_core::kinematics::Wrench;
/// use hapticd_ipc::wrench_share::{MappedWrenchInput, WrenchInputFile};
///
/// let (file, fd) = WrenchInputFile::create()?;
/// let input = MappedWrenchInput::open(&fd)?;
/// // The far side pushes up with a newton; the haptic thread reads it from `file`.
/// input.write(&[Wrench::from_array([0.0, 1.0, 0.0, 0.0, 0.0, 0.0])]);
/// # let _ = file.block();
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct MappedWrenchInput {
    mapping: Mapping,
}

impl MappedWrenchInput {
    /// Map `fd` and check it holds a command block of this layout.
    pub fn open(fd: &OwnedFd) -> Result<Self, MapError> {
        let mapping = Mapping::read_write(fd).map_err(|error| MapError::Map {
            what: "the wrench command",
            error,
        })?;
        // SAFETY: the mapping holds `len` bytes, page-aligned, while self lives.
        unsafe { SharedWrenchCommand::at(mapping.address().cast(), mapping.len()) }
            .map_err(|e| MapError::Layout(e.to_string()))?;
        Ok(Self { mapping })
    }

    /// Command `wrenches`, one per effector in the order of `Effectors` (the rest zero).
    pub fn write(&self, wrenches: &[Wrench]) {
        // SAFETY: checked in `open`; mapped while self lives.
        let block = unsafe { &*self.mapping.address().cast::<SharedWrenchCommand>() };
        block.write(wrenches);
    }
}
