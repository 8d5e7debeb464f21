//! Scene extension `"hapticd.scene.mobility/1"`: how a jointed body answers the hand.
//!
//! A scene plugin offers it through [`HapticdSceneVtable::get_extension`](crate::HapticdSceneVtable::get_extension);
//! its C declarations are the header's section of the same name.
//!
//! A body the haptic side moves itself (local dynamics, [`HapticdLocalBody`](crate::HapticdLocalBody))
//! answers a force by its mass and inertia. A link held by joints answers by its articulated
//! mobility: a door pushed at its handle moves as a mass I/r² would along its swing and not
//! at all along its hinge. The host asks each body a step published for it.

use std::ffi::c_void;

/// The id of [`HapticdSceneMobility`] (since ABI 1.8).
pub const HAPTICD_EXT_SCENE_MOBILITY: &std::ffi::CStr = c"hapticd.scene.mobility/1";

/// How a body held by joints moves under a wrench, as the last step left it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdMobility {
    /// 6×6, by row: the change of (velocity of the centre of mass, spin) that an impulse
    /// (N·s, then N·m·s about the centre of mass, world axes) gives the body through its
    /// joints. Symmetric, positive semi-definite; its null space is what the joints lock.
    pub mobility: [[f64; 6]; 6],
    /// The body's acceleration without the hand or contacts (gravity on the whole
    /// mechanism, through its joints): the centre's (m/s²), then the spin's (rad/s²).
    pub acceleration: [f64; 6],
}

/// Extension [`HAPTICD_EXT_SCENE_MOBILITY`] of a multi-rate scene plugin.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdSceneMobility {
    /// `sizeof(HapticdSceneMobility)` as the plugin was compiled.
    pub struct_size: u32,
    /// [physics, after `step_world`] Write the mobility of body `body` (as numbered in the
    /// step's [`HapticdLocalBody`](crate::HapticdLocalBody)) to `out` and return
    /// [`HAPTICD_OK`](crate::HAPTICD_OK), or [`HAPTICD_ERROR_ARGUMENT`](crate::HAPTICD_ERROR_ARGUMENT)
    /// for a free body, which its mass and inertia describe.
    pub mobility: Option<
        unsafe extern "C" fn(instance: *mut c_void, body: u32, out: *mut HapticdMobility) -> i32,
    >,
}
