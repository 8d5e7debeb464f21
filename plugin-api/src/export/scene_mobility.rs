//! Extension `"hapticd.scene.mobility/1"` served from a [`SceneInstance`]'s jointed bodies.

use crate::ext::scene_mobility::*;

use super::answer;

unsafe extern "C" fn mobility_of(
    instance: *mut std::ffi::c_void,
    body: u32,
    out: *mut HapticdMobility,
) -> i32 {
    // SAFETY: the host keeps the extension's contract: a live instance on its physics
    // thread, `out` null or valid.
    unsafe { answer(instance, out, |scene| scene.mobility(body)) }
}

/// The mobility extension every Rust scene plugin serves, around [`SceneInstance::mobility`].
pub(super) static SCENE_MOBILITY: HapticdSceneMobility = HapticdSceneMobility {
    struct_size: std::mem::size_of::<HapticdSceneMobility>() as u32,
    mobility: Some(mobility_of),
};
