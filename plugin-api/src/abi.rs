//! The `#[repr(C)]` types of ABI v1 but for the scene extensions (`ext`, which build on them).
//! `include/hapticd_plugin.h` is generated from this file and theirs.
//!
//! Rules of the boundary: memory is never freed across it (the host copies what a plugin
//! returns, a plugin's descriptor lives forever), every function returns a status code
//! instead of unwinding, and every function states the thread it may be called on.

use std::ffi::{c_char, c_void};

/// Major ABI version: a plugin whose major differs from the host's is refused.
pub const HAPTICD_ABI_MAJOR: u32 = 1;
/// Minor ABI version. Minors only append (struct fields, constants, extensions), so a
/// plugin of any minor loads: the host reads no field newer than its own minor, and a
/// plugin reads the host's minor in [`HapticdHost::abi_minor`] and asks for newer services
/// through [`HapticdHost::get_extension`].
pub const HAPTICD_ABI_MINOR: u32 = 12;

/// Plugin kind: a mechanism (string geometry and motor constants of a SPIDAR-like device).
pub const HAPTICD_KIND_MECHANISM: u32 = 1;
/// Plugin kind: scene physics.
pub const HAPTICD_KIND_SCENE: u32 = 2;

/// Scene style: the plugin steps the whole world inside every haptic tick and returns the
/// wrench on each pointer (the penalty method of thesis Ch. 5).
pub const HAPTICD_SCENE_DIRECT: u32 = 1;
/// Scene style: the plugin steps the world in its own physics thread at its own rate,
/// publishes for each pointer the nearby surfaces as planes, and takes back the impulses the
/// haptic thread applied (the analytic method of thesis Ch. 6).
pub const HAPTICD_SCENE_MULTIRATE: u32 = 2;

/// Most planes published for one pointer per physics step.
pub const HAPTICD_MAX_PLANES: usize = 8;

/// Most bodies a physics step hands the haptic side to move itself (local dynamics).
pub const HAPTICD_MAX_LOCAL_BODIES: usize = 8;

/// Most contacts with the rest of the world published for one such body: a block in a corner
/// stands on a floor and against two walls with four corners each.
pub const HAPTICD_MAX_BODY_CONTACTS: usize = 16;

/// Status: success.
pub const HAPTICD_OK: i32 = 0;
/// Status: an argument was out of range or a pointer was null.
pub const HAPTICD_ERROR_ARGUMENT: i32 = -1;
/// Status: the plugin panicked (or threw); the host disables it.
pub const HAPTICD_ERROR_PANIC: i32 = -2;
/// Status: the plugin failed for a reason it has logged through the host.
pub const HAPTICD_ERROR_FAILED: i32 = -3;

/// Log level: an error the user must act on.
pub const HAPTICD_LOG_ERROR: u32 = 1;
/// Log level: something unexpected that the plugin worked around.
pub const HAPTICD_LOG_WARN: u32 = 2;
/// Log level: normal operation.
pub const HAPTICD_LOG_INFO: u32 = 3;
/// Log level: detail for developers.
pub const HAPTICD_LOG_DEBUG: u32 = 4;

/// Longest effector name in bytes, including the terminating NUL.
pub const HAPTICD_NAME_CAPACITY: usize = 32;

/// Services the host offers a plugin. Valid for the life of the process.
///
/// A plugin carries its own copy of its language runtime, so its own logging would not
/// reach the journal: it logs through `log` instead.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdHost {
    /// The host's [`HAPTICD_ABI_MAJOR`].
    pub abi_major: u32,
    /// The host's [`HAPTICD_ABI_MINOR`].
    pub abi_minor: u32,
    /// Opaque host pointer, passed back to every host function.
    pub context: *mut c_void,
    /// [main, physics] Log a UTF-8 message of `len` bytes (not necessarily NUL-terminated).
    /// Never call it from [rt] functions.
    pub log: Option<
        unsafe extern "C" fn(context: *mut c_void, level: u32, message: *const c_char, len: usize),
    >,
    /// [any] Monotonic clock in nanoseconds (CLOCK_MONOTONIC).
    pub now_ns: Option<unsafe extern "C" fn(context: *mut c_void) -> u64>,
    /// [any] Since ABI 1.1 (read it only when `abi_minor` ≥ 1): the host's extension called
    /// `id`, a NUL-terminated name with its version such as `hapticd.example/1`, or null
    /// when the host offers none of that name. Services added after 1.1 come as
    /// extensions, so a plugin asks for what it can use instead of being refused by an
    /// older host.
    pub get_extension:
        Option<unsafe extern "C" fn(context: *mut c_void, id: *const c_char) -> *const c_void>,
}

/// A pointer (end effector) as a scene sees it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdPointer {
    /// Grip position, metres.
    pub position: [f64; 3],
    /// Grip orientation, unit quaternion (w, x, y, z).
    pub orientation: [f64; 4],
    /// Grip velocity, m/s.
    pub velocity: [f64; 3],
}

/// A force and torque on a pointer (the torque about the grip centre).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdWrench {
    /// Force, newtons.
    pub force: [f64; 3],
    /// Torque, newton-metres.
    pub torque: [f64; 3],
}

/// A surface near a pointer: the solid lies behind the plane through `point` with outward
/// `normal`, and moves with `velocity` there.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdPlane {
    /// The object the surface belongs to (the target of impulses).
    pub object: u32,
    /// Nearest point of the object to the pointer, metres.
    pub point: [f64; 3],
    /// Outward unit normal at that point.
    pub normal: [f64; 3],
    /// Velocity of the object's surface at that point, m/s.
    pub velocity: [f64; 3],
}

/// The planes published for one pointer.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdPlanes {
    /// Planes in use.
    pub count: u32,
    /// The planes.
    pub planes: [HapticdPlane; HAPTICD_MAX_PLANES],
}

/// Momentum the haptic thread gave an object over one physics period, and where.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdImpulse {
    /// The object pushed.
    pub object: u32,
    /// Where the force acted (its force-weighted mean point), metres.
    pub point: [f64; 3],
    /// ∫F dt over the period, N·s.
    pub impulse: [f64; 3],
}

/// A contact of a body with the rest of the world as a physics step left it: the other
/// solid is taken to stay where it is until the next step.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdBodyContact {
    /// The contact point, metres.
    pub point: [f64; 3],
    /// Unit normal along which the other solid pushes this body.
    pub normal: [f64; 3],
    /// Gap between the two solids along `normal`, metres (negative: overlapping).
    pub gap: f64,
    /// Coulomb friction coefficient of the contact.
    pub friction: f64,
}

/// A body near a pointer that the haptic side moves itself between physics steps (local
/// dynamics, thesis 6.5.4): its state after the step, how it answers a force (its mass and
/// inertia), what moves it without the hand (the free acceleration), and its contacts with
/// the rest of the world, which the haptic side keeps as constraints over the period.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdLocalBody {
    /// The body's number (its place in the scene's list of bodies).
    pub body: u32,
    /// Its objects (the `object` of its planes) are `first_object .. first_object + object_count`.
    pub first_object: u32,
    /// How many objects the body has.
    pub object_count: u32,
    /// Since ABI 1.6: 1 when the step left the change numbered `applied` out (taking it in
    /// would have put the body deeper into a fixed solid), 0 when it took it in. The host
    /// reads it from plugins of 1.6 and later only (it fills what was padding before).
    pub left_out: u32,
    /// The [`HapticdLocalState::sequence`] of the last change of the hand this step took in
    /// (or left out) for the body (0: none yet).
    pub applied: u64,
    /// Centre of mass, metres.
    pub position: [f64; 3],
    /// Orientation, unit quaternion (w, x, y, z).
    pub orientation: [f64; 4],
    /// Velocity of the centre of mass, m/s.
    pub velocity: [f64; 3],
    /// Angular velocity, rad/s.
    pub spin: [f64; 3],
    /// 1 / mass, 1/kg.
    pub inverse_mass: f64,
    /// Inverse inertia about the centre of mass in world axes, row-major, 1/(kg·m²).
    pub inverse_inertia: [f64; 9],
    /// Acceleration of the centre without the hand or contacts (gravity), m/s².
    pub acceleration: [f64; 3],
    /// Contacts in use.
    pub contact_count: u32,
    /// Its contacts with other solids.
    pub contacts: [HapticdBodyContact; HAPTICD_MAX_BODY_CONTACTS],
}

/// What the hand did to a locally moved body over one physics period: how far its motion
/// differs from the motion the haptic side computed for it without the hand. The physics
/// adds it to the body at its next step.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdLocalState {
    /// The body's number.
    pub body: u32,
    /// Increases with every change the haptic side hands back.
    pub sequence: u64,
    /// Displacement of the centre of mass, metres.
    pub displacement: [f64; 3],
    /// Rotation about the centre of mass, as a rotation vector (axis × angle), radians.
    pub rotation: [f64; 3],
    /// Velocity change, m/s.
    pub velocity: [f64; 3],
    /// Angular velocity change, rad/s.
    pub spin: [f64; 3],
}

/// The input of a physics step since ABI 1.3.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdPhysicsInput {
    /// Seconds to advance.
    pub dt: f64,
    /// Number of pointers: `pointers`, `proxies` and the output's `planes` hold this many.
    pub pointer_count: u32,
    /// The grips.
    pub pointers: *const HapticdPointer,
    /// Where each pointer's proxy rests (the god-object: never inside a solid the haptic
    /// side renders). Planes are built around these, so a normal never turns over under a
    /// finger that presses through a thin solid. A proxy's `velocity` is as fast as its
    /// finger pushed at most over the period (its grip's speed, with the speed its proxy
    /// catches up with a grip gone deeper; the grip's own velocity from hosts of ABI 1.5 and
    /// earlier): no impulse may carry the point it acts at faster than that.
    pub proxies: *const HapticdPointer,
    /// Impulses on objects the haptic side did not move itself.
    pub impulse_count: u32,
    /// The impulses (may be null when `impulse_count` is 0).
    pub impulses: *const HapticdImpulse,
    /// Changes of the hand on locally moved bodies.
    pub local_count: u32,
    /// The changes (may be null when `local_count` is 0).
    pub locals: *const HapticdLocalState,
}

/// Where a physics step since ABI 1.3 writes what it publishes.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdPhysicsOutput {
    /// One set of planes per pointer.
    pub planes: *mut HapticdPlanes,
    /// Room for `body_capacity` bodies to move locally.
    pub bodies: *mut HapticdLocalBody,
    /// At most [`HAPTICD_MAX_LOCAL_BODIES`].
    pub body_capacity: u32,
    /// Written by the plugin: bodies in `bodies` (0: the haptic side moves none, and hands
    /// back impulses only).
    pub body_count: u32,
}

/// Where a body of a scene is: for pictures of the world.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdBodyPose {
    /// The body's centre of mass, metres (the origin its shapes are placed around).
    pub position: [f64; 3],
    /// The body's orientation, unit quaternion (w, x, y, z).
    pub orientation: [f64; 4],
}

/// What a scene instance tells the host when created.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdSceneInfo {
    /// [`HAPTICD_SCENE_DIRECT`] or [`HAPTICD_SCENE_MULTIRATE`].
    pub style: u32,
    /// Multi-rate scenes: physics steps per second (10–1000). Ignored for direct scenes.
    pub physics_rate: f64,
}

/// Functions of a scene plugin. Fields appended by later minors are present only when
/// `struct_size` covers them.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdSceneVtable {
    /// `sizeof(HapticdSceneVtable)` as the plugin was compiled.
    pub struct_size: u32,
    /// [main] Create an instance for `pointer_count` pointers from the NUL-terminated scene
    /// file `path` (null: the plugin's default scene); write it to `instance` and describe it
    /// in `info`.
    pub create: Option<
        unsafe extern "C" fn(
            path: *const c_char,
            pointer_count: u32,
            instance: *mut *mut c_void,
            info: *mut HapticdSceneInfo,
        ) -> i32,
    >,
    /// [main] Destroy an instance no thread uses any more.
    pub destroy: Option<unsafe extern "C" fn(instance: *mut c_void)>,
    /// [rt] Direct scenes: advance `dt` seconds with the pointers at `pointers` and write
    /// one wrench per pointer to `wrenches`. Must not allocate, lock, log or block.
    pub step_direct: Option<
        unsafe extern "C" fn(
            instance: *mut c_void,
            dt: f64,
            pointers: *const HapticdPointer,
            pointer_count: u32,
            wrenches: *mut HapticdWrench,
        ) -> i32,
    >,
    /// [physics] Multi-rate scenes: apply `impulses`, advance `dt` seconds with the pointers
    /// at `pointers`, and write each pointer's nearby planes to `planes` (one per pointer).
    pub step_physics: Option<
        unsafe extern "C" fn(
            instance: *mut c_void,
            dt: f64,
            pointers: *const HapticdPointer,
            pointer_count: u32,
            impulses: *const HapticdImpulse,
            impulse_count: u32,
            planes: *mut HapticdPlanes,
        ) -> i32,
    >,
    /// [the thread that steps the instance: rt for direct scenes, physics for multi-rate
    /// ones] Since ABI 1.2 (absent from older plugins, and may be null): write the poses of
    /// the world's first `capacity` bodies, in the order of their ids (those the geometry
    /// extension gives its solids; else the scene file's order), to `poses` and return
    /// how many bodies the world has. The host draws them; like a step it must not
    /// allocate, lock, log or block.
    pub poses: Option<
        unsafe extern "C" fn(
            instance: *mut c_void,
            poses: *mut HapticdBodyPose,
            capacity: u32,
        ) -> u32,
    >,
    /// [physics] Since ABI 1.3 (may be null; the host then calls `step_physics`): one
    /// physics step with everything the haptic side knows: take the hand's changes and
    /// impulses, advance, write each pointer's planes around its proxy and, for local
    /// dynamics, the bodies near the pointers.
    pub step_world: Option<
        unsafe extern "C" fn(
            instance: *mut c_void,
            input: *const HapticdPhysicsInput,
            output: *mut HapticdPhysicsOutput,
        ) -> i32,
    >,
    /// [any] Since ABI 1.4 (may be null): the plugin's extension called `id`, a
    /// NUL-terminated name with its version such as [`HAPTICD_EXT_SCENE_GEOMETRY`], or null
    /// when it has none of that name. What scenes offer after 1.4 comes as extensions, each
    /// a struct of its own below, so the vtable itself stops growing.
    pub get_extension: Option<unsafe extern "C" fn(id: *const c_char) -> *const c_void>,
}

/// What `hapticd_plugin_entry` returns: who the plugin is and what it implements.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdPluginDescriptor {
    /// ABI major the plugin was built against; must equal the host's.
    pub abi_major: u32,
    /// ABI minor the plugin was built against; must not exceed the host's.
    pub abi_minor: u32,
    /// [`HAPTICD_KIND_MECHANISM`] or [`HAPTICD_KIND_SCENE`].
    pub kind: u32,
    /// NUL-terminated name, unique among installed plugins of its kind (e.g. `spidar-g`).
    pub name: *const c_char,
    /// NUL-terminated version string of the plugin.
    pub version: *const c_char,
    /// NUL-terminated one-line description.
    pub description: *const c_char,
    /// The mechanism functions; non-null exactly when `kind` is [`HAPTICD_KIND_MECHANISM`].
    pub mechanism: *const HapticdMechanismVtable,
    /// The scene functions; non-null exactly when `kind` is [`HAPTICD_KIND_SCENE`].
    pub scene: *const HapticdSceneVtable,
}

/// Summary of a mechanism.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HapticdMechanismInfo {
    /// Number of end effectors (grips or finger caps).
    pub effector_count: u32,
    /// Number of strings, all effectors together.
    pub string_count: u32,
    /// λ of the tension problem min |Wτ − f|² + λ|τ|² (thesis eq. 3.16).
    pub lambda: f64,
    /// Weight of the torque rows of W relative to the force rows, in 1/m² (1 = as written).
    pub torque_weight: f64,
}

/// One end effector.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HapticdEffector {
    /// NUL-terminated name, unique within the mechanism.
    pub name: [c_char; HAPTICD_NAME_CAPACITY],
    /// 3 for a point grip (translation only), 6 for a rigid grip.
    pub dof: u32,
    /// Grip position while calibrating, metres, frame-centred.
    pub calibration_position: [f64; 3],
    /// Grip orientation while calibrating, unit quaternion (w, x, y, z).
    pub calibration_orientation: [f64; 4],
}

/// One string, from its motor on the frame to its knot on an effector.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HapticdString {
    /// Index of the effector the string pulls on.
    pub effector: u32,
    /// Exit point of the string on the frame, metres, frame-centred.
    pub motor: [f64; 3],
    /// Attachment point on the effector, metres, effector frame (zero for a point grip).
    pub knot: [f64; 3],
    /// String length per encoder count, metres; negative when the encoder counts backwards.
    pub metres_per_pulse: f64,
    /// Amplifier input per newton of tension, V/N; negative when the motor is wound backwards.
    pub volts_per_newton: f64,
    /// Lowest tension the motor holds (keeps the string taut), newtons.
    pub tension_min: f64,
    /// Highest tension the motor may apply, newtons.
    pub tension_max: f64,
}

/// Functions of a mechanism plugin. Fields appended by later minors are present only when
/// `struct_size` covers them.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdMechanismVtable {
    /// `sizeof(HapticdMechanismVtable)` as the plugin was compiled.
    pub struct_size: u32,
    /// [main] Write the mechanism summary to `out`.
    pub info: Option<unsafe extern "C" fn(out: *mut HapticdMechanismInfo) -> i32>,
    /// [main] Write effector `index` (0 ≤ index < effector_count) to `out`.
    pub effector: Option<unsafe extern "C" fn(index: u32, out: *mut HapticdEffector) -> i32>,
    /// [main] Write string `index` (0 ≤ index < string_count) to `out`.
    pub string: Option<unsafe extern "C" fn(index: u32, out: *mut HapticdString) -> i32>,
}

/// Type of the exported entry symbol `hapticd_plugin_entry`.
///
/// [main] Called once after loading; returns null on failure. The returned descriptor must
/// stay valid for the life of the process.
pub type HapticdPluginEntry =
    unsafe extern "C" fn(host: *const HapticdHost) -> *const HapticdPluginDescriptor;
