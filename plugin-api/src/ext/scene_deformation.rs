//! Scene extension `"hapticd.scene.deformation/1"`: where deforming solids stand now.
//!
//! Pictures show a soft body as it bends by the corners of its triangles as they move.
//!
//! A scene plugin offers it through [`HapticdSceneVtable::get_extension`](crate::HapticdSceneVtable::get_extension);
//! its C declarations are the header's section of the same name.

use std::ffi::c_void;

/// The id of [`HapticdSceneDeformation`] (since ABI 1.9).
pub const HAPTICD_EXT_SCENE_DEFORMATION: &std::ffi::CStr = c"hapticd.scene.deformation/1";

/// Extension [`HAPTICD_EXT_SCENE_DEFORMATION`] of a scene plugin: the corners of the
/// triangles of its [`HAPTICD_SOLID_DEFORMING`](crate::HAPTICD_SOLID_DEFORMING) solids as
/// they stand after the last step. The geometry extension gives those triangles as they
/// stand at load; this gives the same corners, moved.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdSceneDeformation {
    /// `sizeof(HapticdSceneDeformation)` as the plugin was compiled.
    pub struct_size: u32,
    /// [the thread that steps the instance, between steps] Write the corners, metres in
    /// each solid's frame, three floats each, solid by solid and triangle by triangle in
    /// the geometry's order, to `out` (at most `capacity` corners); return how many corners
    /// the deforming solids have. Like a step it must not allocate, lock, log or block.
    pub corners:
        Option<unsafe extern "C" fn(instance: *mut c_void, out: *mut f32, capacity: u32) -> u32>,
}
