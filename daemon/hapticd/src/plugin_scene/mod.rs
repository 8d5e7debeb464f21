//! Scenes from plugins, in both styles of the scene ABI.
//!
//! - Direct ([`HAPTICD_SCENE_DIRECT`]): the plugin steps its world inside every haptic tick
//!   and returns the wrench on each pointer.
//! - Multi-rate ([`HAPTICD_SCENE_MULTIRATE`], thesis Ch. 6): the plugin steps in a physics
//!   thread at its own rate and publishes, for each pointer, the nearby surfaces as planes.
//!   The haptic thread interpolates each plane between the last two sets (6.3.2), renders
//!   them through the proxy (6.3.3), sums the force it displays into an impulse per object
//!   over each physics period (6.3.4) and hands those back (6.3.5).
//!
//! A plugin that fails or panics is disabled: its wrenches are zero and the loop reports the
//! fault, so the forces ramp down. So is one whose wrenches or planes no world gives
//! ([`output_check`](hapticd_core::scene::output_check): checked here, at the boundary), and
//! the scene says why ([`Scene::fault`]) for the daemon to log. A multi-rate scene that stops
//! publishing is treated the same way once its planes are three periods old.

mod direct;
mod extensions;
mod multirate;

use std::ffi::{CString, c_void};
use std::path::{Path, PathBuf};

use hapticd_plugin_api::export::{PhysicsInput, PhysicsOutput};
use hapticd_plugin_api::*;

use glam::DVec3;
use hapticd_config::plugin;
use hapticd_core::kinematics::MAX_EFFECTORS;
use hapticd_core::scene::control::{Answer, Order, Reply, Request, SceneControl};
use hapticd_core::scene::exact_shapes::ExactShapes;
use hapticd_core::scene::held_part::HeldPart;
use hapticd_core::scene::output_check::WrenchChecker;
use hapticd_core::scene::{Pointer, Scene, Touch};
use hapticd_core::sync::spsc;

use direct::DirectScene;
pub(crate) use extensions::Commands;
pub use extensions::ExtensionFault;
use extensions::{read_bodies, read_contacts, read_control, read_geometry};
pub(crate) use multirate::MultiRateScene;
/// A created scene instance; destroyed when dropped.
struct Instance {
    vtable: HapticdSceneVtable,
    pointer: *mut c_void,
    /// The control extension's `apply`, when the plugin has one.
    apply: Option<
        unsafe extern "C" fn(*mut c_void, *const HapticdSceneCommand, *mut HapticdBodyState) -> i32,
    >,
    /// The contacts extension's `touch`, when the plugin has one.
    touch: Option<unsafe extern "C" fn(*mut c_void, u32, *mut HapticdTouch) -> i32>,
    /// The joints extension's `drive`, when the plugin has one.
    drive: Option<
        unsafe extern "C" fn(
            *mut c_void,
            *const HapticdJointCommand,
            *mut HapticdJointState,
        ) -> i32,
    >,
    /// The mobility extension's function, when the plugin has one.
    mobility: Option<unsafe extern "C" fn(*mut c_void, u32, *mut HapticdMobility) -> i32>,
    /// The deformation extension's function, when the plugin has one.
    corners: Option<unsafe extern "C" fn(*mut c_void, *mut f32, u32) -> u32>,
    /// The compliance extension's function, when the plugin has one.
    compliance:
        Option<unsafe extern "C" fn(*mut c_void, u32, u32, *mut HapticdPlaneCompliance) -> i32>,
    /// The ABI minor the plugin was built for: fields newer than it are not read.
    minor: u32,
}

// SAFETY: an instance is used by one thread at a time (the haptic thread for direct scenes,
// the physics thread for multi-rate ones), as the ABI's thread annotations require.
unsafe impl Send for Instance {}

impl Instance {
    /// [the stepping thread, between steps] Carry out `request` and answer it through
    /// `replies` (a full ring drops the answer: its caller has given up waiting).
    fn carry_out(&self, request: &Request, replies: &mut spsc::Producer<Reply>) {
        let answer = match request.order() {
            Order::Body(command) => {
                let mut state = HapticdBodyState::default();
                let status = self.apply(command, &mut state);
                (status, Answer::Body(state))
            }
            Order::Joint(command) => {
                let mut state = HapticdJointState::default();
                let status = match self.drive {
                    // SAFETY: a live instance on its stepping thread, valid command and state.
                    Some(drive) => unsafe { drive(self.pointer, command, &mut state) },
                    None => HAPTICD_ERROR_FAILED,
                };
                (status, Answer::Joint(state))
            }
        };
        replies.push(Reply::to(request, answer.0, answer.1));
    }

    /// [the stepping thread, between steps] Carry out body `command` through the control
    /// extension, writing the body's state after it to `state`: the plugin's status.
    fn apply(&self, command: &HapticdSceneCommand, state: &mut HapticdBodyState) -> i32 {
        match self.apply {
            Some(apply) => {
                if command.kind == HAPTICD_COMMAND_IMPULSE_AT_CENTRE && self.minor < 7 {
                    // A plugin before ABI 1.7: the centre read now and the impulse given
                    // there between the same two steps, so it is where the body is.
                    let query = HapticdSceneCommand::new(HAPTICD_COMMAND_QUERY, command.body);
                    // SAFETY: a live instance on its stepping thread, valid command and state.
                    match unsafe { apply(self.pointer, &query, state) } {
                        HAPTICD_OK => {
                            let through = HapticdSceneCommand {
                                position: state.position,
                                vector: command.vector,
                                ..HapticdSceneCommand::new(HAPTICD_COMMAND_IMPULSE, command.body)
                            };
                            // SAFETY: as above.
                            unsafe { apply(self.pointer, &through, state) }
                        }
                        failed => failed,
                    }
                } else {
                    // SAFETY: as above.
                    unsafe { apply(self.pointer, command, state) }
                }
            }
            None => HAPTICD_ERROR_FAILED,
        }
    }

    /// [rt, after a direct step] What each pointer touches, into `touches`.
    fn touches(&self, touches: &mut [Touch]) {
        let Some(touch) = self.touch else {
            return;
        };
        for (pointer, out) in touches.iter_mut().enumerate() {
            let mut found = HapticdTouch::default();
            // SAFETY: a live instance on its stepping thread, a valid out pointer.
            if unsafe { touch(self.pointer, pointer as u32, &mut found) } == HAPTICD_OK {
                let normal = DVec3::from(found.normal);
                let point = DVec3::from(found.point);
                *out = Touch {
                    touching: true,
                    body: found.body,
                    point: if point.is_finite() {
                        point
                    } else {
                        DVec3::ZERO
                    },
                    // What no unit normal is, is said as none.
                    normal: normal.try_normalize().unwrap_or(DVec3::ZERO),
                    slipping: found.flags & HAPTICD_TOUCH_SLIPPING != 0,
                };
            }
        }
    }

    /// [physics, after a step] How the joints let each of `bodies` move, into `out` (None
    /// for a free body, and for every body of a plugin without the mobility extension).
    fn mobilities(&self, bodies: &[HapticdLocalBody], out: &mut [Option<HapticdMobility>]) {
        for (body, out) in bodies.iter().zip(out) {
            *out = self.mobility.and_then(|mobility| {
                let mut found = HapticdMobility::default();
                // SAFETY: a live instance on its physics thread, a valid out pointer.
                let status = unsafe { mobility(self.pointer, body.body, &mut found) };
                (status == HAPTICD_OK).then_some(found)
            });
        }
    }

    /// [physics, after a step] How each of its `planes` gives, pointer by pointer, into `out`
    /// (rigid for every plane of a plugin without the compliance extension).
    fn compliances(
        &self,
        planes: &[HapticdPlanes],
        out: &mut [[HapticdPlaneCompliance; HAPTICD_MAX_PLANES]],
    ) {
        for (pointer, (set, out)) in planes.iter().zip(out).enumerate() {
            let count = (set.count as usize).min(HAPTICD_MAX_PLANES);
            for (plane, out) in out.iter_mut().enumerate() {
                *out = HapticdPlaneCompliance::default();
                let Some(compliance) = self.compliance.filter(|_| plane < count) else {
                    continue;
                };
                // SAFETY: a live instance on its physics thread, a valid out pointer.
                let status = unsafe { compliance(self.pointer, pointer as u32, plane as u32, out) };
                if status != HAPTICD_OK {
                    *out = HapticdPlaneCompliance::default();
                }
            }
        }
    }

    /// [the stepping thread] Where the corners of the plugin's deforming solids stand, into
    /// `corners`; how many there are (none without the deformation extension).
    fn corners(&self, corners: &mut [[f32; 3]]) -> usize {
        let Some(write) = self.corners else {
            return 0;
        };
        let capacity = corners.len().min(u32::MAX as usize) as u32;
        // SAFETY: `corners` holds `capacity` corners of three floats; the instance is this
        // thread's.
        unsafe { write(self.pointer, corners.as_mut_ptr().cast(), capacity) as usize }
    }

    /// [the stepping thread] The plugin's bodies into `poses`; how many it has (none when
    /// it cannot tell, before ABI 1.2).
    fn poses(&self, poses: &mut [HapticdBodyPose]) -> usize {
        let Some(write) = self.vtable.poses else {
            return 0;
        };
        let capacity = poses.len().min(u32::MAX as usize) as u32;
        // SAFETY: `poses` holds `capacity` elements; the instance is this thread's.
        unsafe { write(self.pointer, poses.as_mut_ptr(), capacity) as usize }
    }
}

/// The grips and where their proxies rest, as the haptic side last published them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Hands {
    pub(crate) pointers: [HapticdPointer; MAX_EFFECTORS],
    pub(crate) proxies: [HapticdPointer; MAX_EFFECTORS],
}

/// The physics thread's end of the hand-backs of one step.
pub(crate) struct Taken {
    pub(crate) impulses: Vec<HapticdImpulse>,
    pub(crate) locals: Vec<HapticdLocalState>,
    /// For each of `locals`, whether the hand moved the body.
    pub(crate) touched: Vec<bool>,
}

impl Instance {
    /// [physics] One step of `input` into `output`: the plugin's status.
    fn step(&self, input: &PhysicsInput, output: &mut PhysicsOutput) -> i32 {
        let n = input.pointers.len();
        if output.planes.len() < n || input.proxies.len() < n {
            return HAPTICD_ERROR_ARGUMENT;
        }
        let Some(step_world) = self.vtable.step_world else {
            // Before ABI 1.3: planes around the grips, impulses only.
            let step = self.vtable.step_physics.expect("checked at load");
            *output.body_count = 0;
            // SAFETY: the buffers hold `n` pointers and planes and the impulses listed; the
            // instance belongs to this thread.
            return unsafe {
                step(
                    self.pointer,
                    input.dt,
                    input.pointers.as_ptr(),
                    n as u32,
                    input.impulses.as_ptr(),
                    input.impulses.len() as u32,
                    output.planes.as_mut_ptr(),
                )
            };
        };
        let raw_input = HapticdPhysicsInput {
            dt: input.dt,
            pointer_count: n as u32,
            pointers: input.pointers.as_ptr(),
            proxies: input.proxies.as_ptr(),
            impulse_count: input.impulses.len() as u32,
            impulses: input.impulses.as_ptr(),
            local_count: input.locals.len() as u32,
            locals: input.locals.as_ptr(),
        };
        let capacity = output.bodies.len().min(u32::MAX as usize) as u32;
        let mut raw_output = HapticdPhysicsOutput {
            planes: output.planes.as_mut_ptr(),
            bodies: output.bodies.as_mut_ptr(),
            body_capacity: capacity,
            body_count: 0,
        };
        // SAFETY: every array holds the count the input and output state; the instance
        // belongs to this thread.
        let status = unsafe { step_world(self.pointer, &raw_input, &mut raw_output) };
        let count = raw_output.body_count.min(capacity);
        *output.body_count = count;
        if self.minor < 6 {
            // What was padding before ABI 1.6: whatever the plugin left there.
            for body in &mut output.bodies[..count as usize] {
                body.left_out = 0;
            }
        }
        status
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        if let Some(destroy) = self.vtable.destroy {
            // SAFETY: created by this vtable's create and no longer used.
            unsafe { destroy(self.pointer) };
        }
    }
}

/// Why a scene plugin could not be started.
#[derive(Debug, Clone, PartialEq)]
pub enum LoadError {
    /// More pointers than any scene takes.
    TooManyPointers,
    /// The plugin is refused (permissions, ABI, symbols).
    Plugin(plugin::PluginError),
    /// The scene file's path holds a NUL byte.
    NulInPath,
    /// The plugin is loaded, but starting the scene failed.
    Scene {
        /// The plugin.
        plugin: PathBuf,
        /// What failed.
        fault: SceneFault,
    },
}

/// What failed in starting a loaded plugin's scene.
#[derive(Debug, Clone, PartialEq)]
pub enum SceneFault {
    /// Its `create` failed with this status.
    Create {
        /// The status returned.
        status: i32,
        /// The plugin runs scene files and was given none.
        wants_file: bool,
    },
    /// Its world's solids cannot be read.
    Geometry(ExtensionFault),
    /// Its bodies cannot be listed.
    Control(ExtensionFault),
    /// The body its pointer holds cannot be held.
    Held(ExtensionFault),
    /// Its physics thread could not be started, for this reason.
    Thread(std::io::ErrorKind),
    /// A scene style, or a physics rate, the host does not run.
    Style {
        /// The style it declares.
        style: u32,
        /// Its physics rate, Hz.
        rate: f64,
    },
}

impl std::fmt::Display for LoadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LoadError::TooManyPointers => write!(f, "at most {MAX_EFFECTORS} pointers"),
            LoadError::Plugin(e) => e.fmt(f),
            LoadError::NulInPath => f.write_str("scene file path contains NUL"),
            LoadError::Scene { plugin, fault } => write!(f, "{}: {fault}", plugin.display()),
        }
    }
}

impl std::fmt::Display for SceneFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SceneFault::Create { status, wants_file } => {
                let said = status_name(*status);
                if *wants_file {
                    // A plugin of scene files asked for none is the usual mistake: say so.
                    write!(
                        f,
                        "it runs scene files and was given none ({said}): switch to a scene \
                         file of its engine (one of Scenes, or `hapticctl scene switch \
                         FILE.yaml`)"
                    )
                } else {
                    write!(f, "creating the scene failed ({said})")
                }
            }
            SceneFault::Geometry(e) => write!(f, "cannot draw its world: {e}"),
            SceneFault::Control(e) => write!(f, "cannot list its bodies: {e}"),
            SceneFault::Held(e) => write!(f, "cannot hold its held body: {e}"),
            SceneFault::Thread(e) => write!(f, "cannot start its physics thread: {e}"),
            SceneFault::Style { style, rate } => {
                write!(f, "unsupported scene style {style} (physics rate {rate})")
            }
        }
    }
}

impl std::error::Error for LoadError {}

/// A scene plugin's instance, created, with what its extensions tell.
struct Created {
    instance: Instance,
    info: HapticdSceneInfo,
    name: String,
    geometry: Geometry,
    control: Option<SceneControl>,
    commands: Option<Commands>,
    object_bodies: Vec<u32>,
    /// The body a pointer holds, rendered by its god-object.
    held: Option<HeldPart>,
    /// The pieces of its bodies that are exactly balls or boxes.
    exact: ExactShapes,
}

/// Create the scene of the plugin at `path` for `pointers` pointers, with an optional scene
/// file.
fn create(path: &Path, scene_file: Option<&Path>, pointers: usize) -> Result<Created, LoadError> {
    if pointers > MAX_EFFECTORS {
        return Err(LoadError::TooManyPointers);
    }
    let loaded = plugin::load(path).map_err(LoadError::Plugin)?;
    let vtable = loaded.scene_vtable().map_err(LoadError::Plugin)?;
    let file = scene_file
        .map(|f| CString::new(f.as_os_str().as_encoded_bytes()))
        .transpose()
        .map_err(|_| LoadError::NulInPath)?;
    let failed = |fault| LoadError::Scene {
        plugin: path.to_path_buf(),
        fault,
    };
    let mut pointer = std::ptr::null_mut();
    let mut info = HapticdSceneInfo::default();
    let create = vtable.create.expect("checked by scene_vtable");
    // SAFETY: arguments follow the ABI: a NUL-terminated path or null, valid out pointers.
    let status = unsafe {
        create(
            file.as_ref().map_or(std::ptr::null(), |f| f.as_ptr()),
            pointers as u32,
            &mut pointer,
            &mut info,
        )
    };
    if status != HAPTICD_OK || pointer.is_null() {
        // SAFETY: HapticdSceneFiles is the struct of the files extension.
        let files: Option<HapticdSceneFiles> =
            unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_FILES) };
        return Err(failed(SceneFault::Create {
            status,
            wants_file: scene_file.is_none() && files.is_some(),
        }));
    }
    let mut instance = Instance {
        vtable,
        pointer,
        apply: None,
        touch: None,
        drive: None,
        mobility: None,
        corners: None,
        compliance: None,
        minor: loaded.abi.1,
    };
    let geometry =
        read_geometry(&loaded, &instance).map_err(|e| failed(SceneFault::Geometry(e)))?;
    let (control, commands) = read_control(&loaded, &mut instance)
        .map_err(|e| failed(SceneFault::Control(e)))?
        .unzip();
    let object_bodies = read_contacts(&loaded, &mut instance);
    let (held, exact) = read_bodies(
        &loaded,
        &instance,
        (&object_bodies, pointers),
        geometry.body_count,
    )
    .map_err(|e| failed(SceneFault::Held(e)))?;
    // SAFETY: HapticdSceneMobility is the struct of the mobility extension.
    let mobility: Option<HapticdSceneMobility> =
        unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_MOBILITY) };
    instance.mobility = mobility.and_then(|m| m.mobility);
    // SAFETY: HapticdSceneDeformation is the struct of the deformation extension.
    let deformation: Option<HapticdSceneDeformation> =
        unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_DEFORMATION) };
    instance.corners = deformation.and_then(|d| d.corners);
    // SAFETY: HapticdSceneCompliance is the struct of the compliance extension.
    let compliance: Option<HapticdSceneCompliance> =
        unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_COMPLIANCE) };
    instance.compliance = compliance.and_then(|c| c.compliance);
    // A plugin running a scene file is known by the file's name (`blocks`), not the engine's.
    let name = scene_file
        .and_then(|f| f.file_stem()?.to_str())
        .map_or(loaded.name, str::to_string);
    Ok(Created {
        instance,
        info,
        name,
        geometry,
        control,
        commands,
        object_bodies,
        held,
        exact,
    })
}

/// Load the scene plugin at `path` for `pointers`, with an optional scene file.
pub fn load(
    path: &Path,
    scene_file: Option<&Path>,
    pointers: &[Pointer],
) -> Result<Box<dyn Scene>, LoadError> {
    let created = create(path, scene_file, pointers.len())?;
    let (info, vtable) = (created.info, created.instance.vtable);
    let failed = |fault| LoadError::Scene {
        plugin: path.to_path_buf(),
        fault,
    };
    match info.style {
        HAPTICD_SCENE_DIRECT if vtable.step_direct.is_some() => Ok(Box::new(DirectScene {
            name: created.name,
            instance: created.instance,
            geometry: created.geometry,
            control: created.control,
            commands: created.commands,
            pointers: vec![HapticdPointer::default(); pointers.len()],
            wrenches: vec![HapticdWrench::default(); pointers.len()],
            failed: false,
            check: WrenchChecker::default(),
            fault: None,
            surfaces: Default::default(),
        })),
        HAPTICD_SCENE_MULTIRATE if is_multirate(&info, &vtable) => {
            let scene = MultiRateScene::start(
                created.name,
                created.instance,
                (
                    created.geometry,
                    created.control,
                    created.commands,
                    created.object_bodies,
                ),
                (created.held, created.exact),
                info.physics_rate,
                pointers,
            )
            .map_err(|e| failed(SceneFault::Thread(e.kind())))?;
            Ok(Box::new(scene))
        }
        style => Err(failed(SceneFault::Style {
            style,
            rate: info.physics_rate,
        })),
    }
}

/// Whether a plugin that says it is multi-rate is one this daemon can step.
fn is_multirate(info: &HapticdSceneInfo, vtable: &HapticdSceneVtable) -> bool {
    info.style == HAPTICD_SCENE_MULTIRATE
        && vtable.step_physics.is_some()
        && (10.0..=1000.0).contains(&info.physics_rate)
}

/// A multi-rate scene plugin's world, stepped by whoever holds it (the
/// daemon's thread of a world its devices share).
pub struct PluginWorld {
    instance: Instance,
    /// The scene's name.
    pub name: String,
    /// Its physics rate, steps a second.
    pub rate: f64,
    /// What is drawn of it.
    pub geometry: Geometry,
    /// The body of each object of its planes.
    pub object_bodies: Vec<u32>,
}

impl hapticd_core::scene::shared_world::Stepped for PluginWorld {
    fn step(&mut self, input: &PhysicsInput, output: &mut PhysicsOutput) -> bool {
        self.instance.step(input, output) == HAPTICD_OK
    }

    fn poses(&mut self, poses: &mut [HapticdBodyPose]) -> usize {
        self.instance.poses(poses)
    }

    fn mobilities(&self, bodies: &[HapticdLocalBody], out: &mut [Option<HapticdMobility>]) {
        self.instance.mobilities(bodies, out);
    }

    fn compliances(
        &self,
        planes: &[HapticdPlanes],
        out: &mut [[HapticdPlaneCompliance; HAPTICD_MAX_PLANES]],
    ) {
        self.instance.compliances(planes, out);
    }
}

/// The world of the scene plugin at `path` (with an optional scene file) for `pointers`
/// pointers, when it is a multi-rate one that takes back local bodies (ABI 1.3); None for
/// any other.
pub fn load_world(
    path: &Path,
    scene_file: Option<&Path>,
    pointers: usize,
) -> Result<Option<PluginWorld>, LoadError> {
    let created = create(path, scene_file, pointers)?;
    let vtable = &created.instance.vtable;
    if !is_multirate(&created.info, vtable) || vtable.step_world.is_none() {
        return Ok(None);
    }
    Ok(Some(PluginWorld {
        rate: created.info.physics_rate,
        instance: created.instance,
        name: created.name,
        geometry: created.geometry,
        object_bodies: created.object_bodies,
    }))
}

/// A plugin's status code in words.
fn status_name(status: i32) -> String {
    match status {
        HAPTICD_ERROR_ARGUMENT => "a bad argument".into(),
        HAPTICD_ERROR_PANIC => "the plugin panicked".into(),
        HAPTICD_ERROR_FAILED => "the plugin failed".into(),
        HAPTICD_OK => "no scene returned".into(),
        other => format!("status {other}"),
    }
}
