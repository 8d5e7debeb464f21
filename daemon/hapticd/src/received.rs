//! Scene files a caller sends by descriptor (`SwitchSceneFile`): the caller opens its file
//! with its own rights, the daemon reads only from the descriptor, and never a path the
//! caller names, so it can neither be made to read a file the caller could not, nor resolve
//! a path in its own sandbox that means something else to the caller.
//!
//! What was read is kept as `NAME.yaml` in a directory of the daemon's own: under systemd
//! `$RUNTIME_DIRECTORY/scenes`, readable by the renderer, which draws the active scene from
//! its file; elsewhere a new directory of a random name in the temporary directory, made
//! for this process alone (mode 0700). A directory that is a link, is not the daemon's, or
//! others may write is refused, and each file is written through a new temporary that no
//! link can stand in for: another user who can write the temporary directory cannot make
//! the daemon write anywhere else. Plugins get the copy's path as they get any scene file's.

use std::fs::File;
use std::io::Write;
use std::os::fd::OwnedFd;
use std::os::unix::fs::{DirBuilderExt, MetadataExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

use hapticd_core::diagnostics::{Diagnostics, FileError, MAX_FILE_BYTES, Refusal, read_opened};

/// Where received scene files are kept; the directory is made when the first one comes,
/// and removed with everything in it when this is dropped.
#[derive(Debug, Default)]
pub struct Received {
    /// Under systemd, the runtime directory (made by systemd for this service).
    runtime: Option<PathBuf>,
    dir: Mutex<Option<PathBuf>>,
}

impl Received {
    /// The directory this process keeps received files in: under `$RUNTIME_DIRECTORY` (its
    /// first entry) when systemd gives one, else a new one in the temporary directory.
    pub fn from_environment() -> Self {
        // systemd may list several, separated by colons: the first is this daemon's.
        let runtime = std::env::var_os("RUNTIME_DIRECTORY")
            .and_then(|dirs| std::env::split_paths(&dirs).next())
            .filter(|d| d.is_absolute());
        Self {
            runtime,
            dir: Mutex::new(None),
        }
    }

    /// Kept under `runtime` as its `scenes` directory.
    pub fn under(runtime: &Path) -> Self {
        Self {
            runtime: Some(runtime.to_path_buf()),
            dir: Mutex::new(None),
        }
    }

    /// [main] Read the scene file `name` sent as `fd`, and keep it as `NAME.yaml`; returns
    /// the copy's path. Only a regular file of at most [`MAX_FILE_BYTES`] of text is taken
    /// (the guarded reader's rule): a pipe or device could block the reader or never end.
    pub fn keep(&self, fd: OwnedFd, name: &str) -> Result<PathBuf, Diagnostics> {
        let shown = PathBuf::from(format!("{name}.yaml"));
        let bytes = read_opened(File::from(fd), &shown, MAX_FILE_BYTES)?;
        if std::str::from_utf8(&bytes).is_err() {
            return Err(FileError {
                file: shown,
                refusal: Refusal::NotText,
            }
            .into());
        }
        self.store(&shown, &bytes)
            .map_err(|e| Diagnostics::file(&shown, format!("cannot keep the file sent: {e}")))
    }

    /// [main] Keep `text`, a scene file hapticd made (a running scene with a body added or
    /// removed), as `NAME.yaml`; returns its path.
    pub fn keep_text(&self, text: &str, name: &str) -> Result<PathBuf, Diagnostics> {
        let shown = PathBuf::from(format!("{name}.yaml"));
        self.store(&shown, text.as_bytes())
            .map_err(|e| Diagnostics::file(&shown, format!("cannot keep the scene: {e}")))
    }

    /// Write `bytes` as `file` in the directory (made if need be) through a new temporary
    /// file and a rename, readable by all (the renderer runs as another user; the daemon's
    /// umask is 077).
    fn store(&self, file: &Path, bytes: &[u8]) -> std::io::Result<PathBuf> {
        let mut dir = self.dir.lock().unwrap_or_else(PoisonError::into_inner);
        let dir = match &mut *dir {
            Some(dir) => {
                owned_privately(dir)?;
                dir
            }
            empty => empty.insert(self.make()?),
        };
        let path = dir.join(file);
        let temporary = dir.join(format!(".{}.new", file.display()));
        let open = || {
            std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .mode(0o644)
                .custom_flags(libc::O_NOFOLLOW | libc::O_CLOEXEC)
                .open(&temporary)
        };
        let mut out = match open() {
            // Left by a run that stopped mid-write: only the name is removed, never what
            // it might point to.
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                std::fs::remove_file(&temporary)?;
                open()?
            }
            other => other?,
        };
        out.set_permissions(std::fs::Permissions::from_mode(0o644))?;
        out.write_all(bytes)?;
        std::fs::rename(&temporary, &path)?;
        Ok(path)
    }

    /// Make the directory: `scenes` in the runtime directory (kept if it is already the
    /// daemon's), or a new one of a random name in the temporary directory.
    fn make(&self) -> std::io::Result<PathBuf> {
        let Some(runtime) = &self.runtime else {
            let template = std::env::temp_dir().join("hapticd-scenes-XXXXXX");
            let dir = nix::unistd::mkdtemp(&template).map_err(std::io::Error::from)?;
            owned_privately(&dir)?;
            return Ok(dir);
        };
        owned_privately(runtime)?;
        let dir = runtime.join("scenes");
        match std::fs::DirBuilder::new().mode(0o755).create(&dir) {
            Err(e) if e.kind() != std::io::ErrorKind::AlreadyExists => return Err(e),
            _ => {}
        }
        owned_privately(&dir)?;
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755))?;
        Ok(dir)
    }
}

impl Drop for Received {
    /// The copies of scene files callers sent are of this run only.
    fn drop(&mut self) {
        if let Some(dir) = self.dir.get_mut().unwrap_or_else(PoisonError::into_inner) {
            let _ = std::fs::remove_dir_all(dir);
        }
    }
}

/// Refuse `dir` unless it is a directory itself (not a link to one), this process's user
/// owns it, and no one else may write in it.
fn owned_privately(dir: &Path) -> std::io::Result<()> {
    let meta = std::fs::symlink_metadata(dir)?;
    let refuse = |why: &str| {
        Err(std::io::Error::new(
            std::io::ErrorKind::PermissionDenied,
            format!("{}: {why}", dir.display()),
        ))
    };
    if !meta.file_type().is_dir() {
        return refuse("not a directory of hapticd's own (a link, or not a directory)");
    }
    if meta.uid() != nix::unistd::geteuid().as_raw() {
        return refuse("owned by another user");
    }
    if meta.mode() & 0o022 != 0 {
        return refuse("others may write in it");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("received-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::DirBuilder::new().mode(0o755).create(&dir).unwrap();
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
        dir
    }

    #[test]
    fn a_file_sent_is_kept_under_its_name_readable_by_all() {
        let dir = scratch("kept");
        let sent = dir.join("mine.yaml");
        std::fs::write(&sent, "shapes: []\n").unwrap();
        let received = Received::under(&dir);
        let kept = received
            .keep(File::open(&sent).unwrap().into(), "mine")
            .unwrap();
        assert_eq!(kept, dir.join("scenes/mine.yaml"));
        assert_eq!(std::fs::read_to_string(&kept).unwrap(), "shapes: []\n");
        let mode = std::fs::metadata(&kept).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o644);
        drop(received);
        assert!(!dir.join("scenes").exists(), "removed with the daemon");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn pipes_directories_and_huge_files_are_refused() {
        let dir = scratch("refused");
        let received = Received::under(&dir);
        let (reader, _writer) = std::io::pipe().unwrap();
        let refused = received.keep(OwnedFd::from(reader), "pipe").unwrap_err();
        assert_eq!(refused.to_string(), "pipe.yaml: error: not a regular file");
        let directory = File::open(&dir).unwrap();
        assert!(received.keep(directory.into(), "dir").is_err());
        let huge = dir.join("huge.yaml");
        File::create(&huge).unwrap().set_len(20 << 30).unwrap();
        let refused = received
            .keep(File::open(&huge).unwrap().into(), "huge")
            .unwrap_err();
        assert!(refused.to_string().contains("more than"), "{refused:?}");
        assert!(!dir.join("scenes").exists(), "nothing was kept");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// What another user could plant beside or inside the directory makes the daemon write
    /// nowhere but its own new files.
    #[test]
    fn planted_links_and_directories_of_others_are_never_written_through() {
        let dir = scratch("planted");
        // A file of root's that a link planted at the temporary's name points to.
        let precious = dir.join("precious");
        std::fs::write(&precious, "root's own\n").unwrap();
        std::fs::set_permissions(&precious, std::fs::Permissions::from_mode(0o600)).unwrap();
        let scenes = dir.join("scenes");
        std::fs::DirBuilder::new()
            .mode(0o755)
            .create(&scenes)
            .unwrap();
        std::os::unix::fs::symlink(&precious, scenes.join(".mine.yaml.new")).unwrap();
        let received = Received::under(&dir);
        let kept = received.keep_text("shapes: []\n", "mine").unwrap();
        assert_eq!(std::fs::read_to_string(&kept).unwrap(), "shapes: []\n");
        assert_eq!(std::fs::read_to_string(&precious).unwrap(), "root's own\n");
        let mode = std::fs::metadata(&precious).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
        drop(received);
        // A `scenes` that is a link to a directory elsewhere, or one others may write in,
        // is refused, with why.
        let elsewhere = dir.join("elsewhere");
        std::fs::create_dir(&elsewhere).unwrap();
        std::os::unix::fs::symlink(&elsewhere, dir.join("scenes")).unwrap();
        let e = Received::under(&dir)
            .keep_text("shapes: []\n", "mine")
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a directory of hapticd's own"), "{e}");
        assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 0);
        std::fs::remove_file(dir.join("scenes")).unwrap();
        std::fs::create_dir(dir.join("scenes")).unwrap();
        std::fs::set_permissions(dir.join("scenes"), std::fs::Permissions::from_mode(0o777))
            .unwrap();
        let e = Received::under(&dir)
            .keep_text("shapes: []\n", "mine")
            .unwrap_err()
            .to_string();
        assert!(e.contains("others may write in it"), "{e}");
        // Owned by another user (as root, the tests can give it away).
        if nix::unistd::geteuid().is_root() {
            std::fs::set_permissions(dir.join("scenes"), std::fs::Permissions::from_mode(0o755))
                .unwrap();
            std::os::unix::fs::chown(dir.join("scenes"), Some(65534), Some(65534)).unwrap();
            let e = Received::under(&dir)
                .keep_text("shapes: []\n", "mine")
                .unwrap_err()
                .to_string();
            assert!(e.contains("owned by another user"), "{e}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Outside systemd: a new private directory each time, never a name another user could
    /// have made first.
    #[test]
    fn outside_systemd_a_new_private_directory_is_made() {
        let (a, b) = (Received::default(), Received::default());
        let kept = a.keep_text("shapes: []\n", "mine").unwrap();
        let other = b.keep_text("shapes: []\n", "mine").unwrap();
        let dir = kept.parent().unwrap().to_path_buf();
        assert_ne!(dir, other.parent().unwrap());
        let meta = std::fs::symlink_metadata(&dir).unwrap();
        assert_eq!(meta.mode() & 0o777, 0o700);
        assert_eq!(meta.uid(), nix::unistd::geteuid().as_raw());
        drop(a);
        assert!(!dir.exists());
    }
}
