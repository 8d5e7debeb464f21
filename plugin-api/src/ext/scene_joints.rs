//! Scene extension `"hapticd.scene.joints/1"`: a running world's joints, read and driven.
//!
//! A scene plugin offers it through [`HapticdSceneVtable::get_extension`](crate::HapticdSceneVtable::get_extension);
//! its C declarations are the header's section of the same name.

use std::ffi::{c_char, c_void};

use super::scene_control::HAPTICD_BODY_NAME_CAPACITY;

/// The id of [`HapticdSceneJoints`] (since ABI 1.8).
pub const HAPTICD_EXT_SCENE_JOINTS: &std::ffi::CStr = c"hapticd.scene.joints/1";

/// Joint kind: a weld.
pub const HAPTICD_JOINT_FIXED: u32 = 0;
/// Joint kind: a hinge; its coordinate is an angle, rad.
pub const HAPTICD_JOINT_REVOLUTE: u32 = 1;
/// Joint kind: a slider; its coordinate is a distance, m.
pub const HAPTICD_JOINT_PRISMATIC: u32 = 2;
/// Joint kind: a ball joint, without a coordinate.
pub const HAPTICD_JOINT_SPHERICAL: u32 = 3;

/// Joint command: change nothing; only report the joint's coordinate and rate.
pub const HAPTICD_JOINT_QUERY: u32 = 0;
/// Joint command: drive the coordinate at the rate `target` (rad/s or m/s) with at most
/// `max_force` (N·m or N).
pub const HAPTICD_JOINT_MOTOR_VELOCITY: u32 = 1;
/// Joint command: drive the coordinate to `target` (rad or m) with at most `max_force`.
pub const HAPTICD_JOINT_MOTOR_POSITION: u32 = 2;
/// Joint command: stop driving it (its spring and damper, if any, stay).
pub const HAPTICD_JOINT_MOTOR_OFF: u32 = 3;

/// A joint of a running world, as the joints extension lists it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HapticdJointInfo {
    /// NUL-terminated UTF-8 name (unique within the world).
    pub name: [c_char; HAPTICD_BODY_NAME_CAPACITY],
    /// One of the `HAPTICD_JOINT_` kinds.
    pub kind: u32,
}

/// A command to one joint of a running world.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdJointCommand {
    /// One of the `HAPTICD_JOINT_` commands.
    pub kind: u32,
    /// The joint's place in the list.
    pub joint: u32,
    /// The motor's target: rad/s or m/s, or rad or m.
    pub target: f64,
    /// The most force or torque the motor gives, N or N·m.
    pub max_force: f64,
}

/// Where a joint stands.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdJointState {
    /// Its coordinate: rad (a hinge's counted in whole turns from load) or m.
    pub position: f64,
    /// Its rate, rad/s or m/s.
    pub velocity: f64,
}

/// Extension [`HAPTICD_EXT_SCENE_JOINTS`] of a scene plugin: a running world's joints
/// listed, read and driven one command at a time between steps. The host checks each
/// command (a joint it lists, with a coordinate for a motor, finite values in range)
/// before it is sent.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdSceneJoints {
    /// `sizeof(HapticdSceneJoints)` as the plugin was compiled.
    pub struct_size: u32,
    /// [main] After `create`, before the first step: write joint `index` to `out`;
    /// [`HAPTICD_ERROR_ARGUMENT`](crate::HAPTICD_ERROR_ARGUMENT) past the last joint.
    pub joint: Option<
        unsafe extern "C" fn(instance: *mut c_void, index: u32, out: *mut HapticdJointInfo) -> i32,
    >,
    /// [the thread that steps the instance, between steps] Carry out `command` and write the
    /// joint's state after it to `state`. Like a step it must not allocate, lock, log or block.
    pub drive: Option<
        unsafe extern "C" fn(
            instance: *mut c_void,
            command: *const HapticdJointCommand,
            state: *mut HapticdJointState,
        ) -> i32,
    >,
}
