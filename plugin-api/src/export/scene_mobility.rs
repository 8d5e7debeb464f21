//! Extension `"hapticd.scene.mobility/1"` served from a [`SceneInstance`]'s jointed bodies.

use crate::abi::*;
use crate::ext::scene_mobility::*;

use super::{guard, instance_mut, write_out};

unsafe extern "C" fn mobility_of(
    instance: *mut std::ffi::c_void,
    body: u32,
    out: *mut HapticdMobility,
) -> i32 {
    if instance.is_null() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: the host keeps the extension's contract: a live instance on its physics thread.
    let scene = unsafe { instance_mut(instance) };
    let mut mobility = None;
    let status = guard(|| {
        mobility = scene.mobility(body);
        HAPTICD_OK
    });
    if status != HAPTICD_OK {
        return status;
    }
    // SAFETY: `out` is null or valid for one write, per the contract.
    unsafe { write_out(out, mobility) }
}

/// The mobility extension every Rust scene plugin serves, around [`SceneInstance::mobility`].
pub(super) static SCENE_MOBILITY: HapticdSceneMobility = HapticdSceneMobility {
    struct_size: std::mem::size_of::<HapticdSceneMobility>() as u32,
    mobility: Some(mobility_of),
};
