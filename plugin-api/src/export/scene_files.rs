//! Extension `"hapticd.scene.files/1"`: the engines a plugin runs and its check of a file.

use std::ffi::{CStr, c_char};

use crate::abi::*;
use crate::ext::scene_files::*;

use super::{SceneCheck, guard};
/// A files extension that may live in a `static`.
#[repr(transparent)]
#[doc(hidden)]
pub struct StaticSceneFiles(pub HapticdSceneFiles);

// SAFETY: it holds only function pointers and a size.
unsafe impl Sync for StaticSceneFiles {}

/// Body of the exported files extension's `engine` function.
#[doc(hidden)]
pub fn scene_engine(engines: &'static [&'static CStr], index: u32) -> *const c_char {
    engines
        .get(index as usize)
        .map_or(std::ptr::null(), |e| e.as_ptr())
}

/// Body of the exported files extension's `check` function.
///
/// # Safety
/// `path` is null or NUL-terminated; `message` is null or holds `capacity` bytes.
#[doc(hidden)]
pub unsafe fn scene_check(
    check: SceneCheck,
    path: *const c_char,
    pointer_count: u32,
    message: *mut c_char,
    capacity: usize,
) -> i32 {
    if path.is_null() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: non-null and NUL-terminated, per the contract.
    let path = unsafe { CStr::from_ptr(path) }
        .to_string_lossy()
        .into_owned();
    let mut findings = None;
    let status = guard(|| match check(&path, pointer_count as usize) {
        Ok(()) => HAPTICD_OK,
        Err(e) => {
            findings = Some(e.to_string());
            HAPTICD_ERROR_FAILED
        }
    });
    if let (Some(text), false, 1..) = (findings, message.is_null(), capacity) {
        let mut end = text.len().min(capacity - 1);
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        // SAFETY: `message` holds `capacity` > `end` bytes, per the contract.
        unsafe {
            std::ptr::copy_nonoverlapping(text.as_ptr().cast::<c_char>(), message, end);
            message.add(end).write(0);
        }
    }
    status
}
