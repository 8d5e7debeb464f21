//! Installed mechanisms: YAML descriptors and mechanism plugins found in search directories.
//!
//! Directories are searched in order and the first mechanism of a name wins, so
//! `/etc/hapticd/mechanisms` overrides what the package installed.
//! The default directories are the installation's ([`Layout::mechanism_dirs`]).

use std::path::{Path, PathBuf};

use crate::layout::Layout;
use crate::plugin;
use hapticd_core::diagnostics::Diagnostics;
use hapticd_core::mechanism::{Mechanism, descriptor};

/// Environment variable that replaces the default search path (colon-separated).
pub const PATH_VARIABLE: &str = "HAPTICD_MECHANISM_PATH";

/// One file found in the search path.
#[derive(Debug)]
pub struct Entry {
    /// The file.
    pub path: PathBuf,
    /// The mechanism, or why it could not be loaded.
    pub mechanism: Result<Mechanism, Diagnostics>,
    /// Whether an earlier directory already provides a mechanism of the same name.
    pub shadowed: bool,
}

/// The ordered list of directories mechanisms are looked up in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Catalog {
    dirs: Vec<PathBuf>,
}

impl Catalog {
    /// A catalog over `dirs`, searched in order.
    pub fn new(dirs: Vec<PathBuf>) -> Self {
        Self { dirs }
    }

    /// The default directories, or those of `$HAPTICD_MECHANISM_PATH` when set.
    pub fn from_env() -> Self {
        match std::env::var_os(PATH_VARIABLE) {
            Some(path) => Self::new(std::env::split_paths(&path).collect()),
            None => Self::new(Layout::of_this_program().mechanism_dirs()),
        }
    }

    /// The search directories.
    pub fn dirs(&self) -> &[PathBuf] {
        &self.dirs
    }

    /// Whether `spec` is a mechanism name rather than a path to a descriptor or plugin.
    pub fn is_name(spec: &str) -> bool {
        !spec.contains('/') && !is_mechanism_file(Path::new(spec))
    }

    /// Every descriptor and plugin in the search path, loaded, in search order.
    pub fn entries(&self) -> Vec<Entry> {
        let mut entries: Vec<Entry> = Vec::new();
        for dir in &self.dirs {
            let Ok(listing) = std::fs::read_dir(dir) else {
                continue;
            };
            let mut files: Vec<PathBuf> = listing
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| is_mechanism_file(p))
                .collect();
            files.sort();
            for path in files {
                let mechanism = load(&path);
                let shadowed = mechanism.as_ref().is_ok_and(|m| {
                    entries
                        .iter()
                        .any(|e| e.mechanism.as_ref().is_ok_and(|o| o.name == m.name))
                });
                entries.push(Entry {
                    path,
                    mechanism,
                    shadowed,
                });
            }
        }
        entries
    }

    /// The mechanism `spec` names: a path to a `.yaml`/`.yml`/`.so` file, or the name of an
    /// installed mechanism.
    pub fn resolve(&self, spec: &str) -> Result<Mechanism, Diagnostics> {
        if !Self::is_name(spec) {
            return load(Path::new(spec));
        }
        self.resolve_among(&self.entries(), spec)
    }

    /// The mechanism `spec` names, an installed one looked up among `entries` (what
    /// [`Catalog::entries`] found): each plugin is loaded once per look through the search
    /// path, however many devices ask.
    pub fn resolve_among(&self, entries: &[Entry], spec: &str) -> Result<Mechanism, Diagnostics> {
        let as_path = Path::new(spec);
        if !Self::is_name(spec) {
            return load(as_path);
        }
        entries
            .iter()
            .find_map(|e| e.mechanism.as_ref().ok().filter(|m| m.name == spec))
            .cloned()
            .ok_or_else(|| {
                let dirs: Vec<_> = self.dirs.iter().map(|d| d.display().to_string()).collect();
                Diagnostics::file(
                    as_path,
                    format!(
                        "no installed mechanism of this name (searched {}; set {PATH_VARIABLE} \
                         or give a path to a .yaml or .so file)",
                        dirs.join(":")
                    ),
                )
            })
    }
}

fn is_mechanism_file(path: &Path) -> bool {
    matches!(
        path.extension().and_then(|e| e.to_str()),
        Some("yaml" | "yml" | "so")
    )
}

/// Load the descriptor or plugin at `path`, judged by its extension.
pub fn load(path: &Path) -> Result<Mechanism, Diagnostics> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("so") => {
            let refused = |e: plugin::PluginError| Diagnostics::file(path, e.reason);
            let plugin = plugin::load(path).map_err(refused)?;
            let spec = plugin.mechanism_spec().map_err(refused)?;
            Mechanism::from_spec(&plugin.name, &plugin.description, path, &spec, &|_| None)
        }
        Some("yaml" | "yml") => {
            // A descriptor sets motor voltages as surely as a plugin: the same owners only.
            plugin::check_permissions(path).map_err(|e| Diagnostics::file(path, e.reason))?;
            descriptor::load(path)
        }
        _ => Err(Diagnostics::file(
            path,
            "not a mechanism: expected a .yaml descriptor or a .so plugin",
        )),
    }
}
