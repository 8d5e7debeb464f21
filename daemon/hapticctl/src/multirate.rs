//! A multi-rate scene run in simulated time exactly as hapticd runs it: haptic ticks at the
//! loop's rate render the planes through [`PlaneRenderer`], and a physics step runs whenever
//! the physics clock comes due, `phase` seconds after the haptic clock's start, taking the
//! pointers and proxies the last tick published and what was handed back so far (hapticd's
//! physics thread does the same against the real clock).

use glam::DVec3;
use hapticd_core::kinematics::{MAX_EFFECTORS, Pose, Wrench};
use hapticd_core::scene::Pointer;
use hapticd_core::scene::multirate::{HandBack, PlaneRenderer, PlaneSet, pose_between};
use hapticd_physics::scene::MultiRateWorld;
use hapticd_plugin_api::export::{PhysicsInput, PhysicsOutput};
use hapticd_plugin_api::{HapticdImpulse, HapticdLocalState, HapticdPointer};
use hapticd_rapier::world::{BodyState, RapierWorld};

/// A rapier world and the haptic side, stepped in lockstep.
pub struct Lockstep {
    /// The world.
    pub world: RapierWorld,
    /// Every body as the step before last and the last step left it.
    poses: (Vec<BodyState>, Vec<BodyState>),
    renderer: PlaneRenderer,
    haptic_period: f64,
    physics_period: f64,
    /// Haptic time, seconds.
    time: f64,
    next_physics: f64,
    set: PlaneSet,
    published: [HapticdPointer; MAX_EFFECTORS],
    proxies: [HapticdPointer; MAX_EFFECTORS],
    impulses: Vec<HapticdImpulse>,
    locals: Vec<HapticdLocalState>,
    count: usize,
}

impl Lockstep {
    /// The world of `spec` for `pointers`, haptics at `haptic_rate` Hz and the physics clock
    /// `phase` seconds behind the haptic one (taken modulo the physics period).
    pub fn new(spec: &MultiRateWorld, pointers: &[Pointer], haptic_rate: f64, phase: f64) -> Self {
        let physics_period = 1.0 / spec.rate;
        let mut published = [HapticdPointer::default(); MAX_EFFECTORS];
        for (out, p) in published.iter_mut().zip(pointers) {
            *out = p.to_abi();
        }
        let world = RapierWorld::new(spec, pointers.len());
        let now: Vec<BodyState> = (0..world.body_count()).map(|i| world.body(i)).collect();
        Self {
            poses: (now.clone(), now),
            world,
            renderer: PlaneRenderer::new(spec.rate, pointers),
            haptic_period: 1.0 / haptic_rate,
            physics_period,
            time: 0.0,
            next_physics: phase.rem_euclid(physics_period),
            set: PlaneSet::default(),
            published,
            proxies: published,
            impulses: Vec::with_capacity(64),
            locals: Vec::with_capacity(64),
            count: pointers.len().min(MAX_EFFECTORS),
        }
    }

    /// Haptic time, seconds.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// One haptic tick with the pointers at `pointers`: the physics steps first when its
    /// clock is due; `wrenches` get what the hand feels. An error when the world stops being
    /// finite.
    pub fn tick(&mut self, pointers: &[Pointer], wrenches: &mut [Wrench]) -> Result<(), String> {
        // Against rounding: a step due within a nanosecond of this tick is due now.
        while self.next_physics <= self.time + 1e-9 {
            let n = self.count;
            let mut set = PlaneSet {
                sequence: self.set.sequence + 1,
                ..PlaneSet::default()
            };
            let mut body_count = 0;
            let finite = self.world.step(
                &PhysicsInput {
                    dt: self.physics_period,
                    pointers: &self.published[..n],
                    proxies: &self.proxies[..n],
                    impulses: &self.impulses,
                    locals: &self.locals,
                },
                &mut PhysicsOutput {
                    planes: &mut set.planes[..n],
                    bodies: &mut set.bodies,
                    body_count: &mut body_count,
                },
            );
            if !finite {
                return Err(format!(
                    "at t = {:.4} s the world is no longer finite",
                    self.time
                ));
            }
            set.body_count = body_count;
            self.impulses.clear();
            self.locals.clear();
            std::mem::swap(&mut self.poses.0, &mut self.poses.1);
            for (i, pose) in self.poses.1.iter_mut().enumerate() {
                *pose = self.world.body(i);
            }
            self.set = set;
            self.next_physics += self.physics_period;
        }
        let (impulses, locals) = (&mut self.impulses, &mut self.locals);
        self.renderer.tick(
            &self.set,
            pointers,
            self.haptic_period,
            wrenches,
            |back| match back {
                HandBack::Impulse(i) => impulses.push(i),
                HandBack::Local(l) => locals.push(l),
            },
        );
        for ((out, proxy), (p, at)) in self
            .published
            .iter_mut()
            .zip(self.proxies.iter_mut())
            .zip(pointers.iter().zip(self.renderer.proxies()))
        {
            *out = p.to_abi();
            *proxy = HapticdPointer {
                position: at.to_array(),
                ..*out
            };
        }
        self.time += self.haptic_period;
        Ok(())
    }

    /// Body `i` where graphics and telemetry show it: where the haptic side moves it, if it
    /// does (local dynamics), else between the last two physics steps by the fraction the
    /// haptic side renders the planes at (thesis 6.5.2), so it moves smoothly, a physics
    /// period behind, as the hand feels it.
    pub fn body(&self, i: usize) -> BodyState {
        if let Some(m) = self.renderer.local(i as u32) {
            return BodyState {
                position: m.position,
                orientation: m.orientation,
                velocity: m.velocity,
                spin: m.spin,
            };
        }
        let (before, after) = (&self.poses.0[i], &self.poses.1[i]);
        let fraction = self.renderer.fraction();
        let between = pose_between(&before.pose(), &after.pose(), fraction);
        BodyState {
            position: between.position,
            orientation: between.orientation,
            velocity: before.velocity.lerp(after.velocity, fraction),
            spin: before.spin.lerp(after.spin, fraction),
        }
    }

    /// Where each pointer's proxy rests.
    pub fn proxies(&self) -> Vec<DVec3> {
        self.renderer.proxies().collect()
    }

    /// The pointers at `positions`, moving at `velocities`, as the loop hands them over.
    pub fn pointers(positions: &[(DVec3, DVec3)]) -> Vec<Pointer> {
        positions
            .iter()
            .map(|&(position, velocity)| Pointer {
                pose: Pose {
                    position,
                    ..Default::default()
                },
                velocity,
            })
            .collect()
    }
}
