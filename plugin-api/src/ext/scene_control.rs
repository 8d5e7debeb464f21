//! Scene extension `"hapticd.scene.control/1"`: a running world changed from outside.
//!
//! A scene plugin offers it through [`HapticdSceneVtable::get_extension`](crate::HapticdSceneVtable::get_extension);
//! its C declarations are the header's section of the same name.

use std::ffi::{c_char, c_void};

/// The id of [`HapticdSceneControl`] (since ABI 1.5).
pub const HAPTICD_EXT_SCENE_CONTROL: &std::ffi::CStr = c"hapticd.scene.control/1";

/// Command: change nothing; only report the body's state.
pub const HAPTICD_COMMAND_QUERY: u32 = 0;
/// Command: put the body's centre of mass at `position` with `orientation`, keeping its
/// velocities.
pub const HAPTICD_COMMAND_SET_POSE: u32 = 1;
/// Command: give the body the velocity `vector` and angular velocity `spin`.
pub const HAPTICD_COMMAND_SET_VELOCITY: u32 = 2;
/// Command: give the body the momentum `vector` (N·s) at the point `position`: Δv = J/m,
/// Δω = I⁻¹((p − c) × J).
pub const HAPTICD_COMMAND_IMPULSE: u32 = 3;
/// Command: push the body with the force `vector` (N) at its centre of mass at every step
/// from now on, besides gravity (zero ends it).
pub const HAPTICD_COMMAND_SET_FORCE: u32 = 4;
/// Command: make the body's mass `value` kg, its inertia scaled with it (same shape, other
/// density).
pub const HAPTICD_COMMAND_SET_MASS: u32 = 5;
/// Command: make the friction coefficient of the body's contacts `value` (a contact takes
/// the lower of its two bodies'; a static coefficient keeps its ratio to the dynamic one).
pub const HAPTICD_COMMAND_SET_FRICTION: u32 = 6;

/// Command (since ABI 1.7): give the body the momentum `vector` (N·s) through its centre of
/// mass, where it is when the command is carried out: Δv = J/m, no turn. (A centre read
/// by an earlier query has moved by then; the host asks plugins of older minors for the
/// centre and gives the impulse there between the same two steps.)
pub const HAPTICD_COMMAND_IMPULSE_AT_CENTRE: u32 = 7;

/// Command (since ABI 1.11): make a soft body of Young's modulus `vector[0]` (Pa), Poisson's
/// ratio `vector[1]` and damping `vector[2]` (s), its shape and motion kept.
pub const HAPTICD_COMMAND_SET_MATERIAL: u32 = 8;

/// Command (since ABI 1.11): hold still the nodes of a soft body that stand where
/// n·x ≤ `value` (m) now, n the unit vector `vector`.
pub const HAPTICD_COMMAND_PIN: u32 = 9;

/// Command (since ABI 1.11): let go the held nodes of a soft body that stand where
/// n·x ≤ `value` (m) now, n the unit vector `vector`.
pub const HAPTICD_COMMAND_RELEASE: u32 = 10;

/// Longest body name in bytes, including the terminating NUL.
pub const HAPTICD_BODY_NAME_CAPACITY: usize = 64;

/// A body of a running world, as the control extension lists it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HapticdBodyInfo {
    /// NUL-terminated UTF-8 name, the scene file's (unique within the world, or empty).
    pub name: [c_char; HAPTICD_BODY_NAME_CAPACITY],
    /// [`HAPTICD_SOLID_FIXED`] for a body forces do not move.
    pub flags: u32,
}

/// A change to one body of a running world.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdSceneCommand {
    /// One of the `HAPTICD_COMMAND_` constants.
    pub kind: u32,
    /// The body's id (its place in `poses`).
    pub body: u32,
    /// [`HAPTICD_COMMAND_SET_POSE`]: where its centre of mass goes; [`HAPTICD_COMMAND_IMPULSE`]:
    /// where the impulse acts. Metres.
    pub position: [f64; 3],
    /// [`HAPTICD_COMMAND_SET_POSE`]: its orientation, unit quaternion (w, x, y, z).
    pub orientation: [f64; 4],
    /// The velocity (m/s), impulse (N·s) or force (N) the kind names;
    /// [`HAPTICD_COMMAND_SET_MATERIAL`]: the material; [`HAPTICD_COMMAND_PIN`] and
    /// [`HAPTICD_COMMAND_RELEASE`]: the normal of the plane bounding the nodes.
    pub vector: [f64; 3],
    /// [`HAPTICD_COMMAND_SET_VELOCITY`]: the angular velocity, rad/s.
    pub spin: [f64; 3],
    /// [`HAPTICD_COMMAND_SET_MASS`]: kg; [`HAPTICD_COMMAND_SET_FRICTION`]: the coefficient;
    /// [`HAPTICD_COMMAND_PIN`] and [`HAPTICD_COMMAND_RELEASE`]: the plane's offset, m.
    pub value: f64,
}

/// A body's state, as a command left it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdBodyState {
    /// Centre of mass, metres.
    pub position: [f64; 3],
    /// Orientation, unit quaternion (w, x, y, z).
    pub orientation: [f64; 4],
    /// Velocity of the centre of mass, m/s.
    pub velocity: [f64; 3],
    /// Angular velocity, rad/s.
    pub spin: [f64; 3],
    /// Mass, kg (infinite for a fixed body).
    pub mass: f64,
    /// The friction coefficient of its contacts.
    pub friction: f64,
    /// The force pushing it besides gravity ([`HAPTICD_COMMAND_SET_FORCE`]), N.
    pub force: [f64; 3],
}

/// Extension [`HAPTICD_EXT_SCENE_CONTROL`] of a scene plugin: a running world's bodies
/// listed, and changed one command at a time between steps. The host checks each command
/// (a body it lists, finite values in range, no force on a fixed body) before it is sent;
/// the plugin refuses what it still cannot do with [`HAPTICD_ERROR_ARGUMENT`].
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdSceneControl {
    /// `sizeof(HapticdSceneControl)` as the plugin was compiled.
    pub struct_size: u32,
    /// [main] After `create`, before the first step: write body `index` to `out`;
    /// [`HAPTICD_ERROR_ARGUMENT`] past the last body.
    pub body: Option<
        unsafe extern "C" fn(instance: *mut c_void, index: u32, out: *mut HapticdBodyInfo) -> i32,
    >,
    /// [the thread that steps the instance, between steps] Carry out `command` and write the
    /// body's state after it to `state`. Like a step it must not allocate, lock, log or block.
    pub apply: Option<
        unsafe extern "C" fn(
            instance: *mut c_void,
            command: *const HapticdSceneCommand,
            state: *mut HapticdBodyState,
        ) -> i32,
    >,
}
