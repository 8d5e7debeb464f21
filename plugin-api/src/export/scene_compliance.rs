//! Extension `"hapticd.scene.compliance/1"` served from a [`SceneInstance`]'s soft surfaces.

use crate::ext::scene_compliance::*;

use super::answer;

unsafe extern "C" fn compliance_of(
    instance: *mut std::ffi::c_void,
    pointer: u32,
    plane: u32,
    out: *mut HapticdPlaneCompliance,
) -> i32 {
    // SAFETY: the host keeps the extension's contract: a live instance on its physics
    // thread, `out` null or valid.
    unsafe { answer(instance, out, |scene| scene.compliance(pointer, plane)) }
}

/// The compliance extension every Rust scene plugin serves, around
/// [`SceneInstance::compliance`].
pub(super) static SCENE_COMPLIANCE: HapticdSceneCompliance = HapticdSceneCompliance {
    struct_size: std::mem::size_of::<HapticdSceneCompliance>() as u32,
    compliance: Some(compliance_of),
};
