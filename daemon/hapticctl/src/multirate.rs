//! A multi-rate scene run in simulated time exactly as hapticd runs it: haptic ticks at the
//! loop's rate render the planes through [`PlaneRenderer`], and a physics step runs whenever
//! the physics clock comes due, `phase` seconds after the haptic clock's start, taking the
//! pointers and proxies the last tick published and what was handed back so far (hapticd's
//! physics thread does the same against the real clock).

use glam::DVec3;
use hapticd_core::kinematics::{MAX_EFFECTORS, Pose, Wrench};
use hapticd_core::scene::Pointer;
use hapticd_core::scene::exact_shapes::ExactShapes;
use hapticd_core::scene::held_part::HeldPart;
use hapticd_core::scene::multirate::{
    HandBack, PlaneRenderer, PlaneSet, pose_between, proxy_record,
};
use hapticd_core::scene::shared_world::Stepped;
use hapticd_physics::scene::RapierScene;
use hapticd_plugin_api::export::{PhysicsInput, PhysicsOutput};
use hapticd_plugin_api::{HapticdImpulse, HapticdLocalState, HapticdPointer};
use hapticd_rapier::world::{BodyState, RapierWorld};

/// The world stopped being finite at haptic time `time`, seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NotFinite {
    /// Haptic time, seconds.
    pub time: f64,
}

impl std::fmt::Display for NotFinite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "at t = {:.4} s the world is no longer finite", self.time)
    }
}

impl std::error::Error for NotFinite {}

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
    pub fn new(spec: &RapierScene, pointers: &[Pointer], haptic_rate: f64, phase: f64) -> Self {
        let physics_period = 1.0 / spec.rate;
        let mut published = [HapticdPointer::default(); MAX_EFFECTORS];
        for (out, p) in published.iter_mut().zip(pointers) {
            *out = p.to_abi();
        }
        let world = RapierWorld::new(spec, pointers.len());
        let now: Vec<BodyState> = (0..world.body_count()).map(|i| world.body(i)).collect();
        let mut renderer = PlaneRenderer::new(spec.rate, pointers);
        let pieces = spec.surface_pieces();
        if let Some(held) = &spec.held {
            let part = HeldPart::build(held, &pieces)
                .expect("reading a scene file checks that its surfaces are closed");
            renderer.hold(part);
        }
        renderer.set_exact_shapes(ExactShapes::of_pieces(&pieces));
        Self {
            poses: (now.clone(), now),
            world,
            renderer,
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
    pub fn tick(&mut self, pointers: &[Pointer], wrenches: &mut [Wrench]) -> Result<(), NotFinite> {
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
                return Err(NotFinite { time: self.time });
            }
            set.body_count = body_count;
            let count = body_count as usize;
            self.world
                .mobilities(&set.bodies[..count], &mut set.mobilities[..count]);
            self.world
                .compliances(&set.planes[..n], &mut set.compliances[..n]);
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
                HandBack::Local(l, _) => locals.push(l),
            },
        );
        for ((out, proxy), (p, at)) in self
            .published
            .iter_mut()
            .zip(self.proxies.iter_mut())
            .zip(pointers.iter().zip(self.renderer.queries()))
        {
            *out = p.to_abi();
            *proxy = proxy_record(out, at);
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

#[cfg(test)]
mod tests {
    use super::*;
    use hapticd_physics::scene::{Feedback, SceneFile};

    /// A 4 mm plate (top at y = 0.004) over a 2 cm floor (top at y = −0.05), at 20 Hz.
    const PLATES: &str = "name: plates
engine: rapier
rate: 20
material: { static_friction: 0.3, friction: 0.3 }
bodies:
  - { name: plate, box: [0.2, 0.004, 0.2], position: [0, 0.002, 0], fixed: true }
  - { name: floor, box: [0.6, 0.02, 0.6], position: [0, -0.06, 0], fixed: true }
pointer:
  sphere: 0.005
";

    /// Press straight down at `x` onto the surface at height `top` with `force` newtons of
    /// the 2 kN/m proxy spring, and back up: the force never points into the surface, the
    /// proxy stays on the top face, and the force changes smoothly.
    fn press(top: f64, x: f64, force: f64) {
        let SceneFile::Rapier(spec) =
            SceneFile::parse(PLATES, std::path::Path::new("plates.yaml"), 1).unwrap()
        else {
            panic!("a rapier scene");
        };
        let above = DVec3::new(x, top + 0.01, 0.0);
        let mut lockstep = Lockstep::new(
            &spec,
            &Lockstep::pointers(&[(above, DVec3::ZERO)]),
            1000.0,
            0.0,
        );
        let depth = force / 2000.0;
        let (speed, dt) = (0.05, 1e-3);
        let down = ((0.01 + depth) / speed / dt).round() as usize;
        let mut felt = [Wrench::ZERO];
        let mut last = DVec3::ZERO;
        let mut deepest: f64 = 0.0;
        for tick in 0..(2 * down + 200) {
            // Down at 5 cm/s to `depth` below the face, held, then back up.
            let s = if tick < down {
                tick as f64
            } else if tick < down + 200 {
                down as f64
            } else {
                (2 * down + 200 - tick) as f64
            };
            let v = if tick < down {
                -speed
            } else if tick < down + 200 {
                0.0
            } else {
                speed
            };
            let grip = above - DVec3::Y * (s * speed * dt);
            lockstep
                .tick(&Lockstep::pointers(&[(grip, DVec3::Y * v)]), &mut felt)
                .unwrap();
            let f = felt[0].force;
            let proxy = lockstep.proxies()[0];
            assert!(f.y >= -1e-9, "tick {tick}: {f} points into the surface");
            assert!(
                proxy.y >= top - 1e-6,
                "tick {tick}: the proxy is at {proxy}, in the solid"
            );
            // A spring of 2 kN/m and a 5 N·s/m damper on a grip moving 50 µm a tick.
            assert!(
                (f - last).length() < 2000.0 * speed * dt + 5.0 * speed + 1e-6,
                "tick {tick}: {last} → {f}"
            );
            last = f;
            deepest = deepest.max(top - grip.y);
        }
        assert!((deepest - depth).abs() < 1e-3, "{deepest}");
        assert!(last.length() < 1e-9, "{last} once out");
    }

    #[test]
    fn a_finger_pressed_through_a_thin_plate_or_a_floor_is_held_on_the_top_face() {
        for force in [20.0, 40.0] {
            press(0.004, 0.0, force);
            press(-0.05, 0.2, force);
        }
    }

    /// The force felt with position feedback when a 5 mm finger presses `solid` (a 4 cm
    /// cube's body keys) from above onto a floor and holds 1.5 mm into it, and what the
    /// 2 kN/m proxy spring gives for the overlap of finger and cube where they end.
    fn pressed_by_position(solid: &str) -> (f64, f64) {
        let text = format!(
            "name: press
engine: rapier
rate: 60
feedback: position
gravity: [0, -9.81, 0]
material: {{ static_friction: 0.4, friction: 0.3 }}
bodies:
  - {{ name: floor, box: [0.4, 0.02, 0.3], position: [0, -0.04, 0], fixed: true }}
  - {{ name: cube, {solid}, position: [0, -0.01, 0], density: 1000 }}
pointer:
  sphere: 0.005
"
        );
        // Beside the public corpus, where its meshes are.
        let at =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/corpus/press.yaml");
        let SceneFile::Rapier(spec) = SceneFile::parse(&text, &at, 1).unwrap() else {
            panic!("a rapier scene");
        };
        let above = DVec3::new(0.0, 0.03, 0.0);
        let mut lockstep = Lockstep::new(
            &spec,
            &Lockstep::pointers(&[(above, DVec3::ZERO)]),
            1000.0,
            0.0,
        );
        let (radius, half, low) = (0.005, 0.02, 0.013);
        let mut felt = [Wrench::ZERO];
        for tick in 0..1200 {
            // Down at 3.4 cm/s for 0.5 s, then held.
            let s = (tick as f64 / 500.0).min(1.0);
            let v = if tick < 500 {
                (low - above.y) / 0.5
            } else {
                0.0
            };
            let grip = above.lerp(DVec3::new(0.0, low, 0.0), s);
            lockstep
                .tick(&Lockstep::pointers(&[(grip, DVec3::Y * v)]), &mut felt)
                .unwrap();
        }
        let top = lockstep.body(1).position.y + half;
        (felt[0].force.y, 2000.0 * (top + radius - low))
    }

    #[test]
    fn position_feedback_is_felt_where_the_finger_solid_meets_a_body_box_or_mesh() {
        // The physics pushes bodies with the `pointer:` solid; the haptic side renders the
        // grip, a point, so the planes stand off by the solid. Without that a body stays a
        // finger's radius ahead of the grip and nothing is felt.
        let (boxed, expected) = pressed_by_position("box: [0.04, 0.04, 0.04]");
        eprintln!("box: {boxed:.3} N felt, {expected:.3} N from the overlap");
        assert!(expected > 2.0, "the finger overlaps the cube: {expected} N");
        assert!(
            (boxed - expected).abs() < 0.05 * expected,
            "box: {boxed} N, {expected} N expected"
        );
        let (mesh, expected) = pressed_by_position("mesh: BoxTextured.glb, scale: 0.04");
        assert!(
            (mesh - expected).abs() < 0.05 * expected,
            "mesh: {mesh} N, {expected} N expected"
        );
        assert!(
            (mesh - boxed).abs() < 0.01 * boxed,
            "{mesh} N against {boxed} N"
        );
    }

    /// A 4 cm, 0.1 kg block in the corner of a floor and two walls, at `rate` Hz.
    fn corner(rate: f64, feedback: Feedback) -> RapierScene {
        let text = format!(
            "name: corner
engine: rapier
rate: {rate}
gravity: [0, -9.81, 0]
material: {{ static_friction: 0.3, friction: 0.3 }}
bodies:
  - {{ name: floor, box: [0.4, 0.02, 0.4], position: [0, -0.01, 0], fixed: true }}
  - {{ name: wall, box: [0.02, 0.1, 0.4], position: [-0.03, 0.05, 0], fixed: true }}
  - {{ name: back, box: [0.4, 0.1, 0.02], position: [0, 0.05, -0.03], fixed: true }}
  - {{ name: block, box: [0.04, 0.04, 0.04], position: [0, 0.02, 0], density: 1562.5 }}
pointer:
  sphere: 0.005
"
        );
        let SceneFile::Rapier(mut spec) =
            SceneFile::parse(&text, std::path::Path::new("corner.yaml"), 1).unwrap()
        else {
            panic!("a rapier scene");
        };
        spec.feedback = feedback;
        *spec
    }

    /// What a hand beating at 5 Hz on the block's free edge, toward the corner, does: the
    /// block's largest kinetic energy, the energy the device gave the hand (negative: the
    /// hand put it in), how far the block ended from where it stood, and the hand's top speed.
    fn beat(rate: f64, phase: f64, feedback: Feedback) -> (f64, f64, f64, f64) {
        let spec = corner(rate, feedback);
        let (mass, side) = (0.1, 0.04);
        let inertia = mass * side * side / 6.0;
        let edge = DVec3::new(0.02, 0.02, 0.02);
        let toward = DVec3::new(1.0, 0.0, 1.0).normalize();
        let start = edge + toward * 0.02;
        let mut lockstep = Lockstep::new(
            &spec,
            &Lockstep::pointers(&[(start, DVec3::ZERO)]),
            1000.0,
            phase,
        );
        let block = 3;
        let rest = lockstep.body(block).position;
        let (dt, w, amplitude) = (1e-3, 2.0 * std::f64::consts::PI * 5.0, 0.004);
        let mut felt = [Wrench::ZERO];
        let (mut peak, mut given): (f64, f64) = (0.0, 0.0);
        for tick in 0..3000 {
            let t = tick as f64 * dt;
            // In to the edge over 0.2 s, then about 2 mm in, 4 mm either way, five times a
            // second.
            let (s, v) = if t < 0.2 {
                (0.02 - 0.022 * t / 0.2, -0.022 / 0.2)
            } else {
                let a = w * (t - 0.2);
                (-0.002 + amplitude * a.sin(), amplitude * w * a.cos())
            };
            let velocity = toward * v;
            lockstep
                .tick(
                    &Lockstep::pointers(&[(edge + toward * s, velocity)]),
                    &mut felt,
                )
                .unwrap();
            given += felt[0].force.dot(velocity) * dt;
            let b = lockstep.body(block);
            let energy =
                0.5 * mass * b.velocity.length_squared() + 0.5 * inertia * b.spin.length_squared();
            peak = peak.max(energy);
        }
        let moved = (lockstep.body(block).position - rest).length();
        (peak, given, moved, amplitude * w)
    }

    #[test]
    fn a_light_block_beaten_into_a_corner_stays_there_and_gives_back_no_energy() {
        for (rate, phase) in [(10.0, 0.0), (10.0, 0.05), (20.0, 0.02)] {
            let (peak, given, moved, hand) = beat(rate, phase, Feedback::Local);
            // Its energy stays that of a block moving about as fast as the hand (it can
            // only rattle: the walls hold it), and the hand gets nothing back overall.
            let bound = 8.0 * 0.5 * 0.1 * hand * hand;
            assert!(peak < bound, "{rate} Hz: {peak} J against {bound} J");
            assert!(given < 0.005, "{rate} Hz: the hand got {given} J");
            assert!(moved < 0.003, "{rate} Hz: the block went {moved} m");
            // Impulses summed over a period on a block the physics has not moved threw it
            // metres; bounded by how fast the finger pushed, they leave it in its corner.
            let (thrown, _, gone, _) = beat(rate, phase, Feedback::Impulse);
            assert!(
                thrown < bound,
                "{rate} Hz: impulses, {thrown} J against {bound} J"
            );
            assert!(gone < 0.003, "{rate} Hz: impulses, the block went {gone} m");
        }
    }
}
