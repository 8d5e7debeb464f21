//! Extension `"hapticd.scene.deformation/1"` served from a [`SceneInstance`]'s corners.

use crate::ext::scene_deformation::*;

use super::{guard, instance_mut};

unsafe extern "C" fn deformation_corners(
    instance: *mut std::ffi::c_void,
    out: *mut f32,
    capacity: u32,
) -> u32 {
    if instance.is_null() || (out.is_null() && capacity > 0) {
        return 0;
    }
    let mut count = 0;
    guard(|| {
        // SAFETY: the host keeps the extension's contract: a live instance on its stepping
        // thread.
        let scene = unsafe { instance_mut(instance) };
        let corners = if capacity == 0 {
            &mut [][..]
        } else {
            // SAFETY: non-null with `capacity` corners of three floats each (an array of
            // three f32 has the alignment of one), per the contract.
            unsafe { std::slice::from_raw_parts_mut(out.cast::<[f32; 3]>(), capacity as usize) }
        };
        count = u32::try_from(scene.corners(corners)).unwrap_or(u32::MAX);
        crate::HAPTICD_OK
    });
    count
}

/// The deformation extension every Rust scene plugin serves, around
/// [`SceneInstance::corners`](super::SceneInstance::corners).
pub(super) static SCENE_DEFORMATION: HapticdSceneDeformation = HapticdSceneDeformation {
    struct_size: std::mem::size_of::<HapticdSceneDeformation>() as u32,
    corners: Some(deformation_corners),
};
