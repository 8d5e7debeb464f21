//! The stable plugin boundary of hapticd.
//!
//! A plugin is a shared library exporting one symbol, `hapticd_plugin_entry`, that returns a
//! [`HapticdPluginDescriptor`]: ABI version, kind, name, version and a vtable. The host
//! refuses a plugin whose ABI major differs from its own or whose minor is newer.
//!
//! [`abi`] holds the `#[repr(C)]` types (the C header `include/hapticd_plugin.h` is generated
//! from it); [`export`], [`export_mechanism!`] and [`export_scene!`] are the safe side for
//! Rust authors.

pub mod abi;
pub mod export;

pub use abi::*;
pub use export::{MechanismSpec, SceneFactory, SceneInstance, log};
