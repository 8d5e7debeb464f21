//! Extension `"hapticd.scene.held/1"` served from a [`SceneInstance`]'s held body.

use crate::abi::*;
use crate::ext::scene_geometry::HapticdTriangle;
use crate::ext::scene_held::*;

use super::{answer, guard, instance_mut};

unsafe extern "C" fn held_of(instance: *mut std::ffi::c_void, out: *mut HapticdHeld) -> i32 {
    // SAFETY: the host keeps the extension's contract: a live instance on its main thread,
    // `out` null or valid.
    unsafe { answer(instance, out, |scene| scene.held()) }
}

unsafe extern "C" fn surface_of(
    instance: *mut std::ffi::c_void,
    body: u32,
    piece: u32,
    info: *mut HapticdSurfacePiece,
    out: *mut HapticdTriangle,
    capacity: u32,
) -> i32 {
    if instance.is_null() || info.is_null() || (out.is_null() && capacity > 0) {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: non-null, and live and this thread's, per the contract.
    let scene = unsafe { instance_mut(instance) };
    let mut found = None;
    let status = guard(|| {
        found = scene.surface(body, piece);
        HAPTICD_OK
    });
    if status != HAPTICD_OK {
        return status;
    }
    let Some((piece, triangles)) = found else {
        return HAPTICD_ERROR_ARGUMENT;
    };
    let written = triangles.len().min(capacity as usize);
    // SAFETY: `info` is valid for one write and `out` for `capacity` triangles, per the
    // contract; `written` is at most `capacity`.
    unsafe {
        info.write(HapticdSurfacePiece {
            triangle_count: triangles.len() as u32,
            ..piece
        });
        if written > 0 {
            std::ptr::copy_nonoverlapping(triangles.as_ptr(), out, written);
        }
    }
    HAPTICD_OK
}

/// The held extension every Rust scene plugin serves, around [`SceneInstance::held`] and
/// [`SceneInstance::surface`].
pub(super) static SCENE_HELD: HapticdSceneHeld = HapticdSceneHeld {
    struct_size: std::mem::size_of::<HapticdSceneHeld>() as u32,
    held: Some(held_of),
    surface: Some(surface_of),
};
