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
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::Parser;
use hapticd::bus;
use hapticd::control::{self, Daemon};
use hapticd::scenes;
use hapticd::state::StateDir;
use hapticd_config::Config;
use hapticd_config::layout::Layout;
use hapticd_device::guardian::{self, Guardian};
use hapticd_device::hotplug::Arrivals;
use hapticd_device::sim::hand::Script;
use hapticd_device::usb::find_devices;
use hapticd_ipc::bus::Bus;
use hapticd_service::cli::Cli;
use hapticd_service::sd_notify;

use device::{Common, Device, Recording};
use supervisor::{Ending, Supervisor};
use transport::Kind;

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
    let (kinds, arrivals) = devices_present(&cli);
    let script = match cli.hand.as_ref().or(config.simulator.hand.as_ref()) {
        Some(path) => Script::load(path)?,
        None => Script::default(),
    };
    let state_dir = state_dir(&cli);
    let _cpu_latency = keep_resident();
    signals::install()?;
    let common = Common {
        config: &config,
        catalog: &catalog,
        entries: &entries,
        sim: cli.sim.as_deref(),
        rate: cli.rate,
        scene: cli.scene.as_deref().unwrap_or(&config.scene),
        scene_file: cli.scene_file.as_deref(),
        script: &script,
        state_dir: state_dir.as_ref(),
        done: &DONE,
        guardian: &guardian,
    };
    let mut devices = start_devices(kinds, &common, &cli)?;
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

/// The devices to drive: every amplifier plugged in (in bus order, so that device 0 is the
/// same amplifier at every start) unless told to simulate or replay, the simulated SPIDAR
/// when there is none; and, when amplifiers are looked for, what tells later arrivals.
fn devices_present(cli: &Cli) -> (Vec<Kind>, Option<Arrivals>) {
    let hardware = cli.sim.is_none() && cli.replay.is_none();
    let mut kinds: Vec<Kind> = match (hardware, &cli.replay) {
        (true, _) => match find_devices() {
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
        },
        (false, Some(path)) => vec![Kind::Replay(path.clone())],
        (false, None) => Vec::new(),
    };
    // What is on the bus now is what hapticd could use: only later arrivals are news.
    let arrivals = hardware.then(|| Arrivals::new(kinds.iter().map(Kind::identity).collect()));
    if kinds.is_empty() {
        kinds.push(Kind::Simulator);
    }
    (kinds, arrivals)
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
/// enough; the recordings are of the first device. One device that cannot start leaves the
/// others running; with none, hapticd fails.
fn start_devices(kinds: Vec<Kind>, common: &Common, cli: &Cli) -> Result<Vec<Device>, String> {
    let plan = hapticd_service::cpus::allowed()
        .ok()
        .and_then(|allowed| hapticd_service::cpus::Plan::new(&allowed, kinds.len()));
    if let Some(plan) = &plan
        && let Err(e) = plan.keep_daemon_off()
    {
        tracing::warn!("cannot keep the daemon's threads off the haptic CPUs: {e}");
    }
    let (mut devices, mut failures) = (Vec::new(), Vec::new());
    for (index, kind) in kinds.into_iter().enumerate() {
        let recording = match index {
            0 => Recording {
                frames: cli.record.as_deref(),
                traffic: cli.record_traffic.as_deref(),
            },
            _ => Recording::default(),
        };
        let identity = kind.identity();
        let cpu = plan.as_ref().map(|p| p.haptic[index]);
        match device::start(kind, index as u32, common, recording, cpu) {
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
    Ok(devices)
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
