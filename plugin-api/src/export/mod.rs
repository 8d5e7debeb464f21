//! The Rust side of the boundary: what [`export_mechanism!`](crate::export_mechanism) expands to.
//!
//! Every exported function runs inside `catch_unwind`, because a panic unwinding through an
//! `extern "C"` frame aborts the whole daemon.

use std::ffi::{CStr, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicPtr, Ordering};
use std::sync::{Once, OnceLock};

use crate::abi::*;
use crate::ext::{
    scene_compliance::*, scene_contacts::*, scene_control::*, scene_deformation::*, scene_files::*,
    scene_geometry::*, scene_held::*, scene_joints::*, scene_mobility::*,
};

mod macros;
mod scene;
mod scene_compliance;
mod scene_contacts;
mod scene_control;
mod scene_deformation;
mod scene_files;
mod scene_geometry;
mod scene_held;
mod scene_joints;
mod scene_mobility;

use scene::instance_mut;
pub use scene::*;
use scene_compliance::SCENE_COMPLIANCE;
use scene_contacts::SCENE_CONTACTS;
use scene_control::SCENE_CONTROL;
use scene_deformation::SCENE_DEFORMATION;
pub use scene_files::*;
use scene_geometry::SCENE_GEOMETRY;
use scene_held::SCENE_HELD;
use scene_joints::SCENE_JOINTS;
use scene_mobility::SCENE_MOBILITY;

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

/// Body of an extension function that answers one thing of an instance through `out`: what
/// `ask` finds, [`HAPTICD_ERROR_ARGUMENT`] for a null instance or nothing to answer, the
/// panic status if `ask` panics.
///
/// # Safety
/// `instance` is null or a live instance this thread may use, as the extension's contract
/// says; `out` is null or valid for writing one `T`.
unsafe fn answer<T>(
    instance: *mut std::ffi::c_void,
    out: *mut T,
    ask: impl FnOnce(&mut dyn SceneInstance) -> Option<T>,
) -> i32 {
    if instance.is_null() {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: non-null, and live and this thread's, per the contract.
    let scene = unsafe { instance_mut(instance) };
    let mut found = None;
    let status = guard(|| {
        found = ask(scene.as_mut());
        HAPTICD_OK
    });
    if status != HAPTICD_OK {
        return status;
    }
    // SAFETY: `out` is null or valid for one write, per the contract.
    unsafe { write_out(out, found) }
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

/// Why a Rust scene plugin refuses a scene file: any error, its text what the host logs or
/// hands on (a `String` or `&str` turns into one with `into()` or `?`).
pub type SceneError = Box<dyn std::error::Error + Send + Sync>;

/// How a Rust scene plugin checks one of its scene files for a number of pointers: nothing,
/// or its findings, one a line.
pub type SceneCheck = fn(&str, usize) -> Result<(), SceneError>;

/// Body of the exported `get_extension` function: the geometry, control, contacts,
/// mobility, joints, deformation, compliance and held extensions, and the files extension when the plugin
/// runs scene files.
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
    if id == HAPTICD_EXT_SCENE_MOBILITY {
        return (&SCENE_MOBILITY as *const HapticdSceneMobility).cast();
    }
    if id == HAPTICD_EXT_SCENE_JOINTS {
        return (&SCENE_JOINTS as *const HapticdSceneJoints).cast();
    }
    if id == HAPTICD_EXT_SCENE_DEFORMATION {
        return (&SCENE_DEFORMATION as *const HapticdSceneDeformation).cast();
    }
    if id == HAPTICD_EXT_SCENE_COMPLIANCE {
        return (&SCENE_COMPLIANCE as *const HapticdSceneCompliance).cast();
    }
    if id == HAPTICD_EXT_SCENE_HELD {
        return (&SCENE_HELD as *const HapticdSceneHeld).cast();
    }
    match files {
        Some(files) if id == HAPTICD_EXT_SCENE_FILES => {
            (&files.0 as *const HapticdSceneFiles).cast()
        }
        _ => std::ptr::null(),
    }
}
