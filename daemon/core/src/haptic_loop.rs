//! One device's haptic loop, one tick at a time:
//!
//! 1. one transport update: write the D/A values of the previous tick, read the counters;
//! 2. counts → lengths → pose of each effector (two warm-started Gauss–Newton iterations);
//! 3. the scene renders a wrench for each pointer;
//! 4. the passive effects join the scene's wrench, then the passivity controller; the
//!    active effects and a wrench commanded from outside (teleoperation) are added, then
//!    limits, NaN guard and fault ramp;
//! 5. wrench → tensions (the box QP) → D/A values, never above a motor's limit.
//!
//! Between ticks the loop takes [`LoopCommand`]s: new parameters, a calibration, a fault
//! reset, an effect added, changed or removed, a new scene (swapped in once the forces have ramped to zero, then ramped back up),
//! the device opened again after it came back, a new source of commanded wrenches.
//!
//! Everything is allocated in [`HapticLoop::new`]; a tick allocates nothing, takes no lock
//! and makes no system call but the device I/O. A replaced scene or link is handed back
//! through [`HapticLoop::take_retired`] so that it is freed off the real-time thread.

use glam::DVec3;
use hapticd_plugin_api::HapticdBodyPose;

use crate::fault_hold::{FaultHold, SCENE_RECOVERY};
use crate::haptics::effects::{EffectCommand, EffectSet, Grip};
use crate::haptics::passivity::{PassivityController, PassivityLimits};
use crate::haptics::safety::{SafetyGuard, SafetyLimits};
use crate::haptics::surface::SurfaceFeel;
use crate::haptics::wrench_command::{CommandState, WrenchCommand, WrenchSource};
use crate::kinematics::{
    MAX_EFFECTORS, MAX_STRINGS_PER_EFFECTOR, Pose, Wrench, pose_of, rotation_vector,
};
use crate::mechanism::Mechanism;
use crate::parameters::Parameters;
use crate::scene::output_check::OutputFault;
use crate::scene::{MAX_BODIES, Pointer, Scene, Touch};
use crate::solver::calibration::{lengths_from_counts, offsets_into};
use crate::solver::pose::PoseSolver;
use crate::solver::tension::{TensionSettings, TensionSolver};
use crate::transport::{
    CHANNELS, Link, Reading, Transport, TransportError, dac_for_tension, dac_limit,
};

/// Largest root-mean-square misfit, metres, between the measured string lengths and the best
/// pose for the counts to fit the calibration. Elastic stretch and encoder steps give well
/// under a millimetre (0.06 mm pressing on the simulated SPIDAR-G), small errors of a
/// descriptor a few; counts that a board restarted with its strings elsewhere miss by
/// centimetres (4 to 8 cm in the tests).
pub const FITTING_MISFIT: f64 = 0.01;

/// Gauss–Newton iterations when the grip may have moved far since the last reading.
const SEARCH_ITERATIONS: usize = 50;

/// Settings of a haptic loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopSettings {
    /// Gauss–Newton iterations per tick.
    pub pose_iterations: usize,
    /// Cut-off of the velocity filter, hertz.
    pub velocity_cutoff: f64,
    /// Force and torque limits and fault ramps.
    pub safety: SafetyLimits,
    /// How hard the passivity controller may act.
    pub passivity: PassivityLimits,
    /// How fast an effect's force may change as it starts, stops or changes, N/s.
    pub max_force_rate: f64,
}

/// The default force-rate limit, N/s: MaxForce's default, 10 N, in 2 ms.
pub const MAX_FORCE_RATE: f64 = 5000.0;

impl Default for LoopSettings {
    fn default() -> Self {
        Self {
            pose_iterations: 2,
            velocity_cutoff: 200.0,
            safety: SafetyLimits::default(),
            passivity: PassivityLimits::default(),
            max_force_rate: MAX_FORCE_RATE,
        }
    }
}

/// The device's state as the loop sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DeviceState {
    /// Rendering forces.
    #[default]
    Running,
    /// A fault drives the forces to zero (a failed scene, until it has rendered well for
    /// [`SCENE_RECOVERY`] seconds; or a non-finite wrench).
    Fault,
    /// The device does not answer.
    Disconnected,
    /// The counts fit no pose (checked every tick, with a search when the device returns,
    /// at start on a saved calibration, and whenever the warm-started pose misses): forces
    /// stay at zero until it is calibrated again.
    Uncalibrated,
}

impl DeviceState {
    /// The state in one lowercase word, as the bus and the pictures say it.
    pub fn name(self) -> &'static str {
        match self {
            DeviceState::Running => "running",
            DeviceState::Fault => "fault",
            DeviceState::Disconnected => "disconnected",
            DeviceState::Uncalibrated => "uncalibrated",
        }
    }
}

/// What one tick did: published to the rest of the daemon and to recordings.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Frame {
    /// Loop time, seconds since start.
    pub time: f64,
    /// State after this tick.
    pub state: DeviceState,
    /// Last transport error, if the device is not answering.
    pub error: Option<TransportError>,
    /// Effectors in use.
    pub effectors: usize,
    /// Solved pose of each effector.
    pub poses: [Pose; MAX_EFFECTORS],
    /// Filtered velocity of each effector.
    pub velocities: [DVec3; MAX_EFFECTORS],
    /// Filtered angular velocity of each effector, rad/s (zero for three degrees of freedom).
    pub angular_velocities: [DVec3; MAX_EFFECTORS],
    /// Wrench displayed on each effector (after passivity and safety).
    pub wrenches: [Wrench; MAX_EFFECTORS],
    /// Effects held (fading ones included).
    pub effects: usize,
    /// What each effector's pointer touches, as the scene says.
    pub touches: [Touch; MAX_EFFECTORS],
    /// Strings in use.
    pub strings: usize,
    /// Tension commanded on each string, newtons.
    pub tensions: [f64; CHANNELS],
    /// D/A value written next tick for each channel.
    pub dac: [i16; CHANNELS],
    /// Whether the counter offsets are set.
    pub calibrated: bool,
    /// Calibrations taken since start (the first reading counts as one).
    pub calibrations: u32,
    /// Counter offset of each string, metres.
    pub offsets: [f64; CHANNELS],
    /// Offsets measured by [`LoopCommand::MeasureOffsets`] and not yet used, metres.
    pub measured: [f64; CHANNELS],
    /// Measurements taken since start.
    pub measurements: u32,
    /// Scenes swapped in since start.
    pub scene_switches: u32,
    /// What became of the wrench commanded from outside.
    pub command: CommandState,
    /// Why the device is in fault, when it is.
    pub fault: FaultCause,
}

/// Why a tick left the device in fault: what the bus and the log say of it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum FaultCause {
    /// No fault.
    #[default]
    None,
    /// A wrench that is not a finite number.
    NotFinite,
    /// The scene's plugin output was refused at the boundary, and the plugin disabled.
    SceneOutput(OutputFault),
    /// The scene did not render (its plugin failed, or has not rendered well for long enough
    /// since).
    SceneFailed,
}

impl std::fmt::Display for FaultCause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FaultCause::None => Ok(()),
            FaultCause::NotFinite => f.write_str("a wrench that is not a finite number"),
            FaultCause::SceneOutput(fault) => write!(
                f,
                "the scene plugin's output was refused ({fault}): the plugin is disabled until \
                 a scene is switched to"
            ),
            FaultCause::SceneFailed => f.write_str(
                "the scene did not render (its plugin failed, or has not yet rendered well for \
                 long enough since)",
            ),
        }
    }
}

/// A request to the haptic loop, applied between ticks.
// An effect crosses to the haptic thread by value, so that the thread never frees it: the
// ring's slots are as large as an effect (a waveform's samples).
#[allow(clippy::large_enum_variant)]
pub enum LoopCommand {
    /// Render with these parameters from now on.
    Tune(Parameters),
    /// Measure the counter offsets of the next reading into [`Frame::measured`] (the grips
    /// are at their calibration poses), without using them: a calibration is used only once
    /// it is saved.
    MeasureOffsets,
    /// Calibrate with these counter offsets (one per string, from
    /// [`LoopCommand::MeasureOffsets`]): the grips are near their calibration poses.
    UseOffsets([f64; CHANNELS]),
    /// Forget the scene's contact state and start the forces again from zero.
    ResetFault,
    /// Ramp the forces to zero, swap in this scene, ramp them back up.
    SwitchScene(Box<dyn Scene>),
    /// Talk to the device through this link from now on: it was unplugged and is back.
    Reconnect(Box<dyn Link>),
    /// Add the wrenches commanded in this block to the displayed ones from now on (the
    /// block read before is handed back).
    CommandWrenches(Box<dyn WrenchSource>),
    /// Add, change or remove an effect.
    Effect(EffectCommand),
}

/// Something the loop no longer uses, handed back to be freed off the real-time thread.
pub enum Retired {
    /// A scene swapped out.
    Scene(Box<dyn Scene>),
    /// A link replaced (or one that could not be used), still open.
    Link(Box<dyn Link>),
    /// A block of commanded wrenches no longer read.
    WrenchSource(Box<dyn WrenchSource>),
}

struct EffectorLoop {
    strings: [usize; MAX_STRINGS_PER_EFFECTOR],
    count: usize,
    pose: PoseSolver,
    tension: TensionSolver,
    passivity: PassivityController,
    guard: SafetyGuard,
    previous: Pose,
    velocity: DVec3,
    spin: DVec3,
    /// What it feels of the surface materials it touches.
    surface: SurfaceFeel,
}

/// The haptic loop of one device.
pub struct HapticLoop {
    mechanism: Mechanism,
    transport: Box<dyn Transport>,
    scene: Box<dyn Scene>,
    settings: LoopSettings,
    effectors: Vec<EffectorLoop>,
    offsets: Vec<f64>,
    /// Largest D/A magnitude of each string: its tension limit within the amplifier's range.
    dac_limits: [i16; CHANNELS],
    calibration_lengths: Vec<f64>,
    metres_per_pulse: Vec<f64>,
    calibrated: bool,
    /// A measurement of the offsets is asked for.
    measure: bool,
    reading: Reading,
    lengths: Vec<f64>,
    pointers: Vec<Pointer>,
    wrenches: Vec<Wrench>,
    /// The wrench commanded from outside, and each effector's share of it this tick.
    command: WrenchCommand,
    commanded: [Wrench; MAX_EFFECTORS],
    effects: EffectSet,
    /// The poses of the bodies effects move with, this tick (on the heap: a loop is moved
    /// whole to its thread).
    body_poses: Box<[HapticdBodyPose]>,
    frame: Frame,
    parameters: Option<Parameters>,
    incoming: Option<Box<dyn Scene>>,
    check_fit: bool,
    misfit: bool,
    /// A scene that failed is trusted again only once it has rendered well for a while.
    scene_hold: FaultHold,
    retired_scene: Option<Box<dyn Scene>>,
    retired_link: Option<Box<dyn Link>>,
    retired_source: Option<Box<dyn WrenchSource>>,
}

/// Why a loop cannot be built.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LoopError(pub String);

impl std::fmt::Display for LoopError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for LoopError {}

impl HapticLoop {
    /// A loop for `mechanism` on `transport`, rendering `scene`. Until calibrated, the first
    /// reading is taken with every grip at its calibration pose.
    pub fn new(
        mechanism: Mechanism,
        transport: Box<dyn Transport>,
        mut scene: Box<dyn Scene>,
        settings: LoopSettings,
    ) -> Result<Self, LoopError> {
        if mechanism.strings.len() > CHANNELS {
            return Err(LoopError(format!(
                "{} has {} strings; one amplifier board drives {CHANNELS}",
                mechanism.name,
                mechanism.strings.len()
            )));
        }
        if mechanism.effectors.len() > MAX_EFFECTORS {
            return Err(LoopError(format!(
                "at most {MAX_EFFECTORS} effectors per device"
            )));
        }
        let effectors: Vec<EffectorLoop> = mechanism
            .effectors
            .iter()
            .enumerate()
            .map(|(index, e)| {
                let mut strings = [0; MAX_STRINGS_PER_EFFECTOR];
                strings[..e.strings.len()].copy_from_slice(&e.strings);
                EffectorLoop {
                    strings,
                    count: e.strings.len(),
                    pose: PoseSolver::new(mechanism.kinematics(index), e.calibration),
                    tension: mechanism.tension_solver(index),
                    passivity: PassivityController::new(settings.passivity),
                    guard: SafetyGuard::new(settings.safety),
                    previous: e.calibration,
                    velocity: DVec3::ZERO,
                    spin: DVec3::ZERO,
                    surface: SurfaceFeel::default(),
                }
            })
            .collect();
        let pointers = Pointer::at_calibration(&mechanism);
        scene.set_wrench_limits(settings.safety.max_force, settings.safety.max_torque);
        let frame = Frame {
            effectors: mechanism.effectors.len(),
            strings: mechanism.strings.len(),
            ..Frame::default()
        };
        Ok(Self {
            offsets: vec![0.0; mechanism.strings.len()],
            dac_limits: std::array::from_fn(|i| {
                mechanism
                    .strings
                    .get(i)
                    .map_or(0, |s| dac_limit(s.tension_max, s.volts_per_newton))
            }),
            calibration_lengths: mechanism.calibration_lengths(),
            metres_per_pulse: mechanism.metres_per_pulse(),
            calibrated: false,
            measure: false,
            reading: Reading::default(),
            lengths: vec![0.0; mechanism.strings.len()],
            wrenches: vec![Wrench::ZERO; pointers.len()],
            command: WrenchCommand::new(),
            commanded: [Wrench::ZERO; MAX_EFFECTORS],
            effects: EffectSet::new(settings.safety.max_force, settings.max_force_rate),
            body_poses: vec![HapticdBodyPose::default(); MAX_BODIES].into_boxed_slice(),
            pointers,
            effectors,
            settings,
            mechanism,
            transport,
            scene,
            frame,
            parameters: None,
            incoming: None,
            check_fit: false,
            misfit: false,
            scene_hold: FaultHold::new(SCENE_RECOVERY),
            retired_scene: None,
            retired_link: None,
            retired_source: None,
        })
    }

    /// Start from these counter offsets (a saved calibration) instead of calibrating on the
    /// first reading. Refused unless there is one offset per string.
    pub fn restore_calibration(&mut self, offsets: &[f64]) -> Result<(), LoopError> {
        if offsets.len() != self.offsets.len() || offsets.iter().any(|o| !o.is_finite()) {
            return Err(LoopError(format!(
                "a calibration of {} finite offsets is needed for {}, not {offsets:?}",
                self.offsets.len(),
                self.mechanism.name
            )));
        }
        self.offsets.copy_from_slice(offsets);
        self.calibrated = true;
        // The board may have restarted its counts elsewhere since they were saved.
        self.check_fit = true;
        self.frame.calibrated = true;
        self.frame.offsets[..offsets.len()].copy_from_slice(offsets);
        Ok(())
    }

    /// [rt] Apply `command` (takes effect at the next tick).
    pub fn command(&mut self, command: LoopCommand) {
        match command {
            LoopCommand::Tune(parameters) => {
                for e in &mut self.effectors {
                    let settings = e.tension.settings();
                    e.tension.set_settings(TensionSettings {
                        lambda: parameters.lambda,
                        ..settings
                    });
                    e.guard.set_limits(SafetyLimits {
                        max_force: parameters.max_force,
                        max_torque: parameters.max_torque,
                        ..*e.guard.limits()
                    });
                }
                self.scene.set_proxy(&parameters.proxy);
                self.scene
                    .set_wrench_limits(parameters.max_force, parameters.max_torque);
                self.effects
                    .set_limits(parameters.max_force, self.settings.max_force_rate);
                self.parameters = Some(parameters);
            }
            LoopCommand::MeasureOffsets => self.measure = true,
            LoopCommand::UseOffsets(offsets) => {
                let strings = self.offsets.len();
                self.offsets.copy_from_slice(&offsets[..strings]);
                self.calibrated = true;
                (self.check_fit, self.misfit) = (false, false);
                // The grips are held at their calibration poses: search from there.
                for (e, effector) in self.effectors.iter_mut().zip(&self.mechanism.effectors) {
                    e.pose.reset(effector.calibration);
                }
                self.frame.calibrated = true;
                self.frame.calibrations += 1;
                self.frame.offsets[..strings].copy_from_slice(&self.offsets);
            }
            LoopCommand::ResetFault => {
                self.scene.reset(&self.pointers);
                self.scene_hold.clear();
                for e in &mut self.effectors {
                    e.passivity.reset();
                    e.surface.reset();
                }
            }
            LoopCommand::SwitchScene(scene) => {
                // A scene still waiting for its turn is dropped for the newer one.
                if let Some(waiting) = self.incoming.replace(scene) {
                    self.keep_retired(Retired::Scene(waiting));
                }
            }
            LoopCommand::Reconnect(link) => {
                // The link replaced, or the one sent if this transport cannot take it.
                let old = self
                    .transport
                    .replace_link(link)
                    .unwrap_or_else(|sent| sent);
                self.keep_retired(Retired::Link(old));
            }
            LoopCommand::CommandWrenches(source) => {
                if let Some(old) = self.command.replace(source) {
                    self.keep_retired(Retired::WrenchSource(old));
                }
            }
            // The control plane numbers effects and counts them against MAX_EFFECTS.
            LoopCommand::Effect(command) => {
                let _ = self.effects.command(command);
            }
        }
    }

    /// [rt] Something the loop stopped using, to be freed by another thread.
    pub fn take_retired(&mut self) -> Option<Retired> {
        self.retired_link
            .take()
            .map(Retired::Link)
            .or_else(|| self.retired_scene.take().map(Retired::Scene))
            .or_else(|| self.retired_source.take().map(Retired::WrenchSource))
    }

    /// [rt] Hold `retired` until [`HapticLoop::take_retired`] hands it on (again, when it could
    /// not be sent). One of each kind waits; an older one would be freed here, which cannot
    /// happen while the daemon collects each before it sends the next.
    pub fn keep_retired(&mut self, retired: Retired) {
        match retired {
            Retired::Scene(scene) => drop(self.retired_scene.replace(scene)),
            Retired::Link(link) => drop(self.retired_link.replace(link)),
            Retired::WrenchSource(source) => drop(self.retired_source.replace(source)),
        }
    }

    /// Swap in the incoming scene once every effector's force is down to zero, and let the
    /// scene carry out what waited for that.
    fn swap_scene_when_quiet(&mut self) {
        if self.effectors.iter().any(|e| e.guard.gain() > 0.0) {
            return;
        }
        if self.scene.needs_quiet() {
            self.scene.quiet();
        }
        let Some(mut scene) = self.incoming.take() else {
            return;
        };
        scene.reset(&self.pointers);
        if let Some(p) = &self.parameters {
            scene.set_proxy(&p.proxy);
        }
        let limits = self.limits();
        scene.set_wrench_limits(limits.max_force, limits.max_torque);
        let old = std::mem::replace(&mut self.scene, scene);
        self.scene_hold.clear();
        self.keep_retired(Retired::Scene(old));
        self.frame.scene_switches += 1;
    }

    /// The force and torque limits in force (every effector has the same).
    fn limits(&self) -> SafetyLimits {
        self.effectors
            .first()
            .map_or(self.settings.safety, |e| *e.guard.limits())
    }

    /// The mechanism driven.
    pub fn mechanism(&self) -> &Mechanism {
        &self.mechanism
    }

    /// The transport.
    pub fn transport(&self) -> &dyn Transport {
        self.transport.as_ref()
    }

    /// The scene rendered.
    pub fn scene(&self) -> &dyn Scene {
        self.scene.as_ref()
    }

    /// [rt] The scene rendered, to ask it what pictures show.
    pub fn scene_mut(&mut self) -> &mut dyn Scene {
        self.scene.as_mut()
    }

    /// The last tick's frame.
    pub fn frame(&self) -> &Frame {
        &self.frame
    }

    /// [rt] Run one tick of `dt` seconds.
    pub fn tick(&mut self, dt: f64) -> &Frame {
        self.frame.time += dt;
        let update = self.transport.update(&self.frame.dac, &mut self.reading);
        let connected = update.is_ok();
        let mut scene_ok = true;
        if connected {
            scene_ok = self.sense_and_render(dt);
        } else {
            self.wrenches.fill(Wrench::ZERO);
        }
        let switching = self.incoming.is_some() || self.scene.needs_quiet();
        let limits = self.limits();
        let n = self.effectors.len();
        self.command.update(dt, &limits, &mut self.commanded[..n]);
        self.frame.command = self.command.state();
        let healthy = connected && scene_ok && !switching && !self.misfit;
        let all_finite = self.drive_strings(dt, healthy);
        self.set_state(update, all_finite, scene_ok);
        &self.frame
    }

    /// [rt] Take offsets when due, solve the poses and render the scene; whether it is healthy.
    #[inline]
    fn sense_and_render(&mut self, dt: f64) -> bool {
        self.take_offsets();
        let returning = self.frame.state == DeviceState::Disconnected;
        // After a restore or a return the grip may be anywhere: search for it.
        let search = std::mem::take(&mut self.check_fit) || returning;
        let fits = |misfit: f64| misfit <= FITTING_MISFIT;
        let mut misfit = self.solve_poses(dt, search);
        if !search && !fits(misfit) {
            // The warm start lost the grip (or the counts went wrong): search first.
            misfit = self.solve_poses(dt, true);
        }
        // Counts that fit no pose (NaN included) are not trusted until calibrated again.
        if !fits(misfit) {
            self.misfit = true;
            self.frame.calibrated = false;
        }
        if returning {
            self.scene.reset(&self.pointers);
        }
        self.swap_scene_when_quiet();
        let rendered = self.scene.render(&self.pointers, dt, &mut self.wrenches);
        let scene_ok = self.scene_hold.update(rendered, dt);
        self.frame.touches = [Touch::NONE; MAX_EFFECTORS];
        if rendered {
            let n = self.pointers.len();
            self.scene.write_touches(&mut self.frame.touches[..n]);
        }
        scene_ok
    }

    /// [rt] Take the offsets from the counts: at start if uncalibrated, and when asked to measure.
    #[inline]
    fn take_offsets(&mut self) {
        if !self.calibrated {
            // Grips are held at their calibration poses when the device starts.
            let counts = &self.reading.counts[..self.mechanism.strings.len()];
            offsets_into(
                &self.calibration_lengths,
                &self.metres_per_pulse,
                counts,
                &mut self.offsets,
            );
            self.calibrated = true;
            (self.check_fit, self.misfit) = (false, false);
            self.frame.calibrated = true;
            self.frame.calibrations += 1;
            self.frame.offsets[..self.offsets.len()].copy_from_slice(&self.offsets);
        }
        if std::mem::take(&mut self.measure) {
            let strings = self.offsets.len();
            offsets_into(
                &self.calibration_lengths,
                &self.metres_per_pulse,
                &self.reading.counts[..strings],
                &mut self.frame.measured[..strings],
            );
            self.frame.measurements += 1;
        }
    }

    /// [rt] Guard each effector's wrench and set its strings' currents; whether all were finite.
    #[inline]
    fn drive_strings(&mut self, dt: f64, healthy: bool) -> bool {
        let mut all_finite = true;
        self.effects.advance(dt);
        self.frame.effects = self.effects.count();
        // The bodies effects move with, and those whose textures or shaded meshes the pointers
        // touch (the materials are looked up again below: reading the poses takes the scene
        // mutably).
        let touched = (0..self.effectors.len()).filter_map(|i| {
            let touch = &self.frame.touches[i];
            let textured = self
                .scene
                .material(i, touch)
                .is_some_and(|m| m.texture.is_some());
            let felt = textured || self.scene.smooth_mesh(touch).is_some();
            let body = touch.body as usize;
            (felt && body < MAX_BODIES).then_some(body + 1)
        });
        let needed = touched.fold(self.effects.bodies_needed(), usize::max);
        let bodies = match needed {
            0 => 0,
            n => self.scene.write_bodies(&mut self.body_poses[..n]).min(n),
        };
        for (index, e) in self.effectors.iter_mut().enumerate() {
            let grip = Grip {
                pose: *e.pose.pose(),
                velocity: e.velocity,
            };
            let touch = &self.frame.touches[index];
            let material = self.scene.material(index, touch);
            let body = self.body_poses[..bodies]
                .get(touch.body as usize)
                .map(pose_of);
            if let (Some(mesh), Some(body)) = (self.scene.smooth_mesh(touch), body) {
                let force = &mut self.wrenches[index].force;
                *force = mesh.shade(*force, touch, &body);
            }
            let (texture, ring) = e.surface.update(material, touch, body, e.velocity, dt);
            let (passive, active) =
                self.effects
                    .wrenches(index, &grip, dt, ring, &self.body_poses[..bodies]);
            // Passive effects and textures are watched by the observer like the scene.
            let mut wrench = self.wrenches[index] + passive + Wrench::force(texture);
            wrench.force = e.passivity.filter(wrench.force, e.velocity, dt);
            // What active effects and the far side give is energy by design: past the
            // passivity controller, but within the limits and the guard like the rest.
            wrench = wrench + active + self.commanded[index];
            all_finite &= e.guard.apply(&mut wrench, healthy, dt);
            self.frame.wrenches[index] = wrench;
            self.frame.poses[index] = *e.pose.pose();
            self.frame.velocities[index] = e.velocity;
            self.frame.angular_velocities[index] = e.spin;
            let solved =
                (e.guard.gain() > 0.0).then(|| e.tension.solve(e.pose.geometry(), &wrench));
            for k in 0..e.count {
                let s = &self.mechanism.strings[e.strings[k]];
                let tension = solved.map_or(0.0, |t| t.tensions[k].clamp(0.0, s.tension_max));
                self.frame.tensions[e.strings[k]] = tension;
                // Whatever the solver and the descriptor gave, never past the string's limit.
                let limit = self.dac_limits[e.strings[k]];
                self.frame.dac[e.strings[k]] =
                    dac_for_tension(tension, s.volts_per_newton).clamp(-limit, limit);
            }
        }
        all_finite
    }

    /// [rt] Set the frame's state, transport error and fault cause from how the tick went.
    #[inline]
    fn set_state(&mut self, update: Result<(), TransportError>, all_finite: bool, scene_ok: bool) {
        (self.frame.state, self.frame.error) = match update {
            Err(e) => (DeviceState::Disconnected, Some(e)),
            Ok(()) if self.misfit => (DeviceState::Uncalibrated, None),
            Ok(()) if !all_finite || !scene_ok => (DeviceState::Fault, None),
            Ok(()) => (DeviceState::Running, None),
        };
        self.frame.fault = match (self.frame.state, self.scene.fault()) {
            (DeviceState::Fault, _) if !all_finite => FaultCause::NotFinite,
            (DeviceState::Fault, Some(fault)) => FaultCause::SceneOutput(fault),
            (DeviceState::Fault, None) => FaultCause::SceneFailed,
            _ => FaultCause::None,
        };
    }

    /// Solve every effector's pose, warm-started, or with a long `search` from the last pose
    /// (the velocity then starts again from rest); returns the largest misfit (RMS, metres).
    fn solve_poses(&mut self, dt: f64, search: bool) -> f64 {
        let iterations = if search {
            SEARCH_ITERATIONS
        } else {
            self.settings.pose_iterations
        };
        lengths_from_counts(
            &self.offsets,
            &self.metres_per_pulse,
            &self.reading.counts,
            &mut self.lengths,
        );
        let alpha = (-std::f64::consts::TAU * self.settings.velocity_cutoff * dt).exp();
        let mut misfit: f64 = 0.0;
        for (e, pointer) in self.effectors.iter_mut().zip(&mut self.pointers) {
            let mut own = [0.0; MAX_STRINGS_PER_EFFECTOR];
            for (length, &s) in own.iter_mut().zip(&e.strings[..e.count]) {
                *length = self.lengths[s];
            }
            let estimate = e.pose.solve(&own[..e.count], iterations);
            misfit = misfit.max(estimate.residual);
            let pose = estimate.pose;
            (e.velocity, e.spin) = if search {
                (DVec3::ZERO, DVec3::ZERO)
            } else {
                let moved = (pose.position - e.previous.position) / dt;
                let turned =
                    rotation_vector(pose.orientation * e.previous.orientation.inverse()) / dt;
                (
                    alpha * e.velocity + (1.0 - alpha) * moved,
                    alpha * e.spin + (1.0 - alpha) * turned,
                )
            };
            e.previous = pose;
            *pointer = Pointer {
                pose,
                velocity: e.velocity,
            };
        }
        misfit
    }

    /// [rt] Write zero currents to every motor (on shutdown).
    pub fn zero_motors(&mut self) -> Result<(), TransportError> {
        self.frame.dac = [0; CHANNELS];
        self.frame.tensions = [0.0; CHANNELS];
        self.transport.update(&[0; CHANNELS], &mut self.reading)
    }
}
