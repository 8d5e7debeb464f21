//! The first bytes of every block the haptic thread shares with other processes (the world's
//! picture, the telemetry ring): what it is, its layout's version and its size, so that a
//! reader of another version, or of another kind of block, refuses it instead of misreading.

/// A shared block's header.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// What the block is (`hapticdW`, `hapticdT`).
    pub magic: [u8; 8],
    /// Its layout's version.
    pub version: u32,
    /// Its size in bytes as the writer has it.
    pub size: u32,
}

/// Why a mapped block is not the one a reader understands.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WrongLayout(pub String);

impl std::fmt::Display for WrongLayout {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for WrongLayout {}

impl Header {
    /// The header of a block `magic` of layout `version`, `size` bytes.
    pub const fn new(magic: [u8; 8], version: u32, size: usize) -> Self {
        Self {
            magic,
            version,
            size: size as u32,
        }
    }

    /// Whether the block at `block`, `len` bytes mapped, starts with this header; `what`
    /// names it in the refusal.
    ///
    /// # Safety
    /// `block` is valid for reads of `len` bytes and aligned for `Header`.
    pub unsafe fn check(
        &self,
        block: *const Header,
        len: usize,
        what: &str,
    ) -> Result<(), WrongLayout> {
        let size = self.size as usize;
        if len < size {
            return Err(WrongLayout(format!("{len} bytes, {what} has {size}")));
        }
        // SAFETY: the header lies within the `len` bytes checked above.
        let found = unsafe { block.read_volatile() };
        if found != *self {
            return Err(WrongLayout(format!(
                "not {what} of layout {} ({size} bytes): magic {:?}, layout {}, {} bytes",
                self.version, found.magic, found.version, found.size
            )));
        }
        Ok(())
    }
}
