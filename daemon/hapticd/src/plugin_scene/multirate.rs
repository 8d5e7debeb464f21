//! A multi-rate scene (thesis Ch. 6): the plugin steps in a physics thread, the haptic side
//! renders its planes in the tick.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;

use hapticd_plugin_api::export::{PhysicsInput, PhysicsOutput};
use hapticd_plugin_api::*;

use crate::physics_budget::Pacer;
use glam::DVec3;
use hapticd_core::haptics::proxy::ProxyParameters;
use hapticd_core::haptics::shading::SmoothMesh;
use hapticd_core::haptics::surface::{Material, Surfaces};
use hapticd_core::kinematics::{MAX_EFFECTORS, Wrench};
use hapticd_core::scene::control::{Incoming, Reply, Request, SceneControl};
use hapticd_core::scene::exact_shapes::ExactShapes;
use hapticd_core::scene::held_part::HeldPart;
use hapticd_core::scene::multirate::{
    HandBack, PlaneRenderer, PlaneSet, pose_between, proxy_record,
};
use hapticd_core::scene::output_check::{
    OutputFault, check_bodies, check_compliances, check_mobilities, check_planes,
};
use hapticd_core::scene::{Pointer, Scene, Touch};
use hapticd_core::sync::spsc;
use hapticd_core::sync::triple_buffer::{self, Reader, Writer};
use hapticd_core::world_state::{MAX_BODIES, body_pose, pose_of};
use hapticd_service::clock::monotonic_ns;

use super::{Commands, Hands, Instance, Taken};

/// The bodies as the last two physics steps left them, for pictures between steps.
#[derive(Clone)]
pub(crate) struct BodySet {
    count: usize,
    before: Box<[HapticdBodyPose]>,
    /// Where the last step left them.
    pub(crate) after: Box<[HapticdBodyPose]>,
}

impl BodySet {
    fn new() -> Self {
        Self {
            count: 0,
            before: vec![HapticdBodyPose::default(); MAX_BODIES].into(),
            after: vec![HapticdBodyPose::default(); MAX_BODIES].into(),
        }
    }
}

/// A multi-rate scene: the plugin runs in a physics thread, the haptic side in the tick.
pub(crate) struct MultiRateScene {
    name: String,
    geometry: Geometry,
    /// The control plane's end of its world's control, until taken.
    control: Option<SceneControl>,
    /// Requests from the control plane, handed on to the physics thread.
    incoming: Option<Incoming>,
    /// The body of each object of its planes.
    object_bodies: Vec<u32>,
    to_physics: spsc::Producer<Request>,
    /// The sequence of the latest planes, and the one a change that waited for quiet is
    /// felt from (the physics has carried it out and published planes after it).
    seen: u64,
    settling: Option<u64>,
    renderer: PlaneRenderer,
    bodies_in: Reader<BodySet>,
    hands_out: Writer<Hands>,
    planes_in: Reader<PlaneSet>,
    hand_backs: spsc::Producer<HandBack>,
    rate: f64,
    /// Physics steps taken, and how many of them fell behind the world's rate.
    steps: Arc<(AtomicU64, AtomicU64)>,
    failed: Arc<AtomicBool>,
    /// Why the physics thread disabled the plugin, when it was for its planes: sent before
    /// `failed` is set, kept in `fault` once taken.
    faults_in: spsc::Consumer<OutputFault>,
    fault: Option<OutputFault>,
    stop: Arc<AtomicBool>,
    /// The thread that steps or receives the world.
    pub(crate) thread: Option<JoinHandle<()>>,
    /// The materials of its bodies' surfaces.
    surfaces: Surfaces,
}

/// The physics thread's ends of a multi-rate scene's channels, and what it publishes.
pub(crate) struct PhysicsSide {
    requests: spsc::Consumer<Request>,
    /// The grips and proxies as the haptic side last published them.
    pub(crate) hands_in: Reader<Hands>,
    planes_out: Writer<PlaneSet>,
    bodies_out: Writer<BodySet>,
    hand_backs_in: spsc::Consumer<HandBack>,
    faults_out: spsc::Producer<OutputFault>,
    stop: Arc<AtomicBool>,
    failed: Arc<AtomicBool>,
    /// Steps taken, and how many fell behind the world's rate.
    pub(crate) steps: Arc<(AtomicU64, AtomicU64)>,
    /// Pointers of the scene.
    pub(crate) pointers: usize,
    /// The sequence of the last set published.
    sequence: u64,
    /// Where the bodies were after the last two steps; a step writes `after`.
    pub(crate) bodies: BodySet,
}

impl PhysicsSide {
    /// Whether the scene is being dropped.
    pub(crate) fn stopping(&self) -> bool {
        self.stop.load(Ordering::Acquire)
    }

    /// What the haptic side handed back since the last call, into `taken` (emptied first).
    fn take_hand_backs(&mut self, taken: &mut Taken) {
        taken.impulses.clear();
        taken.locals.clear();
        taken.touched.clear();
        self.add_hand_backs(taken);
    }

    /// What the haptic side handed back since the last call, added to `taken`.
    pub(crate) fn add_hand_backs(&mut self, taken: &mut Taken) {
        while let Some(back) = self.hand_backs_in.pop() {
            match back {
                HandBack::Impulse(i) => taken.impulses.push(i),
                HandBack::Local(l, touched) => {
                    taken.locals.push(l);
                    taken.touched.push(touched);
                }
            }
        }
    }

    /// Disable the scene, for `fault` when it is the world's output.
    pub(crate) fn fail(&mut self, fault: Option<OutputFault>) {
        if let Some(fault) = fault {
            self.faults_out.push(fault);
        }
        self.failed.store(true, Ordering::Release);
    }

    /// Publish `set` as the next one, with the first `count` poses of `bodies.after`; planes
    /// or bodies no world publishes disable the scene instead, as a failure does (false).
    pub(crate) fn publish(&mut self, set: &mut PlaneSet, count: usize) -> bool {
        let checked = check_planes(&set.planes[..self.pointers])
            .and_then(|()| check_bodies(&set.bodies, set.body_count))
            .and_then(|()| check_mobilities(&set.mobilities, set.body_count))
            .and_then(|()| check_compliances(&set.planes, &set.compliances));
        if let Err(fault) = checked {
            self.fail(Some(fault));
            return false;
        }
        self.sequence += 1;
        set.sequence = self.sequence;
        self.planes_out.publish(|out| *out = *set);
        let bodies = &mut self.bodies;
        if self.sequence == 1 {
            bodies.before[..count].copy_from_slice(&bodies.after[..count]);
        }
        self.bodies_out.publish(|out| {
            out.count = count;
            out.before[..count].copy_from_slice(&bodies.before[..count]);
            out.after[..count].copy_from_slice(&bodies.after[..count]);
        });
        std::mem::swap(&mut bodies.before, &mut bodies.after);
        bodies.after[..count].copy_from_slice(&bodies.before[..count]);
        true
    }
}

impl MultiRateScene {
    /// The haptic side of a world at `rate` Hz for `pointers`, and the physics side's ends;
    /// no thread yet.
    pub(crate) fn new(
        name: String,
        (geometry, control, commands, object_bodies): (
            Geometry,
            Option<SceneControl>,
            Option<Commands>,
            Vec<u32>,
        ),
        rate: f64,
        pointers: &[Pointer],
    ) -> (Self, PhysicsSide, Option<spsc::Producer<Reply>>) {
        let (incoming, replies) = commands.unzip();
        let (to_physics, requests) = spsc::channel(16);
        let mut initial = [HapticdPointer::default(); MAX_EFFECTORS];
        for (out, p) in initial.iter_mut().zip(pointers) {
            *out = p.to_abi();
        }
        let (hands_out, hands_in) = triple_buffer::triple_buffer(Hands {
            pointers: initial,
            proxies: initial,
        });
        let (planes_out, planes_in) = triple_buffer::triple_buffer(PlaneSet::default());
        let (bodies_out, bodies_in) = triple_buffer::triple_buffer(BodySet::new());
        let (hand_backs, hand_backs_in) = spsc::channel(1024);
        let (faults_out, faults_in) = spsc::channel(1);
        let (stop, failed) = (
            Arc::new(AtomicBool::new(false)),
            Arc::new(AtomicBool::new(false)),
        );
        let steps = Arc::new((AtomicU64::new(0), AtomicU64::new(0)));
        let physics = PhysicsSide {
            requests,
            hands_in,
            planes_out,
            bodies_out,
            hand_backs_in,
            faults_out,
            stop: stop.clone(),
            failed: failed.clone(),
            steps: steps.clone(),
            pointers: pointers.len(),
            sequence: 0,
            bodies: BodySet::new(),
        };
        let scene = Self {
            name,
            geometry,
            control,
            incoming,
            object_bodies,
            to_physics,
            seen: 0,
            settling: None,
            renderer: PlaneRenderer::new(rate, pointers),
            bodies_in,
            hands_out,
            planes_in,
            hand_backs,
            rate,
            steps,
            failed,
            faults_in,
            fault: None,
            stop,
            thread: None,
            surfaces: Surfaces::default(),
        };
        (scene, physics, replies)
    }

    /// Start the physics thread of `instance` at `rate` Hz for `pointers`, the `held` body
    /// rendered by its god-object and the `exact` balls and boxes touched as themselves.
    pub(super) fn start(
        name: String,
        instance: Instance,
        parts: (Geometry, Option<SceneControl>, Option<Commands>, Vec<u32>),
        (held, exact): (Option<HeldPart>, ExactShapes),
        rate: f64,
        pointers: &[Pointer],
    ) -> std::io::Result<Self> {
        let (mut scene, mut physics, mut replies) = Self::new(name, parts, rate, pointers);
        if let Some(mut held) = held {
            held.keep_to_the_clock();
            scene.renderer.hold(held);
        }
        scene.renderer.set_exact_shapes(exact);
        let n = pointers.len();
        let period_ns = (1e9 / rate) as u64;
        let name = scene.name.clone();
        scene.thread = Some(
            std::thread::Builder::new()
                .name("hapticd-physics".into())
                .spawn(move || {
                    // Off the haptic CPUs like every helper, and real-time only while its
                    // steps fit its budget.
                    let mut pacer = Pacer::new(name, period_ns);
                    // Move the whole instance in (not just its fields): it is destroyed with
                    // it.
                    let instance = instance;
                    let mut taken = Taken {
                        impulses: Vec::with_capacity(1024),
                        locals: Vec::with_capacity(1024),
                        touched: Vec::with_capacity(1024),
                    };
                    let mut set = PlaneSet::default();
                    while !physics.stopping() {
                        if let Some(replies) = &mut replies {
                            while let Some(request) = physics.requests.pop() {
                                instance.carry_out(&request, replies);
                            }
                        }
                        physics.take_hand_backs(&mut taken);
                        let hands = *physics.hands_in.latest();
                        let started = monotonic_ns();
                        let input = PhysicsInput {
                            dt: period_ns as f64 * 1e-9,
                            pointers: &hands.pointers[..n],
                            proxies: &hands.proxies[..n],
                            impulses: &taken.impulses,
                            locals: &taken.locals,
                        };
                        let status = instance.step(
                            &input,
                            &mut PhysicsOutput {
                                planes: &mut set.planes,
                                bodies: &mut set.bodies,
                                body_count: &mut set.body_count,
                            },
                        );
                        if status == HAPTICD_OK {
                            let count = (set.body_count as usize).min(set.bodies.len());
                            instance.mobilities(&set.bodies[..count], &mut set.mobilities);
                            instance.compliances(&set.planes, &mut set.compliances);
                        }
                        set.step = (monotonic_ns() - started) as f64 * 1e-9;
                        set.yielding = pacer.judge();
                        if status != HAPTICD_OK {
                            physics.fail(None);
                            return;
                        }
                        let count = instance.poses(&mut physics.bodies.after).min(MAX_BODIES);
                        if !physics.publish(&mut set, count) {
                            return;
                        }
                        if pacer.rest() {
                            physics.steps.1.fetch_add(1, Ordering::Relaxed);
                        }
                        physics.steps.0.fetch_add(1, Ordering::Relaxed);
                    }
                })?,
        );
        Ok(scene)
    }
}

impl Scene for MultiRateScene {
    fn name(&self) -> &str {
        &self.name
    }

    fn render(&mut self, pointers: &[Pointer], dt: f64, wrenches: &mut [Wrench]) -> bool {
        if let Some(incoming) = &mut self.incoming {
            while let Some(request) = incoming.due() {
                self.to_physics.push(request);
            }
        }
        let latest = self.planes_in.latest();
        self.seen = latest.sequence;
        if self.settling.is_some_and(|from| self.seen >= from) {
            self.settling = None;
        }
        let hand_backs = &mut self.hand_backs;
        // A full channel (a stalled physics thread) drops a hand-back rather than wait.
        let fresh = self.renderer.tick(latest, pointers, dt, wrenches, |back| {
            hand_backs.push(back);
        });
        let renderer = &self.renderer;
        self.hands_out.publish(|out| {
            let both = out.pointers.iter_mut().zip(out.proxies.iter_mut());
            for ((grip, proxy), (p, at)) in both.zip(pointers.iter().zip(renderer.queries())) {
                *grip = p.to_abi();
                *proxy = proxy_record(grip, at);
            }
        });
        if self.failed.load(Ordering::Acquire) || !fresh {
            if let Some(fault) = self.faults_in.pop() {
                self.fault = Some(fault);
            }
            wrenches.fill(Wrench::ZERO);
            return false;
        }
        true
    }

    fn fault(&self) -> Option<OutputFault> {
        self.fault
    }

    fn reset(&mut self, pointers: &[Pointer]) {
        self.renderer.reset(pointers);
    }

    fn take_control(&mut self) -> Option<SceneControl> {
        self.control.take()
    }

    fn write_touches(&self, touches: &mut [Touch]) {
        self.renderer.write_touches(&self.object_bodies, touches);
    }

    fn set_surfaces(&mut self, mut surfaces: Surfaces) {
        surfaces.shade(&self.geometry);
        self.surfaces = surfaces;
    }

    fn material(&self, _pointer: usize, touch: &Touch) -> Option<&Material> {
        self.surfaces.of(touch.body)
    }

    fn smooth_mesh(&self, touch: &Touch) -> Option<&SmoothMesh> {
        self.surfaces.smooth(touch.body)
    }

    fn needs_quiet(&self) -> bool {
        self.incoming.as_ref().is_some_and(Incoming::holding) || self.settling.is_some()
    }

    /// The change goes to the physics; the forces come back once planes after it arrive
    /// (two steps on: the next may have begun before the change reached it).
    fn quiet(&mut self) {
        if let Some(request) = self.incoming.as_mut().and_then(Incoming::release) {
            self.to_physics.push(request);
            self.settling = Some(self.seen + 2);
        }
    }

    fn set_proxy(&mut self, parameters: &ProxyParameters) {
        self.renderer.set_parameters(parameters);
    }

    fn proxy(&self) -> Option<ProxyParameters> {
        Some(self.renderer.parameters())
    }

    fn write_proxies(&self, proxies: &mut [DVec3]) -> bool {
        for (out, p) in proxies.iter_mut().zip(self.renderer.proxies()) {
            *out = p;
        }
        true
    }

    /// The bodies moved as far between the last two steps as the planes felt (6.5.2), and
    /// those moved here where they are felt.
    fn write_bodies(&mut self, poses: &mut [HapticdBodyPose]) -> usize {
        let fraction = self.renderer.fraction();
        let set = self.bodies_in.latest();
        let shown = set.before[..set.count].iter().zip(&set.after[..set.count]);
        for (i, (out, (before, after))) in poses.iter_mut().zip(shown).enumerate() {
            let pose = self.renderer.local(i as u32).map_or_else(
                || pose_between(&pose_of(before), &pose_of(after), fraction),
                |m| m.pose(),
            );
            *out = body_pose(&pose);
        }
        set.count
    }

    fn geometry(&self) -> &Geometry {
        &self.geometry
    }
}

impl Drop for MultiRateScene {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        let (steps, late) = (
            self.steps.0.load(Ordering::Relaxed),
            self.steps.1.load(Ordering::Relaxed),
        );
        if late > 0 {
            tracing::warn!(
                "scene {}: {late} of {steps} physics steps fell behind the world's {:.1} ms \
                 period (a step that leaves less of it than it took is followed by as long a \
                 rest, so the world ran slower); give it a lower rate or fewer bodies",
                self.name,
                1e3 / self.rate
            );
        }
    }
}
