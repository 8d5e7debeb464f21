//! Scene files by name, as the daemon takes them: `hapticctl render blocks` finds the
//! installed `blocks.yaml` in the scene directories of the installation's configuration.

use std::path::{Path, PathBuf};

use hapticd_config::Config;
use hapticd_config::layout::Layout;

use crate::Failure;

/// The scene file `arg` names: a path as given, or the name of an installed scene (`blocks`),
/// looked up in the scene directories of the installation's configuration as the daemon
/// looks names up.
pub fn resolve(arg: &Path) -> Result<PathBuf, Failure> {
    let name = match arg.to_str() {
        Some(name) if hapticd_config::scene_name::is_name(name) && !arg.exists() => name,
        _ => return Ok(arg.to_path_buf()),
    };
    let layout = Layout::of_this_program();
    let config = layout.config_file();
    // A configuration that does not load is the daemon's to report; its defaults serve here.
    let dirs = Config::load(&config)
        .map(|c| c.scene_dirs)
        .unwrap_or_else(|_| layout.scene_dirs());
    hapticd_config::scene_name::locate(name, &dirs).map_err(|e| Failure::usage(e.to_string()))
}
