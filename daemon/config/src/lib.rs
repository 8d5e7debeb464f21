//! An installation of hapticd as its programs see it, for the daemon and its clients alike
//! (`hapticctl` links this, never the daemon):
//!
//! - [`layout`]: where the installed tree keeps its files;
//! - [`file`]: `hapticd.yaml`, the daemon's configuration;
//! - [`plugin`]: loading plugins safely through the C ABI of `hapticd-plugin-api`;
//! - [`catalog`]: the mechanisms (descriptors and plugins) in the configured directories;
//! - [`scene_name`]: scene names, and the scene files they stand for.

pub mod catalog;
pub mod file;
pub mod layout;
pub mod plugin;
pub mod scene_name;

pub use file::Config;
