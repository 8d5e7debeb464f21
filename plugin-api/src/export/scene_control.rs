//! Extension `"hapticd.scene.control/1"` served from a [`SceneInstance`]'s bodies and
//! commands.

use std::ffi::{CStr, c_char};

use crate::abi::*;
use crate::ext::{scene_control::*, scene_geometry::*};

use super::{answer, guard, instance_mut};
impl HapticdSceneCommand {
    /// A command of `kind` for body `body`, its numbers zero and its orientation none turned.
    pub fn new(kind: u32, body: u32) -> Self {
        Self {
            kind,
            body,
            orientation: [1.0, 0.0, 0.0, 0.0],
            ..Self::default()
        }
    }

    /// Whether every number the command carries is finite (a plugin takes no other).
    pub fn is_finite(&self) -> bool {
        self.position
            .iter()
            .chain(&self.orientation)
            .chain(&self.vector)
            .chain(&self.spin)
            .chain(std::iter::once(&self.value))
            .all(|v| v.is_finite())
    }
}

/// `name` as a body's or joint's NUL-terminated name: cut at a character to fit
/// [`HAPTICD_BODY_NAME_CAPACITY`] − 1 bytes (a NUL ends it early).
pub(super) fn name_buffer(name: &str) -> [c_char; HAPTICD_BODY_NAME_CAPACITY] {
    let mut end = name.len().min(HAPTICD_BODY_NAME_CAPACITY - 1);
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    let mut buf = [0 as c_char; HAPTICD_BODY_NAME_CAPACITY];
    for (slot, byte) in buf.iter_mut().zip(name[..end].bytes()) {
        *slot = byte as c_char;
    }
    buf
}

/// A name buffer's text up to its NUL, or `None` if it is unterminated or not UTF-8.
pub(super) fn name_text(name: &[c_char; HAPTICD_BODY_NAME_CAPACITY]) -> Option<&str> {
    // SAFETY: c_char and u8 have the same size and alignment.
    let bytes: &[u8; HAPTICD_BODY_NAME_CAPACITY] = unsafe { &*name.as_ptr().cast() };
    CStr::from_bytes_until_nul(bytes).ok()?.to_str().ok()
}

impl HapticdBodyInfo {
    /// A body called `name` (cut at a character to fit [`HAPTICD_BODY_NAME_CAPACITY`] − 1
    /// bytes; a NUL ends it early), fixed or free.
    pub fn new(name: &str, fixed: bool) -> Self {
        Self {
            name: name_buffer(name),
            flags: if fixed { HAPTICD_SOLID_FIXED } else { 0 },
        }
    }

    /// The name up to its NUL, or `None` if it is unterminated or not UTF-8.
    pub fn name_str(&self) -> Option<&str> {
        name_text(&self.name)
    }
}

unsafe extern "C" fn control_body(
    instance: *mut std::ffi::c_void,
    index: u32,
    out: *mut HapticdBodyInfo,
) -> i32 {
    // SAFETY: the host keeps the extension's contract: a live instance on the main thread,
    // `out` null or valid.
    unsafe { answer(instance, out, |scene| scene.body(index as usize)) }
}

unsafe extern "C" fn control_apply(
    instance: *mut std::ffi::c_void,
    command: *const HapticdSceneCommand,
    state: *mut HapticdBodyState,
) -> i32 {
    if instance.is_null() || command.is_null() || state.is_null() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: non-null and valid, on the thread that steps the instance, per the contract.
    let (scene, command, state) = unsafe { (instance_mut(instance), &*command, &mut *state) };
    guard(|| scene.apply(command, state))
}

/// The control extension every Rust scene plugin serves, around [`SceneInstance::body`]
/// and [`SceneInstance::apply`].
pub(super) static SCENE_CONTROL: HapticdSceneControl = HapticdSceneControl {
    struct_size: std::mem::size_of::<HapticdSceneControl>() as u32,
    body: Some(control_body),
    apply: Some(control_apply),
};
