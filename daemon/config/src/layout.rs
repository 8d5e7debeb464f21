//! Where an installation keeps its files, found from where the running program lies.
//!
//! `make install PREFIX=…` puts the programs in `<prefix>/bin`, plugins under
//! `<prefix>/lib/hapticd`, descriptors and scenes under `<prefix>/share/hapticd`, and the
//! configuration in `/etc/hapticd` for the `/usr` prefix or `<prefix>/etc/hapticd` for any
//! other. A program in a directory named `bin` reads the tree around it, so one build serves
//! every prefix (build and install are separate steps, and only the install knows the
//! prefix); one run from elsewhere (the build tree) reads the system's `/usr` installation.

use std::path::{Path, PathBuf};

/// The prefix of a distribution's packages, whose configuration lives in `/etc`.
const SYSTEM_PREFIX: &str = "/usr";

/// The directories of one installation.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    prefix: PathBuf,
    sysconfdir: PathBuf,
}

impl Layout {
    /// The installation of the running program (see the module documentation).
    pub fn of_this_program() -> Self {
        let prefix = std::env::current_exe().ok().and_then(|exe| {
            let bin = exe.parent()?;
            (bin.file_name()? == "bin").then(|| bin.parent().map(Path::to_path_buf))?
        });
        Self::for_prefix(prefix.as_deref().unwrap_or(Path::new(SYSTEM_PREFIX)))
    }

    /// The installation under `prefix`, laid out as `make install` lays it out.
    pub fn for_prefix(prefix: &Path) -> Self {
        let sysconfdir = if prefix == Path::new(SYSTEM_PREFIX) {
            PathBuf::from("/etc")
        } else {
            prefix.join("etc")
        };
        Self {
            prefix: prefix.to_path_buf(),
            sysconfdir,
        }
    }

    /// `hapticd.yaml`.
    pub fn config_file(&self) -> PathBuf {
        self.sysconfdir.join("hapticd/hapticd.yaml")
    }

    /// Mechanisms: local overrides, then plugins, then packaged descriptors.
    pub fn mechanism_dirs(&self) -> Vec<PathBuf> {
        vec![
            self.sysconfdir.join("hapticd/mechanisms"),
            self.prefix.join("lib/hapticd/plugins"),
            self.prefix.join("share/hapticd/mechanisms"),
        ]
    }

    /// Scene files: local ones, then packaged ones.
    pub fn scene_dirs(&self) -> Vec<PathBuf> {
        vec![
            self.sysconfdir.join("hapticd/scenes"),
            self.prefix.join("share/hapticd/scenes"),
        ]
    }

    /// Scene plugins (the engines physics scene files run on).
    pub fn scene_plugin_dirs(&self) -> Vec<PathBuf> {
        vec![self.prefix.join("lib/hapticd/scenes")]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_system_prefix_keeps_its_configuration_in_etc_and_others_under_themselves() {
        let usr = Layout::for_prefix(Path::new("/usr"));
        assert_eq!(usr.config_file(), Path::new("/etc/hapticd/hapticd.yaml"));
        assert_eq!(
            usr.mechanism_dirs(),
            [
                "/etc/hapticd/mechanisms",
                "/usr/lib/hapticd/plugins",
                "/usr/share/hapticd/mechanisms"
            ]
            .map(PathBuf::from)
        );
        let opt = Layout::for_prefix(Path::new("/opt/hapticd"));
        assert_eq!(
            opt.config_file(),
            Path::new("/opt/hapticd/etc/hapticd/hapticd.yaml")
        );
        assert_eq!(
            opt.scene_dirs(),
            [
                "/opt/hapticd/etc/hapticd/scenes",
                "/opt/hapticd/share/hapticd/scenes"
            ]
            .map(PathBuf::from)
        );
        assert_eq!(
            opt.scene_plugin_dirs(),
            [PathBuf::from("/opt/hapticd/lib/hapticd/scenes")]
        );
    }

    #[test]
    fn a_program_outside_a_bin_directory_reads_the_system_installation() {
        // Unit tests run from target/…/deps.
        assert_eq!(
            Layout::of_this_program(),
            Layout::for_prefix(Path::new("/usr"))
        );
    }
}
