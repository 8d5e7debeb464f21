//! Finding a scene by name: a scene plugin (`.so`), a scene file, or the name of a scene in
//! the configured directories. Of a scene file the daemon reads only its engine
//! ([`engine_of`]): static solids it renders itself; any other engine's files run on the scene
//! plugin `libhapticd_scene_ENGINE.so` that declares that engine (the plugin's
//! [`HAPTICD_EXT_SCENE_FILES`] extension), which checks them, too. A file of
//! `engine: remote` is a world on another machine ([`crate::remote_scene`]).

use std::ffi::{CStr, CString, c_char};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use hapticd_core::diagnostics::Diagnostics;
use hapticd_core::haptics::surface::{self, Surfaces};
use hapticd_core::kinematics::{MAX_EFFECTORS, Wrench};
use hapticd_core::scene::engine::{Engine, engine_of};
use hapticd_core::scene::remote::{self, RemoteSceneSpec};
use hapticd_core::scene::static_scene::{StaticScene, StaticSceneSpec};
use hapticd_core::scene::{Pointer, Scene};
use hapticd_ipc::world_link_share::WorldLink;
use hapticd_plugin_api::{HAPTICD_EXT_SCENE_FILES, HAPTICD_OK, HapticdSceneFiles};

use crate::physics_budget::thread_cpu_ns;
use crate::plugin_scene::LoadError;
use crate::shared_scene::{self, Host, WorldThread};
use hapticd_config::plugin;
use hapticd_config::scene_name::{is_name, locate};

/// Why a scene could not be opened.
#[derive(Debug, Clone, PartialEq)]
pub enum OpenError {
    /// No scene of that name or path.
    NotFound(String),
    /// The scene file is malformed: every finding, located in it.
    Invalid(Diagnostics),
    /// A scene plugin refused the file, in its own words, or none runs its engine.
    Refused(String),
    /// A scene plugin could not be loaded or could not start its scene.
    Plugin(LoadError),
    /// The scene loads, but its fastest trial tick took more than half the loop's period.
    TooSlow {
        /// The scene's name.
        scene: String,
        /// Its fastest trial tick.
        tick: Duration,
        /// The loop's rate, Hz.
        rate: f64,
    },
}

impl std::fmt::Display for OpenError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            OpenError::NotFound(m) | OpenError::Refused(m) => f.write_str(m),
            OpenError::Invalid(findings) => findings.fmt(f),
            OpenError::Plugin(e) => e.fmt(f),
            OpenError::TooSlow { scene, tick, rate } => write!(
                f,
                "scene {scene} takes {:.0} µs to compute a tick, more than half of the {:.0} µs \
                 tick at {rate} Hz: give it a longer physics step or run the loop slower",
                tick.as_secs_f64() * 1e6,
                1e6 / rate
            ),
        }
    }
}

impl std::error::Error for OpenError {}

/// Where scenes are found.
#[derive(Debug, Clone, Copy)]
pub struct Places<'a> {
    /// Directories of scene files, searched in order.
    pub dirs: &'a [PathBuf],
    /// Directories of scene plugins, for the engines of physics scene files.
    pub plugin_dirs: &'a [PathBuf],
    /// The device's link to the network bridge, for scenes whose world is on another
    /// machine (none: such scenes are refused).
    pub world_link: Option<&'a Arc<WorldLink>>,
}

/// [main] The scene `name` for `pointers`, to render at `rate` Hz: a scene plugin (`.so`,
/// given `file`), a scene file (a path), or the name of a scene in `places` (searched in
/// order). Static scene files render in the daemon; physics scene files (their `bodies:`
/// say so) run on their engine's plugin. A scene that cannot compute a tick in half of one
/// is refused.
pub fn open(
    name: &str,
    file: Option<&Path>,
    places: Places,
    pointers: &[Pointer],
    rate: f64,
) -> Result<Box<dyn Scene>, OpenError> {
    let mut scene = find(name, file, places, pointers)?;
    fits_tick(scene.as_mut(), pointers, rate)?;
    Ok(scene)
}

/// Ticks a new scene is tried for before it reaches the haptic thread.
const TRIAL_TICKS: usize = 3;

/// Refuse `scene` if its fastest of a few trial ticks, run here off the real-time thread,
/// takes more than half the tick: on the haptic thread it would overrun every tick. A tick
/// is timed by this thread's CPU clock: beside a running loop on a small machine the wall
/// clock counted the time others preempted it (the shipped weight's tick, 118 µs alone,
/// was refused at 632 µs).
fn fits_tick(scene: &mut dyn Scene, pointers: &[Pointer], rate: f64) -> Result<(), OpenError> {
    let period = 1.0 / rate;
    let mut wrenches = vec![Wrench::ZERO; pointers.len()];
    let mut fastest = Duration::MAX;
    for _ in 0..TRIAL_TICKS {
        let started = thread_cpu_ns();
        scene.render(pointers, period, &mut wrenches);
        fastest = fastest.min(Duration::from_nanos(thread_cpu_ns() - started));
    }
    scene.reset(pointers);
    if fastest.as_secs_f64() > 0.5 * period {
        return Err(OpenError::TooSlow {
            scene: scene.name().to_string(),
            tick: fastest,
            rate,
        });
    }
    Ok(())
}

/// The file pictures of scene `name` are drawn from, absolute: the scene file, or for a
/// scene plugin the `file` it is given; None when there is none.
pub fn file_of(name: &str, file: Option<&Path>, dirs: &[PathBuf]) -> Option<PathBuf> {
    let path = locate(name, dirs).ok()?;
    let path = if path.extension().is_some_and(|e| e == "so") {
        file?.to_path_buf()
    } else {
        path
    };
    std::fs::canonicalize(path).ok()
}

/// Longest findings a plugin's check hands back, bytes.
const FINDINGS_CAPACITY: usize = 64 << 10;

/// A scene plugin that runs the scene files of an engine.
struct EnginePlugin {
    path: PathBuf,
    files: HapticdSceneFiles,
}

impl EnginePlugin {
    /// [main] The plugin of `engine` (named in scene file `file`) in the first of
    /// `plugin_dirs` that has one, refused unless it declares the engine.
    fn find(engine: &str, file: &Path, plugin_dirs: &[PathBuf]) -> Result<Self, OpenError> {
        let refused = |why: String| OpenError::Refused(format!("{}: {why}", file.display()));
        if !is_name(engine) {
            return Err(refused(format!("engine {engine:?} is not a name")));
        }
        let path = scene_plugin(engine, plugin_dirs).ok_or_else(|| {
            refused(format!(
                "no scene plugin libhapticd_scene_{engine}.so in {plugin_dirs:?} runs engine \
                 {engine}"
            ))
        })?;
        let loaded = plugin::load(&path).map_err(|e| refused(e.to_string()))?;
        // SAFETY: HapticdSceneFiles is the struct of the files extension.
        let files: Option<HapticdSceneFiles> =
            unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_FILES) };
        let plugin = files
            .map(|files| Self { path, files })
            .filter(|p| p.declares(engine));
        plugin.ok_or_else(|| {
            refused(format!(
                "{}: declares no engine {engine} (its scene-files extension lists none)",
                loaded.path.display()
            ))
        })
    }

    /// Whether the plugin declares `engine` among its `engine:` values.
    fn declares(&self, engine: &str) -> bool {
        let Some(name_of) = self.files.engine else {
            return false;
        };
        // A plugin's list is short; the bound keeps a broken one from looping forever.
        (0..64)
            // SAFETY: any index may be asked; the plugin answers null or a name it keeps.
            .map(|k| unsafe { name_of(k) })
            .take_while(|name| !name.is_null())
            .any(|name| {
                // SAFETY: non-null, NUL-terminated and valid for the process' life (the ABI).
                unsafe { CStr::from_ptr(name) }.to_bytes() == engine.as_bytes()
            })
    }

    /// [main] The plugin's findings about the scene file `file` for `pointers` pointers.
    fn check(&self, file: &Path, pointers: usize) -> Result<(), OpenError> {
        let Some(check) = self.files.check else {
            return Ok(());
        };
        let path = CString::new(file.as_os_str().as_encoded_bytes())
            .map_err(|_| OpenError::Plugin(LoadError::NulInPath))?;
        let mut findings = vec![0 as c_char; FINDINGS_CAPACITY];
        // SAFETY: a NUL-terminated path and a buffer of the capacity given.
        let status = unsafe {
            check(
                path.as_ptr(),
                pointers as u32,
                findings.as_mut_ptr(),
                findings.len(),
            )
        };
        if status == HAPTICD_OK {
            return Ok(());
        }
        // SAFETY: c_char and u8 have one layout; the plugin NUL-terminates within the buffer.
        let bytes: &[u8] =
            unsafe { std::slice::from_raw_parts(findings.as_ptr().cast(), findings.len()) };
        let text = CStr::from_bytes_until_nul(bytes)
            .map(|t| t.to_string_lossy().into_owned())
            .unwrap_or_default();
        Err(OpenError::Refused(if text.is_empty() {
            format!(
                "{}: refused by {} (status {status})",
                file.display(),
                self.path.display()
            )
        } else {
            text
        }))
    }
}

/// The scene plugin called `name` (`libhapticd_scene_NAME.so`) in the first of
/// `plugin_dirs` that has it.
pub(crate) fn scene_plugin(name: &str, plugin_dirs: &[PathBuf]) -> Option<PathBuf> {
    let file = format!("libhapticd_scene_{}.so", name.replace('-', "_"));
    plugin_dirs
        .iter()
        .map(|d| d.join(&file))
        .find(|p| p.exists())
}

/// What a scene name comes to.
enum Resolved {
    /// A scene plugin, with the scene file it runs if any (checked by it), and the file's
    /// surface materials (a physics scene file's; none for a plugin's own format).
    Plugin(PathBuf, Option<PathBuf>, Surfaces),
    /// A static scene file, rendered by the daemon.
    Static(PathBuf),
    /// A world on another machine.
    Remote(PathBuf),
}

/// [main] What scene `name` (a plugin given `file`) is, for `pointers` pointers.
fn resolve(
    name: &str,
    file: Option<&Path>,
    places: Places,
    pointers: usize,
) -> Result<Resolved, OpenError> {
    let path = match locate(name, places.dirs) {
        Ok(path) => path,
        // A name that is no scene file may be a scene plugin's.
        Err(why) if is_name(name) => scene_plugin(name, places.plugin_dirs).ok_or_else(|| {
            OpenError::NotFound(format!(
                "{why}, nor a scene plugin libhapticd_scene_{name}.so in {:?}",
                places.plugin_dirs
            ))
        })?,
        Err(why) => return Err(OpenError::NotFound(why.to_string())),
    };
    if path.extension().is_some_and(|e| e == "so") {
        return Ok(Resolved::Plugin(
            path,
            file.map(Path::to_path_buf),
            Surfaces::default(),
        ));
    }
    let engine = engine_of(&path).map_err(OpenError::Invalid)?;
    if engine == Engine::Plugin(remote::ENGINE.into()) {
        return Ok(Resolved::Remote(path));
    }
    let Engine::Plugin(engine) = engine else {
        return Ok(Resolved::Static(path));
    };
    let runner = EnginePlugin::find(&engine, &path, places.plugin_dirs)?;
    // Checked first, so that mistakes come back with their places.
    runner.check(&path, pointers)?;
    let surfaces = surface::listed_in(&path, &hapticd_mesh::height_map::height_map)
        .map_err(OpenError::Invalid)?;
    Ok(Resolved::Plugin(runner.path, Some(path), surfaces))
}

fn find(
    name: &str,
    file: Option<&Path>,
    places: Places,
    pointers: &[Pointer],
) -> Result<Box<dyn Scene>, OpenError> {
    match resolve(name, file, places, pointers.len())? {
        Resolved::Plugin(plugin, file, surfaces) => {
            let mut scene = crate::plugin_scene::load(&plugin, file.as_deref(), pointers)
                .map_err(OpenError::Plugin)?;
            scene.set_surfaces(surfaces);
            Ok(scene)
        }
        Resolved::Remote(path) => open_remote(&path, places, pointers),
        Resolved::Static(path) => {
            let spec = StaticSceneSpec::load_with_files(&path, hapticd_mesh::scene_files())
                .map_err(OpenError::Invalid)?;
            Ok(Box::new(StaticScene::new(spec, pointers)))
        }
    }
}

/// Whether several devices share one world.
pub enum Sharing {
    /// They do: each device's scene, in order, and the thread stepping their world.
    Shared {
        /// Each device's scene.
        scenes: Vec<Box<dyn Scene>>,
        /// The world's thread.
        world: WorldThread,
    },
    /// Each renders a scene of its own, for this reason.
    Apart(String),
}

/// [main] Scene `name` (a plugin given `file`) as one world for every device of `hosts`,
/// when it is a multi-rate world with room for all their grips: a world stepped in each
/// device's haptic tick cannot be shared between haptic threads.
pub fn open_shared(
    name: &str,
    file: Option<&Path>,
    places: Places,
    hosts: &[Host],
) -> Result<Sharing, OpenError> {
    let pointers: usize = hosts.iter().map(|h| h.pointers.len()).sum();
    if pointers > MAX_EFFECTORS {
        return Ok(Sharing::Apart(format!(
            "the devices' {pointers} grips are more than a scene's {MAX_EFFECTORS}"
        )));
    }
    let Resolved::Plugin(plugin, file, surfaces) = resolve(name, file, places, pointers)? else {
        return Ok(Sharing::Apart(
            "it is no physics scene (a static or remote one)".into(),
        ));
    };
    let world = crate::plugin_scene::load_world(&plugin, file.as_deref(), pointers)
        .map_err(OpenError::Plugin)?;
    let Some(world) = world else {
        return Ok(Sharing::Apart(
            "its world is stepped in the haptic tick (a penalty one, or a direct plugin), which \
             one device's haptic thread cannot share with another's; a multi-rate scene \
             (engine: rapier) can be shared"
                .into(),
        ));
    };
    let (mut scenes, world) = shared_scene::start(world, hosts)
        .map_err(|e| OpenError::Refused(format!("{name}: cannot start its world's thread: {e}")))?;
    for (scene, host) in scenes.iter_mut().zip(hosts) {
        scene.set_surfaces(surfaces.clone());
        fits_tick(scene.as_mut(), host.pointers, host.rate)?;
    }
    Ok(Sharing::Shared { scenes, world })
}

/// The scene of remote scene file `path`: a world on another machine, through the device's
/// link to the bridge.
fn open_remote(
    path: &Path,
    places: Places,
    pointers: &[Pointer],
) -> Result<Box<dyn Scene>, OpenError> {
    let text = hapticd_core::diagnostics::read_text(path).map_err(OpenError::Invalid)?;
    let spec = RemoteSceneSpec::parse(&text, path).map_err(OpenError::Invalid)?;
    let link = places.world_link.ok_or_else(|| {
        OpenError::Refused(format!(
            "{}: its world is on another machine, and this device has no link to the network \
             bridge (see the log)",
            path.display()
        ))
    })?;
    let name = path
        .file_stem()
        .map_or("remote".into(), |s| s.to_string_lossy().into_owned());
    crate::remote_scene::open(name, &spec, link.clone(), pointers).map_err(|e| {
        OpenError::Refused(format!("{}: cannot start its thread: {e}", path.display()))
    })
}
