//! The scene extensions of the ABI, one file each (the C header gives each a section of its
//! own): a scene offers what came after ABI 1.4 as extensions, found by id through
//! [`HapticdSceneVtable::get_extension`](crate::HapticdSceneVtable::get_extension), so the
//! vtable stops growing. An id carries its version (`/1`): a changed extension is a new id.
//!
//! - [`scene_geometry`]: `"hapticd.scene.geometry/1"`, what a scene's world looks like.
//! - [`scene_files`]: `"hapticd.scene.files/1"`, the scene files a plugin runs.
//! - [`scene_control`]: `"hapticd.scene.control/1"`, a running world changed from outside.
//! - [`scene_contacts`]: `"hapticd.scene.contacts/1"`, what each pointer touches.
//! - [`scene_mobility`]: `"hapticd.scene.mobility/1"`, how a jointed body answers the hand.
//! - [`scene_joints`]: `"hapticd.scene.joints/1"`, a running world's joints, read and driven.
//! - [`scene_deformation`]: `"hapticd.scene.deformation/1"`, where deforming solids stand.
//! - [`scene_compliance`]: `"hapticd.scene.compliance/1"`, how a soft surface gives between
//!   two physics steps.
//! - [`scene_held`]: `"hapticd.scene.held/1"`, a body a pointer holds and the exact surfaces
//!   it meets.

pub mod scene_compliance;
pub mod scene_contacts;
pub mod scene_control;
pub mod scene_deformation;
pub mod scene_files;
pub mod scene_geometry;
pub mod scene_held;
pub mod scene_joints;
pub mod scene_mobility;
