//! Scene files a caller sends by descriptor (`SwitchSceneFile`): the caller opens its file
//! with its own rights, the daemon reads only from the descriptor, and never a path the
//! caller names, so it can neither be made to read a file the caller could not, nor resolve
//! a path in its own sandbox that means something else to the caller.
//!
//! What was read is kept as `NAME.yaml` in a directory of the daemon's own (its runtime
//! directory under systemd), readable by the renderer, which draws the active scene from its
//! file; plugins get that copy's path as they get any scene file's.

use std::fs::File;
use std::io::{Read, Write};
use std::os::fd::OwnedFd;
use std::os::unix::fs::{DirBuilderExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

use hapticd_core::diagnostics::MAX_FILE_BYTES;

/// Why a sent scene file was refused.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refused(pub String);

/// The directory received scene files are kept in: `$RUNTIME_DIRECTORY/scenes` under
/// systemd, else one of this process's own under the temporary directory.
pub fn directory() -> PathBuf {
    match std::env::var_os("RUNTIME_DIRECTORY") {
        // systemd may list several, separated by colons: the first is this daemon's.
        Some(dirs) => {
            let first = dirs.to_string_lossy().split(':').next().map(PathBuf::from);
            first.unwrap_or_default().join("scenes")
        }
        None => std::env::temp_dir().join(format!("hapticd-{}-scenes", std::process::id())),
    }
}

/// [main] Read the scene file `name` sent as `fd`, and keep it as `NAME.yaml` in `dir`;
/// returns the copy's path. Only a regular file of at most [`MAX_FILE_BYTES`] of text is
/// taken: a pipe or device could block the reader or never end.
pub fn keep(fd: OwnedFd, name: &str, dir: &Path) -> Result<PathBuf, Refused> {
    let mut file = File::from(fd);
    let meta = file
        .metadata()
        .map_err(|e| Refused(format!("{name}: cannot read the file sent: {e}")))?;
    if !meta.file_type().is_file() {
        return Err(Refused(format!(
            "{name}: what was sent is not a regular file"
        )));
    }
    if meta.len() > MAX_FILE_BYTES {
        return Err(Refused(format!(
            "{name}: {} bytes is more than the {MAX_FILE_BYTES} a scene file may have",
            meta.len()
        )));
    }
    let mut bytes = Vec::new();
    // The caller may still be writing to it: read no more than the limit, whatever fstat said.
    (&mut file)
        .take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Refused(format!("{name}: cannot read the file sent: {e}")))?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(Refused(format!(
            "{name}: more than the {MAX_FILE_BYTES} bytes a scene file may have"
        )));
    }
    if std::str::from_utf8(&bytes).is_err() {
        return Err(Refused(format!("{name}: the file sent is not UTF-8 text")));
    }
    let kept = dir.join(format!("{name}.yaml"));
    store(dir, &kept, &bytes)
        .map_err(|e| Refused(format!("{name}: cannot keep the file sent: {e}")))?;
    Ok(kept)
}

/// Write `bytes` to `path` in `dir` (made if needed) through a temporary file and a rename,
/// readable by all (the renderer runs as another user; the daemon's umask is 077).
fn store(dir: &Path, path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    std::fs::DirBuilder::new()
        .recursive(true)
        .mode(0o755)
        .create(dir)?;
    std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o755))?;
    let temporary = path.with_extension("yaml.new");
    let mut out = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o644)
        .open(&temporary)?;
    out.set_permissions(std::fs::Permissions::from_mode(0o644))?;
    out.write_all(bytes)?;
    std::fs::rename(&temporary, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("received-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn a_file_sent_is_kept_under_its_name_readable_by_all() {
        let dir = scratch("kept");
        let sent = dir.join("mine.yaml");
        std::fs::write(&sent, "shapes: []\n").unwrap();
        let kept = keep(
            File::open(&sent).unwrap().into(),
            "mine",
            &dir.join("scenes"),
        )
        .unwrap();
        assert_eq!(kept, dir.join("scenes/mine.yaml"));
        assert_eq!(std::fs::read_to_string(&kept).unwrap(), "shapes: []\n");
        let mode = std::fs::metadata(&kept).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o644);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn pipes_directories_and_huge_files_are_refused() {
        let dir = scratch("refused");
        let (reader, _writer) = std::io::pipe().unwrap();
        let refused = keep(OwnedFd::from(reader), "pipe", &dir).unwrap_err();
        assert!(refused.0.contains("not a regular file"), "{refused:?}");
        let directory = File::open(&dir).unwrap();
        assert!(keep(directory.into(), "dir", &dir).is_err());
        let huge = dir.join("huge.yaml");
        File::create(&huge).unwrap().set_len(20 << 30).unwrap();
        let refused = keep(File::open(&huge).unwrap().into(), "huge", &dir).unwrap_err();
        assert!(refused.0.contains("more than"), "{refused:?}");
        assert!(!dir.join("huge.yaml.new").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
