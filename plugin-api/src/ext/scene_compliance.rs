//! Scene extension `"hapticd.scene.compliance/1"`: how far a soft surface gives under a
//! finger between two physics steps.
//!
//! A multi-rate world publishes a surface as a plane a physics period old. A rigid one stays
//! where it is until the next step; a soft one gives under the finger in the meantime, or
//! the finger would press on a wall for a period and then find it gone (a press at 60 Hz
//! rings at the physics rate). The plugin says, for each plane it publishes, how far the
//! surface there moves along the plane's normal for each newton pressed on it (the contact
//! region's compliance through the world's own step), and the normal force of the hand the
//! step that published it took in there (the plane stands where that force holds it). The
//! haptic side moves the plane in by the compliance times the press beyond that force, each
//! tick (thesis 6.5.5).
//!
//! A scene plugin offers it through [`HapticdSceneVtable::get_extension`](crate::HapticdSceneVtable::get_extension);
//! its C declarations are the header's section of the same name.

use std::ffi::c_void;

/// The id of [`HapticdSceneCompliance`] (since ABI 1.10).
pub const HAPTICD_EXT_SCENE_COMPLIANCE: &std::ffi::CStr = c"hapticd.scene.compliance/1";

/// How a published plane gives under a press.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdPlaneCompliance {
    /// How far the surface moves in along the plane's normal for each newton pressed on it
    /// there, m/N (0: rigid).
    pub compliance: f64,
    /// The normal force of the hand the step took in there, N (the plane stands where it
    /// holds it; 0 when the hand pressed nothing).
    pub load: f64,
}

/// Extension [`HAPTICD_EXT_SCENE_COMPLIANCE`] of a multi-rate scene plugin.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdSceneCompliance {
    /// `sizeof(HapticdSceneCompliance)` as the plugin was compiled.
    pub struct_size: u32,
    /// [physics, after `step_world`] Write how plane `plane` of pointer `pointer` (as the
    /// step published them) gives to `out` and return [`HAPTICD_OK`](crate::HAPTICD_OK), or
    /// [`HAPTICD_ERROR_ARGUMENT`](crate::HAPTICD_ERROR_ARGUMENT) for a rigid one.
    pub compliance: Option<
        unsafe extern "C" fn(
            instance: *mut c_void,
            pointer: u32,
            plane: u32,
            out: *mut HapticdPlaneCompliance,
        ) -> i32,
    >,
}
