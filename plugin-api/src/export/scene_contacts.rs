//! Extension `"hapticd.scene.contacts/1"` served from a [`SceneInstance`]'s touches.

use crate::abi::*;
use crate::ext::{scene_contacts::*, scene_geometry::*};

use super::{answer, guard, instance_mut};
unsafe extern "C" fn contacts_object_body(instance: *mut std::ffi::c_void, object: u32) -> u32 {
    if instance.is_null() {
        return HAPTICD_NO_BODY;
    }
    // SAFETY: the host keeps the extension's contract: a live instance on the main thread.
    let scene = unsafe { instance_mut(instance) };
    let mut body = HAPTICD_NO_BODY;
    guard(|| {
        body = scene.object_body(object).unwrap_or(HAPTICD_NO_BODY);
        HAPTICD_OK
    });
    body
}

unsafe extern "C" fn contacts_touch(
    instance: *mut std::ffi::c_void,
    pointer: u32,
    out: *mut HapticdTouch,
) -> i32 {
    // SAFETY: the host keeps the extension's contract: a live instance on its stepping
    // thread, `out` null or valid.
    unsafe { answer(instance, out, |scene| scene.touch(pointer as usize)) }
}

/// The contacts extension every Rust scene plugin serves, around
/// [`SceneInstance::object_body`] and [`SceneInstance::touch`].
pub(super) static SCENE_CONTACTS: HapticdSceneContacts = HapticdSceneContacts {
    struct_size: std::mem::size_of::<HapticdSceneContacts>() as u32,
    object_body: Some(contacts_object_body),
    touch: Some(contacts_touch),
};
