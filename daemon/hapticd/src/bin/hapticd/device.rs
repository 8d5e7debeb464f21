//! One device, from its saved state to its running real-time thread: which mechanism it
//! drives, at which rate, its scene, its parameters and calibration, its loop and the threads
//! that log and record it.

use std::os::linux::net::SocketAddrExt;
use std::os::unix::net::{SocketAddr, UnixDatagram};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicI32};
use std::thread::JoinHandle;

use hapticd::control::{DeviceHandle, DeviceSetup, Fixed, Telemetry, scene_geometry};
use hapticd::realtime::{Channels, RealtimeLoop, RealtimeSettings, Scheduling};
use hapticd::scenes;
use hapticd::state::{DeviceRecord, StateDir};
use hapticd_config::Config;
use hapticd_config::catalog::{Catalog, Entry};
use hapticd_core::haptic_loop::{Frame, HapticLoop, LoopCommand, LoopSettings, Retired};
use hapticd_core::haptics::safety::SafetyLimits;
use hapticd_core::mechanism::Mechanism;
use hapticd_core::parameters::Parameters;
use hapticd_core::scene::{Pointer, Scene};
use hapticd_core::stats::LoopStats;
use hapticd_core::sync::spsc;
use hapticd_core::telemetry::TelemetryWriter;
use hapticd_core::world_state::WorldWriter;
use hapticd_device::Protocol;
use hapticd_device::guardian::Guardian;
use hapticd_device::hotplug::Reconnector;
use hapticd_device::replay::{self, Transfer};
use hapticd_ipc::telemetry_share::SharedTelemetryFile;
use hapticd_ipc::world_link_share::WorldLinkFile;
use hapticd_ipc::world_share::SharedWorldFile;

use crate::saved::{load_record, set_aside};
use crate::transport::{self, Kind};
use crate::{events, recording};

/// What every device is started with.
pub struct Common<'a> {
    /// The configuration.
    pub config: &'a Config,
    /// The installed mechanisms.
    pub catalog: &'a Catalog,
    /// What the catalog found at start.
    pub entries: &'a [Entry],
    /// `--rate`: ticks per second, whatever is saved or configured.
    pub rate: Option<f64>,
    /// `--scene`, or the configured scene.
    pub scene: &'a str,
    /// `--scene-file`, handed to a scene plugin.
    pub scene_file: Option<&'a Path>,
    /// Where calibration and parameters are kept.
    pub state_dir: Option<&'a StateDir>,
    /// Set when the daemon stops: the logging and recording threads finish then.
    pub done: &'static AtomicBool,
    /// The process that zeroes the amplifiers should this one die.
    pub guardian: &'a Guardian,
}

/// What one device records (the first device only: the files are named once).
#[derive(Default)]
pub struct Recording<'a> {
    /// `--record`: every frame as CSV.
    pub frames: Option<&'a Path>,
    /// `--record-traffic`: every transfer with the device.
    pub traffic: Option<&'a Path>,
}

/// A device whose loop runs.
pub struct Device {
    /// Its real-time loop.
    pub rt: RealtimeLoop,
    /// The device as the control plane sees it.
    pub handle: Arc<DeviceHandle>,
    /// Scenes and links the loop stopped using, to be freed by the main thread.
    pub retired: spsc::Consumer<Retired>,
    /// Its slot with the guardian.
    pub slot: u32,
    /// Set for a USB amplifier: opens it again after an unplug, and the protocol it speaks.
    pub reconnector: Option<(Reconnector, Protocol)>,
    /// The scene it renders.
    pub scene: String,
    /// The thread logging its events.
    pub logger: JoinHandle<()>,
    /// The threads writing its recordings.
    pub writers: Vec<JoinHandle<std::io::Result<()>>>,
    /// Why a recording stopped early, once one has.
    pub recording_failed: Option<String>,
    /// Its name, held on this host while it runs.
    _name: Option<UnixDatagram>,
}

/// A device about to start: what it is, what it drives, at which rate.
pub struct Prepared {
    kind: Kind,
    identity: String,
    record: DeviceRecord,
    mechanism_name: String,
    mechanism: Mechanism,
    /// Its ticks a second.
    pub rate: f64,
    /// Its grips at calibration, as its scene sees them.
    pub pointers: Vec<Pointer>,
}

impl Prepared {
    /// Its identity.
    pub fn identity(&self) -> &str {
        &self.identity
    }
}

/// The device of `kind` as `common` and its saved state say: its mechanism, rate and grips.
pub fn prepare(kind: Kind, common: &Common) -> Result<Prepared, String> {
    let identity = kind.identity();
    let record = load_record(common.state_dir, &identity);
    let (mechanism_name, mechanism) = mechanism(&kind, &identity, &record, common)?;
    let rate = rate(common, &record)?;
    Ok(Prepared {
        pointers: Pointer::at_calibration(&mechanism),
        kind,
        identity,
        record,
        mechanism_name,
        mechanism,
        rate,
    })
}

/// Start `device` with what `common` says, recording what `recording` asks, its haptic
/// thread on `cpu` when given (with whether the daemon's other threads keep off it),
/// rendering `scene` if given (a world it shares with other
/// devices) or else the scene `common` names; the guardian knows it as `slot`.
pub fn start(
    device: Prepared,
    slot: u32,
    common: &Common,
    recording: Recording,
    cpu: Option<(usize, bool)>,
    scene: Option<Box<dyn Scene>>,
) -> Result<Device, String> {
    let (kind, identity, mut record) = (device.kind, device.identity, device.record);
    let (mechanism_name, mechanism) = (device.mechanism_name, device.mechanism);
    let (rate, pointers) = (device.rate, device.pointers);
    let fixed = Fixed {
        mechanism: kind.fixed_mechanism().is_some(),
        rate: common.rate.is_some(),
    };
    let name = claim_name(&identity);
    let mut writers = Vec::new();
    let (traffic, reconnector) = watch(&kind, slot, common, recording.traffic, &mut writers)?;
    let transport = transport::open(kind, &identity, traffic, &mechanism, rate)?;
    let (mut scene, world_link) = scene_and_link(scene, common, &identity, &pointers, rate)?;
    let control = scene.take_control();
    let scene_name = scene.name().to_string();
    let defaults = default_parameters(&*scene, &mechanism, common);
    keep_consistent_parameters(&mut record, &defaults, common.state_dir, &identity);
    let header = recording::csv_header(&mechanism);
    let effectors = mechanism.effectors.iter().map(|e| e.name.clone()).collect();
    let strings = mechanism.strings.len();
    let settings = loop_settings(common);
    // The first scene is the one the frames count as no switch.
    let geometry = scene_geometry(&identity, 0, scene.geometry());
    let mut haptic =
        HapticLoop::new(mechanism, transport, scene, settings).map_err(|e| e.to_string())?;
    haptic.command(LoopCommand::Tune(record.parameters.resolve(&defaults)));
    restore_calibration(&mut haptic, &record, (&mechanism_name, strings), &identity)?;
    let (event_tx, event_rx) = spsc::channel(1024);
    let thread_id = Arc::new(AtomicI32::new(0));
    let logger =
        events::spawn_event_logger(identity.clone(), event_rx, common.done, thread_id.clone());
    let frames = frame_recorder(recording.frames, header, rate, common.done, &mut writers)?;
    let (command_tx, command_rx) = spsc::channel(64);
    let (retired_tx, retired) = spsc::channel(4);
    let (world, world_writer) = shared_world(&identity);
    let (telemetry, telemetry_writer) = telemetry_ring(&identity, rate);
    let mut rt = RealtimeLoop::start(
        haptic,
        RealtimeSettings {
            priority: common.config.realtime.priority,
            rate,
            cpu: cpu.map(|(cpu, _)| cpu),
        },
        Channels {
            events: event_tx,
            recorder: frames,
            commands: command_rx,
            retired: retired_tx,
            world: world_writer,
            telemetry: telemetry_writer,
            heartbeat: common.guardian.heartbeat(slot),
            thread_id,
        },
    )
    .map_err(|e| format!("cannot start the haptic thread of {identity}: {e}"))?;
    let started = format!("{mechanism_name} on {identity}, scene {scene_name}, {rate} Hz");
    let scheduling = report_scheduling(&rt, &identity, &started, cpu.is_some_and(|c| c.1));
    let handle = Arc::new(DeviceHandle::new(
        DeviceSetup {
            identity,
            mechanism: mechanism_name,
            effectors,
            pointers,
            rate,
            scheduling,
            state_dir: common.state_dir.cloned(),
            record,
            defaults,
            world,
            geometry,
            telemetry,
            world_link,
            fixed,
            control,
        },
        command_tx,
    ));
    if let Err(e) = make_ready(&handle, &mut rt, common) {
        let _ = rt.stop();
        return Err(format!("the effects of scene {scene_name}: {e}"));
    }
    Ok(Device {
        rt,
        handle,
        retired,
        slot,
        reconnector,
        scene: scene_name,
        logger,
        writers,
        recording_failed: None,
        _name: name,
    })
}

/// Make `handle` ready for the bus: the loop's first telemetry (of `rt`), and the first
/// scene's effects started as a switch to the scene would start them: a scene file's own (a
/// scene plugin's file is in its own format).
fn make_ready(
    handle: &DeviceHandle,
    rt: &mut RealtimeLoop,
    common: &Common,
) -> Result<(), hapticd::control::Error> {
    handle.publish(Telemetry {
        frame: *rt.frame(),
        stats: *rt.stats(),
    });
    let file = scenes::file_of(common.scene, None, &common.config.scene_dirs);
    handle.replace_scene_effects(handle.scene_effects(file.as_deref())?)
}

/// Hold device name `identity` on this host while the returned socket lives (an abstract
/// Unix socket: the kernel frees it with the process, whatever ends it). Another hapticd
/// driving a device of the same name is told: their topics on the network would mix.
fn claim_name(identity: &str) -> Option<UnixDatagram> {
    let address = SocketAddr::from_abstract_name(format!("hapticd/device/{identity}")).ok()?;
    match UnixDatagram::bind_addr(&address) {
        Ok(socket) => Some(socket),
        Err(e) if e.kind() == std::io::ErrorKind::AddrInUse => {
            tracing::warn!(
                "another hapticd on this host drives a device named {identity}: their topics \
                 on the network mix (name this one in the configuration's `devices`)"
            );
            None
        }
        Err(e) => {
            tracing::warn!("{identity}: cannot hold its name on this host: {e}");
            None
        }
    }
}

/// The device's world link (for remote scenes), and `given` (a world it shares) or else the
/// scene `common` names.
fn scene_and_link(
    given: Option<Box<dyn Scene>>,
    common: &Common,
    identity: &str,
    pointers: &[Pointer],
    rate: f64,
) -> Result<(Box<dyn Scene>, Option<WorldLinkFile>), String> {
    let world_link = WorldLinkFile::create()
        .map_err(|e| tracing::warn!("{identity}: no world link for remote scenes: {e}"))
        .ok();
    let scene = match given {
        Some(scene) => scene,
        None => open_scene(common, world_link.as_ref(), pointers, rate)?,
    };
    Ok((scene, world_link))
}

/// The scene `common` names, a remote world reaching it through `world_link`.
fn open_scene(
    common: &Common,
    world_link: Option<&WorldLinkFile>,
    pointers: &[Pointer],
    rate: f64,
) -> Result<Box<dyn Scene>, String> {
    let places = scenes::Places {
        dirs: &common.config.scene_dirs,
        plugin_dirs: &common.config.scene_plugin_dirs,
        world_link: world_link.map(WorldLinkFile::link),
    };
    scenes::open(common.scene, common.scene_file, places, pointers, rate).map_err(|e| e.to_string())
}

/// The parameters a device starts from: the scene's proxy, the mechanism's λ, the limits.
fn default_parameters(scene: &dyn Scene, mechanism: &Mechanism, common: &Common) -> Parameters {
    Parameters {
        proxy: scene.proxy().unwrap_or_default(),
        lambda: mechanism.tension.lambda,
        max_force: common.config.safety.max_force,
        max_torque: common.config.safety.max_torque,
    }
}

/// The loop's settings: the defaults, with the configured force and torque limits.
fn loop_settings(common: &Common) -> LoopSettings {
    LoopSettings {
        safety: SafetyLimits {
            max_force: common.config.safety.max_force,
            max_torque: common.config.safety.max_torque,
            ..SafetyLimits::default()
        },
        max_force_rate: common.config.safety.max_force_rate,
        ..LoopSettings::default()
    }
}

/// The ring to a thread writing every frame of a loop at `rate` hertz to `path` as CSV, if
/// asked; it joins `writers`.
fn frame_recorder(
    path: Option<&Path>,
    header: String,
    rate: f64,
    done: &'static AtomicBool,
    writers: &mut Vec<JoinHandle<std::io::Result<()>>>,
) -> Result<Option<spsc::Producer<Frame>>, String> {
    match path {
        Some(path) => {
            let (tx, rx) = spsc::channel(1 << 16);
            let writer = recording::spawn_recorder(path.to_path_buf(), header, rate, rx, done);
            writers.push(writer?);
            Ok(Some(tx))
        }
        None => Ok(None),
    }
}

/// The mechanism device `kind` drives, and its name: the command line's first, then the one
/// the user bound over D-Bus (saved in `record`), then the configured one.
fn mechanism(
    kind: &Kind,
    identity: &str,
    record: &DeviceRecord,
    common: &Common,
) -> Result<(String, Mechanism), String> {
    let configured = match kind {
        Kind::Usb(_) => &common.config.hardware.mechanism,
        _ => &common.config.simulator.mechanism,
    };
    let fixed = kind.fixed_mechanism();
    let name = match (fixed, &record.mechanism) {
        (Some(sim), _) => sim.to_string(),
        (None, Some(bound)) => bound.clone(),
        (None, None) => configured.clone(),
    };
    match common.catalog.resolve_among(common.entries, &name) {
        Ok(m) => Ok((name, m)),
        // A binding to a mechanism since removed must not keep the device from starting: the
        // binding stays saved (the plugin may come back) and the configured one drives.
        Err(e) if fixed.is_none() && record.mechanism.is_some() => {
            let file = common.state_dir.map(|d| d.device_file(identity));
            tracing::warn!(
                "{identity}: the mechanism {name:?} bound in {} cannot be used, so \
                 {configured:?} drives it until it can: {e}",
                file.map_or("memory".into(), |f| f.display().to_string())
            );
            let m = common.catalog.resolve_among(common.entries, configured)?;
            Ok((configured.clone(), m))
        }
        Err(e) => Err(e.to_string()),
    }
}

/// The tick rate: the command line's, else the saved one, else the configured one; a rate
/// from outside the configuration file is checked as the file's would be.
fn rate(common: &Common, record: &DeviceRecord) -> Result<f64, String> {
    let Some(rate) = common.rate.or(record.parameters.rate()) else {
        return Ok(common.config.realtime.rate);
    };
    let mut config = common.config.clone();
    config.realtime.rate = rate;
    config.check(Path::new("rate"))?;
    Ok(rate)
}

/// The guardian told about device `kind` (the amplifier to zero, or the recording to
/// replay), its traffic recorded to `traffic` when given (the writer joins `writers`), and
/// for a USB amplifier what opens it again after an unplug.
fn watch(
    kind: &Kind,
    slot: u32,
    common: &Common,
    traffic: Option<&Path>,
    writers: &mut Vec<JoinHandle<std::io::Result<()>>>,
) -> Result<Watched, String> {
    // Simulated and replayed devices speak the SH4 protocol.
    let protocol = match kind {
        Kind::Usb(device) => device.model.protocol,
        _ => Protocol::Sh4,
    };
    let recorder = match traffic {
        Some(path) => {
            let (tx, rx) = spsc::channel(1 << 14);
            writers.push(
                replay::spawn_traffic_writer(path, rx, common.done)
                    .map_err(|e| format!("{}: cannot create: {e}", path.display()))?,
            );
            common.guardian.watch_recording(slot, protocol, path);
            Some(tx)
        }
        None => None,
    };
    let reconnector = match kind {
        Kind::Usb(device) => {
            common
                .guardian
                .watch_amplifier(slot, protocol, device.link.node());
            Some((Reconnector::new(kind.identity(), device.model), protocol))
        }
        _ => None,
    };
    Ok((recorder, reconnector))
}

/// What [`watch`] sets up: the traffic recorder's end, and a USB amplifier's reconnector.
type Watched = (
    Option<spsc::Producer<Transfer>>,
    Option<(Reconnector, Protocol)>,
);

/// Saved parameters that are each in range but do not fit this scene's defaults together
/// (μ > μ0) are set aside, and the device starts from the defaults.
fn keep_consistent_parameters(
    record: &mut DeviceRecord,
    defaults: &Parameters,
    state_dir: Option<&StateDir>,
    identity: &str,
) {
    if let Err(e) = record.parameters.check(defaults)
        && let Some(dir) = state_dir
    {
        set_aside(
            dir,
            identity,
            &format!("saved parameters of {identity}: {e}"),
        );
        record.parameters = Default::default();
    }
}

/// Give `haptic` the saved calibration when it was taken for this mechanism (its name and
/// string count).
fn restore_calibration(
    haptic: &mut HapticLoop,
    record: &DeviceRecord,
    (mechanism, strings): (&str, usize),
    identity: &str,
) -> Result<(), String> {
    match &record.calibration {
        Some(c) if c.mechanism == mechanism && c.offsets.len() == strings => {
            haptic
                .restore_calibration(&c.offsets)
                .map_err(|e| format!("saved calibration of {identity}: {e}"))?;
            tracing::info!("restored the calibration of {identity}");
        }
        Some(c) => tracing::warn!(
            "the saved calibration of {identity} is for {}, not {mechanism}: calibrate again",
            c.mechanism
        ),
        None => {}
    }
    Ok(())
}

/// The memory the loop draws its world into, and its writer; without it the loop runs as
/// well, only pictures are missing.
fn shared_world(identity: &str) -> (Option<SharedWorldFile>, Option<WorldWriter>) {
    match SharedWorldFile::create() {
        Ok((file, writer)) => (Some(file), Some(writer)),
        Err(e) => {
            tracing::warn!("{identity}: no shared world for the renderer: {e}");
            (None, None)
        }
    }
}

/// The ring the loop writes every tick into for readers outside, and its writer; without
/// it the loop runs as well, only the ticks stay inside.
fn telemetry_ring(
    identity: &str,
    rate: f64,
) -> (Option<SharedTelemetryFile>, Option<TelemetryWriter>) {
    match SharedTelemetryFile::create(rate) {
        Ok((file, writer)) => (Some(file), Some(writer)),
        Err(e) => {
            tracing::warn!("{identity}: no telemetry ring: {e}");
            (None, None)
        }
    }
}

/// Log where the haptic thread of `identity` runs (`alone`: the daemon's other threads keep
/// off its CPU) and how it is scheduled (with `started`, what runs), and return the
/// scheduling as the Device interface shows it.
fn report_scheduling(rt: &RealtimeLoop, identity: &str, started: &str, alone: bool) -> String {
    match rt.pinned() {
        Some(Ok(cpu)) if alone => {
            tracing::info!("the haptic thread of {identity} runs on CPU {cpu} alone")
        }
        Some(Ok(cpu)) => tracing::info!("the haptic thread of {identity} runs on CPU {cpu}"),
        Some(Err(e)) => {
            tracing::warn!("cannot keep the haptic thread of {identity} on its CPU: {e}")
        }
        None => {}
    }
    match rt.scheduling() {
        Scheduling::Fifo(priority) => {
            tracing::info!("{started}, SCHED_FIFO {priority}");
            format!("SCHED_FIFO {priority}")
        }
        Scheduling::Refused(why) => {
            tracing::error!("running WITHOUT real-time scheduling: {why}");
            tracing::info!("{started}");
            format!("SCHED_OTHER: {why}")
        }
    }
}

impl Device {
    /// Report at once a recording whose writer stopped early (a full disk, a removed
    /// directory): the loop goes on without it.
    pub fn report_failed_recordings(&mut self) {
        let (stopped, running): (Vec<_>, Vec<_>) =
            self.writers.drain(..).partition(JoinHandle::is_finished);
        self.writers = running;
        for writer in stopped {
            if let Err(error) = joined(writer) {
                tracing::error!(
                    "{}: recording stopped, the loop goes on without it: {error}",
                    self.handle.identity()
                );
                self.recording_failed.get_or_insert(error);
            }
        }
    }

    /// Stop the loop, which writes zero currents first. Its threads finish once `done` is set.
    pub fn stop(self) -> Stopped {
        let stats = self.rt.stop();
        Stopped {
            identity: self.handle.identity().to_string(),
            stats,
            logger: self.logger,
            writers: self.writers,
            recording_failed: self.recording_failed,
        }
    }
}

/// How a recording's writer thread ended.
fn joined(writer: JoinHandle<std::io::Result<()>>) -> Result<(), String> {
    match writer.join() {
        Ok(result) => result.map_err(|e| format!("writing a recording: {e}")),
        Err(_) => Err("a recording thread panicked".to_string()),
    }
}

/// A device whose loop has stopped, its threads still finishing.
pub struct Stopped {
    identity: String,
    stats: LoopStats,
    logger: JoinHandle<()>,
    writers: Vec<JoinHandle<std::io::Result<()>>>,
    recording_failed: Option<String>,
}

impl Stopped {
    /// Wait for the logging and recording threads (`done` must be set), log how the loop
    /// ran, and fail if a recording did.
    pub fn finish(self) -> Result<(), String> {
        let _ = self.logger.join();
        let mut failed = self.recording_failed;
        for writer in self.writers {
            if let Err(e) = joined(writer) {
                failed.get_or_insert(e);
            }
        }
        let stats = self.stats;
        tracing::info!(
            "{}: stopped after {} ticks; motors at zero; wake latency p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs (tick {}); {} overruns, {} of them woken late",
            self.identity,
            stats.ticks,
            stats.wait_percentile_ns(0.5) as f64 / 1e3,
            stats.wait_percentile_ns(0.99) as f64 / 1e3,
            stats.wait_max_ns as f64 / 1e3,
            stats.wait_max_tick,
            stats.overruns,
            stats.overruns_woken_late
        );
        failed.map_or(Ok(()), Err)
    }
}
