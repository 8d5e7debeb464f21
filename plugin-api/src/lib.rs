//! The stable plugin boundary of hapticd.
//!
//! A plugin is a shared library exporting one symbol, `hapticd_plugin_entry`, that returns a
//! [`HapticdPluginDescriptor`]: ABI version, kind, name, version and a vtable. The host
//! refuses a plugin whose ABI major differs from its own; minors only append, so plugins
//! of older and newer minors load alike, and newer host services are found by name through
//! [`HapticdHost::get_extension`] (see [`export::extension`]).
//!
//! [`abi`] holds the `#[repr(C)]` types and [`ext`] the scene extensions', one file each (the
//! C header `include/hapticd_plugin.h` is generated from them, a section each); [`export`],
//! [`export_mechanism!`] and [`export_scene!`] are the safe side for Rust authors;
//! [`geometry`] is a scene's drawable world as one value.

pub mod abi;
pub mod export;
pub mod ext;
pub mod geometry;

pub use abi::*;
pub use export::{
    MechanismSpec, PhysicsInput, PhysicsOutput, SceneCheck, SceneError, SceneFactory,
    SceneInstance, log,
};
pub use ext::{
    scene_compliance::*, scene_contacts::*, scene_control::*, scene_deformation::*, scene_files::*,
    scene_geometry::*, scene_held::*, scene_joints::*, scene_mobility::*,
};
pub use geometry::Geometry;
