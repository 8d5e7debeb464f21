//! `org.hapticd.Hapticd1.Device` at `/org/hapticd/Hapticd1/device/N`.

// The Touch signal carries nine values, and zbus makes each an argument of the function it
// generates (which no attribute of ours reaches).
#![allow(clippy::too_many_arguments)]

use std::collections::HashMap;
use std::sync::Arc;

use hapticd_core::haptic_loop::DeviceState;
use hapticd_core::kinematics::{Wrench, quat_to_wxyz};
use hapticd_core::parameters::Name;
use hapticd_ipc::DEVICE_INTERFACE;
use hapticd_service::Workers;
use zbus::Variant;
use zbus::interface;
use zbus::message::Header;
use zbus::object_server::SignalEmitter;

use super::BusError;
use super::{audit, caller, report};
use crate::control::{Daemon, DeviceHandle, Telemetry};

/// One haptic device.
pub struct DeviceInterface {
    daemon: Arc<Daemon>,
    device: Arc<DeviceHandle>,
    workers: Arc<Workers>,
}

impl DeviceInterface {
    /// The interface of `device`, running blocking requests on `workers`.
    pub fn new(daemon: Arc<Daemon>, device: Arc<DeviceHandle>, workers: Arc<Workers>) -> Self {
        Self {
            daemon,
            device,
            workers,
        }
    }

    /// Set parameter `name` for the sender of `header`, and log it.
    async fn set(
        &self,
        name: Name,
        value: f64,
        connection: &zbus::Connection,
        header: Option<Header<'_>>,
    ) -> Result<(), BusError> {
        let device = self.device.clone();
        let result = self
            .workers
            .run(move || device.set_parameter(name, value))
            .await;
        let who = caller(connection, header.as_ref()).await;
        let what = format!(
            "set {} of {} to {value}",
            name.as_str(),
            self.device.identity()
        );
        audit(&what, &who, &result);
        Ok(result?)
    }

    /// The change to the effects `what` that the sender of `header` asked for, done with
    /// `result`: audited, and `Effects` announced when it took.
    async fn effects_changed_by<T>(
        &self,
        what: &str,
        result: Result<T, crate::control::Error>,
        (emitter, connection, header): (&SignalEmitter<'_>, &zbus::Connection, &Header<'_>),
    ) -> Result<T, BusError> {
        let who = caller(connection, Some(header)).await;
        audit(what, &who, &result.as_ref().map(|_| ()));
        let done = result?;
        report(self.effects_changed(emitter).await);
        Ok(done)
    }
}

/// Refuse `options` of `method`, which takes none yet.
fn no_options(
    method: &str,
    options: &HashMap<String, zbus::OwnedVariant>,
) -> Result<(), crate::control::Error> {
    match options.keys().next() {
        Some(key) => Err(crate::control::Error::OutOfRange(format!(
            "{method} takes no option {key:?}"
        ))),
        None => Ok(()),
    }
}

/// A descriptor that moves the motors, `opened` for the caller of `header` to `what`:
/// audited, whatever became of it.
async fn audited(
    what: &str,
    connection: &zbus::Connection,
    header: &Header<'_>,
    opened: Result<std::os::fd::OwnedFd, crate::control::Error>,
) -> Result<zbus::OwnedFd, BusError> {
    let who = caller(connection, Some(header)).await;
    audit(what, &who, &opened.as_ref().map(|_| ()));
    Ok(opened?.into())
}

fn state_name(t: &Telemetry) -> &'static str {
    match (t.frame.state, t.frame.calibrated) {
        (DeviceState::Running, false) => "calibrating",
        (state, _) => state.name(),
    }
}

fn pose(t: &Telemetry) -> Vec<f64> {
    t.frame.poses[..t.frame.effectors]
        .iter()
        .flat_map(|p| {
            let (x, [w, qx, qy, qz]) = (p.position, quat_to_wxyz(p.orientation));
            [x.x, x.y, x.z, w, qx, qy, qz]
        })
        .collect()
}

fn force(t: &Telemetry) -> Vec<f64> {
    t.frame.wrenches[..t.frame.effectors]
        .iter()
        .flat_map(Wrench::to_array)
        .collect()
}

fn statistics(t: &Telemetry) -> HashMap<String, f64> {
    let s = &t.stats;
    let us = |ns: u64| ns as f64 / 1e3;
    HashMap::from([
        ("ticks".to_string(), s.ticks as f64),
        ("overruns".to_string(), s.overruns as f64),
        (
            "overruns_woken_late".to_string(),
            s.overruns_woken_late as f64,
        ),
        ("wait_p50_us".to_string(), us(s.wait_percentile_ns(0.5))),
        ("wait_p99_us".to_string(), us(s.wait_percentile_ns(0.99))),
        ("wait_max_us".to_string(), us(s.wait_max_ns)),
        ("busy_mean_us".to_string(), us(s.busy_mean_ns())),
        ("busy_max_us".to_string(), us(s.busy_max_ns)),
    ])
}

/// The object of device `index` on `connection`.
async fn device_interface(
    connection: &zbus::Connection,
    index: usize,
) -> Option<zbus::object_server::InterfaceRef<DeviceInterface>> {
    let path = super::device_path(index);
    connection
        .object_server()
        .interface::<_, DeviceInterface>(path.as_str())
        .await
        .ok()
}

/// The telemetry of device `index` as it is now, for [`announce`] to compare with.
pub(super) async fn baseline(connection: &zbus::Connection, index: usize) -> Option<Telemetry> {
    let iface = device_interface(connection, index).await?;
    Some(iface.get().await.device.telemetry())
}

/// Announce what changed on device `index` since `last` was announced; returns what is
/// announced now.
pub(super) async fn announce(
    connection: &zbus::Connection,
    index: usize,
    last: Option<Telemetry>,
) -> Option<Telemetry> {
    let iface = device_interface(connection, index).await?;
    let device = iface.get().await;
    let now = device.device.telemetry();
    let emitter = iface.signal_emitter();
    if last.is_none_or(|l| state_name(&l) != state_name(&now)) {
        report(device.state_changed(emitter).await);
    }
    if last.is_none_or(|l| l.frame.command != now.frame.command) {
        report(device.wrench_command_changed(emitter).await);
    }
    let calibration = |t: &Telemetry| (t.frame.calibrated, t.frame.calibrations);
    if last.is_none_or(|l| calibration(&l) != calibration(&now)) {
        report(device.calibrated_changed(emitter).await);
        report(device.calibration_offsets_changed(emitter).await);
    }
    if last.is_none_or(|l| l.frame.time != now.frame.time) {
        // One signal for the whole burst: a client sees pose and force of the same tick.
        let changed = HashMap::from([
            ("Pose", Variant::from(pose(&now))),
            ("Force", Variant::from(force(&now))),
            ("Tensions", Variant::from(device.tensions())),
            ("Statistics", Variant::from(statistics(&now))),
        ]);
        let interface = zbus::names::InterfaceName::from_static_str_unchecked(DEVICE_INTERFACE);
        report(
            zbus::fdo::Properties::properties_changed(
                emitter,
                interface,
                changed,
                (&[][..]).into(),
            )
            .await,
        );
    }
    Some(now)
}

/// Announce `touches` of device `index`, a `Touch` signal each, the bodies named as
/// `bodies` names them.
pub(super) async fn announce_touches(
    connection: &zbus::Connection,
    index: usize,
    touches: &[super::touches::Touch],
    bodies: &[crate::control::Body],
) {
    let Some(iface) = device_interface(connection, index).await else {
        return;
    };
    let emitter = iface.signal_emitter();
    for t in touches {
        let name = bodies.get(t.body as usize).map_or("", |b| b.name.as_str());
        let body = i32::try_from(t.body).unwrap_or(-1);
        report(
            DeviceInterface::touch(
                emitter,
                t.effector,
                t.event.name(),
                t.tick,
                t.time,
                body,
                name,
                t.point.to_vec(),
                t.normal.to_vec(),
                t.force.to_vec(),
            )
            .await,
        );
    }
}

/// The Device interface: the methods and read-only properties as written, and a getter and
/// a checked, audited setter for each tunable parameter, generated from one table (name of
/// the getter, of the setter, the [`Name`], and the property's documentation).
macro_rules! device_interface {
    (
        parameters { $( $(#[doc = $doc:tt])* $get:ident, $set:ident => $name:ident; )* }
        $($members:tt)*
    ) => {
        /// A haptic device: its state and telemetry (updated ten times a second), its
        /// calibration, and the rendering parameters, which are checked, saved and applied
        /// on write.
        #[interface(name = "org.hapticd.Hapticd1.Device")]
        impl DeviceInterface {
            $(
                $(#[doc = $doc])*
                #[zbus(property)]
                fn $get(&self) -> f64 {
                    self.device.parameter(Name::$name)
                }

                #[zbus(property)]
                async fn $set(
                    &self,
                    value: f64,
                    #[zbus(connection)] connection: &zbus::Connection,
                    #[zbus(header)] header: Option<Header<'_>>,
                ) -> Result<(), BusError> {
                    self.set(Name::$name, value, connection, header).await
                }
            )*

            $($members)*
        }
    };
}

device_interface! {
    parameters {
        /// Tick rate for the next start, Hz (100 to 10000; USB amplifiers reach about 4000).
        rate, set_rate => Rate;
        /// Proxy spring, N/m (0 < k ≤ 100000), for scenes rendered through the proxy.
        stiffness, set_stiffness => Stiffness;
        /// Proxy damper, N·s/m (0 to 500).
        damping, set_damping => Damping;
        /// Static friction coefficient μ0 of the proxy (0 to 2).
        static_friction, set_static_friction => StaticFriction;
        /// Dynamic friction coefficient μ of the proxy (0 to StaticFriction).
        dynamic_friction, set_dynamic_friction => DynamicFriction;
        /// Regularisation λ of the string tension computation (0 to 10): larger values trade
        /// force accuracy for smoother tensions.
        lambda, set_lambda => Lambda;
        /// Largest force displayed on an end effector, N (0 < f ≤ 50).
        max_force, set_max_force => MaxForce;
        /// Largest torque displayed on an end effector, N·m (0 < τ ≤ 5).
        max_torque, set_max_torque => MaxTorque;
    }

    /// The device's identity: `usb:BUS-PORT` for an amplifier, `sim` for the simulated
    /// SPIDAR, `replay:FILE` for a recording. Calibration and parameters are remembered
    /// under it.
    #[zbus(property(emits_changed_signal = "const"))]
    fn identity(&self) -> String {
        self.device.identity().to_string()
    }

    /// The mechanism driven.
    #[zbus(property(emits_changed_signal = "const"))]
    fn mechanism(&self) -> String {
        self.device.mechanism().to_string()
    }

    /// The mechanism's end effectors by name, in the order of Pose (seven numbers each) and
    /// Force (six each).
    #[zbus(property(emits_changed_signal = "const"))]
    fn effectors(&self) -> Vec<String> {
        self.device.effectors().to_vec()
    }

    /// The mechanism bound with BindMechanism for the next start; empty when none.
    #[zbus(property)]
    fn bound_mechanism(&self) -> String {
        self.device.bound_mechanism().unwrap_or_default()
    }

    /// What the next start of the loop changes (Manager.Restart starts it): `mechanism` (a
    /// mechanism bound with BindMechanism) and `rate` (a changed Rate), with the values they
    /// will have; empty when nothing waits. Read it when needed: no signal announces it.
    #[zbus(property(emits_changed_signal = "false"))]
    fn pending(&self) -> HashMap<String, String> {
        self.device.pending().into_iter().collect()
    }

    /// running, calibrating, fault (forces ramped to zero), disconnected, or uncalibrated (the
    /// counts no longer fit the calibration: forces stay at zero until `Calibrate()`).
    #[zbus(property)]
    fn state(&self) -> String {
        state_name(&self.device.telemetry()).to_string()
    }

    /// Why the device is in its State, in a sentence: empty while running; for a fault,
    /// what faulted (a scene's output refused and why, a scene that did not render, a wrench
    /// that is not finite); for disconnected, the device's error; for uncalibrated, what to do.
    #[zbus(property)]
    fn state_reason(&self) -> String {
        let t = self.device.telemetry();
        match (t.frame.state, t.frame.calibrated) {
            (DeviceState::Running, false) => "waiting for the device's first reading".into(),
            (DeviceState::Running, true) => String::new(),
            (DeviceState::Fault, _) => t.frame.fault.to_string(),
            (DeviceState::Disconnected, _) => t
                .frame
                .error
                .map_or_else(|| "the device does not answer".into(), |e| e.to_string()),
            (DeviceState::Uncalibrated, _) => {
                "the counts no longer fit the calibration: forces stay at zero until Calibrate()"
                    .into()
            }
        }
    }

    /// The wrench commanded from outside (OpenWrenchInput): none (never opened), waiting
    /// (nothing written yet), active, or stale (ramped out).
    #[zbus(property)]
    fn wrench_command(&self) -> String {
        self.device.telemetry().frame.command.name().to_string()
    }

    /// Whether the counter offsets are set (by Calibrate, a saved calibration, or the first
    /// reading with the grips at their calibration poses).
    #[zbus(property)]
    fn calibrated(&self) -> bool {
        self.device.telemetry().frame.calibrated
    }

    /// Counter offset of each string, metres.
    #[zbus(property)]
    fn calibration_offsets(&self) -> Vec<f64> {
        let f = self.device.telemetry().frame;
        f.offsets[..f.strings].to_vec()
    }

    /// Pose of each end effector: x, y, z (m), then the orientation quaternion w, x, y, z.
    #[zbus(property)]
    fn pose(&self) -> Vec<f64> {
        pose(&self.device.telemetry())
    }

    /// Wrench displayed on each end effector: force x, y, z (N), then torque x, y, z (N·m).
    #[zbus(property)]
    fn force(&self) -> Vec<f64> {
        force(&self.device.telemetry())
    }

    /// Tension commanded on each string, newtons.
    #[zbus(property)]
    fn tensions(&self) -> Vec<f64> {
        let f = self.device.telemetry().frame;
        f.tensions[..f.strings].to_vec()
    }

    /// Haptic loop statistics: ticks, overruns, wake latency percentiles and maximum
    /// (wait_*_us) and tick compute time (busy_*_us), in microseconds.
    #[zbus(property)]
    fn statistics(&self) -> HashMap<String, f64> {
        statistics(&self.device.telemetry())
    }

    /// The real-time scheduling the haptic thread got (SCHED_FIFO and its priority, or why
    /// it was refused).
    #[zbus(property(emits_changed_signal = "const"))]
    fn scheduling(&self) -> String {
        self.device.scheduling().to_string()
    }

    /// The rate the haptic loop runs at now, ticks per second.
    #[zbus(property(emits_changed_signal = "const"))]
    fn loop_rate(&self) -> f64 {
        self.device.rate()
    }

    /// An effector's touch changed (`event`): it began touching a body (`begin`, also when
    /// it goes from one body to another), stopped (`end`), or began to slide along it after
    /// sticking (`slip`); at `tick` (loop time `time`, seconds), touching `body` (its id in
    /// the scene's Bodies, -1 for a solid that is no body) called `name`, at `point`
    /// (metres) along the surface's outward `normal` (the force's direction where the scene
    /// cannot say), displaying `force` (newtons). Read from the telemetry ring, so no tick's
    /// touch is missed; at most ten a device each tenth of a second.
    #[zbus(signal)]
    async fn touch(
        emitter: &SignalEmitter<'_>,
        effector: u32,
        event: &str,
        tick: u64,
        time: f64,
        body: i32,
        name: &str,
        point: Vec<f64>,
        normal: Vec<f64>,
        force: Vec<f64>,
    ) -> zbus::Result<()>;

    /// The world as pictures show it: a sealed memfd, read-only to the caller, that the
    /// haptic loop writes 60 times a second under a sequence lock (the layout is
    /// `hapticd_core::world_state::SharedWorld`). The renderer draws from it.
    fn open_world(&self) -> Result<zbus::OwnedFd, BusError> {
        Ok(self.device.open_world()?.into())
    }

    /// The running scene's solids as pictures show them: a sealed memfd, read-only to the
    /// caller, written once and sized by the scene (the layout is
    /// `hapticd_core::world_geometry`), and the `scene_switches` of the world's frames that
    /// count that scene. Ask again when the frames count another.
    fn open_geometry(&self) -> Result<(zbus::OwnedFd, u32), BusError> {
        let (fd, switches) = self.device.open_geometry()?;
        Ok((fd.into(), switches))
    }

    /// Every tick of the haptic loop: a sealed memfd, read-only to the caller, holding a ring
    /// of the last 8192 ticks (tick number, time, state, each effector's pose, velocity,
    /// angular velocity and wrench, contacts, tensions, D/A values), each slot under a sequence lock of its own
    /// (the layout is `hapticd_core::telemetry::SharedTelemetry`). A reader that falls behind
    /// only misses ticks, and sees which. `options` takes no key yet; any is refused.
    fn open_telemetry(
        &self,
        options: HashMap<String, zbus::OwnedVariant>,
    ) -> Result<zbus::OwnedFd, BusError> {
        if let Some(key) = options.keys().next() {
            return Err(crate::control::Error::OutOfRange(format!(
                "OpenTelemetry takes no option {key:?}"
            ))
            .into());
        }
        Ok(self.device.open_telemetry()?.into())
    }

    /// A wrench to add to what the scene displays, commanded from outside (teleoperation: what
    /// a remote robot feels): a memfd, readable and writable by the caller, holding a wrench
    /// per effector under a sequence lock (the layout is
    /// `hapticd_core::haptics::wrench_command::SharedWrenchCommand`). The haptic thread reads
    /// it every tick: each wrench is bounded by MaxForce and MaxTorque, ramped in, and ramped
    /// out when none newer has come for 0.1 s or one holds a NaN (WrenchCommand says
    /// `stale`). Each call replaces the block before. `options` takes no key yet.
    async fn open_wrench_input(
        &self,
        options: HashMap<String, zbus::OwnedVariant>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<zbus::OwnedFd, BusError> {
        let opened = no_options("OpenWrenchInput", &options)
            .and_then(|()| self.device.open_wrench_input());
        let what = format!("open the wrench input of {}", self.device.identity());
        audited(&what, connection, &header, opened).await
    }

    /// The link through which the device's remote scenes (`engine: remote`) reach a world
    /// stepped on another machine: a memfd, readable and writable by the caller (the network
    /// bridge), holding the latest world update and a ring of the device's messages to the
    /// world, each under a sequence lock (the layout is
    /// `hapticd_core::scene::world_link::SharedWorldLink`). What the caller delivers is
    /// checked as a plugin's planes are; a world that stops coming fades. Every call hands out
    /// the same link. `options` takes no key yet.
    async fn open_world_link(
        &self,
        options: HashMap<String, zbus::OwnedVariant>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<zbus::OwnedFd, BusError> {
        let opened =
            no_options("OpenWorldLink", &options).and_then(|()| self.device.open_world_link());
        let what = format!("open the world link of {}", self.device.identity());
        audited(&what, connection, &header, opened).await
    }

    /// Take the counter offsets now, with every grip held at its calibration pose; they are
    /// saved and restored when the device returns or the daemon restarts.
    async fn calibrate(
        &self,
        #[zbus(signal_emitter)] emitter: SignalEmitter<'_>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<(), BusError> {
        let device = self.device.clone();
        let result = self.workers.run(move || device.calibrate()).await;
        let who = caller(connection, Some(&header)).await;
        audit(
            &format!("calibrate {}", self.device.identity()),
            &who,
            &result,
        );
        result?;
        report(self.calibrated_changed(&emitter).await);
        report(self.calibration_offsets_changed(&emitter).await);
        Ok(())
    }

    /// The effects the device renders besides its scene, by id, each as written (YAML).
    #[zbus(property)]
    fn effects(&self) -> Vec<(u32, String)> {
        self.device.effects()
    }

    /// Start an effect (a spring, damper, friction, vibration, constant force, field or
    /// magnet: `effect` in YAML, one entry of a scene file's `effects:`); its id. Checked
    /// against the device (its effectors, MaxForce, rate): every mistake is an
    /// InvalidEffect error naming its place, and nothing starts.
    async fn add_effect(
        &self,
        effect: String,
        #[zbus(signal_emitter)] emitter: SignalEmitter<'_>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<u32, BusError> {
        let device = self.device.clone();
        let result = self.workers.run(move || device.add_effect(&effect)).await;
        let what = format!("add an effect to {}", self.device.identity());
        let asked = (&emitter, connection, &header);
        self.effects_changed_by(&what, result, asked).await
    }

    /// Cross-fade effect `id` into `effect` (YAML), never faster than the force-rate limit.
    async fn change_effect(
        &self,
        id: u32,
        effect: String,
        #[zbus(signal_emitter)] emitter: SignalEmitter<'_>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<(), BusError> {
        let device = self.device.clone();
        let result = self.workers.run(move || device.change_effect(id, &effect)).await;
        let what = format!("change effect {id} of {}", self.device.identity());
        let asked = (&emitter, connection, &header);
        self.effects_changed_by(&what, result, asked).await
    }

    /// Fade effect `id` out (over its fade, never faster than the force-rate limit).
    async fn remove_effect(
        &self,
        id: u32,
        #[zbus(signal_emitter)] emitter: SignalEmitter<'_>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<(), BusError> {
        let result = self.device.remove_effect(id);
        let what = format!("remove effect {id} of {}", self.device.identity());
        let asked = (&emitter, connection, &header);
        self.effects_changed_by(&what, result, asked).await
    }

    /// Fade every effect out.
    async fn clear_effects(
        &self,
        #[zbus(signal_emitter)] emitter: SignalEmitter<'_>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<(), BusError> {
        let result = self.device.clear_effects();
        let what = format!("clear the effects of {}", self.device.identity());
        let asked = (&emitter, connection, &header);
        self.effects_changed_by(&what, result, asked).await
    }

    /// Forget the scene's contact state and let the forces come back after a fault.
    async fn reset_fault(
        &self,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<(), BusError> {
        let device = self.device.clone();
        let result = self.workers.run(move || device.reset_fault()).await;
        let who = caller(connection, Some(&header)).await;
        audit(
            &format!("reset the fault of {}", self.device.identity()),
            &who,
            &result,
        );
        Ok(result?)
    }

    /// Drive this device with another installed mechanism from the next start (see
    /// Manager.Mechanisms); saved with the device's state.
    async fn bind_mechanism(
        &self,
        mechanism: String,
        #[zbus(signal_emitter)] emitter: SignalEmitter<'_>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<(), BusError> {
        let (daemon, device) = (self.daemon.clone(), self.device.clone());
        let what = format!("bind {} to mechanism {mechanism:?}", self.device.identity());
        let result = self
            .workers
            .run(move || daemon.bind_mechanism(&device, &mechanism))
            .await;
        audit(&what, &caller(connection, Some(&header)).await, &result);
        result?;
        report(self.bound_mechanism_changed(&emitter).await);
        Ok(())
    }
}
