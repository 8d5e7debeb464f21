//! Scene extension `"hapticd.scene.contacts/1"`: what each pointer touches.
//!
//! A scene plugin offers it through [`HapticdSceneVtable::get_extension`](crate::HapticdSceneVtable::get_extension);
//! its C declarations are the header's section of the same name.

use std::ffi::c_void;

/// The id of [`HapticdSceneContacts`] (since ABI 1.5).
pub const HAPTICD_EXT_SCENE_CONTACTS: &std::ffi::CStr = c"hapticd.scene.contacts/1";

/// Touch flag: the pointer slides along the surface (dynamic friction) instead of sticking.
pub const HAPTICD_TOUCH_SLIPPING: u32 = 1;

/// What a pointer touches after a step.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdTouch {
    /// The body touched (its id), or [`HAPTICD_NO_BODY`] for a solid that is no body.
    pub body: u32,
    /// `HAPTICD_TOUCH_` flags.
    pub flags: u32,
    /// Where they touch, metres.
    pub point: [f64; 3],
    /// Unit normal of the touched surface, pointing out of it (toward the pointer).
    pub normal: [f64; 3],
}

/// Extension [`HAPTICD_EXT_SCENE_CONTACTS`] of a scene plugin: which body each pointer
/// touches, for contact events. A multi-rate scene names the body of each object of its
/// planes; a direct scene says after each step what each pointer touches.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdSceneContacts {
    /// `sizeof(HapticdSceneContacts)` as the plugin was compiled.
    pub struct_size: u32,
    /// [main] After `create`: the body that object `object` (of planes and impulses, numbered
    /// from 0 without gaps) belongs to; [`HAPTICD_NO_BODY`] past the last object.
    pub object_body: Option<unsafe extern "C" fn(instance: *mut c_void, object: u32) -> u32>,
    /// [rt, after `step_direct`] Direct scenes: write what pointer `pointer` touches to `out`
    /// and return [`HAPTICD_OK`], or [`HAPTICD_ERROR_ARGUMENT`] when it touches nothing. Must
    /// not allocate, lock, log or block.
    pub touch: Option<
        unsafe extern "C" fn(instance: *mut c_void, pointer: u32, out: *mut HapticdTouch) -> i32,
    >,
}
