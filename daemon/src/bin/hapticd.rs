//! `hapticd`: the haptics daemon. Runs the haptic loop of a SPIDAR in real time; with no
//! hardware (or with `--sim`) it drives the simulated SPIDAR.

use std::io::Write;
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use clap::Parser;
use glam::DVec3;
use hapticd::bus::{self, Bus};
use hapticd::config::Config;
use hapticd::control::{self, Daemon, DeviceHandle, DeviceSetup, Telemetry};
use hapticd::device::Protocol;
use hapticd::device::hotplug::{Arrivals, Lookup, Reconnector};
use hapticd::device::replay::{self, RecordingLink, ReplayLink};
use hapticd::device::transport::{Link, Sh4Transport, SimpleTransport, Transport};
use hapticd::device::usb::find_devices;
use hapticd::haptics::safety::SafetyLimits;
use hapticd::mechanism::Mechanism;
use hapticd::parameters::Parameters;
use hapticd::runtime::haptic_loop::{DeviceState, Frame, HapticLoop, LoopCommand, LoopSettings};
use hapticd::runtime::realtime::{Channels, LoopEvent, RealtimeLoop, RealtimeSettings, Scheduling};
use hapticd::runtime::spsc;
use hapticd::scene::{self, Pointer};
use hapticd::sd_notify;
use hapticd::sim::hand::Script;
use hapticd::sim::{SimParameters, SimulatedBoard};
use hapticd::state::{DeviceRecord, StateDir};

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

static STOP: AtomicBool = AtomicBool::new(false);

/// Set by SIGXCPU: the haptic thread ran past LimitRTTIME= without sleeping.
static OVERTIME: AtomicBool = AtomicBool::new(false);
/// Set by SIGHUP: re-read the configuration and rescan plugins.
static RELOAD: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(signal: libc::c_int) {
    match signal {
        libc::SIGHUP => RELOAD.store(true, Ordering::Release),
        libc::SIGXCPU => {
            OVERTIME.store(true, Ordering::Release);
            STOP.store(true, Ordering::Release);
        }
        _ => STOP.store(true, Ordering::Release),
    }
}

fn install_signal_handlers() -> Result<(), String> {
    use nix::sys::signal::{SaFlags, SigAction, SigHandler, SigSet, Signal, sigaction};
    let action = SigAction::new(
        SigHandler::Handler(on_signal),
        SaFlags::SA_RESTART,
        SigSet::empty(),
    );
    for signal in [
        Signal::SIGTERM,
        Signal::SIGINT,
        Signal::SIGHUP,
        Signal::SIGXCPU,
    ] {
        // SAFETY: the handler only stores to atomics, which is async-signal-safe.
        unsafe { sigaction(signal, &action) }
            .map_err(|e| format!("cannot handle {signal}: {e}"))?;
    }
    Ok(())
}

/// The SH4 protocol over `link`, its traffic recorded when `recorder` is given.
fn sh4_transport<L: Link + 'static>(
    link: L,
    identity: &str,
    recorder: Option<spsc::Producer<replay::Transfer>>,
) -> Box<dyn Transport> {
    match recorder {
        Some(ring) => Box::new(Sh4Transport::new(RecordingLink::new(link, ring), identity)),
        None => Box::new(Sh4Transport::new(link, identity)),
    }
}

/// Keep the state file of `identity` aside (as `….json.corrupt`) because of `why`, so the
/// device starts afresh without losing what the file held.
fn set_aside(dir: &StateDir, identity: &str, why: &str) {
    let file = dir.device_file(identity);
    let aside = file.with_extension("json.corrupt");
    match std::fs::rename(&file, &aside) {
        Ok(()) => tracing::error!("{why}; kept as {} and starting afresh", aside.display()),
        Err(_) => tracing::error!("{why}; starting afresh"),
    }
}

/// The saved state of `identity`; a file that cannot be parsed, or holds a value out of
/// range, is set aside and the device starts afresh.
fn load_record(state_dir: Option<&StateDir>, identity: &str) -> DeviceRecord {
    let Some(dir) = state_dir else {
        return DeviceRecord::default();
    };
    let checked = dir.load(identity).and_then(|record| {
        record
            .parameters
            .check_ranges()
            .map(|()| record)
            .map_err(|e| format!("{}: {e}", dir.device_file(identity).display()))
    });
    checked.unwrap_or_else(|why| {
        set_aside(dir, identity, &why);
        DeviceRecord::default()
    })
}

fn csv_header(mechanism: &Mechanism) -> String {
    let mut header = String::from("time,state");
    for e in &mechanism.effectors {
        for field in [
            "x", "y", "z", "qw", "qx", "qy", "qz", "fx", "fy", "fz", "tx", "ty", "tz",
        ] {
            header += &format!(",{}_{field}", e.name);
        }
    }
    for i in 0..mechanism.strings.len() {
        header += &format!(",tension_{i}");
    }
    header
}

fn csv_row(frame: &Frame) -> String {
    let state = match frame.state {
        DeviceState::Running => "running",
        DeviceState::Fault => "fault",
        DeviceState::Disconnected => "disconnected",
    };
    let mut row = format!("{:.6},{state}", frame.time);
    for e in 0..frame.effectors {
        let (p, q, w) = (
            frame.poses[e].position,
            frame.poses[e].orientation,
            frame.wrenches[e],
        );
        for v in [p.x, p.y, p.z, q.w, q.x, q.y, q.z] {
            row += &format!(",{v:.7}");
        }
        for v in w {
            row += &format!(",{v:.5}");
        }
    }
    for t in &frame.tensions[..frame.strings] {
        row += &format!(",{t:.5}");
    }
    row
}

/// Drain `frames` into a CSV file until `done` is set and the ring is empty.
fn spawn_recorder(
    path: PathBuf,
    header: String,
    mut frames: spsc::Consumer<Frame>,
    done: &'static AtomicBool,
) -> Result<std::thread::JoinHandle<std::io::Result<()>>, String> {
    let file = std::fs::File::create(&path)
        .map_err(|e| format!("{}: cannot create: {e}", path.display()))?;
    Ok(std::thread::spawn(move || {
        let mut out = std::io::BufWriter::new(file);
        writeln!(out, "{header}")?;
        loop {
            let finished = done.load(Ordering::Acquire);
            while let Some(frame) = frames.pop() {
                writeln!(out, "{}", csv_row(&frame))?;
            }
            if finished {
                return out.flush();
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }))
}

/// Print the loop's events as they come (the real-time thread must not write itself).
fn spawn_event_logger(
    mut events: spsc::Consumer<LoopEvent>,
    done: &'static AtomicBool,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let mut overruns = 0u64;
        loop {
            let finished = done.load(Ordering::Acquire);
            while let Some(event) = events.pop() {
                match event {
                    LoopEvent::State { time, state, error } => match (state, error) {
                        (_, Some(e)) => tracing::error!("{time:.3} s: device {state:?}: {e}"),
                        (DeviceState::Running, None) => {
                            tracing::info!("{time:.3} s: device {state:?}")
                        }
                        (_, None) => {
                            tracing::error!("{time:.3} s: device {state:?}: forces ramped to zero")
                        }
                    },
                    LoopEvent::Overrun { time, late_ns } => {
                        overruns += 1;
                        // The first few in full; then only every thousandth.
                        if overruns <= 5 || overruns.is_multiple_of(1000) {
                            tracing::warn!(
                                "{time:.3} s: tick overran by {:.1} µs ({overruns} so far)",
                                late_ns as f64 / 1e3
                            );
                        }
                    }
                }
            }
            if finished {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    })
}

fn status_line(frame: &Frame, rt: &mut RealtimeLoop) -> String {
    let p = frame.poses[0].position;
    let f = DVec3::new(
        frame.wrenches[0][0],
        frame.wrenches[0][1],
        frame.wrenches[0][2],
    );
    let stats = *rt.stats();
    format!(
        "t={:6.2} s  {:?}  grip ({:+.4}, {:+.4}, {:+.4}) m  force ({:+.2}, {:+.2}, {:+.2}) N  \
         wait p99 {:.0} µs  busy {:.1} µs  overruns {}",
        frame.time,
        frame.state,
        p.x,
        p.y,
        p.z,
        f.x,
        f.y,
        f.z,
        stats.wait_percentile_ns(0.99) as f64 / 1e3,
        stats.busy_mean_ns() as f64 / 1e3,
        stats.overruns
    )
}

/// How a run ended well.
enum Ending {
    /// Asked to stop, or its time was up.
    Done,
    /// An amplifier was plugged in while simulating: start again, on it.
    Restart,
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
    let mut reconnector = usb
        .as_ref()
        .map(|device| Reconnector::new(&identity, device.model));
    let mut arrivals =
        (usb.is_none() && cli.sim.is_none() && cli.replay.is_none()).then(Arrivals::default);
    let transport: Box<dyn Transport> = match (&cli.replay, usb) {
        (_, Some(device)) => {
            // Boxed, so that a link opened after an unplug can take its place.
            let link: Box<dyn Link> = Box::new(device.link);
            match (device.model.protocol, traffic_tx) {
                (Protocol::Sh4, tx) => sh4_transport(link, &identity, tx),
                (Protocol::Simple, None) => Box::new(SimpleTransport::new(link, &identity)),
                (Protocol::Simple, Some(ring)) => Box::new(SimpleTransport::new(
                    RecordingLink::new(link, ring),
                    &identity,
                )),
            }
        }
        (Some(path), None) => {
            let transfers = replay::read_recording(path).map_err(|e| e.to_string())?;
            sh4_transport(ReplayLink::new(transfers), &identity, traffic_tx)
        }
        (None, None) => {
            let board =
                SimulatedBoard::new(&mechanism, 1.0 / rate, &script, SimParameters::default());
            sh4_transport(board, &identity, traffic_tx)
        }
    };
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
    let header = csv_header(&mechanism);
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
    install_signal_handlers()?;
    let (event_tx, event_rx) = spsc::channel(1024);
    let logger = spawn_event_logger(event_rx, &DONE);
    let (recorder_tx, recorder) = match &cli.record {
        Some(path) => {
            let (tx, rx) = spsc::channel(1 << 16);
            (
                Some(tx),
                Some(spawn_recorder(path.clone(), header, rx, &DONE)?),
            )
        }
        None => (None, None),
    };
    let (command_tx, command_rx) = spsc::channel(64);
    let (retired_tx, mut retired_rx) = spsc::channel(4);
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
    let started = Instant::now();
    let watchdog = sd_notify::watchdog_interval().map(|w| w / 2);
    let (mut last_ping, mut last_beat) = (Instant::now(), 0);
    let (mut last_status, mut last_publish) = (Instant::now(), Instant::now());
    let mut ending = Ending::Done;
    while !STOP.load(Ordering::Acquire) {
        if cli
            .duration
            .is_some_and(|d| started.elapsed().as_secs_f64() >= d)
        {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
        // Ping the watchdog only while the haptic loop is alive.
        let beat = rt.heartbeat();
        if let Some(interval) = watchdog
            && beat > last_beat
            && last_ping.elapsed() >= interval
        {
            let _ = sd_notify::notify("WATCHDOG=1");
            last_ping = Instant::now();
        }
        last_beat = beat;
        if RELOAD.swap(false, Ordering::AcqRel) {
            match daemon.reload() {
                Ok(()) => tracing::info!("reloaded the configuration and plugins"),
                Err(e) => tracing::error!("reload refused, nothing changed: {e}"),
            }
        }
        // Scenes and links replaced are freed here, off the real-time thread.
        while retired_rx.pop().is_some() {}
        if let Some(r) = reconnector.as_mut() {
            let missing = rt.frame().state == DeviceState::Disconnected;
            match r.poll(missing, Instant::now()) {
                Lookup::Back(link) => match device.reconnect(link) {
                    Ok(()) => tracing::info!("{identity} is back: reconnected"),
                    Err(e) => tracing::warn!("{identity} is back but not reconnected: {e}"),
                },
                Lookup::Refused(why) => tracing::warn!("{why}"),
                Lookup::Idle | Lookup::Absent => {}
            }
        }
        if let Some((plugged, model)) = arrivals.as_mut().and_then(|a| a.poll(Instant::now())) {
            tracing::info!(
                "{plugged} ({}) plugged in: starting again on it",
                model.name
            );
            ending = Ending::Restart;
            break;
        }
        if last_publish.elapsed() >= Duration::from_millis(100) {
            device.publish(Telemetry {
                frame: *rt.frame(),
                stats: *rt.stats(),
            });
            last_publish = Instant::now();
        }
        if last_status.elapsed() >= Duration::from_millis(500) {
            let frame = *rt.frame();
            println!("{}", status_line(&frame, &mut rt));
            last_status = Instant::now();
        }
    }
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
    if OVERTIME.load(Ordering::Acquire) {
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
