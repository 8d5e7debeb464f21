//! Shared helpers of the end-to-end tests: where the built artifacts are, the shipped
//! mechanisms, and a small deterministic random generator.

#![allow(dead_code)] // each test binary uses its own subset

pub mod amplifier;
pub mod ball_mesh;
pub mod bus;
pub mod daemon;
pub mod haptic_cpu;
pub mod netns;
pub mod pile;
pub mod qp;
pub mod relay;
pub mod rng;

pub use rng::Rng;

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::DQuat;
use hapticctl::experiments::Session;
use hapticd_config::catalog;
use hapticd_core::haptic_loop::{HapticLoop, LoopSettings};
use hapticd_core::kinematics::Pose;
use hapticd_core::mechanism::Mechanism;
use hapticd_core::scene::static_scene::StaticSceneSpec;
use hapticd_core::solver::closure::is_force_closed;
use hapticd_core::solver::geometry::StringGeometry;
use hapticd_device::sim::hand::Script;

/// The cargo profile directory the tests were built into (target/debug or target/release).
pub fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/<test binary>
    exe.parent()
        .and_then(Path::parent)
        .expect("test binary lives in target/<profile>/deps")
        .to_path_buf()
}

/// A built artifact of the workspace; fails with advice when it was not built.
pub fn artifact(file: &str) -> PathBuf {
    let path = profile_dir().join(file);
    assert!(
        path.exists(),
        "{} is missing: build the workspace first (cargo build --workspace{})",
        path.display(),
        if cfg!(debug_assertions) {
            ""
        } else {
            " --release"
        }
    );
    path
}

/// A child process killed (and reaped) when dropped.
pub struct Killed(pub std::process::Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A Zenoh endpoint on the loopback at a port free a moment ago, and the port.
pub fn loopback_endpoint() -> (String, u16) {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    (format!("tcp/127.0.0.1:{port}"), port)
}

/// A 10 cm block of 1 kg on a floor, its top at y = 0.05 and its edges at x = ±0.05, in
/// rapier's world stepped at 10 Hz: a finger slid off its top shows whether the haptic side
/// touches the block itself or the last step's plane.
pub const BLOCK_AT_10_HZ: &str = "name: edge
engine: rapier
rate: 10
gravity: [0, -9.81, 0]
material: { static_friction: 0.5, friction: 0.5 }
bodies:
  - { name: floor, box: [0.3, 0.02, 0.3], position: [0, -0.06, 0], fixed: true }
  - { name: block, box: [0.1, 0.1, 0.1], position: [0, 0, 0], density: 1000 }
pointer:
  sphere: 0.005
";

/// The repository root.
pub fn repo_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ sits in the repository")
        .to_path_buf()
}

/// The shared library of the Rust mechanism plugin crate `crate_name`.
pub fn plugin_path(crate_name: &str) -> PathBuf {
    artifact(&format!("lib{}.so", crate_name.replace('-', "_")))
}

/// The shipped mechanisms: the three plugins and the YAML-only example.
pub fn shipped_mechanisms() -> Vec<Mechanism> {
    let mut paths: Vec<PathBuf> = ["hapticd-spidar", "hapticd-spidar-g", "hapticd-spidar-ii"]
        .iter()
        .map(|c| plugin_path(c))
        .collect();
    paths.push(repo_dir().join("config/mechanisms/spidar-6s.yaml"));
    paths
        .iter()
        .map(|p| catalog::load(p).unwrap_or_else(|e| panic!("{e}")))
        .collect()
}

/// One shipped mechanism by name.
pub fn shipped(name: &str) -> Mechanism {
    shipped_mechanisms()
        .into_iter()
        .find(|m| m.name == name)
        .unwrap_or_else(|| panic!("no shipped mechanism {name}"))
}

/// `hapticctl` as built, its meshes' convex pieces kept in [`mesh_cache`].
pub fn hapticctl() -> Command {
    let mut command = Command::new(artifact("hapticctl"));
    command
        .env_remove("HAPTICD_MECHANISM_PATH")
        .env("CACHE_DIRECTORY", mesh_cache());
    command
}

/// Where tests keep meshes' convex pieces (`$CACHE_DIRECTORY` of what they start): in the
/// build tree, never the user's own cache, and shared so that each mesh is cut once.
pub fn mesh_cache() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("mesh-cache")
}

/// A directory holding `package` from PyPI and what it needs, for `/usr/bin/python3`'s
/// `PYTHONPATH`: installed once (by pip, into the test's own target directory) and kept.
pub fn python_package(package: &str) -> PathBuf {
    static INSTALLING: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = INSTALLING.lock().unwrap_or_else(|p| p.into_inner());
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("python-{package}"));
    if dir.join(".installed").exists() {
        return dir;
    }
    let _ = std::fs::remove_dir_all(&dir);
    let out = Command::new("/usr/bin/python3")
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "--target",
        ])
        .arg(&dir)
        .arg(package)
        .output()
        .expect("python3-pip is installed by `make deps`");
    assert!(out.status.success(), "pip install {package}: {out:?}");
    std::fs::write(dir.join(".installed"), "").unwrap();
    dir
}

/// Half the extent of the frame: the largest motor coordinate of effector `index`.
pub fn frame_half(m: &Mechanism, index: usize) -> f64 {
    m.kinematics(index)
        .motors()
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0, f64::max)
}

/// A random pose of effector `index` inside its complete region (or, for a mechanism that
/// is never force-closed, near its calibration pose).
pub fn pose_inside(m: &Mechanism, index: usize, rng: &mut Rng) -> Pose {
    let effector = &m.effectors[index];
    let kinematics = m.kinematics(index);
    let half = frame_half(m, index);
    let six = effector.dof.count() == 6;
    let closable = effector.strings.len() > effector.dof.count();
    loop {
        let reach = if closable { 0.6 * half } else { 0.1 * half };
        let pose = Pose {
            position: effector.calibration.position + rng.cube(reach),
            orientation: if six {
                rng.rotation(0.3) * effector.calibration.orientation
            } else {
                DQuat::IDENTITY
            },
        };
        let geometry = StringGeometry::at(&kinematics, &pose);
        let slack = geometry.lengths().iter().all(|&l| l > 0.01);
        if slack && (!closable || is_force_closed(&geometry)) {
            return pose;
        }
    }
}

/// `out` of a program that must have succeeded; fails the test with its standard error.
pub fn succeeded(out: std::process::Output) -> std::process::Output {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Whether the tests run as root (needed to act as an unprivileged user).
pub fn is_root() -> bool {
    nix::unistd::geteuid().is_root()
}

/// A fresh scratch directory `hapticd-KIND-PID-NAME` under the system's temporary directory
/// that others may enter (an unprivileged client must reach a bus socket in it).
pub fn shared_scratch(kind: &str, name: &str) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let dir = std::env::temp_dir().join(format!("hapticd-{kind}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
    dir
}

/// This process's scratch directory `hapticd-KIND-PID-NAME` for a test's files, in cargo's
/// scratch directory; created when missing (tests running side by side may share one), mode
/// 0755 as the plugin loader requires of any directory a plugin lies in.
pub fn scratch(kind: &str, name: &str) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let dir = scratch_root().join(format!("hapticd-{kind}-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
    dir
}

/// Where tests may create files: cargo's per-target scratch directory, inside target/.
pub fn scratch_root() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
}

/// A scratch directory `name` of this process holding the repository's mesh file `mesh` as
/// `file`, as a user keeps a model beside the scene file that names it.
pub fn dir_with_mesh(name: &str, mesh: &str, file: &str) -> PathBuf {
    let dir = scratch_root().join(format!("{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::copy(repo_dir().join(mesh), dir.join(file)).unwrap();
    dir
}

/// The haptic loop of `m` on a simulated board whose hands follow `script`, rendering the
/// shipped static scene, ticking every `dt` seconds.
pub fn simulated_loop(m: &Mechanism, script: &str, dt: f64) -> HapticLoop {
    Session {
        mechanism: m.clone(),
        scene: StaticSceneSpec::load(&repo_dir().join("config/scenes/static.yaml")).unwrap(),
        script: Script::parse(script, std::path::Path::new("hand.yaml")).unwrap(),
        rate: 1.0 / dt,
        settings: LoopSettings::default(),
    }
    .haptic_loop()
    .expect("a mechanism one board drives")
}
