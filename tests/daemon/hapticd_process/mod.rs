//! `hapticd` as a process on the simulated SPIDAR-G: it runs for a set time, records, stops
//! on SIGTERM with zero currents as the last bytes written, replays a recording exactly,
//! refuses a bad configuration with its place, and its haptic thread makes no system call
//! but its sleep.

use crate::support;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use hapticd_device::replay::{Direction, Recording};
use hapticd_device::sh4;
use support::daemon::Isolated;
use support::{plugin_path, repo_dir, scratch_root, shipped};

mod faults;
mod haptic_thread;
mod runs;
mod scenes;

/// The plugins staged as an install would have them.
fn mechanisms() -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = scratch_root().join(format!("hapticd-process-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for plugin in ["hapticd-spidar-g", "hapticd-spidar-ii"] {
            let from = plugin_path(plugin);
            std::fs::copy(&from, dir.join(from.file_name().unwrap())).unwrap();
        }
        dir
    })
    .clone()
}

fn static_scene() -> PathBuf {
    repo_dir().join("config/scenes/static.yaml")
}

/// A private bus and a configuration of test `name`'s own for its hapticd.
fn on_bus(name: &str) -> Isolated {
    Isolated::on_private_bus(&scratch_file(&format!("{name}.daemon")), &mechanisms())
}

fn hapticd(at: &Isolated, args: &[&str]) -> Command {
    hapticd_with_scene(at, &static_scene(), args)
}

fn hapticd_with_scene(at: &Isolated, scene: &Path, args: &[&str]) -> Command {
    let mut c = at.hapticd(&["--scene", scene.to_str().unwrap()]);
    c.args(args).stdout(Stdio::piped()).stderr(Stdio::piped());
    c
}

/// A file of this process's called `name`, in cargo's scratch directory.
fn scratch_file(name: &str) -> PathBuf {
    scratch_root().join(format!("{}-{name}", std::process::id()))
}

fn press() -> String {
    repo_dir()
        .join("config/hands/press-floor.yaml")
        .display()
        .to_string()
}

/// Run hapticd to the end on the simulated SPIDAR-G on a bus of its own, touching `scene`,
/// with the hand pressing on the floor for `seconds`, recording to `csv`, plus `extra`
/// arguments.
fn pressed(scene: &Path, seconds: &str, csv: &Path, extra: &[&str]) -> Output {
    handled(scene, Path::new(&press()), seconds, csv, extra)
}

/// Run hapticd to the end on the simulated SPIDAR-G on a bus of its own, touching `scene`,
/// with the hand script `hand` moving the grip for `seconds`, recording to `csv`, plus
/// `extra` arguments.
fn handled(scene: &Path, hand: &Path, seconds: &str, csv: &Path, extra: &[&str]) -> Output {
    let hand = hand.to_str().unwrap();
    let mut args = vec!["--sim", "spidar-g", "--hand", hand, "--duration", seconds];
    args.extend(["--record", csv.to_str().unwrap()]);
    args.extend(extra);
    let at = on_bus(csv.file_name().unwrap().to_str().unwrap());
    finish(hapticd_with_scene(&at, scene, &args).spawn().unwrap())
}

fn finish(child: Child) -> Output {
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "hapticd failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The named columns of a recording, row by row.
fn columns(path: &Path, names: &[&str]) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let index: Vec<usize> = names
        .iter()
        .map(|n| header.iter().position(|h| h == n).unwrap())
        .collect();
    lines
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            index.iter().map(|&c| v[c].to_string()).collect()
        })
        .collect()
}

/// CSV rows as (time, grip y, force y).
fn recorded(path: &Path) -> Vec<(f64, f64, f64)> {
    columns(path, &["time", "pose_y", "force_y"])
        .iter()
        .map(|r| {
            (
                r[0].parse().unwrap(),
                r[1].parse().unwrap(),
                r[2].parse().unwrap(),
            )
        })
        .collect()
}
