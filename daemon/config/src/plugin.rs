//! Loading plugins: permission checks, `dlopen`, ABI negotiation, host services.
//!
//! A plugin runs with the daemon's privileges (root, real-time), so only files that an
//! unprivileged user cannot have planted or modified are loaded: owned by root or by the
//! daemon's own user, and neither they nor any directory above them writable by group or
//! others (a sticky directory such as /tmp is accepted: others cannot replace entries in it).
//! Libraries are opened with `RTLD_NOW | RTLD_LOCAL` so a missing symbol fails at load time,
//! not in the middle of a haptic tick, and are never closed: code a thread may still be
//! running must stay mapped.

use std::ffi::{CStr, CString, c_char, c_void};
use std::fmt;
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};

use hapticd_plugin_api::*;

/// Why a plugin was refused.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PluginError {
    /// The file that was refused.
    pub path: PathBuf,
    /// Why, in words.
    pub reason: String,
}

impl fmt::Display for PluginError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.reason)
    }
}

impl std::error::Error for PluginError {}

fn refuse(path: &Path, reason: impl Into<String>) -> PluginError {
    PluginError {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

/// A plugin that passed every check. Its library stays loaded for the life of the process.
#[derive(Debug, Clone)]
pub struct LoadedPlugin {
    /// Where it was loaded from.
    pub path: PathBuf,
    /// Its name.
    pub name: String,
    /// Its version string.
    pub version: String,
    /// Its one-line description.
    pub description: String,
    /// ABI version it was built against (major, minor).
    pub abi: (u32, u32),
    descriptor: &'static HapticdPluginDescriptor,
}

/// Refuse `path` unless it is a regular file that only root or this process's user could
/// have written, in directories only they could have written; the file, resolved.
pub fn check_permissions(path: &Path) -> Result<PathBuf, PluginError> {
    let canonical = path
        .canonicalize()
        .map_err(|e| refuse(path, format!("cannot resolve path: {e}")))?;
    let euid = nix::unistd::geteuid().as_raw();
    let meta =
        std::fs::metadata(&canonical).map_err(|e| refuse(path, format!("cannot stat: {e}")))?;
    if !meta.is_file() {
        return Err(refuse(path, "is not a regular file"));
    }
    let mut current = Some(canonical.as_path());
    while let Some(p) = current {
        let meta = std::fs::metadata(p)
            .map_err(|e| refuse(path, format!("cannot stat {}: {e}", p.display())))?;
        let mode = meta.permissions().mode();
        let what = if p == canonical {
            "the file"
        } else {
            "directory"
        };
        if meta.uid() != 0 && meta.uid() != euid {
            return Err(refuse(
                path,
                format!(
                    "unsafe permissions: {what} {} is owned by uid {}, not by root or by uid {euid}",
                    p.display(),
                    meta.uid()
                ),
            ));
        }
        let sticky_dir = meta.is_dir() && mode & 0o1000 != 0;
        if mode & 0o022 != 0 && !sticky_dir {
            return Err(refuse(
                path,
                format!(
                    "unsafe permissions: {what} {} is writable by group or others (mode {:04o})",
                    p.display(),
                    mode & 0o7777
                ),
            ));
        }
        current = p.parent();
    }
    Ok(canonical)
}

/// [main, physics] Host log service handed to plugins; `context` is the plugin's file name.
unsafe extern "C" fn host_log(
    context: *mut c_void,
    level: u32,
    message: *const c_char,
    len: usize,
) {
    if message.is_null() {
        return;
    }
    // SAFETY: the plugin passes `len` readable bytes; context is the leaked CString below.
    let (bytes, origin) = unsafe {
        (
            std::slice::from_raw_parts(message.cast::<u8>(), len),
            CStr::from_ptr(context.cast::<c_char>()),
        )
    };
    let (plugin, message) = (origin.to_string_lossy(), String::from_utf8_lossy(bytes));
    match level {
        HAPTICD_LOG_ERROR => tracing::error!(%plugin, "plugin {plugin}: {message}"),
        HAPTICD_LOG_WARN => tracing::warn!(%plugin, "plugin {plugin}: {message}"),
        HAPTICD_LOG_INFO => tracing::info!(%plugin, "plugin {plugin}: {message}"),
        _ => tracing::debug!(%plugin, "plugin {plugin}: {message}"),
    }
}

/// [any] Host clock service: CLOCK_MONOTONIC in nanoseconds.
unsafe extern "C" fn host_now_ns(_context: *mut c_void) -> u64 {
    hapticd_service::clock::monotonic_ns()
}

/// [any] Host extension lookup. ABI 1.1 defines no extension yet: every name is answered
/// with null, which a plugin takes as "not offered".
unsafe extern "C" fn host_get_extension(
    _context: *mut c_void,
    _id: *const c_char,
) -> *const c_void {
    std::ptr::null()
}

/// Check, open and negotiate with the plugin at `path`.
pub fn load(path: &Path) -> Result<LoadedPlugin, PluginError> {
    // The resolved path: a bare file name would send dlopen searching the library path.
    let resolved = check_permissions(path)?;
    let flags = libloading::os::unix::RTLD_NOW | libloading::os::unix::RTLD_LOCAL;
    // SAFETY: loading runs the library's initialisers; the permission check above is what
    // makes running this code acceptable.
    let library = unsafe { libloading::os::unix::Library::open(Some(&resolved), flags) }
        .map_err(|e| refuse(path, format!("cannot load: {e}")))?;
    // SAFETY: the symbol's type is fixed by ABI v1.
    let entry =
        unsafe { library.get::<HapticdPluginEntry>(b"hapticd_plugin_entry\0") }.map_err(|_| {
            refuse(
                path,
                "not a hapticd plugin: it exports no hapticd_plugin_entry",
            )
        })?;
    let entry = *entry;
    // Never dlclose: a plugin's code must stay mapped while anything may call it.
    std::mem::forget(library);

    let origin = CString::new(
        path.file_name()
            .map_or_else(|| path.to_string_lossy(), |n| n.to_string_lossy())
            .into_owned(),
    )
    .unwrap_or_default();
    let host: &'static HapticdHost = Box::leak(Box::new(HapticdHost {
        abi_major: HAPTICD_ABI_MAJOR,
        abi_minor: HAPTICD_ABI_MINOR,
        context: origin.into_raw().cast(),
        log: Some(host_log),
        now_ns: Some(host_now_ns),
        get_extension: Some(host_get_extension),
    }));
    // SAFETY: entry has the ABI v1 signature; host lives forever.
    let descriptor = unsafe { entry(host).as_ref() }.ok_or_else(|| {
        refuse(
            path,
            "hapticd_plugin_entry returned no descriptor (the plugin failed to start or refused \
             this host's ABI)",
        )
    })?;
    let (major, minor) = (descriptor.abi_major, descriptor.abi_minor);
    if major != HAPTICD_ABI_MAJOR {
        return Err(refuse(
            path,
            format!(
                "built for plugin ABI {major}.{minor}, but this hapticd speaks ABI \
                 {HAPTICD_ABI_MAJOR}.{HAPTICD_ABI_MINOR}: rebuild it against hapticd-plugin-api \
                 {HAPTICD_ABI_MAJOR}.x"
            ),
        ));
    }
    if minor > HAPTICD_ABI_MINOR {
        tracing::info!(
            "{}: built for plugin ABI {major}.{minor}, newer than this hapticd's \
             {HAPTICD_ABI_MAJOR}.{HAPTICD_ABI_MINOR}: it runs with the services of \
             {HAPTICD_ABI_MAJOR}.{HAPTICD_ABI_MINOR}",
            path.display()
        );
    }
    let text = |ptr: *const c_char, what: &str| {
        if ptr.is_null() {
            return Err(refuse(path, format!("descriptor has no {what}")));
        }
        // SAFETY: the ABI requires a NUL-terminated string valid for the process lifetime.
        unsafe { CStr::from_ptr(ptr) }
            .to_str()
            .map(str::to_owned)
            .map_err(|_| refuse(path, format!("descriptor {what} is not UTF-8")))
    };
    Ok(LoadedPlugin {
        path: path.to_path_buf(),
        name: text(descriptor.name, "name")?,
        version: text(descriptor.version, "version")?,
        description: text(descriptor.description, "description")?,
        abi: (major, minor),
        descriptor,
    })
}

impl LoadedPlugin {
    /// Whether it is a mechanism plugin.
    pub fn is_mechanism(&self) -> bool {
        self.descriptor.kind == HAPTICD_KIND_MECHANISM
    }

    /// Whether it is a scene plugin.
    pub fn is_scene(&self) -> bool {
        self.descriptor.kind == HAPTICD_KIND_SCENE
    }

    /// [main] The scene functions, checked to be complete. Functions a later ABI minor
    /// appended are null when the plugin's vtable is older (shorter).
    pub fn scene_vtable(&self) -> Result<HapticdSceneVtable, PluginError> {
        let path = &self.path;
        if !self.is_scene() {
            return Err(refuse(
                path,
                format!("is a plugin of kind {}, not a scene", self.descriptor.kind),
            ));
        }
        let raw = self.descriptor.scene;
        if raw.is_null() {
            return Err(refuse(path, "scene plugin without a scene vtable"));
        }
        // SAFETY: for kind SCENE the ABI requires a valid vtable of at least its first
        // field, which says how long the whole is.
        let size = unsafe { std::ptr::addr_of!((*raw).struct_size).read() } as usize;
        // The fields of ABI 1.0 and 1.1 end where `poses` (1.2) begins.
        if size < std::mem::offset_of!(HapticdSceneVtable, poses) {
            return Err(refuse(
                path,
                "scene vtable is smaller than ABI 1.0 requires",
            ));
        }
        let mut vtable = HapticdSceneVtable {
            struct_size: 0,
            create: None,
            destroy: None,
            step_direct: None,
            step_physics: None,
            poses: None,
            step_world: None,
            get_extension: None,
        };
        // SAFETY: the plugin's vtable holds `size` bytes; only as many as both have are
        // copied, and a null function pointer is the all-zero `None` the rest keep.
        unsafe {
            std::ptr::copy_nonoverlapping(
                raw.cast::<u8>(),
                std::ptr::addr_of_mut!(vtable).cast::<u8>(),
                size.min(std::mem::size_of::<HapticdSceneVtable>()),
            )
        };
        if vtable.create.is_none() || vtable.destroy.is_none() {
            return Err(refuse(
                path,
                "scene vtable has no create or destroy function",
            ));
        }
        Ok(vtable)
    }

    /// [main] The scene extension `id` this plugin offers whole, copied (None when it
    /// offers none of that name, predates ABI 1.4, or is no scene).
    ///
    /// # Safety
    /// `T` is the ABI's struct of extension `id`, whose first field is its `struct_size`.
    pub unsafe fn scene_extension<T: Copy>(&self, id: &CStr) -> Option<T> {
        let get = self.scene_vtable().ok()?.get_extension?;
        // SAFETY: a NUL-terminated id; the plugin returns null or its extension struct.
        let raw = unsafe { get(id.as_ptr()) }.cast::<T>();
        if raw.is_null() {
            return None;
        }
        // SAFETY: an extension begins with its size (this function's contract).
        let size = unsafe { raw.cast::<u32>().read() } as usize;
        // SAFETY: the plugin's struct holds `size` bytes, checked to cover a whole `T`.
        (size >= std::mem::size_of::<T>()).then(|| unsafe { raw.read() })
    }

    /// [main] Read the mechanism's geometry through its vtable.
    pub fn mechanism_spec(&self) -> Result<MechanismSpec, PluginError> {
        let path = &self.path;
        if !self.is_mechanism() {
            return Err(refuse(
                path,
                format!(
                    "is a plugin of kind {}, not a mechanism",
                    self.descriptor.kind
                ),
            ));
        }
        // SAFETY: for kind MECHANISM the ABI requires a valid vtable pointer or null.
        let vtable = unsafe { self.descriptor.mechanism.as_ref() }
            .ok_or_else(|| refuse(path, "mechanism plugin without a mechanism vtable"))?;
        if (vtable.struct_size as usize) < std::mem::size_of::<HapticdMechanismVtable>() {
            return Err(refuse(
                path,
                "mechanism vtable is smaller than ABI 1.0 requires",
            ));
        }
        let (Some(info_fn), Some(effector_fn), Some(string_fn)) =
            (vtable.info, vtable.effector, vtable.string)
        else {
            return Err(refuse(path, "mechanism vtable has null functions"));
        };
        let check = |status: i32, call: String| match status {
            HAPTICD_OK => Ok(()),
            HAPTICD_ERROR_PANIC => Err(refuse(
                path,
                format!("the plugin panicked in {call}; it is disabled"),
            )),
            other => Err(refuse(path, format!("{call} failed with status {other}"))),
        };
        let mut info = HapticdMechanismInfo {
            effector_count: 0,
            string_count: 0,
            lambda: 0.0,
            torque_weight: 0.0,
        };
        // SAFETY: info writes one HapticdMechanismInfo to a valid pointer.
        check(unsafe { info_fn(&mut info) }, "info()".into())?;
        const LIMIT: u32 = 1024;
        if info.effector_count > LIMIT || info.string_count > LIMIT {
            return Err(refuse(path, "implausible effector or string count"));
        }
        let mut effectors = Vec::with_capacity(info.effector_count as usize);
        for i in 0..info.effector_count {
            let mut e = HapticdEffector::new("", 0);
            // SAFETY: effector writes one HapticdEffector to a valid pointer.
            check(unsafe { effector_fn(i, &mut e) }, format!("effector({i})"))?;
            effectors.push(e);
        }
        let mut strings = Vec::with_capacity(info.string_count as usize);
        for i in 0..info.string_count {
            let mut s = HapticdString {
                effector: 0,
                motor: [0.0; 3],
                knot: [0.0; 3],
                metres_per_pulse: 0.0,
                volts_per_newton: 0.0,
                tension_min: 0.0,
                tension_max: 0.0,
            };
            // SAFETY: string writes one HapticdString to a valid pointer.
            check(unsafe { string_fn(i, &mut s) }, format!("string({i})"))?;
            strings.push(s);
        }
        Ok(MechanismSpec {
            lambda: info.lambda,
            torque_weight: info.torque_weight,
            effectors,
            strings,
        })
    }
}
