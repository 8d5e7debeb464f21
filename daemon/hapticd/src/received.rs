//! Scene files a caller sends by descriptor (`SwitchSceneFile`): the caller opens its file
//! with its own rights, the daemon reads only from the descriptor, and never a path the
//! caller names, so it can neither be made to read a file the caller could not, nor resolve
//! a path in its own sandbox that means something else to the caller.
//!
//! What was read is kept as `NAME.yaml` in a directory of the daemon's own (its runtime
//! directory under systemd), readable by the renderer, which draws the active scene from its
//! file; plugins get that copy's path as they get any scene file's.

use std::fs::File;
use std::io::Write;
use std::os::fd::OwnedFd;
use std::os::unix::fs::{DirBuilderExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

use hapticd_core::diagnostics::{Diagnostics, FileError, MAX_FILE_BYTES, Refusal, read_opened};

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
/// taken (the guarded reader's rule): a pipe or device could block the reader or never end.
pub fn keep(fd: OwnedFd, name: &str, dir: &Path) -> Result<PathBuf, Diagnostics> {
    let shown = PathBuf::from(format!("{name}.yaml"));
    let bytes = read_opened(File::from(fd), &shown, MAX_FILE_BYTES)?;
    if std::str::from_utf8(&bytes).is_err() {
        return Err(FileError {
            file: shown,
            refusal: Refusal::NotText,
        }
        .into());
    }
    let kept = dir.join(&shown);
    store(dir, &kept, &bytes)
        .map_err(|e| Diagnostics::file(&shown, format!("cannot keep the file sent: {e}")))?;
    Ok(kept)
}

/// [main] Keep `text`, a scene file hapticd made (a running scene with a body added or
/// removed), as `NAME.yaml` in `dir`; returns its path.
pub fn keep_text(text: &str, name: &str, dir: &Path) -> Result<PathBuf, Diagnostics> {
    let shown = PathBuf::from(format!("{name}.yaml"));
    let kept = dir.join(&shown);
    store(dir, &kept, text.as_bytes())
        .map_err(|e| Diagnostics::file(&shown, format!("cannot keep the scene: {e}")))?;
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
        assert_eq!(refused.to_string(), "pipe.yaml: error: not a regular file");
        let directory = File::open(&dir).unwrap();
        assert!(keep(directory.into(), "dir", &dir).is_err());
        let huge = dir.join("huge.yaml");
        File::create(&huge).unwrap().set_len(20 << 30).unwrap();
        let refused = keep(File::open(&huge).unwrap().into(), "huge", &dir).unwrap_err();
        assert!(refused.to_string().contains("more than"), "{refused:?}");
        assert!(!dir.join("huge.yaml.new").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
