//! Scene extension `"hapticd.scene.files/1"`: the scene files a plugin runs.
//!
//! A scene plugin offers it through [`HapticdSceneVtable::get_extension`](crate::HapticdSceneVtable::get_extension);
//! its C declarations are the header's section of the same name.

use std::ffi::c_char;

/// The id of [`HapticdSceneFiles`].
pub const HAPTICD_EXT_SCENE_FILES: &std::ffi::CStr = c"hapticd.scene.files/1";

/// Extension [`HAPTICD_EXT_SCENE_FILES`] of a scene plugin: the `engine:` values of the scene
/// files it runs, and a check of such a file. The host reads a file's `engine:` key alone
/// and hands the file to the plugin that declares it.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdSceneFiles {
    /// `sizeof(HapticdSceneFiles)` as the plugin was compiled.
    pub struct_size: u32,
    /// [any] The `index`-th `engine:` value it runs (from 0), NUL-terminated and valid for
    /// the life of the process; null past the last.
    pub engine: Option<unsafe extern "C" fn(index: u32) -> *const c_char>,
    /// [main] Check the NUL-terminated scene file `path` for `pointer_count` pointers without
    /// creating anything: [`HAPTICD_OK`], or [`HAPTICD_ERROR_FAILED`] with what is wrong
    /// (one finding a line, `file:line:column: error: field: message`) written to `message`,
    /// at most `capacity` bytes with its NUL.
    pub check: Option<
        unsafe extern "C" fn(
            path: *const c_char,
            pointer_count: u32,
            message: *mut c_char,
            capacity: usize,
        ) -> i32,
    >,
}
