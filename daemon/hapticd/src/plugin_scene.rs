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

use std::ffi::{CString, c_void};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;

use hapticd_plugin_api::*;

use crate::clock::monotonic_ns;
use crate::physics_budget::Pacer;
use crate::plugin;
use glam::DVec3;
use hapticd_core::haptics::proxy::ProxyParameters;
use hapticd_core::kinematics::{MAX_EFFECTORS, Wrench};
use hapticd_core::scene::control::{self, Incoming, Reply, Request, SceneControl};
use hapticd_core::scene::multirate::{
    HandBack, PlaneRenderer, PlaneSet, pose_between, proxy_record,
};
use hapticd_core::scene::output_check::{OutputFault, WrenchChecker, check_bodies, check_planes};
use hapticd_core::scene::{Pointer, Scene, Touch};
use hapticd_core::sync::spsc;
use hapticd_core::sync::triple_buffer::{self, Reader, Writer};
use hapticd_core::world_geometry::{MAX_SOLIDS, MAX_TRIANGLES};
use hapticd_core::world_state::{MAX_BODIES, body_pose, pose_of};

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
        let mut state = HapticdBodyState::default();
        let status = match self.apply {
            // SAFETY: a live instance on its stepping thread, valid command and state.
            Some(apply) => unsafe { apply(self.pointer, request.command(), &mut state) },
            None => HAPTICD_ERROR_FAILED,
        };
        replies.push(Reply::to(request, status, state));
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
}

impl Instance {
    /// [physics] One step of `dt` for the first `n` of `hands`, taking in `taken`, into
    /// `set` (planes and local bodies; its sequence is left alone). The plugin's status.
    fn step(&self, dt: f64, n: usize, hands: &Hands, taken: &Taken, set: &mut PlaneSet) -> i32 {
        let Some(step_world) = self.vtable.step_world else {
            // Before ABI 1.3: planes around the grips, impulses only.
            let step = self.vtable.step_physics.expect("checked at load");
            set.body_count = 0;
            // SAFETY: buffers hold `n` pointers and planes and the impulses listed; the
            // instance belongs to this thread.
            return unsafe {
                step(
                    self.pointer,
                    dt,
                    hands.pointers.as_ptr(),
                    n as u32,
                    taken.impulses.as_ptr(),
                    taken.impulses.len() as u32,
                    set.planes.as_mut_ptr(),
                )
            };
        };
        let input = HapticdPhysicsInput {
            dt,
            pointer_count: n as u32,
            pointers: hands.pointers.as_ptr(),
            proxies: hands.proxies.as_ptr(),
            impulse_count: taken.impulses.len() as u32,
            impulses: taken.impulses.as_ptr(),
            local_count: taken.locals.len() as u32,
            locals: taken.locals.as_ptr(),
        };
        let mut output = HapticdPhysicsOutput {
            planes: set.planes.as_mut_ptr(),
            bodies: set.bodies.as_mut_ptr(),
            body_capacity: HAPTICD_MAX_LOCAL_BODIES as u32,
            body_count: 0,
        };
        // SAFETY: every array holds the count the input and output state; the instance
        // belongs to this thread.
        let status = unsafe { step_world(self.pointer, &input, &mut output) };
        set.body_count = output.body_count.min(HAPTICD_MAX_LOCAL_BODIES as u32);
        if self.minor < 6 {
            // What was padding before ABI 1.6: whatever the plugin left there.
            for body in &mut set.bodies[..set.body_count as usize] {
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

/// Load the scene plugin at `path` for `pointers`, with an optional scene file.
pub fn load(
    path: &Path,
    scene_file: Option<&Path>,
    pointers: &[Pointer],
) -> Result<Box<dyn Scene>, String> {
    if pointers.len() > MAX_EFFECTORS {
        return Err(format!("at most {MAX_EFFECTORS} pointers"));
    }
    let loaded = plugin::load(path).map_err(|e| e.to_string())?;
    let vtable = loaded.scene_vtable().map_err(|e| e.to_string())?;
    let file = scene_file
        .map(|f| CString::new(f.as_os_str().as_encoded_bytes()))
        .transpose()
        .map_err(|_| "scene file path contains NUL".to_string())?;
    let mut pointer = std::ptr::null_mut();
    let mut info = HapticdSceneInfo::default();
    let create = vtable.create.expect("checked by scene_vtable");
    // SAFETY: arguments follow the ABI: a NUL-terminated path or null, valid out pointers.
    let status = unsafe {
        create(
            file.as_ref().map_or(std::ptr::null(), |f| f.as_ptr()),
            pointers.len() as u32,
            &mut pointer,
            &mut info,
        )
    };
    if status != HAPTICD_OK || pointer.is_null() {
        // A plugin of scene files asked for none is the usual mistake: say so.
        // SAFETY: HapticdSceneFiles is the struct of the files extension.
        let files: Option<HapticdSceneFiles> =
            unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_FILES) };
        let said = status_name(status);
        let why = match (scene_file, files) {
            (None, Some(_)) => format!(
                "it runs scene files and was given none ({said}): switch to a scene file of \
                 its engine (one of Scenes, or `hapticctl scene switch FILE.yaml`)"
            ),
            _ => format!("creating the scene failed ({said})"),
        };
        return Err(format!("{}: {why}", path.display()));
    }
    let mut instance = Instance {
        vtable,
        pointer,
        apply: None,
        touch: None,
        minor: loaded.abi.1,
    };
    let geometry = read_geometry(&loaded, &instance)
        .map_err(|e| format!("{}: cannot draw its world: {e}", path.display()))?;
    let (control, commands) = read_control(&loaded, &mut instance)
        .map_err(|e| format!("{}: cannot list its bodies: {e}", path.display()))?
        .unzip();
    let object_bodies = read_contacts(&loaded, &mut instance);
    // A plugin running a scene file is known by the file's name (`blocks`), not the engine's.
    let name = scene_file
        .and_then(|f| f.file_stem()?.to_str())
        .map_or(loaded.name, str::to_string);
    match info.style {
        HAPTICD_SCENE_DIRECT if vtable.step_direct.is_some() => Ok(Box::new(DirectScene {
            name,
            instance,
            geometry,
            control,
            commands,
            pointers: vec![HapticdPointer::default(); pointers.len()],
            wrenches: vec![HapticdWrench::default(); pointers.len()],
            failed: false,
            check: WrenchChecker::default(),
            fault: None,
        })),
        HAPTICD_SCENE_MULTIRATE
            if vtable.step_physics.is_some() && (10.0..=1000.0).contains(&info.physics_rate) =>
        {
            let scene = MultiRateScene::start(
                name,
                instance,
                (geometry, control, commands, object_bodies),
                info.physics_rate,
                pointers,
            )
            .map_err(|e| format!("{}: cannot start its physics thread: {e}", path.display()))?;
            Ok(Box::new(scene))
        }
        style => Err(format!(
            "{}: unsupported scene style {style} (physics rate {})",
            path.display(),
            info.physics_rate
        )),
    }
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

/// [main] The solids of `instance`'s world as its plugin's geometry extension gives them
/// (none without one), checked: as many as the shared world shows.
fn read_geometry(loaded: &plugin::LoadedPlugin, instance: &Instance) -> Result<Geometry, String> {
    // SAFETY: HapticdSceneGeometry is the struct of the geometry extension.
    let extension: Option<HapticdSceneGeometry> =
        unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_GEOMETRY) };
    let Some(extension) = extension else {
        return Ok(Geometry::default());
    };
    let (Some(counts_of), Some(solid_of), Some(triangles_of)) =
        (extension.counts, extension.solid, extension.triangles)
    else {
        return Err("its geometry extension lacks a function".into());
    };
    let failed = |what: &str, status: i32| format!("reading its {what} failed (status {status})");
    let mut counts = HapticdGeometryCounts::default();
    // SAFETY: a live instance of this plugin on the main thread, a valid out pointer.
    let status = unsafe { counts_of(instance.pointer, &mut counts) };
    if status != HAPTICD_OK {
        return Err(failed("counts", status));
    }
    let mut geometry = Geometry {
        body_count: counts.bodies,
        solids: Vec::new(),
        triangles: vec![HapticdTriangle::default(); (counts.triangles as usize).min(MAX_TRIANGLES)],
    };
    if !geometry.triangles.is_empty() {
        let n = geometry.triangles.len() as u32;
        // SAFETY: as above; `triangles` holds `n` triangles.
        let status =
            unsafe { triangles_of(instance.pointer, 0, n, geometry.triangles.as_mut_ptr()) };
        if status != HAPTICD_OK {
            return Err(failed("triangles", status));
        }
    }
    for index in 0..counts.solids.min(MAX_SOLIDS as u32) {
        let mut solid = HapticdSolid::default();
        // SAFETY: as above.
        let status = unsafe { solid_of(instance.pointer, index, &mut solid) };
        if status != HAPTICD_OK {
            return Err(failed(&format!("solid {index}"), status));
        }
        let end = solid.first_triangle as u64 + solid.triangle_count as u64;
        // A solid whose triangles lie past what pictures hold is left out with them; one
        // past the plugin's own list stays, for the check to refuse.
        let held = geometry.triangles.len() as u64;
        let cut =
            solid.shape == HAPTICD_SHAPE_TRIANGLES && end > held && end <= counts.triangles as u64;
        if !cut {
            geometry.solids.push(solid);
        }
    }
    geometry.check().map_err(|e| e.to_string())?;
    Ok(geometry)
}

/// The stepping side's end of a world's control: the requests, and where answers go.
pub(crate) type Commands = (Incoming, spsc::Producer<Reply>);

/// [main] The bodies of `instance`'s world as its plugin's control extension lists them,
/// with the channel that changes them: the control plane's end and the stepping side's (None
/// without the extension). The extension's `apply` is kept in the instance.
fn read_control(
    loaded: &plugin::LoadedPlugin,
    instance: &mut Instance,
) -> Result<Option<(SceneControl, Commands)>, String> {
    // SAFETY: HapticdSceneControl is the struct of the control extension.
    let extension: Option<HapticdSceneControl> =
        unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_CONTROL) };
    let Some(extension) = extension else {
        return Ok(None);
    };
    let (Some(body_of), Some(apply)) = (extension.body, extension.apply) else {
        return Err("its control extension lacks a function".into());
    };
    let mut bodies = Vec::new();
    for index in 0..MAX_BODIES as u32 {
        let mut info = HapticdBodyInfo::new("", false);
        // SAFETY: a live instance of this plugin on the main thread, a valid out pointer.
        if unsafe { body_of(instance.pointer, index, &mut info) } != HAPTICD_OK {
            break;
        }
        let name = info
            .name_str()
            .ok_or_else(|| format!("body {index} has no UTF-8 name ending in NUL"))?;
        bodies.push(control::Body {
            name: name.to_string(),
            fixed: info.flags & HAPTICD_SOLID_FIXED != 0,
        });
    }
    instance.apply = Some(apply);
    let (control, incoming, replies) = control::channel(bodies);
    Ok(Some((control, (incoming, replies))))
}

/// Most objects a multi-rate scene's planes may name, for contact events.
const MAX_OBJECTS: u32 = 1 << 16;

/// [main] The body of each object of `instance`'s planes, as its plugin's contacts extension
/// names them (none without one); the extension's `touch` is kept in the instance.
fn read_contacts(loaded: &plugin::LoadedPlugin, instance: &mut Instance) -> Vec<u32> {
    // SAFETY: HapticdSceneContacts is the struct of the contacts extension.
    let extension: Option<HapticdSceneContacts> =
        unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_CONTACTS) };
    let Some(extension) = extension else {
        return Vec::new();
    };
    instance.touch = extension.touch;
    let Some(object_body) = extension.object_body else {
        return Vec::new();
    };
    (0..MAX_OBJECTS)
        // SAFETY: a live instance of this plugin on the main thread.
        .map(|object| unsafe { object_body(instance.pointer, object) })
        .take_while(|&body| body != HAPTICD_NO_BODY)
        .collect()
}

/// A direct scene: the plugin runs inside the haptic tick.
struct DirectScene {
    name: String,
    instance: Instance,
    geometry: Geometry,
    /// The control plane's end of its world's control, until taken.
    control: Option<SceneControl>,
    /// The stepping side's.
    commands: Option<Commands>,
    pointers: Vec<HapticdPointer>,
    wrenches: Vec<HapticdWrench>,
    failed: bool,
    check: WrenchChecker,
    /// Why the plugin was disabled, when it was for its wrenches.
    fault: Option<OutputFault>,
}

impl Scene for DirectScene {
    fn name(&self) -> &str {
        &self.name
    }

    fn render(&mut self, pointers: &[Pointer], dt: f64, wrenches: &mut [Wrench]) -> bool {
        wrenches.fill(Wrench::ZERO);
        if self.failed {
            return false;
        }
        if let Some((incoming, replies)) = &mut self.commands {
            while let Some(request) = incoming.due() {
                self.instance.carry_out(&request, replies);
            }
        }
        for (out, p) in self.pointers.iter_mut().zip(pointers) {
            *out = p.to_abi();
        }
        let step = self.instance.vtable.step_direct.expect("checked at load");
        // SAFETY: buffers hold one element per pointer; the instance is this thread's.
        let status = unsafe {
            step(
                self.instance.pointer,
                dt,
                self.pointers.as_ptr(),
                self.pointers.len() as u32,
                self.wrenches.as_mut_ptr(),
            )
        };
        if status != HAPTICD_OK {
            self.failed = true;
            return false;
        }
        for (out, w) in wrenches.iter_mut().zip(&self.wrenches) {
            *out = Wrench::from(*w);
        }
        // Wrenches no world gives disable the plugin, as a failure does, instead of being
        // clamped and felt.
        if let Err(fault) = self.check.check(wrenches) {
            wrenches.fill(Wrench::ZERO);
            (self.failed, self.fault) = (true, Some(fault));
            return false;
        }
        true
    }

    fn reset(&mut self, _pointers: &[Pointer]) {}

    fn set_wrench_limits(&mut self, max_force: f64, max_torque: f64) {
        self.check.set_limits(max_force, max_torque);
    }

    fn fault(&self) -> Option<OutputFault> {
        self.fault
    }

    fn write_bodies(&mut self, poses: &mut [HapticdBodyPose]) -> usize {
        self.instance.poses(poses)
    }

    fn take_control(&mut self) -> Option<SceneControl> {
        self.control.take()
    }

    fn write_touches(&self, touches: &mut [Touch]) {
        if !self.failed {
            self.instance.touches(touches);
        }
    }

    fn needs_quiet(&self) -> bool {
        self.commands.as_ref().is_some_and(|(i, _)| i.holding())
    }

    fn quiet(&mut self) {
        if let Some((incoming, replies)) = &mut self.commands
            && let Some(request) = incoming.release()
        {
            self.instance.carry_out(&request, replies);
        }
    }

    fn geometry(&self) -> &Geometry {
        &self.geometry
    }
}

/// The bodies as the last two physics steps left them, for pictures between steps.
#[derive(Clone)]
pub(crate) struct BodySet {
    count: usize,
    before: Box<[HapticdBodyPose]>,
    /// Where the last step left them.
    pub(crate) after: Box<[HapticdBodyPose]>,
}

impl BodySet {
    fn new() -> Self {
        Self {
            count: 0,
            before: vec![HapticdBodyPose::default(); MAX_BODIES].into(),
            after: vec![HapticdBodyPose::default(); MAX_BODIES].into(),
        }
    }
}

/// A multi-rate scene: the plugin runs in a physics thread, the haptic side in the tick.
pub(crate) struct MultiRateScene {
    name: String,
    geometry: Geometry,
    /// The control plane's end of its world's control, until taken.
    control: Option<SceneControl>,
    /// Requests from the control plane, handed on to the physics thread.
    incoming: Option<Incoming>,
    /// The body of each object of its planes.
    object_bodies: Vec<u32>,
    to_physics: spsc::Producer<Request>,
    /// The sequence of the latest planes, and the one a change that waited for quiet is
    /// felt from (the physics has carried it out and published planes after it).
    seen: u64,
    settling: Option<u64>,
    renderer: PlaneRenderer,
    bodies_in: Reader<BodySet>,
    hands_out: Writer<Hands>,
    planes_in: Reader<PlaneSet>,
    hand_backs: spsc::Producer<HandBack>,
    rate: f64,
    /// Physics steps taken, and how many of them fell behind the world's rate.
    steps: Arc<(AtomicU64, AtomicU64)>,
    failed: Arc<AtomicBool>,
    /// Why the physics thread disabled the plugin, when it was for its planes: sent before
    /// `failed` is set, kept in `fault` once taken.
    faults_in: spsc::Consumer<OutputFault>,
    fault: Option<OutputFault>,
    stop: Arc<AtomicBool>,
    /// The thread that steps or receives the world.
    pub(crate) thread: Option<JoinHandle<()>>,
}

/// The physics thread's ends of a multi-rate scene's channels, and what it publishes.
pub(crate) struct PhysicsSide {
    requests: spsc::Consumer<Request>,
    /// The grips and proxies as the haptic side last published them.
    pub(crate) hands_in: Reader<Hands>,
    planes_out: Writer<PlaneSet>,
    bodies_out: Writer<BodySet>,
    hand_backs_in: spsc::Consumer<HandBack>,
    faults_out: spsc::Producer<OutputFault>,
    stop: Arc<AtomicBool>,
    failed: Arc<AtomicBool>,
    /// Steps taken, and how many fell behind the world's rate.
    pub(crate) steps: Arc<(AtomicU64, AtomicU64)>,
    /// Pointers of the scene.
    pub(crate) pointers: usize,
    /// The sequence of the last set published.
    sequence: u64,
    /// Where the bodies were after the last two steps; a step writes `after`.
    pub(crate) bodies: BodySet,
}

impl PhysicsSide {
    /// Whether the scene is being dropped.
    pub(crate) fn stopping(&self) -> bool {
        self.stop.load(Ordering::Acquire)
    }

    /// What the haptic side handed back since the last call, into `taken` (emptied first).
    fn take_hand_backs(&mut self, taken: &mut Taken) {
        taken.impulses.clear();
        taken.locals.clear();
        self.add_hand_backs(taken);
    }

    /// What the haptic side handed back since the last call, added to `taken`.
    pub(crate) fn add_hand_backs(&mut self, taken: &mut Taken) {
        while let Some(back) = self.hand_backs_in.pop() {
            match back {
                HandBack::Impulse(i) => taken.impulses.push(i),
                HandBack::Local(l) => taken.locals.push(l),
            }
        }
    }

    /// Disable the scene, for `fault` when it is the world's output.
    pub(crate) fn fail(&mut self, fault: Option<OutputFault>) {
        if let Some(fault) = fault {
            self.faults_out.push(fault);
        }
        self.failed.store(true, Ordering::Release);
    }

    /// Publish `set` as the next one, with the first `count` poses of `bodies.after`; planes
    /// or bodies no world publishes disable the scene instead, as a failure does (false).
    pub(crate) fn publish(&mut self, set: &mut PlaneSet, count: usize) -> bool {
        let checked = check_planes(&set.planes[..self.pointers])
            .and_then(|()| check_bodies(&set.bodies, set.body_count));
        if let Err(fault) = checked {
            self.fail(Some(fault));
            return false;
        }
        self.sequence += 1;
        set.sequence = self.sequence;
        self.planes_out.publish(|out| *out = *set);
        let bodies = &mut self.bodies;
        if self.sequence == 1 {
            bodies.before[..count].copy_from_slice(&bodies.after[..count]);
        }
        self.bodies_out.publish(|out| {
            out.count = count;
            out.before[..count].copy_from_slice(&bodies.before[..count]);
            out.after[..count].copy_from_slice(&bodies.after[..count]);
        });
        std::mem::swap(&mut bodies.before, &mut bodies.after);
        bodies.after[..count].copy_from_slice(&bodies.before[..count]);
        true
    }
}

impl MultiRateScene {
    /// The haptic side of a world at `rate` Hz for `pointers`, and the physics side's ends;
    /// no thread yet.
    pub(crate) fn new(
        name: String,
        (geometry, control, commands, object_bodies): (
            Geometry,
            Option<SceneControl>,
            Option<Commands>,
            Vec<u32>,
        ),
        rate: f64,
        pointers: &[Pointer],
    ) -> (Self, PhysicsSide, Option<spsc::Producer<Reply>>) {
        let (incoming, replies) = commands.unzip();
        let (to_physics, requests) = spsc::channel(16);
        let mut initial = [HapticdPointer::default(); MAX_EFFECTORS];
        for (out, p) in initial.iter_mut().zip(pointers) {
            *out = p.to_abi();
        }
        let (hands_out, hands_in) = triple_buffer::triple_buffer(Hands {
            pointers: initial,
            proxies: initial,
        });
        let (planes_out, planes_in) = triple_buffer::triple_buffer(PlaneSet::default());
        let (bodies_out, bodies_in) = triple_buffer::triple_buffer(BodySet::new());
        let (hand_backs, hand_backs_in) = spsc::channel(1024);
        let (faults_out, faults_in) = spsc::channel(1);
        let (stop, failed) = (
            Arc::new(AtomicBool::new(false)),
            Arc::new(AtomicBool::new(false)),
        );
        let steps = Arc::new((AtomicU64::new(0), AtomicU64::new(0)));
        let physics = PhysicsSide {
            requests,
            hands_in,
            planes_out,
            bodies_out,
            hand_backs_in,
            faults_out,
            stop: stop.clone(),
            failed: failed.clone(),
            steps: steps.clone(),
            pointers: pointers.len(),
            sequence: 0,
            bodies: BodySet::new(),
        };
        let scene = Self {
            name,
            geometry,
            control,
            incoming,
            object_bodies,
            to_physics,
            seen: 0,
            settling: None,
            renderer: PlaneRenderer::new(rate, pointers),
            bodies_in,
            hands_out,
            planes_in,
            hand_backs,
            rate,
            steps,
            failed,
            faults_in,
            fault: None,
            stop,
            thread: None,
        };
        (scene, physics, replies)
    }

    /// Start the physics thread of `instance` at `rate` Hz for `pointers`.
    fn start(
        name: String,
        instance: Instance,
        parts: (Geometry, Option<SceneControl>, Option<Commands>, Vec<u32>),
        rate: f64,
        pointers: &[Pointer],
    ) -> std::io::Result<Self> {
        let (mut scene, mut physics, mut replies) = Self::new(name, parts, rate, pointers);
        let n = pointers.len();
        let period_ns = (1e9 / rate) as u64;
        let name = scene.name.clone();
        scene.thread = Some(
            std::thread::Builder::new()
                .name("hapticd-physics".into())
                .spawn(move || {
                    // Off the haptic CPUs like every helper, and real-time only while its
                    // steps fit its budget.
                    let mut pacer = Pacer::new(name, period_ns);
                    // Move the whole instance in (not just its fields): it is destroyed with
                    // it.
                    let instance = instance;
                    let mut taken = Taken {
                        impulses: Vec::with_capacity(1024),
                        locals: Vec::with_capacity(1024),
                    };
                    let mut set = PlaneSet::default();
                    while !physics.stopping() {
                        if let Some(replies) = &mut replies {
                            while let Some(request) = physics.requests.pop() {
                                instance.carry_out(&request, replies);
                            }
                        }
                        physics.take_hand_backs(&mut taken);
                        let hands = *physics.hands_in.latest();
                        let started = monotonic_ns();
                        let status =
                            instance.step(period_ns as f64 * 1e-9, n, &hands, &taken, &mut set);
                        set.step = (monotonic_ns() - started) as f64 * 1e-9;
                        set.yielding = pacer.judge();
                        if status != HAPTICD_OK {
                            physics.fail(None);
                            return;
                        }
                        let count = instance.poses(&mut physics.bodies.after).min(MAX_BODIES);
                        if !physics.publish(&mut set, count) {
                            return;
                        }
                        if pacer.rest() {
                            physics.steps.1.fetch_add(1, Ordering::Relaxed);
                        }
                        physics.steps.0.fetch_add(1, Ordering::Relaxed);
                    }
                })?,
        );
        Ok(scene)
    }
}

impl Scene for MultiRateScene {
    fn name(&self) -> &str {
        &self.name
    }

    fn render(&mut self, pointers: &[Pointer], dt: f64, wrenches: &mut [Wrench]) -> bool {
        if let Some(incoming) = &mut self.incoming {
            while let Some(request) = incoming.due() {
                self.to_physics.push(request);
            }
        }
        let latest = self.planes_in.latest();
        self.seen = latest.sequence;
        if self.settling.is_some_and(|from| self.seen >= from) {
            self.settling = None;
        }
        let hand_backs = &mut self.hand_backs;
        // A full channel (a stalled physics thread) drops a hand-back rather than wait.
        let fresh = self.renderer.tick(latest, pointers, dt, wrenches, |back| {
            hand_backs.push(back);
        });
        let renderer = &self.renderer;
        self.hands_out.publish(|out| {
            let both = out.pointers.iter_mut().zip(out.proxies.iter_mut());
            for ((grip, proxy), (p, at)) in both.zip(pointers.iter().zip(renderer.queries())) {
                *grip = p.to_abi();
                *proxy = proxy_record(grip, at);
            }
        });
        if self.failed.load(Ordering::Acquire) || !fresh {
            if let Some(fault) = self.faults_in.pop() {
                self.fault = Some(fault);
            }
            wrenches.fill(Wrench::ZERO);
            return false;
        }
        true
    }

    fn fault(&self) -> Option<OutputFault> {
        self.fault
    }

    fn reset(&mut self, pointers: &[Pointer]) {
        self.renderer.reset(pointers);
    }

    fn take_control(&mut self) -> Option<SceneControl> {
        self.control.take()
    }

    fn write_touches(&self, touches: &mut [Touch]) {
        self.renderer.write_touches(&self.object_bodies, touches);
    }

    fn needs_quiet(&self) -> bool {
        self.incoming.as_ref().is_some_and(Incoming::holding) || self.settling.is_some()
    }

    /// The change goes to the physics; the forces come back once planes after it arrive
    /// (two steps on: the next may have begun before the change reached it).
    fn quiet(&mut self) {
        if let Some(request) = self.incoming.as_mut().and_then(Incoming::release) {
            self.to_physics.push(request);
            self.settling = Some(self.seen + 2);
        }
    }

    fn set_proxy(&mut self, parameters: &ProxyParameters) {
        self.renderer.set_parameters(parameters);
    }

    fn proxy(&self) -> Option<ProxyParameters> {
        Some(self.renderer.parameters())
    }

    fn write_proxies(&self, proxies: &mut [DVec3]) -> bool {
        for (out, p) in proxies.iter_mut().zip(self.renderer.proxies()) {
            *out = p;
        }
        true
    }

    /// The bodies moved as far between the last two steps as the planes felt (6.5.2), and
    /// those moved here where they are felt.
    fn write_bodies(&mut self, poses: &mut [HapticdBodyPose]) -> usize {
        let fraction = self.renderer.fraction();
        let set = self.bodies_in.latest();
        let shown = set.before[..set.count].iter().zip(&set.after[..set.count]);
        for (i, (out, (before, after))) in poses.iter_mut().zip(shown).enumerate() {
            let pose = self.renderer.local(i as u32).map_or_else(
                || pose_between(&pose_of(before), &pose_of(after), fraction),
                |m| m.pose(),
            );
            *out = body_pose(&pose);
        }
        set.count
    }

    fn geometry(&self) -> &Geometry {
        &self.geometry
    }
}

impl Drop for MultiRateScene {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        let (steps, late) = (
            self.steps.0.load(Ordering::Relaxed),
            self.steps.1.load(Ordering::Relaxed),
        );
        if late > 0 {
            tracing::warn!(
                "scene {}: {late} of {steps} physics steps fell behind the world's {:.1} ms \
                 period (a step that leaves less of it than it took is followed by as long a \
                 rest, so the world ran slower); give it a lower rate or fewer bodies",
                self.name,
                1e3 / self.rate
            );
        }
    }
}
