//! The Rust side of the boundary: what [`export_mechanism!`](crate::export_mechanism) expands to.
//!
//! Every exported function runs inside `catch_unwind`, because a panic unwinding through an
//! `extern "C"` frame aborts the whole daemon.

use std::ffi::{CStr, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicPtr, Ordering};
use std::sync::{Once, OnceLock};

use crate::abi::*;
use crate::geometry::Geometry;

/// A mechanism as a Rust plugin author describes it.
#[derive(Debug, Clone, PartialEq)]
pub struct MechanismSpec {
    /// λ of the tension problem (thesis eq. 3.16).
    pub lambda: f64,
    /// Weight of torque rows relative to force rows (1 = every wrench component weighted 1).
    pub torque_weight: f64,
    /// End effectors, in order.
    pub effectors: Vec<HapticdEffector>,
    /// Strings, in order; each names its effector by index.
    pub strings: Vec<HapticdString>,
}

impl HapticdEffector {
    /// An effector named `name` with `dof` degrees of freedom, calibrated at the frame centre
    /// with identity orientation.
    ///
    /// # Panics
    /// If `name` does not fit in [`HAPTICD_NAME_CAPACITY`] − 1 bytes or contains NUL.
    pub fn new(name: &str, dof: u32) -> Self {
        assert!(
            name.len() < HAPTICD_NAME_CAPACITY && !name.contains('\0'),
            "effector name {name:?} must be shorter than {HAPTICD_NAME_CAPACITY} bytes, without NUL"
        );
        let mut buf = [0 as c_char; HAPTICD_NAME_CAPACITY];
        for (slot, byte) in buf.iter_mut().zip(name.bytes()) {
            *slot = byte as c_char;
        }
        Self {
            name: buf,
            dof,
            calibration_position: [0.0; 3],
            calibration_orientation: [1.0, 0.0, 0.0, 0.0],
        }
    }

    /// The name up to its NUL, or `None` if it is unterminated or not UTF-8.
    pub fn name_str(&self) -> Option<&str> {
        // SAFETY: c_char and u8 have the same size and alignment.
        let bytes: &[u8; HAPTICD_NAME_CAPACITY] = unsafe { &*self.name.as_ptr().cast() };
        CStr::from_bytes_until_nul(bytes).ok()?.to_str().ok()
    }
}

static HOST: AtomicPtr<HapticdHost> = AtomicPtr::new(std::ptr::null_mut());

/// Log through the host (falls back to stderr before `hapticd_plugin_entry` ran).
///
/// [main, physics] only: logging is a syscall the real-time thread must not make.
pub fn log(level: u32, message: &str) {
    let host = HOST.load(Ordering::Acquire);
    // SAFETY: the host guarantees the pointer it passed to the entry outlives the plugin.
    match unsafe { host.as_ref() }.and_then(|h| h.log.map(|log| (h.context, log))) {
        // SAFETY: message is valid for len bytes for the duration of the call.
        Some((context, log)) => unsafe {
            log(context, level, message.as_ptr().cast(), message.len())
        },
        None => eprintln!("{message}"),
    }
}

/// The host's extension called `id` (such as `c"hapticd.example/1"`), or null when the
/// host offers none of that name, is older than ABI 1.1, or has not called the entry yet.
pub fn extension(id: &std::ffi::CStr) -> *const std::ffi::c_void {
    let host = HOST.load(Ordering::Acquire);
    // SAFETY: the host guarantees the pointer it passed to the entry outlives the plugin.
    let Some(host) = (unsafe { host.as_ref() }) else {
        return std::ptr::null();
    };
    // A 1.0 host's struct ends before get_extension: read it only from a 1.1 host on.
    match host.get_extension {
        // SAFETY: id is NUL-terminated and outlives the call.
        Some(get) if host.abi_minor >= 1 => unsafe { get(host.context, id.as_ptr()) },
        _ => std::ptr::null(),
    }
}

/// Report panics through the host log: the plugin's own copy of std would print them to a
/// stderr nobody reads. Installed in the plugin's std only; the host's hook is untouched.
fn install_panic_hook() {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        std::panic::set_hook(Box::new(|info| {
            let at = info
                .location()
                .map(|l| format!(" at {}:{}", l.file(), l.line()))
                .unwrap_or_default();
            let message = info.payload_as_str().unwrap_or("non-string panic payload");
            log(HAPTICD_LOG_ERROR, &format!("panicked{at}: {message}"));
        }))
    });
}

/// Run `f`, turning a panic into [`HAPTICD_ERROR_PANIC`] (the hook has logged it).
fn guard(f: impl FnOnce() -> i32) -> i32 {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or(HAPTICD_ERROR_PANIC)
}

/// Write `value` through `out` if it is non-null.
///
/// # Safety
/// `out` is null or valid for writing one `T`.
unsafe fn write_out<T>(out: *mut T, value: Option<T>) -> i32 {
    match value {
        Some(value) if !out.is_null() => {
            // SAFETY: non-null, and valid for one T by this function's contract.
            unsafe { out.write(value) };
            HAPTICD_OK
        }
        _ => HAPTICD_ERROR_ARGUMENT,
    }
}

/// A descriptor that may live in a `static` (its pointers all point to `'static` data).
#[repr(transparent)]
#[doc(hidden)]
pub struct StaticDescriptor(pub HapticdPluginDescriptor);

// SAFETY: every pointer in a StaticDescriptor points to immutable 'static data.
unsafe impl Sync for StaticDescriptor {}

/// A vtable that may live in a `static`.
#[repr(transparent)]
#[doc(hidden)]
pub struct StaticVtable(pub HapticdMechanismVtable);

// SAFETY: a vtable holds only function pointers.
unsafe impl Sync for StaticVtable {}

/// The state behind an exported mechanism: the author's builder, run once.
#[doc(hidden)]
pub struct MechanismExport {
    build: fn() -> MechanismSpec,
    spec: OnceLock<Option<MechanismSpec>>,
}

impl MechanismExport {
    /// A mechanism built by `build` on first use.
    pub const fn new(build: fn() -> MechanismSpec) -> Self {
        Self {
            build,
            spec: OnceLock::new(),
        }
    }

    fn spec(&self) -> Option<&MechanismSpec> {
        self.spec
            .get_or_init(|| catch_unwind(self.build).ok())
            .as_ref()
    }

    fn with_spec(&self, f: impl FnOnce(&MechanismSpec) -> i32) -> i32 {
        guard(|| self.spec().map_or(HAPTICD_ERROR_PANIC, f))
    }

    /// Body of the exported `info` function.
    ///
    /// # Safety
    /// `out` is null or valid for writing one value.
    pub unsafe fn info(&self, out: *mut HapticdMechanismInfo) -> i32 {
        self.with_spec(|spec| {
            let info = HapticdMechanismInfo {
                effector_count: u32::try_from(spec.effectors.len()).unwrap_or(u32::MAX),
                string_count: u32::try_from(spec.strings.len()).unwrap_or(u32::MAX),
                lambda: spec.lambda,
                torque_weight: spec.torque_weight,
            };
            // SAFETY: forwarded from this function's contract.
            unsafe { write_out(out, Some(info)) }
        })
    }

    /// Body of the exported `effector` function.
    ///
    /// # Safety
    /// `out` is null or valid for writing one value.
    pub unsafe fn effector(&self, index: u32, out: *mut HapticdEffector) -> i32 {
        self.with_spec(|spec| {
            // SAFETY: forwarded from this function's contract.
            unsafe { write_out(out, spec.effectors.get(index as usize).copied()) }
        })
    }

    /// Body of the exported `string` function.
    ///
    /// # Safety
    /// `out` is null or valid for writing one value.
    pub unsafe fn string(&self, index: u32, out: *mut HapticdString) -> i32 {
        self.with_spec(|spec| {
            // SAFETY: forwarded from this function's contract.
            unsafe { write_out(out, spec.strings.get(index as usize).copied()) }
        })
    }
}

/// Body of the exported entry: remember the host, hand out the descriptor.
///
/// # Safety
/// `host` is null or valid for the rest of the process.
#[doc(hidden)]
pub unsafe fn entry(
    host: *const HapticdHost,
    descriptor: &'static StaticDescriptor,
) -> *const HapticdPluginDescriptor {
    install_panic_hook();
    catch_unwind(|| {
        // SAFETY: the host passes a pointer valid for the life of the process, or null.
        if let Some(h) = unsafe { host.as_ref() } {
            if h.abi_major != HAPTICD_ABI_MAJOR {
                return std::ptr::null();
            }
            HOST.store(host.cast_mut(), Ordering::Release);
        }
        &descriptor.0 as *const HapticdPluginDescriptor
    })
    .unwrap_or(std::ptr::null())
}

/// Export a mechanism plugin: defines `hapticd_plugin_entry` and the vtable around a
/// function that builds the [`MechanismSpec`].
///
/// ```
/// use hapticd_plugin_api::{HapticdEffector, HapticdString, MechanismSpec};
///
/// fn build() -> MechanismSpec {
///     let corners = [[-1.0, 1.0, 1.0], [1.0, 1.0, -1.0], [-1.0, -1.0, -1.0], [1.0, -1.0, 1.0]];
///     MechanismSpec {
///         lambda: 0.01,
///         torque_weight: 1.0,
///         effectors: vec![HapticdEffector::new("grip", 3)],
///         strings: corners
///             .iter()
///             .map(|c| HapticdString {
///                 effector: 0,
///                 motor: c.map(|s| s * 0.2),
///                 knot: [0.0; 3],
///                 metres_per_pulse: 2.5e-5,
///                 volts_per_newton: 0.3653,
///                 tension_min: 0.5,
///                 tension_max: 10.0,
///             })
///             .collect(),
///     }
/// }
///
/// hapticd_plugin_api::export_mechanism!(
///     name: "my-spidar",
///     description: "A 4-string SPIDAR on a 0.4 m frame",
///     build: build,
/// );
/// # fn main() {}
/// ```
#[macro_export]
macro_rules! export_mechanism {
    (name: $name:literal, description: $description:literal, build: $build:path $(,)?) => {
        const _: () = {
            use $crate::abi::*;
            use $crate::export::{MechanismExport, StaticVtable};

            static EXPORT: MechanismExport = MechanismExport::new($build);

            // SAFETY (all three): the host passes a pointer valid for one value, per the ABI.
            unsafe extern "C" fn __hapticd_info(out: *mut HapticdMechanismInfo) -> i32 {
                unsafe { EXPORT.info(out) }
            }
            unsafe extern "C" fn __hapticd_effector(index: u32, out: *mut HapticdEffector) -> i32 {
                unsafe { EXPORT.effector(index, out) }
            }
            unsafe extern "C" fn __hapticd_string(index: u32, out: *mut HapticdString) -> i32 {
                unsafe { EXPORT.string(index, out) }
            }

            static VTABLE: StaticVtable = StaticVtable(HapticdMechanismVtable {
                struct_size: ::core::mem::size_of::<HapticdMechanismVtable>() as u32,
                info: Some(__hapticd_info),
                effector: Some(__hapticd_effector),
                string: Some(__hapticd_string),
            });

            $crate::__hapticd_plugin_entry!(
                HAPTICD_KIND_MECHANISM,
                $name,
                $description,
                &VTABLE.0,
                ::core::ptr::null()
            );
        };
    };
}

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
}

impl HapticdSceneCommand {
    /// A command of `kind` for body `body`, its numbers zero and its orientation none turned.
    pub fn new(kind: u32, body: u32) -> Self {
        Self {
            kind,
            body,
            orientation: [1.0, 0.0, 0.0, 0.0],
            ..Self::default()
        }
    }

    /// Whether every number the command carries is finite (a plugin takes no other).
    pub fn is_finite(&self) -> bool {
        self.position
            .iter()
            .chain(&self.orientation)
            .chain(&self.vector)
            .chain(&self.spin)
            .chain(std::iter::once(&self.value))
            .all(|v| v.is_finite())
    }
}

impl HapticdBodyInfo {
    /// A body called `name` (cut at a character to fit [`HAPTICD_BODY_NAME_CAPACITY`] − 1
    /// bytes; a NUL ends it early), fixed or free.
    pub fn new(name: &str, fixed: bool) -> Self {
        let mut end = name.len().min(HAPTICD_BODY_NAME_CAPACITY - 1);
        while !name.is_char_boundary(end) {
            end -= 1;
        }
        let mut buf = [0 as c_char; HAPTICD_BODY_NAME_CAPACITY];
        for (slot, byte) in buf.iter_mut().zip(name[..end].bytes()) {
            *slot = byte as c_char;
        }
        Self {
            name: buf,
            flags: if fixed { HAPTICD_SOLID_FIXED } else { 0 },
        }
    }

    /// The name up to its NUL, or `None` if it is unterminated or not UTF-8.
    pub fn name_str(&self) -> Option<&str> {
        // SAFETY: c_char and u8 have the same size and alignment.
        let bytes: &[u8; HAPTICD_BODY_NAME_CAPACITY] = unsafe { &*self.name.as_ptr().cast() };
        CStr::from_bytes_until_nul(bytes).ok()?.to_str().ok()
    }
}

/// Why a Rust scene plugin refuses a scene file: any error, its text what the host logs or
/// hands on (a `String` or `&str` turns into one with `into()` or `?`).
pub type SceneError = Box<dyn std::error::Error + Send + Sync>;

/// How a Rust scene plugin checks one of its scene files for a number of pointers: nothing,
/// or its findings, one a line.
pub type SceneCheck = fn(&str, usize) -> Result<(), SceneError>;

/// The instance's geometry, if it has one.
///
/// # Safety
/// As [`instance_mut`].
unsafe fn geometry_of<'a>(instance: *mut std::ffi::c_void) -> Option<&'a Geometry> {
    if instance.is_null() {
        return None;
    }
    // SAFETY: per this function's contract.
    let scene = unsafe { instance_mut(instance) };
    let mut found = None;
    guard(|| {
        found = scene.geometry().map(|g| g as *const Geometry);
        HAPTICD_OK
    });
    // SAFETY: the geometry lives in the instance, which outlives the caller's use of it.
    found.map(|g| unsafe { &*g })
}

unsafe extern "C" fn geometry_counts(
    instance: *mut std::ffi::c_void,
    out: *mut HapticdGeometryCounts,
) -> i32 {
    // SAFETY: the host keeps the extension's contract: a live instance, a valid `out`.
    unsafe {
        let counts =
            geometry_of(instance).map_or_else(HapticdGeometryCounts::default, Geometry::counts);
        write_out(out, Some(counts))
    }
}

unsafe extern "C" fn geometry_solid(
    instance: *mut std::ffi::c_void,
    index: u32,
    out: *mut HapticdSolid,
) -> i32 {
    // SAFETY: as in geometry_counts.
    unsafe {
        let solid = geometry_of(instance).and_then(|g| g.solids.get(index as usize).copied());
        write_out(out, solid)
    }
}

unsafe extern "C" fn geometry_triangles(
    instance: *mut std::ffi::c_void,
    first: u32,
    count: u32,
    out: *mut HapticdTriangle,
) -> i32 {
    // SAFETY: as in geometry_counts.
    let Some(geometry) = (unsafe { geometry_of(instance) }) else {
        return HAPTICD_ERROR_ARGUMENT;
    };
    let (first, count) = (first as usize, count as usize);
    let Some(triangles) = geometry.triangles.get(first..first.saturating_add(count)) else {
        return HAPTICD_ERROR_ARGUMENT;
    };
    if out.is_null() && count > 0 {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: `out` holds `count` triangles, per the extension's contract.
    unsafe { std::ptr::copy_nonoverlapping(triangles.as_ptr(), out, count) };
    HAPTICD_OK
}

unsafe extern "C" fn control_body(
    instance: *mut std::ffi::c_void,
    index: u32,
    out: *mut HapticdBodyInfo,
) -> i32 {
    if instance.is_null() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: the host keeps the extension's contract: a live instance on the main thread.
    let scene = unsafe { instance_mut(instance) };
    let mut info = None;
    let status = guard(|| {
        info = scene.body(index as usize);
        HAPTICD_OK
    });
    if status != HAPTICD_OK {
        return status;
    }
    // SAFETY: `out` is null or valid for one write, per the contract.
    unsafe { write_out(out, info) }
}

unsafe extern "C" fn control_apply(
    instance: *mut std::ffi::c_void,
    command: *const HapticdSceneCommand,
    state: *mut HapticdBodyState,
) -> i32 {
    if instance.is_null() || command.is_null() || state.is_null() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: non-null and valid, on the thread that steps the instance, per the contract.
    let (scene, command, state) = unsafe { (instance_mut(instance), &*command, &mut *state) };
    guard(|| scene.apply(command, state))
}

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
    if instance.is_null() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: the host keeps the extension's contract: a live instance on its stepping thread.
    let scene = unsafe { instance_mut(instance) };
    let mut touch = None;
    let status = guard(|| {
        touch = scene.touch(pointer as usize);
        HAPTICD_OK
    });
    if status != HAPTICD_OK {
        return status;
    }
    // SAFETY: `out` is null or valid for one write, per the contract.
    unsafe { write_out(out, touch) }
}

/// The contacts extension every Rust scene plugin serves, around
/// [`SceneInstance::object_body`] and [`SceneInstance::touch`].
static SCENE_CONTACTS: HapticdSceneContacts = HapticdSceneContacts {
    struct_size: std::mem::size_of::<HapticdSceneContacts>() as u32,
    object_body: Some(contacts_object_body),
    touch: Some(contacts_touch),
};

/// The control extension every Rust scene plugin serves, around [`SceneInstance::body`]
/// and [`SceneInstance::apply`].
static SCENE_CONTROL: HapticdSceneControl = HapticdSceneControl {
    struct_size: std::mem::size_of::<HapticdSceneControl>() as u32,
    body: Some(control_body),
    apply: Some(control_apply),
};

/// The geometry extension every Rust scene plugin serves, around
/// [`SceneInstance::geometry`].
static SCENE_GEOMETRY: HapticdSceneGeometry = HapticdSceneGeometry {
    struct_size: std::mem::size_of::<HapticdSceneGeometry>() as u32,
    counts: Some(geometry_counts),
    solid: Some(geometry_solid),
    triangles: Some(geometry_triangles),
};

/// A files extension that may live in a `static`.
#[repr(transparent)]
#[doc(hidden)]
pub struct StaticSceneFiles(pub HapticdSceneFiles);

// SAFETY: it holds only function pointers and a size.
unsafe impl Sync for StaticSceneFiles {}

/// Body of the exported `get_extension` function: the geometry, control and contacts
/// extensions, and the files extension when the plugin runs scene files.
///
/// # Safety
/// `id` is null or NUL-terminated.
#[doc(hidden)]
pub unsafe fn scene_extension(
    id: *const c_char,
    files: Option<&'static StaticSceneFiles>,
) -> *const std::ffi::c_void {
    if id.is_null() {
        return std::ptr::null();
    }
    // SAFETY: non-null and NUL-terminated, per the contract.
    let id = unsafe { CStr::from_ptr(id) };
    if id == HAPTICD_EXT_SCENE_GEOMETRY {
        return (&SCENE_GEOMETRY as *const HapticdSceneGeometry).cast();
    }
    if id == HAPTICD_EXT_SCENE_CONTROL {
        return (&SCENE_CONTROL as *const HapticdSceneControl).cast();
    }
    if id == HAPTICD_EXT_SCENE_CONTACTS {
        return (&SCENE_CONTACTS as *const HapticdSceneContacts).cast();
    }
    match files {
        Some(files) if id == HAPTICD_EXT_SCENE_FILES => {
            (&files.0 as *const HapticdSceneFiles).cast()
        }
        _ => std::ptr::null(),
    }
}

/// Body of the exported files extension's `engine` function.
#[doc(hidden)]
pub fn scene_engine(engines: &'static [&'static CStr], index: u32) -> *const c_char {
    engines
        .get(index as usize)
        .map_or(std::ptr::null(), |e| e.as_ptr())
}

/// Body of the exported files extension's `check` function.
///
/// # Safety
/// `path` is null or NUL-terminated; `message` is null or holds `capacity` bytes.
#[doc(hidden)]
pub unsafe fn scene_check(
    check: SceneCheck,
    path: *const c_char,
    pointer_count: u32,
    message: *mut c_char,
    capacity: usize,
) -> i32 {
    if path.is_null() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: non-null and NUL-terminated, per the contract.
    let path = unsafe { CStr::from_ptr(path) }
        .to_string_lossy()
        .into_owned();
    let mut findings = None;
    let status = guard(|| match check(&path, pointer_count as usize) {
        Ok(()) => HAPTICD_OK,
        Err(e) => {
            findings = Some(e.to_string());
            HAPTICD_ERROR_FAILED
        }
    });
    if let (Some(text), false, 1..) = (findings, message.is_null(), capacity) {
        let mut end = text.len().min(capacity - 1);
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        // SAFETY: `message` holds `capacity` > `end` bytes, per the contract.
        unsafe {
            std::ptr::copy_nonoverlapping(text.as_ptr().cast::<c_char>(), message, end);
            message.add(end).write(0);
        }
    }
    status
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
unsafe fn instance_mut<'a>(instance: *mut std::ffi::c_void) -> &'a mut Box<dyn SceneInstance> {
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

/// Export a scene plugin: defines `hapticd_plugin_entry` and the scene vtable around a
/// [`SceneFactory`].
#[macro_export]
macro_rules! export_scene {
    (name: $name:literal, description: $description:literal, create: $create:path $(,)?) => {
        $crate::export_scene!(@vtable $name, $description, $create, None);
    };
    (
        name: $name:literal,
        description: $description:literal,
        create: $create:path,
        engines: [$($engine:literal),+ $(,)?],
        check: $check:path $(,)?
    ) => {
        const _: () = {
            use $crate::abi::*;

            unsafe extern "C" fn __hapticd_engine(index: u32) -> *const ::core::ffi::c_char {
                const ENGINES: &[&::core::ffi::CStr] = &[$(
                    match ::core::ffi::CStr::from_bytes_with_nul(concat!($engine, "\0").as_bytes()) {
                        Ok(name) => name,
                        Err(_) => panic!("an engine name holds no NUL"),
                    }
                ),+];
                $crate::export::scene_engine(ENGINES, index)
            }
            // SAFETY: the host keeps the extension's contract on every pointer.
            unsafe extern "C" fn __hapticd_check(
                path: *const ::core::ffi::c_char,
                pointer_count: u32,
                message: *mut ::core::ffi::c_char,
                capacity: usize,
            ) -> i32 {
                unsafe {
                    $crate::export::scene_check($check, path, pointer_count, message, capacity)
                }
            }
            static FILES: $crate::export::StaticSceneFiles =
                $crate::export::StaticSceneFiles(HapticdSceneFiles {
                    struct_size: ::core::mem::size_of::<HapticdSceneFiles>() as u32,
                    engine: Some(__hapticd_engine),
                    check: Some(__hapticd_check),
                });
            $crate::export_scene!(@vtable $name, $description, $create, Some(&FILES));
        };
    };
    (@vtable $name:literal, $description:literal, $create:path, $files:expr) => {
        const _: () = {
            use $crate::abi::*;
            use $crate::export::StaticSceneVtable;

            // SAFETY (all seven): the host keeps the ABI's contracts on every pointer.
            unsafe extern "C" fn __hapticd_create(
                path: *const ::core::ffi::c_char,
                pointer_count: u32,
                instance: *mut *mut ::core::ffi::c_void,
                info: *mut HapticdSceneInfo,
            ) -> i32 {
                unsafe {
                    $crate::export::scene_create($create, path, pointer_count, instance, info)
                }
            }
            unsafe extern "C" fn __hapticd_destroy(instance: *mut ::core::ffi::c_void) {
                unsafe { $crate::export::scene_destroy(instance) }
            }
            unsafe extern "C" fn __hapticd_step_direct(
                instance: *mut ::core::ffi::c_void,
                dt: f64,
                pointers: *const HapticdPointer,
                count: u32,
                wrenches: *mut HapticdWrench,
            ) -> i32 {
                unsafe {
                    $crate::export::scene_step_direct(instance, dt, pointers, count, wrenches)
                }
            }
            unsafe extern "C" fn __hapticd_step_physics(
                instance: *mut ::core::ffi::c_void,
                dt: f64,
                pointers: *const HapticdPointer,
                count: u32,
                impulses: *const HapticdImpulse,
                impulse_count: u32,
                planes: *mut HapticdPlanes,
            ) -> i32 {
                unsafe {
                    $crate::export::scene_step_physics(
                        instance,
                        dt,
                        pointers,
                        count,
                        impulses,
                        impulse_count,
                        planes,
                    )
                }
            }

            unsafe extern "C" fn __hapticd_poses(
                instance: *mut ::core::ffi::c_void,
                poses: *mut HapticdBodyPose,
                capacity: u32,
            ) -> u32 {
                unsafe { $crate::export::scene_poses(instance, poses, capacity) }
            }

            unsafe extern "C" fn __hapticd_step_world(
                instance: *mut ::core::ffi::c_void,
                input: *const HapticdPhysicsInput,
                output: *mut HapticdPhysicsOutput,
            ) -> i32 {
                unsafe { $crate::export::scene_step_world(instance, input, output) }
            }

            unsafe extern "C" fn __hapticd_get_extension(
                id: *const ::core::ffi::c_char,
            ) -> *const ::core::ffi::c_void {
                unsafe { $crate::export::scene_extension(id, $files) }
            }

            static VTABLE: StaticSceneVtable = StaticSceneVtable(HapticdSceneVtable {
                struct_size: ::core::mem::size_of::<HapticdSceneVtable>() as u32,
                create: Some(__hapticd_create),
                destroy: Some(__hapticd_destroy),
                step_direct: Some(__hapticd_step_direct),
                step_physics: Some(__hapticd_step_physics),
                poses: Some(__hapticd_poses),
                step_world: Some(__hapticd_step_world),
                get_extension: Some(__hapticd_get_extension),
            });

            $crate::__hapticd_plugin_entry!(
                HAPTICD_KIND_SCENE,
                $name,
                $description,
                ::core::ptr::null(),
                &VTABLE.0
            );
        };
    };
}

/// Defines the descriptor of a plugin of `$kind` and the `hapticd_plugin_entry` that hands
/// it out.
#[doc(hidden)]
#[macro_export]
macro_rules! __hapticd_plugin_entry {
    ($kind:expr, $name:literal, $description:literal, $mechanism:expr, $scene:expr) => {
        static DESCRIPTOR: $crate::export::StaticDescriptor =
            $crate::export::StaticDescriptor($crate::abi::HapticdPluginDescriptor {
                abi_major: $crate::abi::HAPTICD_ABI_MAJOR,
                abi_minor: $crate::abi::HAPTICD_ABI_MINOR,
                kind: $kind,
                name: concat!($name, "\0").as_ptr().cast(),
                version: concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast(),
                description: concat!($description, "\0").as_ptr().cast(),
                mechanism: $mechanism,
                scene: $scene,
            });

        /// [main] The plugin's entry point.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn hapticd_plugin_entry(
            host: *const $crate::abi::HapticdHost,
        ) -> *const $crate::abi::HapticdPluginDescriptor {
            // SAFETY: the host keeps `host` valid for the life of the process (ABI v1).
            unsafe { $crate::export::entry(host, &DESCRIPTOR) }
        }
    };
}
