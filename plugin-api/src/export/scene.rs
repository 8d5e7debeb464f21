//! A scene plugin's side: the [`SceneInstance`] an author implements and the vtable
//! functions `export_scene!` points at, each run inside `catch_unwind`.

use std::ffi::{CStr, c_char};

use crate::abi::*;
use crate::ext::{
    scene_compliance::*, scene_contacts::*, scene_control::*, scene_geometry::HapticdTriangle,
    scene_held::*, scene_joints::*, scene_mobility::*,
};
use crate::geometry::Geometry;

use super::{SceneError, guard, log};
/// A scene instance, as a Rust plugin author implements it. Each method runs on the thread
/// its style names; the default answers [`HAPTICD_ERROR_FAILED`] (wrong style).
pub trait SceneInstance: Send {
    /// [rt] Direct scenes: advance `dt` and write one wrench per pointer. Must not allocate,
    /// lock, log or block.
    fn step_direct(
        &mut self,
        dt: f64,
        pointers: &[HapticdPointer],
        wrenches: &mut [HapticdWrench],
    ) -> i32 {
        let _ = (dt, pointers, wrenches);
        HAPTICD_ERROR_FAILED
    }

    /// [physics] Multi-rate scenes: apply `impulses`, advance `dt`, write each pointer's planes.
    fn step_physics(
        &mut self,
        dt: f64,
        pointers: &[HapticdPointer],
        impulses: &[HapticdImpulse],
        planes: &mut [HapticdPlanes],
    ) -> i32 {
        let _ = (dt, pointers, impulses, planes);
        HAPTICD_ERROR_FAILED
    }

    /// [physics] Since ABI 1.3: one step with what the haptic side knows (`input`'s
    /// proxies and local changes), writing the planes and the locally moved bodies to
    /// `output`. The default is [`step_physics`](Self::step_physics) around the grips,
    /// with no local bodies.
    fn step_world(&mut self, input: &PhysicsInput<'_>, output: &mut PhysicsOutput<'_>) -> i32 {
        *output.body_count = 0;
        self.step_physics(input.dt, input.pointers, input.impulses, output.planes)
    }

    /// [the stepping thread] Write the poses of the first bodies to `poses` (as many as it
    /// holds) and return how many bodies the world has; the default has none to show.
    fn poses(&self, poses: &mut [HapticdBodyPose]) -> usize {
        let _ = poses;
        0
    }

    /// [main] Since ABI 1.4: the world's solids, for pictures (served through
    /// [`HAPTICD_EXT_SCENE_GEOMETRY`]); the default has none to show.
    fn geometry(&self) -> Option<&Geometry> {
        None
    }

    /// [main] Since ABI 1.5: body `index` of those the world lets be changed from outside
    /// (served through [`HAPTICD_EXT_SCENE_CONTROL`]), None past the last; the default
    /// has none.
    fn body(&self, index: usize) -> Option<HapticdBodyInfo> {
        let _ = index;
        None
    }

    /// [the stepping thread, between steps] Since ABI 1.5: carry out `command` and write
    /// the body's state after it to `state`. Must not allocate, lock, log or block.
    fn apply(&mut self, command: &HapticdSceneCommand, state: &mut HapticdBodyState) -> i32 {
        let _ = (command, state);
        HAPTICD_ERROR_FAILED
    }

    /// [main] Since ABI 1.5: the body object `object` of the planes belongs to (served
    /// through [`HAPTICD_EXT_SCENE_CONTACTS`]), None past the last object.
    fn object_body(&self, object: u32) -> Option<u32> {
        let _ = object;
        None
    }

    /// [rt, after a direct step] Since ABI 1.5: what pointer `pointer` touches, if anything.
    /// Must not allocate, lock, log or block.
    fn touch(&self, pointer: usize) -> Option<HapticdTouch> {
        let _ = pointer;
        None
    }

    /// [physics, after a step] Since ABI 1.8: the articulated mobility of body `body`
    /// (served through [`HAPTICD_EXT_SCENE_MOBILITY`]), None for a free body; the default
    /// has no joints.
    fn mobility(&self, body: u32) -> Option<HapticdMobility> {
        let _ = body;
        None
    }

    /// [physics, after a step] Since ABI 1.10: how plane `plane` of pointer `pointer`, as
    /// the last step published them, gives under a press (served through
    /// [`HAPTICD_EXT_SCENE_COMPLIANCE`]), None for a rigid one; the default is all rigid.
    fn compliance(&self, pointer: u32, plane: u32) -> Option<HapticdPlaneCompliance> {
        let _ = (pointer, plane);
        None
    }

    /// [main] Since ABI 1.12: the body a pointer holds (served through
    /// [`HAPTICD_EXT_SCENE_HELD`]), None when none does; the default holds none.
    fn held(&self) -> Option<HapticdHeld> {
        None
    }

    /// [main] Since ABI 1.12: piece `piece` of body `body`'s surface, closed, its triangles
    /// in the body's frame (served through [`HAPTICD_EXT_SCENE_HELD`]), None past the last;
    /// the default has none.
    fn surface(
        &self,
        body: u32,
        piece: u32,
    ) -> Option<(HapticdSurfacePiece, Vec<HapticdTriangle>)> {
        let _ = (body, piece);
        None
    }

    /// [main] Since ABI 1.8: joint `index` of the world (served through
    /// [`HAPTICD_EXT_SCENE_JOINTS`]), None past the last; the default has none.
    fn joint(&self, index: usize) -> Option<HapticdJointInfo> {
        let _ = index;
        None
    }

    /// [the stepping thread, between steps] Since ABI 1.8: carry out `command` on a joint
    /// and write its state after it to `state`. Must not allocate, lock, log or block.
    fn drive(&mut self, command: &HapticdJointCommand, state: &mut HapticdJointState) -> i32 {
        let _ = (command, state);
        HAPTICD_ERROR_FAILED
    }

    /// [the stepping thread, between steps] Since ABI 1.9: the corners of the deforming
    /// solids as they stand now (served through
    /// [`HAPTICD_EXT_SCENE_DEFORMATION`](crate::HAPTICD_EXT_SCENE_DEFORMATION)), the first
    /// ones written to `out` (as many as it holds); returns how many there are. Must not
    /// allocate, lock, log or block. The default has none.
    fn corners(&self, out: &mut [[f32; 3]]) -> usize {
        let _ = out;
        0
    }
}

/// A command's answer as a [`SceneInstance`] method gives it: `value` written to `state`
/// and [`HAPTICD_OK`], or [`HAPTICD_ERROR_ARGUMENT`] for a command the world could not take.
pub fn answered<T>(state: &mut T, value: Option<T>) -> i32 {
    match value {
        Some(value) => {
            *state = value;
            HAPTICD_OK
        }
        None => HAPTICD_ERROR_ARGUMENT,
    }
}

/// [`HapticdPhysicsInput`] as slices.
#[derive(Debug, Clone, Copy)]
pub struct PhysicsInput<'a> {
    /// Seconds to advance.
    pub dt: f64,
    /// The grips.
    pub pointers: &'a [HapticdPointer],
    /// Where each pointer's proxy rests.
    pub proxies: &'a [HapticdPointer],
    /// Impulses on objects the haptic side did not move itself.
    pub impulses: &'a [HapticdImpulse],
    /// Changes of the hand on locally moved bodies.
    pub locals: &'a [HapticdLocalState],
}

/// [`HapticdPhysicsOutput`] as slices.
#[derive(Debug)]
pub struct PhysicsOutput<'a> {
    /// One set of planes per pointer.
    pub planes: &'a mut [HapticdPlanes],
    /// Room for the locally moved bodies.
    pub bodies: &'a mut [HapticdLocalBody],
    /// How many of `bodies` the step wrote.
    pub body_count: &'a mut u32,
}

/// A slice of `count` elements at `data`, which may be null when `count` is 0.
///
/// # Safety
/// Unless `count` is 0, `data` points to `count` initialised elements valid for `'a`.
unsafe fn slice<'a, T>(data: *const T, count: u32) -> Option<&'a [T]> {
    match (count, data.is_null()) {
        (0, _) => Some(&[]),
        (_, true) => None,
        // SAFETY: per this function's contract.
        _ => Some(unsafe { std::slice::from_raw_parts(data, count as usize) }),
    }
}

/// How a Rust scene plugin creates instances: from the scene file (if any) and the number of
/// pointers, an instance and its description, or a message for the host log.
pub type SceneFactory =
    fn(Option<&str>, usize) -> Result<(Box<dyn SceneInstance>, HapticdSceneInfo), SceneError>;

/// A vtable that may live in a `static`.
#[repr(transparent)]
#[doc(hidden)]
pub struct StaticSceneVtable(pub HapticdSceneVtable);

// SAFETY: a vtable holds only function pointers.
unsafe impl Sync for StaticSceneVtable {}

/// Body of the exported `create` function.
///
/// # Safety
/// `path` is null or NUL-terminated; `instance` and `info` are valid for one write each.
#[doc(hidden)]
pub unsafe fn scene_create(
    factory: SceneFactory,
    path: *const c_char,
    pointer_count: u32,
    instance: *mut *mut std::ffi::c_void,
    info: *mut HapticdSceneInfo,
) -> i32 {
    if instance.is_null() || info.is_null() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    guard(|| {
        // SAFETY: the host passes null or a NUL-terminated string.
        let path = unsafe { path.as_ref() }
            .map(|p| unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned());
        match factory(path.as_deref(), pointer_count as usize) {
            Ok((scene, description)) => {
                // SAFETY: both pointers are valid for one write (checked non-null above).
                unsafe {
                    instance.write(Box::into_raw(Box::new(scene)).cast());
                    info.write(description);
                }
                HAPTICD_OK
            }
            Err(e) => {
                log(HAPTICD_LOG_ERROR, &e.to_string());
                HAPTICD_ERROR_FAILED
            }
        }
    })
}

/// The instance behind an opaque pointer made by [`scene_create`].
///
/// # Safety
/// `instance` came from [`scene_create`], was not destroyed, and no other thread uses it.
pub(super) unsafe fn instance_mut<'a>(
    instance: *mut std::ffi::c_void,
) -> &'a mut Box<dyn SceneInstance> {
    // SAFETY: per this function's contract.
    unsafe { &mut *instance.cast::<Box<dyn SceneInstance>>() }
}

/// Body of the exported `destroy` function.
///
/// # Safety
/// As [`instance_mut`]; the instance is not used afterwards.
#[doc(hidden)]
pub unsafe fn scene_destroy(instance: *mut std::ffi::c_void) {
    if !instance.is_null() {
        guard(|| {
            // SAFETY: made by Box::into_raw in scene_create, destroyed once.
            drop(unsafe { Box::from_raw(instance.cast::<Box<dyn SceneInstance>>()) });
            HAPTICD_OK
        });
    }
}

/// Body of the exported `step_direct` function.
///
/// # Safety
/// As [`instance_mut`]; `pointers` and `wrenches` hold `count` elements.
#[doc(hidden)]
pub unsafe fn scene_step_direct(
    instance: *mut std::ffi::c_void,
    dt: f64,
    pointers: *const HapticdPointer,
    count: u32,
    wrenches: *mut HapticdWrench,
) -> i32 {
    if instance.is_null() || pointers.is_null() || wrenches.is_null() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    guard(|| {
        // SAFETY: per this function's contract.
        let (scene, pointers, wrenches) = unsafe {
            (
                instance_mut(instance),
                std::slice::from_raw_parts(pointers, count as usize),
                std::slice::from_raw_parts_mut(wrenches, count as usize),
            )
        };
        scene.step_direct(dt, pointers, wrenches)
    })
}

/// Body of the exported `step_physics` function.
///
/// # Safety
/// As [`instance_mut`]; `pointers` and `planes` hold `count` elements, `impulses` holds
/// `impulse_count` (or is null when there are none).
#[doc(hidden)]
pub unsafe fn scene_step_physics(
    instance: *mut std::ffi::c_void,
    dt: f64,
    pointers: *const HapticdPointer,
    count: u32,
    impulses: *const HapticdImpulse,
    impulse_count: u32,
    planes: *mut HapticdPlanes,
) -> i32 {
    if instance.is_null()
        || pointers.is_null()
        || planes.is_null()
        || (impulses.is_null() && impulse_count > 0)
    {
        return HAPTICD_ERROR_ARGUMENT;
    }
    guard(|| {
        // SAFETY: per this function's contract.
        let (scene, pointers, planes) = unsafe {
            (
                instance_mut(instance),
                std::slice::from_raw_parts(pointers, count as usize),
                std::slice::from_raw_parts_mut(planes, count as usize),
            )
        };
        let impulses = if impulse_count == 0 {
            &[][..]
        } else {
            // SAFETY: non-null with impulse_count elements, per the contract.
            unsafe { std::slice::from_raw_parts(impulses, impulse_count as usize) }
        };
        scene.step_physics(dt, pointers, impulses, planes)
    })
}

/// Body of the exported `step_world` function.
///
/// # Safety
/// As [`instance_mut`]; `input` and `output` are valid, their arrays hold the counts they
/// state (`pointer_count` pointers, proxies and planes; `body_capacity` bodies).
#[doc(hidden)]
pub unsafe fn scene_step_world(
    instance: *mut std::ffi::c_void,
    input: *const HapticdPhysicsInput,
    output: *mut HapticdPhysicsOutput,
) -> i32 {
    if instance.is_null() || input.is_null() || output.is_null() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: both non-null and valid, per the contract.
    let (input, output) = unsafe { (&*input, &mut *output) };
    let n = input.pointer_count;
    let capacity = output.body_capacity.min(HAPTICD_MAX_LOCAL_BODIES as u32);
    // SAFETY: the arrays hold the counts stated, per the contract.
    let arrays = unsafe {
        (
            slice(input.pointers, n),
            slice(input.proxies, n),
            slice(input.impulses, input.impulse_count),
            slice(input.locals, input.local_count),
        )
    };
    let (Some(pointers), Some(proxies), Some(impulses), Some(locals)) = arrays else {
        return HAPTICD_ERROR_ARGUMENT;
    };
    if output.planes.is_null() || (output.bodies.is_null() && capacity > 0) {
        return HAPTICD_ERROR_ARGUMENT;
    }
    guard(|| {
        // SAFETY: per this function's contract; both arrays are non-null (checked above)
        // or empty.
        let (scene, planes, bodies) = unsafe {
            (
                instance_mut(instance),
                std::slice::from_raw_parts_mut(output.planes, n as usize),
                if capacity == 0 {
                    &mut [][..]
                } else {
                    std::slice::from_raw_parts_mut(output.bodies, capacity as usize)
                },
            )
        };
        let mut count = 0;
        let status = scene.step_world(
            &PhysicsInput {
                dt: input.dt,
                pointers,
                proxies,
                impulses,
                locals,
            },
            &mut PhysicsOutput {
                planes,
                bodies,
                body_count: &mut count,
            },
        );
        output.body_count = count.min(capacity);
        status
    })
}

/// Body of the exported `poses` function.
///
/// # Safety
/// As [`instance_mut`]; `poses` holds `capacity` elements (or is null when it is 0).
#[doc(hidden)]
pub unsafe fn scene_poses(
    instance: *mut std::ffi::c_void,
    poses: *mut HapticdBodyPose,
    capacity: u32,
) -> u32 {
    if instance.is_null() || (poses.is_null() && capacity > 0) {
        return 0;
    }
    let mut count = 0;
    guard(|| {
        // SAFETY: per this function's contract.
        let scene = unsafe { instance_mut(instance) };
        let poses = if capacity == 0 {
            &mut [][..]
        } else {
            // SAFETY: non-null with `capacity` elements, per the contract.
            unsafe { std::slice::from_raw_parts_mut(poses, capacity as usize) }
        };
        count = u32::try_from(scene.poses(poses)).unwrap_or(u32::MAX);
        HAPTICD_OK
    });
    count
}
