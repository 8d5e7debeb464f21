//! `hapticd`: the haptics daemon. Runs the haptic loop of a SPIDAR in real time; with no
//! hardware (or with `--sim`) it drives the simulated SPIDAR.

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
use hapticd::bus::{self, Bus};
use hapticd::config::Config;
use hapticd::control::{self, Daemon, DeviceHandle, DeviceSetup, Telemetry};
use hapticd::device::hotplug::{Arrivals, Reconnector};
use hapticd::device::replay;
use hapticd::device::usb::find_devices;
use hapticd::haptics::safety::SafetyLimits;
use hapticd::parameters::Parameters;
use hapticd::runtime::haptic_loop::{HapticLoop, LoopCommand, LoopSettings};
use hapticd::runtime::realtime::{Channels, RealtimeLoop, RealtimeSettings, Scheduling};
use hapticd::runtime::spsc;
use hapticd::scene::{self, Pointer};
use hapticd::sd_notify;
use hapticd::sim::hand::Script;
use hapticd::state::StateDir;

use saved::{load_record, set_aside};
use supervisor::{Ending, Supervisor};
use transport::Source;

/// Real-time haptics daemon for SPIDAR string-driven haptic interfaces.
#[derive(Parser)]
#[command(name = "hapticd", version)]
struct Cli {
    /// Configuration file (default: /etc/hapticd/hapticd.yaml when it exists).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Run the simulated SPIDAR with this mechanism (a name or a descriptor/plugin path),
    /// even when hardware is plugged in.
    #[arg(long, value_name = "MECH")]
    sim: Option<String>,
    /// Scene to render: a name in the scene directories, a scene file, or a scene plugin (.so).
    #[arg(long)]
    scene: Option<String>,
    /// Scene file handed to a scene plugin given with --scene.
    #[arg(long, value_name = "FILE")]
    scene_file: Option<PathBuf>,
    /// Script of the simulated hand.
    #[arg(long, value_name = "FILE")]
    hand: Option<PathBuf>,
    /// Ticks per second (overrides the configuration).
    #[arg(long)]
    rate: Option<f64>,
    /// Run this many seconds, then exit cleanly.
    #[arg(long, value_name = "S")]
    duration: Option<f64>,
    /// Write every tick (time, poses, forces, tensions) to this CSV file.
    #[arg(long, value_name = "FILE.csv")]
    record: Option<PathBuf>,
    /// Record every bulk transfer with the device to this file (replayable with --replay).
    #[arg(long, value_name = "FILE")]
    record_traffic: Option<PathBuf>,
    /// Instead of a device, answer from a traffic recording.
    #[arg(long, value_name = "FILE")]
    replay: Option<PathBuf>,
    /// Look for mechanisms in DIR (repeatable; overrides the configuration).
    #[arg(long = "mechanism-dir", value_name = "DIR")]
    mechanism_dirs: Vec<PathBuf>,
    /// Serve the D-Bus interface on `system`, `session` or a D-Bus address (default: the
    /// system bus when available).
    #[arg(long, value_name = "BUS")]
    bus: Option<Bus>,
    /// Keep calibration and changed parameters in DIR (default: $STATE_DIRECTORY).
    #[arg(long, value_name = "DIR")]
    state_dir: Option<PathBuf>,
}

fn run(cli: Cli) -> Result<Ending, String> {
    let config_path = cli.config.clone().or_else(|| {
        let default = PathBuf::from("/etc/hapticd/hapticd.yaml");
        default.exists().then_some(default)
    });
    let mut config = match &config_path {
        Some(path) => Config::load(path)?,
        None => Config::default(),
    };
    let mechanism_dirs = (!cli.mechanism_dirs.is_empty()).then(|| cli.mechanism_dirs.clone());
    let catalog = control::catalog(&config, mechanism_dirs.as_deref());
    // Hardware unless told to simulate or replay; the simulated SPIDAR when none is found.
    let usb = if cli.sim.is_none() && cli.replay.is_none() {
        match find_devices() {
            Ok((mut found, problems)) => {
                for p in problems {
                    tracing::warn!("{p}");
                }
                (!found.is_empty()).then(|| found.remove(0))
            }
            Err(e) => {
                tracing::warn!("{e}: no USB devices, simulating");
                None
            }
        }
    } else {
        None
    };
    let identity = match (&usb, &cli.replay) {
        (Some(device), _) => device.identity.clone(),
        (None, Some(path)) => format!("replay:{}", path.display()),
        (None, None) => "sim".to_string(),
    };
    let state_dir = cli
        .state_dir
        .clone()
        .map(StateDir::new)
        .or_else(StateDir::from_env);
    let mut record = load_record(state_dir.as_ref(), &identity);
    // The command line first, then what the user set over D-Bus, then the configuration.
    let mechanism_name = match (&cli.sim, &record.mechanism, &usb) {
        (Some(sim), _, _) => sim.clone(),
        (None, Some(bound), _) => bound.clone(),
        (None, None, Some(_)) => config.hardware.mechanism.clone(),
        (None, None, None) => config.simulator.mechanism.clone(),
    };
    if let Some(rate) = cli.rate.or(record.parameters.rate()) {
        config.realtime.rate = rate;
        config.check()?;
    }
    let mechanism = catalog
        .resolve(&mechanism_name)
        .map_err(|e| e.to_string())?;
    let script = match cli.hand.as_ref().or(config.simulator.hand.as_ref()) {
        Some(path) => Script::load(path)?,
        None => Script::default(),
    };
    let rate = config.realtime.rate;
    static DONE: AtomicBool = AtomicBool::new(false);
    let (traffic_tx, traffic_writer) = match &cli.record_traffic {
        Some(path) => {
            let (tx, rx) = spsc::channel(1 << 14);
            let writer = replay::spawn_traffic_writer(path, rx, &DONE)
                .map_err(|e| format!("{}: cannot create: {e}", path.display()))?;
            (Some(tx), Some(writer))
        }
        None => (None, None),
    };
    // A USB amplifier that is unplugged is opened again when it returns; one plugged in while
    // hapticd simulates for want of hardware makes it start again, on that amplifier.
    let reconnector = usb
        .as_ref()
        .map(|device| Reconnector::new(&identity, device.model));
    let arrivals =
        (usb.is_none() && cli.sim.is_none() && cli.replay.is_none()).then(Arrivals::default);
    let source = match (usb, &cli.replay) {
        (Some(device), _) => Source::Usb(device),
        (None, Some(path)) => Source::Replay(path),
        (None, None) => Source::Simulator {
            mechanism: &mechanism,
            rate,
            script: &script,
        },
    };
    let transport = transport::open(source, &identity, traffic_tx)?;
    let pointers = Pointer::at_calibration(&mechanism);
    let scene = scene::open(
        cli.scene.as_deref().unwrap_or(&config.scene),
        cli.scene_file.as_deref(),
        &config.scene_dirs,
        &pointers,
    )
    .map_err(|e| e.to_string())?;
    let scene_name = scene.name().to_string();
    let defaults = Parameters {
        proxy: scene.proxy().unwrap_or_default(),
        lambda: mechanism.tension.lambda,
        max_force: config.safety.max_force,
        max_torque: config.safety.max_torque,
    };
    if let Err(e) = record.parameters.check(&defaults)
        && let Some(dir) = &state_dir
    {
        // Each value is in range, but together with this scene's they are not (μ > μ0).
        set_aside(
            dir,
            &identity,
            &format!("saved parameters of {identity}: {e}"),
        );
        record.parameters = Default::default();
    }
    let settings = LoopSettings {
        safety: SafetyLimits {
            max_force: config.safety.max_force,
            max_torque: config.safety.max_torque,
            ..SafetyLimits::default()
        },
        ..LoopSettings::default()
    };
    let header = recording::csv_header(&mechanism);
    let strings = mechanism.strings.len();
    let mut haptic =
        HapticLoop::new(mechanism, transport, scene, settings).map_err(|e| e.to_string())?;
    haptic.command(LoopCommand::Tune(record.parameters.resolve(&defaults)));
    match &record.calibration {
        Some(c) if c.mechanism == mechanism_name && c.offsets.len() == strings => {
            haptic
                .restore_calibration(&c.offsets)
                .map_err(|e| format!("saved calibration of {identity}: {e}"))?;
            tracing::info!("restored the calibration of {identity}");
        }
        Some(c) => tracing::warn!(
            "the saved calibration of {identity} is for {}, not {mechanism_name}: calibrate again",
            c.mechanism
        ),
        None => {}
    }

    // SAFETY: mlockall takes no pointers.
    if unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) } != 0 {
        tracing::warn!(
            "cannot lock memory ({}); page faults may delay the haptic loop (raise LimitMEMLOCK=)",
            std::io::Error::last_os_error()
        );
    }
    let _cpu_latency = hapticd::runtime::realtime::hold_low_cpu_latency().or_else(|| {
        tracing::warn!(
            "cannot hold /dev/cpu_dma_latency at 0: deep CPU idle states may delay wake-ups"
        );
        None
    });
    signals::install()?;
    let (event_tx, event_rx) = spsc::channel(1024);
    let logger = events::spawn_event_logger(event_rx, &DONE);
    let (recorder_tx, recorder) = match &cli.record {
        Some(path) => {
            let (tx, rx) = spsc::channel(1 << 16);
            (
                Some(tx),
                Some(recording::spawn_recorder(path.clone(), header, rx, &DONE)?),
            )
        }
        None => (None, None),
    };
    let (command_tx, command_rx) = spsc::channel(64);
    let (retired_tx, retired_rx) = spsc::channel(4);
    let mut rt = RealtimeLoop::start(
        haptic,
        RealtimeSettings {
            priority: config.realtime.priority,
            rate,
        },
        Channels {
            events: event_tx,
            recorder: recorder_tx,
            commands: command_rx,
            retired: retired_tx,
        },
    )
    .map_err(|e| format!("cannot start the haptic thread: {e}"))?;
    let scheduling = match rt.scheduling() {
        Scheduling::Fifo(priority) => {
            tracing::info!(
                "{mechanism_name} on {identity}, scene {scene_name}, {rate} Hz, SCHED_FIFO {priority}"
            );
            format!("SCHED_FIFO {priority}")
        }
        Scheduling::Refused(why) => {
            tracing::error!("running WITHOUT real-time scheduling: {why}");
            tracing::info!("{mechanism_name} on {identity}, scene {scene_name}, {rate} Hz");
            format!("SCHED_OTHER: {why}")
        }
    };
    if state_dir.is_none() {
        tracing::warn!(
            "no state directory (--state-dir or $STATE_DIRECTORY): calibration and parameter changes will not survive a restart"
        );
    }
    let device = Arc::new(DeviceHandle::new(
        DeviceSetup {
            identity: identity.clone(),
            mechanism: mechanism_name.clone(),
            pointers,
            rate,
            scheduling,
            state_dir,
            record,
            defaults,
        },
        command_tx,
    ));
    device.publish(Telemetry {
        frame: *rt.frame(),
        stats: *rt.stats(),
    });
    let daemon = Arc::new(Daemon::new(
        config,
        config_path,
        mechanism_dirs,
        scene_name,
        vec![device.clone()],
    ));
    let _service = match (
        &cli.bus,
        bus::serve(cli.bus.clone().unwrap_or(Bus::System), daemon.clone()),
    ) {
        (_, Ok(service)) => Some(service),
        (Some(_), Err(e)) => return Err(e),
        (None, Err(e)) => {
            tracing::warn!("{e}; running without the D-Bus interface");
            None
        }
    };
    let _ = sd_notify::notify(&format!(
        "READY=1\nSTATUS=running {mechanism_name} at {rate} Hz"
    ));
    let ending = Supervisor {
        rt: &mut rt,
        device,
        daemon,
        retired: retired_rx,
        reconnector,
        arrivals,
        duration: cli.duration,
    }
    .run();
    // A restart is, to systemd, a reload: the new image says READY=1 again.
    let _ = sd_notify::notify(match ending {
        Ending::Done => "STOPPING=1",
        Ending::Restart => "RELOADING=1",
    });
    let stats = *rt.stats();
    rt.stop();
    DONE.store(true, Ordering::Release);
    let _ = logger.join();
    for writer in recorder.into_iter().chain(traffic_writer) {
        writer
            .join()
            .map_err(|_| "a recording thread panicked".to_string())?
            .map_err(|e| format!("writing a recording: {e}"))?;
    }
    tracing::info!(
        "stopped after {} ticks; motors at zero; wake latency p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs; {} overruns",
        stats.ticks,
        stats.wait_percentile_ns(0.5) as f64 / 1e3,
        stats.wait_percentile_ns(0.99) as f64 / 1e3,
        stats.wait_max_ns as f64 / 1e3,
        stats.overruns
    );
    if signals::OVERTIME.load(Ordering::Acquire) {
        return Err(
            "the haptic thread ran past LimitRTTIME= without sleeping (SIGXCPU): motors zeroed, \
             exiting for a restart"
                .into(),
        );
    }
    Ok(ending)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    hapticd::logging::init("hapticd", false);
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
