//! Reading and writing the files a person names, guarded: regular files of a bounded size
//! only (never a FIFO that blocks or a device that never ends), and writes that a crash
//! cannot leave half done.

use std::fmt;
use std::fs::File;
use std::path::{Path, PathBuf};

use super::{Diagnostics, MAX_FILE_BYTES};

/// `O_NONBLOCK` of Linux (the core links no libc): opening a FIFO then returns at once
/// instead of waiting for a writer.
#[cfg(any(target_arch = "mips", target_arch = "mips64"))]
pub(super) const O_NONBLOCK: i32 = 0o200;
#[cfg(any(target_arch = "sparc", target_arch = "sparc64"))]
pub(super) const O_NONBLOCK: i32 = 0x4000;
#[cfg(not(any(
    target_arch = "mips",
    target_arch = "mips64",
    target_arch = "sparc",
    target_arch = "sparc64"
)))]
pub(super) const O_NONBLOCK: i32 = 0o4000;

/// What a guarded read accepts, besides being a regular file.
#[derive(Debug, Clone, Copy)]
pub struct FileRules<'a> {
    /// Largest size, bytes.
    pub max_bytes: u64,
    /// A directory the file must lie in once its links are followed, if any.
    pub within: Option<&'a Path>,
}

impl FileRules<'_> {
    /// Files a person wrote: at most [`MAX_FILE_BYTES`], anywhere.
    pub const TEXT: FileRules<'static> = FileRules {
        max_bytes: MAX_FILE_BYTES,
        within: None,
    };
}

/// Why a guarded read refused a file or failed.
#[derive(Debug)]
pub enum Refusal {
    /// The system refused (`NotFound` included).
    Io(std::io::Error),
    /// A FIFO, a device, a directory: reading it could block for ever or never end.
    NotRegular,
    /// More bytes than the rules allow.
    TooLarge {
        /// The file's size (or what was read of it before it grew past the limit).
        bytes: u64,
        /// The limit.
        max: u64,
    },
    /// A link to a file outside the directory the rules confine it to.
    Outside {
        /// Where the link leads.
        target: PathBuf,
        /// The directory.
        dir: PathBuf,
    },
    /// Not UTF-8 text.
    NotText,
}

/// A file a guarded read refused, named as it was given.
#[derive(Debug)]
pub struct FileError {
    /// The file, as given.
    pub file: PathBuf,
    /// Why.
    pub refusal: Refusal,
}

impl FileError {
    /// Whether the file is simply not there.
    pub fn is_missing(&self) -> bool {
        matches!(&self.refusal, Refusal::Io(e) if e.kind() == std::io::ErrorKind::NotFound)
    }

    /// What is wrong, without the file's name.
    pub fn message(&self) -> String {
        match &self.refusal {
            Refusal::Io(e) => format!("cannot read: {e}"),
            Refusal::NotRegular => "not a regular file".into(),
            Refusal::TooLarge { bytes, max } => {
                format!("{bytes} bytes is more than the {max} a file may have")
            }
            Refusal::Outside { target, dir } => {
                format!("a link to {}, outside {}", target.display(), dir.display())
            }
            Refusal::NotText => "not UTF-8 text".into(),
        }
    }
}

impl fmt::Display for FileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: error: {}", self.file.display(), self.message())
    }
}

impl std::error::Error for FileError {}

impl From<FileError> for Diagnostics {
    fn from(e: FileError) -> Self {
        Diagnostics::file(&e.file, e.message())
    }
}

/// The binaries report every error as text.
impl From<FileError> for String {
    fn from(e: FileError) -> String {
        e.to_string()
    }
}

/// Whether `file` may be read under `rules`, looking without opening it (opening a FIFO
/// waits for a writer; opening a device may start it): the path to open, links resolved
/// when the rules confine the file to a directory.
pub fn check_file(file: &Path, rules: FileRules) -> Result<PathBuf, FileError> {
    let refuse = |refusal| FileError {
        file: file.to_path_buf(),
        refusal,
    };
    let path = match rules.within {
        Some(dir) => {
            let target = file.canonicalize().map_err(|e| refuse(Refusal::Io(e)))?;
            let dir = dir.canonicalize().map_err(|e| refuse(Refusal::Io(e)))?;
            if !target.starts_with(&dir) {
                return Err(refuse(Refusal::Outside { target, dir }));
            }
            target
        }
        None => file.to_path_buf(),
    };
    let meta = std::fs::metadata(&path).map_err(|e| refuse(Refusal::Io(e)))?;
    if !meta.is_file() {
        return Err(refuse(Refusal::NotRegular));
    }
    if meta.len() > rules.max_bytes {
        return Err(refuse(Refusal::TooLarge {
            bytes: meta.len(),
            max: rules.max_bytes,
        }));
    }
    Ok(path)
}

/// Why a file could not be replaced, and at which step.
#[derive(Debug)]
pub struct WriteError {
    /// The file.
    pub path: PathBuf,
    /// What could not be done: "create its directory", "create", "write", "flush" or
    /// "replace".
    pub step: &'static str,
    /// Why.
    pub error: std::io::Error,
}

impl std::fmt::Display for WriteError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: cannot {}: {}",
            self.path.display(),
            self.step,
            self.error
        )
    }
}

impl std::error::Error for WriteError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.error)
    }
}

/// Replace `path` with `contents` so that a crash leaves either the old file or the new one:
/// the one writer of every file hapticd keeps (records, caches).
pub fn write_atomically(path: &Path, contents: &[u8]) -> Result<(), WriteError> {
    use std::io::Write;
    let fail = |step: &'static str| {
        move |error: std::io::Error| WriteError {
            path: path.to_path_buf(),
            step,
            error,
        }
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(fail("create its directory"))?;
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into());
    let temporary = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        // A new file of its own: never written through a link left under the temporary name.
        let _ = std::fs::remove_file(&temporary);
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temporary)
            .map_err(fail("create"))?;
        file.write_all(contents).map_err(fail("write"))?;
        file.sync_all().map_err(fail("flush"))?;
        std::fs::rename(&temporary, path).map_err(fail("replace"))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&temporary);
        return result;
    }
    // Renamed, the new file is what the directory holds; should the directory's flush fail,
    // a power loss keeps the old file whole, and an error now would have the caller keep its
    // old record in memory against the new one on disk.
    let _ = File::open(dir).and_then(|d| d.sync_all());
    Ok(())
}

/// The directory `file` lies in: its parent, or `.` for a bare name (whose parent is empty,
/// which names no directory: a scene given as `my.yaml` lost its meshes).
pub fn directory_of(file: &Path) -> &Path {
    match file.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

/// The bytes of `file`, refusing what cannot be a file a person or hapticd wrote: anything
/// but a regular file, more than `rules.max_bytes`, or a link out of `rules.within`. The
/// one reader of every file hapticd and its tools are given.
pub fn read_file(file: &Path, rules: FileRules) -> Result<Vec<u8>, FileError> {
    use std::os::unix::fs::OpenOptionsExt;
    let refuse = |refusal| FileError {
        file: file.to_path_buf(),
        refusal,
    };
    let path = check_file(file, rules)?;
    // Non-blocking, in case a FIFO took the file's place since it was looked at.
    let opened = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(O_NONBLOCK)
        .open(&path)
        .map_err(|e| refuse(Refusal::Io(e)))?;
    read_opened(opened, file, rules.max_bytes)
}

/// The bytes of the file `opened` (named `file` in errors): a regular file of at most
/// `max_bytes`, whatever it grows to while it is read. For a file opened by someone else,
/// as a descriptor a caller sends; [`read_file`] reads every file given by name through it.
pub fn read_opened(opened: File, file: &Path, max_bytes: u64) -> Result<Vec<u8>, FileError> {
    use std::io::Read;
    let refuse = |refusal| FileError {
        file: file.to_path_buf(),
        refusal,
    };
    let meta = opened.metadata().map_err(|e| refuse(Refusal::Io(e)))?;
    if !meta.is_file() {
        return Err(refuse(Refusal::NotRegular));
    }
    let too_large = |bytes| {
        refuse(Refusal::TooLarge {
            bytes,
            max: max_bytes,
        })
    };
    if meta.len() > max_bytes {
        return Err(too_large(meta.len()));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    opened
        .take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| refuse(Refusal::Io(e)))?;
    // It may have grown since it was measured.
    if bytes.len() as u64 > max_bytes {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// [`read_file`] of text under [`FileRules::TEXT`], as findings about the file.
pub fn read_text(file: &Path) -> Result<String, Diagnostics> {
    let bytes = read_file(file, FileRules::TEXT)?;
    String::from_utf8(bytes).map_err(|_| {
        FileError {
            file: file.to_path_buf(),
            refusal: Refusal::NotText,
        }
        .into()
    })
}
