//! What an installation holds: the installed tree, the system files checked with systemd's own
//! tools, and the workspace's layering.

#[path = "../support/mod.rs"]
mod support;

mod install;
mod layers;
mod system_files;
