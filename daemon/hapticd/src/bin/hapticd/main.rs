//! `hapticd`: the haptics daemon. Runs the haptic loop of a SPIDAR in real time; with no
//! hardware (or with `--sim`) it drives the simulated SPIDAR.

mod device;
mod events;
mod recording;
mod saved;
mod signals;
mod supervisor;
mod transport;

use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::Parser;
use hapticd::bus;
use hapticd::control::{self, Daemon};
use hapticd::scenes::{self, Sharing};
use hapticd::shared_scene::{Host, WorldThread};
use hapticd::state::StateDir;
use hapticd_config::Config;
use hapticd_config::file::DeviceConfig;
use hapticd_config::layout::Layout;
use hapticd_core::scene::Scene;
use hapticd_device::guardian::{self, Guardian};
use hapticd_device::hotplug::Arrivals;
use hapticd_device::sim::hand::Script;
use hapticd_device::usb::find_devices;
use hapticd_ipc::bus::Bus;
use hapticd_service::cli::Cli;
use hapticd_service::cpus::Plan;
use hapticd_service::sd_notify;

use device::{Common, Device, Recording};
use supervisor::{Ending, Supervisor};
use transport::{Kind, Simulated};

/// Set when the daemon stops: the logging and recording threads finish then.
static DONE: AtomicBool = AtomicBool::new(false);

/// The daemon from its command line to its end: the configuration, the bus name, the
/// guardian and the devices, each before the next (see each step for why), then the service
/// and the supervisor until a signal, a restart or the `--duration`.
fn run(cli: Cli) -> Result<Ending, String> {
    let (config, config_path) = configuration(&cli)?;
    let mechanism_dirs = (!cli.mechanism_dirs.is_empty()).then(|| cli.mechanism_dirs.clone());
    let catalog = control::catalog(&config, mechanism_dirs.as_deref());
    // One look through the mechanism directories serves every device and the bus.
    let entries = catalog.entries();
    let claim = claim_bus(&cli)?;
    // Before any amplifier is opened too: whatever ends this process from here on, the
    // guardian zeroes what it drove.
    let guardian = Guardian::spawn()
        .map_err(|e| format!("cannot start the guardian that zeroes the motors: {e}"))?;
    let (kinds, arrivals) = devices_present(&cli, &config)?;
    let state_dir = state_dir(&cli);
    let _cpu_latency = keep_resident();
    signals::install()?;
    let common = Common {
        config: &config,
        catalog: &catalog,
        entries: &entries,
        rate: cli.rate,
        scene: cli.scene.as_deref().unwrap_or(&config.scene),
        scene_file: cli.scene_file.as_deref(),
        state_dir: state_dir.as_ref(),
        done: &DONE,
        guardian: &guardian,
    };
    let (mut devices, world) = start_devices(kinds, &common, &cli)?;
    let driven: Vec<String> = devices
        .iter()
        .map(|d| d.handle.identity().to_string())
        .collect();
    let scene_file = scenes::file_of(
        cli.scene.as_deref().unwrap_or(&config.scene),
        cli.scene_file.as_deref(),
        &config.scene_dirs,
    );
    let daemon = Arc::new(Daemon::new(
        config,
        (config_path, mechanism_dirs),
        &entries,
        (devices[0].scene.clone(), scene_file),
        devices.iter().map(|d| d.handle.clone()).collect(),
    ));
    let service = match claim.map(|c| c.serve(daemon.clone())).transpose() {
        Ok(service) => service,
        Err(e) => {
            let _ = stop_all(devices, &guardian);
            drop(world);
            return Err(e.to_string());
        }
    };
    tracing::info!("ready: driving {}", driven.join(", "));
    let _ = sd_notify::notify(&format!("READY=1\nSTATUS=driving {}", driven.join(", ")));
    let ending = Supervisor {
        devices: &mut devices,
        daemon,
        arrivals,
        duration: cli.duration,
        guardian: &guardian,
    }
    .run();
    // A restart is, to systemd, a reload: the new image says READY=1 again.
    let _ = sd_notify::notify(match ending {
        Ending::Done => "STOPPING=1",
        Ending::Restart => "RELOADING=1",
    });
    drop(service);
    stop_all(devices, &guardian)?;
    drop(world);
    if signals::OVERTIME.load(Ordering::Acquire) {
        return Err(
            "the haptic thread ran past LimitRTTIME= without sleeping (SIGXCPU): motors zeroed, \
             exiting for a restart"
                .into(),
        );
    }
    Ok(ending)
}

/// The configuration `--config` names, else the installed file if there is one, else the
/// defaults; and the file it came from.
fn configuration(cli: &Cli) -> Result<(Config, Option<PathBuf>), String> {
    let path = cli.config.clone().or_else(|| {
        let default = Layout::of_this_program().config_file();
        default.exists().then_some(default)
    });
    let config = match &path {
        Some(path) => Config::load(path)?,
        None => Config::default(),
    };
    Ok((config, path))
}

/// The bus name, owned before any amplifier is opened: a second hapticd learns here that the
/// name is taken, not after it has pulled on a string the first one drives. Without a bus
/// hapticd runs, unless a bus was asked for.
fn claim_bus(cli: &Cli) -> Result<Option<bus::Claim>, String> {
    match (&cli.bus, bus::claim(cli.bus.clone().unwrap_or(Bus::System))) {
        (_, Ok(claim)) => Ok(Some(claim)),
        // Another hapticd serves this bus: refuse, whichever bus was meant.
        (_, Err(e @ bus::ServeError::NameTaken(_))) | (Some(_), Err(e)) => Err(e.to_string()),
        (None, Err(e)) => {
            tracing::warn!("{e}; running without the D-Bus interface");
            Ok(None)
        }
    }
}

/// The devices to drive: the simulators `--sim` asks for; else the configuration's
/// `devices`; else every amplifier plugged in (in bus order, so that device 0 is the same
/// amplifier at every start), or the simulated SPIDAR when there is none; and, when
/// amplifiers are looked for, what tells later arrivals.
fn devices_present(cli: &Cli, config: &Config) -> Result<(Vec<Kind>, Option<Arrivals>), String> {
    if let Some(path) = &cli.replay {
        return Ok((vec![Kind::Replay(path.clone())], None));
    }
    let wanted: Vec<DeviceConfig> = match (&cli.sim[..], &config.devices[..]) {
        ([], []) => vec![DeviceConfig {
            usb: Some("all".into()),
            ..DeviceConfig::default()
        }],
        ([], listed) => listed.to_vec(),
        (sims, _) => sims
            .iter()
            .enumerate()
            .map(|(k, sim)| DeviceConfig {
                sim: Some(sim.clone()),
                hand: cli.hand.get(k).or(cli.hand.first()).cloned(),
                ..DeviceConfig::default()
            })
            .collect(),
    };
    let hardware = wanted.iter().any(|d| d.usb.is_some());
    let mut kinds: Vec<Kind> = match hardware {
        true => plugged_in(),
        false => Vec::new(),
    };
    // What is on the bus now is what hapticd could use: only later arrivals are news.
    let arrivals = hardware.then(|| Arrivals::new(kinds.iter().map(Kind::identity).collect()));
    let defaulted = cli.sim.is_empty() && config.devices.is_empty();
    let mut names: Vec<String> = wanted.iter().filter_map(|d| d.name.clone()).collect();
    for device in &wanted {
        let Some(sim) = &device.sim else { continue };
        let hand = match device.hand.as_ref().or(config.simulator.hand.as_ref()) {
            Some(path) => Script::load(path)?,
            None => Script::default(),
        };
        let name = device
            .name
            .clone()
            .unwrap_or_else(|| simulator_name(sim, &names));
        names.push(name.clone());
        kinds.push(Kind::Simulator(Simulated {
            name,
            mechanism: Some(sim.clone()),
            hand,
        }));
    }
    if kinds.is_empty() {
        if !defaulted {
            tracing::warn!("no amplifier plugged in: simulating until one is");
        }
        let mechanism = &config.simulator.mechanism;
        let hand = match cli.hand.first().or(config.simulator.hand.as_ref()) {
            Some(path) => Script::load(path)?,
            None => Script::default(),
        };
        kinds.push(Kind::Simulator(Simulated {
            name: simulator_name(mechanism, &[]),
            mechanism: None,
            hand,
        }));
    }
    Ok((kinds, arrivals))
}

/// Every amplifier plugged in, in bus order.
fn plugged_in() -> Vec<Kind> {
    match find_devices() {
        Ok((mut found, problems)) => {
            for p in problems {
                tracing::warn!("{p}");
            }
            found.sort_by(|a, b| a.identity.cmp(&b.identity));
            found.into_iter().map(Kind::Usb).collect()
        }
        Err(e) => {
            tracing::warn!("{e}: no USB devices, simulating");
            Vec::new()
        }
    }
}

/// The name of a simulator of `mechanism`: `sim-<mechanism>-<n>`, the lowest `n` from 1 that
/// none of `taken` has. A mechanism given by path is named by its file.
fn simulator_name(mechanism: &str, taken: &[String]) -> String {
    let stem = Path::new(mechanism)
        .file_stem()
        .map_or(mechanism.into(), |s| s.to_string_lossy());
    let word: String = stem
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    (1..)
        .map(|n| format!("sim-{word}-{n}"))
        .find(|name| !taken.contains(name))
        .expect("some number is free")
}

/// Where calibration and parameters are kept: `--state-dir`, else systemd's
/// `$STATE_DIRECTORY`; without one, changes do not survive a restart.
fn state_dir(cli: &Cli) -> Option<StateDir> {
    let dir = cli
        .state_dir
        .clone()
        .map(StateDir::new)
        .or_else(StateDir::from_env);
    if dir.is_none() {
        tracing::warn!(
            "no state directory (--state-dir or $STATE_DIRECTORY): calibration and parameter changes will not survive a restart"
        );
    }
    dir
}

/// Lock the process' memory before the loops are built, so that nothing they touch is ever
/// paged out, and hold the CPUs out of deep idle states while the returned guard lives.
fn keep_resident() -> Option<std::fs::File> {
    // SAFETY: mlockall takes no pointers.
    if unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) } != 0 {
        tracing::warn!(
            "cannot lock memory ({}); page faults may delay the haptic loop (raise LimitMEMLOCK=)",
            std::io::Error::last_os_error()
        );
    }
    hapticd::realtime::hold_low_cpu_latency().or_else(|| {
        tracing::warn!(
            "cannot hold /dev/cpu_dma_latency at 0: deep CPU idle states may delay wake-ups"
        );
        None
    })
}

/// Start a loop for each of `kinds`, each haptic thread on a CPU of its own when there are
/// enough, all in one world when their scene can be shared; the recordings are of the first
/// device. One device that cannot start leaves the others running; with none, hapticd fails.
/// Returns the thread of the world they share, if they do.
fn start_devices(
    kinds: Vec<Kind>,
    common: &Common,
    cli: &Cli,
) -> Result<(Vec<Device>, Option<WorldThread>), String> {
    let (mut prepared, mut failures) = (Vec::new(), Vec::new());
    for kind in kinds {
        let identity = kind.identity();
        match device::prepare(kind, common) {
            Ok(device) => prepared.push(device),
            Err(e) => failures.push((identity, e)),
        }
    }
    let plan = cpu_plan(prepared.len());
    let (mut scenes, world) = shared_world(&prepared, common);
    let mut devices = Vec::new();
    for (index, device) in prepared.into_iter().enumerate() {
        let recording = match index {
            0 => Recording {
                frames: cli.record.as_deref(),
                traffic: cli.record_traffic.as_deref(),
            },
            _ => Recording::default(),
        };
        let identity = device.identity().to_string();
        let cpu = plan
            .as_ref()
            .map(|p| (p.haptic[index], !p.shared_with_others()));
        let scene = scenes.as_mut().map(|s| s.remove(0));
        match device::start(device, index as u32, common, recording, cpu, scene) {
            Ok(started) => devices.push(started),
            Err(e) => failures.push((identity, e)),
        }
    }
    if devices.is_empty() {
        let why: Vec<String> = failures.into_iter().map(|(_, e)| e).collect();
        return Err(why.join("\n"));
    }
    for (identity, e) in failures {
        tracing::error!("{identity} is not driven: {e}");
    }
    Ok((devices, world))
}

/// Where the haptic threads of `devices` devices run, the daemon's other threads kept off
/// their CPUs; said when they cannot each have one.
fn cpu_plan(devices: usize) -> Option<Plan> {
    let allowed = hapticd_service::cpus::allowed().ok()?;
    let plan = Plan::new(&allowed, devices);
    match &plan {
        Some(plan) if plan.shared_with_others() => tracing::warn!(
            "{devices} haptic threads on {} CPUs: each has a CPU of its own, which the \
             daemon's other threads share",
            allowed.len()
        ),
        Some(_) => {}
        None if devices > 1 => tracing::warn!(
            "{devices} haptic threads on {} CPUs: they share CPUs, and each delays the others' \
             wake-ups",
            allowed.len()
        ),
        None => {}
    }
    if let Some(plan) = &plan
        && let Err(e) = plan.keep_daemon_off()
    {
        tracing::warn!("cannot keep the daemon's threads off the haptic CPUs: {e}");
    }
    plan
}

/// The scene of every device of `devices` when they are several and their scene can be one
/// world for them all (the scenes in device order, and the world's thread); None when each
/// renders a scene of its own (said why).
fn shared_world(
    devices: &[device::Prepared],
    common: &Common,
) -> (Option<Vec<Box<dyn Scene>>>, Option<WorldThread>) {
    if devices.len() < 2 {
        return (None, None);
    }
    let hosts: Vec<Host> = devices
        .iter()
        .map(|d| Host {
            name: d.identity(),
            pointers: &d.pointers,
            rate: d.rate,
        })
        .collect();
    let places = scenes::Places {
        dirs: &common.config.scene_dirs,
        plugin_dirs: &common.config.scene_plugin_dirs,
        world_link: None,
    };
    match scenes::open_shared(common.scene, common.scene_file, places, &hosts) {
        Ok(Sharing::Shared { scenes, world }) => {
            tracing::info!(
                "{} devices share one world of scene {}",
                devices.len(),
                common.scene
            );
            (Some(scenes), Some(world))
        }
        Ok(Sharing::Apart(why)) => {
            tracing::info!(
                "each device renders a scene {} of its own: {why}",
                common.scene
            );
            (None, None)
        }
        Err(e) => {
            tracing::warn!("the devices cannot share scene {}: {e}", common.scene);
            (None, None)
        }
    }
}

/// Stop every loop (each writes zero currents first), tell the guardian the motors are at
/// zero, then let the loops' threads finish.
fn stop_all(devices: Vec<Device>, guardian: &Guardian) -> Result<(), String> {
    let stopped: Vec<_> = devices.into_iter().map(Device::stop).collect();
    guardian.disarm();
    DONE.store(true, Ordering::Release);
    stopped.into_iter().try_for_each(|d| d.finish())
}

fn main() -> ExitCode {
    if guardian::is_guardian() {
        return guardian::run();
    }
    let cli = Cli::parse();
    hapticd_service::logging::init("hapticd", hapticd_service::logging::Level::INFO);
    match run(cli) {
        Ok(Ending::Done) => ExitCode::SUCCESS,
        Ok(Ending::Restart) => {
            // The same program with the same arguments, in the same process (systemd keeps
            // following it; the bus name is taken again by the new image).
            let error = std::process::Command::new("/proc/self/exe")
                .arg0(std::env::args_os().next().unwrap_or_default())
                .args(std::env::args_os().skip(1))
                .exec();
            tracing::error!("cannot start again: {error}");
            ExitCode::FAILURE
        }
        Err(message) => {
            tracing::error!("{message}");
            ExitCode::FAILURE
        }
    }
}
