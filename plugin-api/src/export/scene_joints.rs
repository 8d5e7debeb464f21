//! Extension `"hapticd.scene.joints/1"` served from a [`SceneInstance`]'s joints.

use crate::abi::*;
use crate::ext::scene_joints::*;

use super::scene_control::{name_buffer, name_text};
use super::{answer, guard, instance_mut};

impl HapticdJointInfo {
    /// A joint called `name` (cut as a body's name is) of `kind`.
    pub fn new(name: &str, kind: u32) -> Self {
        Self {
            name: name_buffer(name),
            kind,
        }
    }

    /// The name up to its NUL, or `None` if it is unterminated or not UTF-8.
    pub fn name_str(&self) -> Option<&str> {
        name_text(&self.name)
    }
}

impl HapticdJointCommand {
    /// Whether every number the command carries is finite (a plugin takes no other).
    pub fn is_finite(&self) -> bool {
        self.target.is_finite() && self.max_force.is_finite()
    }
}

unsafe extern "C" fn joints_joint(
    instance: *mut std::ffi::c_void,
    index: u32,
    out: *mut HapticdJointInfo,
) -> i32 {
    // SAFETY: the host keeps the extension's contract: a live instance on the main thread,
    // `out` null or valid.
    unsafe { answer(instance, out, |scene| scene.joint(index as usize)) }
}

unsafe extern "C" fn joints_drive(
    instance: *mut std::ffi::c_void,
    command: *const HapticdJointCommand,
    state: *mut HapticdJointState,
) -> i32 {
    if instance.is_null() || command.is_null() || state.is_null() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: the host keeps the extension's contract: a live instance on its stepping
    // thread, a valid command and state.
    let (scene, command, state) = unsafe { (instance_mut(instance), *command, &mut *state) };
    if !command.is_finite() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    guard(|| scene.drive(&command, state))
}

/// The joints extension every Rust scene plugin serves, around [`SceneInstance::joint`]
/// and [`SceneInstance::drive`].
pub(super) static SCENE_JOINTS: HapticdSceneJoints = HapticdSceneJoints {
    struct_size: std::mem::size_of::<HapticdSceneJoints>() as u32,
    joint: Some(joints_joint),
    drive: Some(joints_drive),
};
