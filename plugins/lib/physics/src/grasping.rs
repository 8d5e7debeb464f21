//! Bodies held between pointers (thesis 4.2–4.7) in a penalty world.
//!
//! Every box-shaped body that can move is a candidate. Its grasp model
//! ([`hapticd_core::haptics::grasp`]) follows the pointers into the box grown by the
//! pointer's half size (so a finger touches where the pointer solid does), and the contacts
//! between the body and the pointers touching it are the model's, not the world's: one
//! spring per finger while they only touch or push it, and once two press it from opposite
//! sides, the grasp: the pointers feel its forces (grip, plus their share of the resultant)
//! and the body gets the resultant as a load. The same springs before, during and after a
//! grasp, so none starts or ends with a jump. The body's contacts with the rest of the world
//! (the table it is lifted from, the block it knocks) go on as always. Opening the fingers
//! ends the grasp.

use glam::{DQuat, DVec3};
use hapticd_core::haptics::grasp::{Grasp, GraspSettings, MAX_FINGERS, Object};
use hapticd_core::kinematics::Wrench;

use crate::body::Body;
use crate::world::World;

/// A body that may be held.
#[derive(Debug, Clone)]
struct Candidate {
    body: usize,
    /// The box's half edges grown by the pointer's half size, metres.
    half: DVec3,
    /// The box's orientation in the body's frame.
    turn: DQuat,
    model: Grasp,
}

/// The grasps of a world's bodies by its pointers.
#[derive(Debug, Clone)]
pub struct Grasping {
    candidates: Vec<Candidate>,
    /// The held body's candidate, if one is held.
    held: Option<usize>,
    /// Force on each pointer from the bodies it touches, in the last step.
    felt: [DVec3; MAX_FINGERS],
}

impl Grasping {
    /// Candidates among `bodies`: those that can move and are one box, given by the box's
    /// half edges and orientation in the body frame (`boxes`, one per body); `pointer` is
    /// the pointer's half size. `settings` per body come from `settings_for(mass)`.
    pub fn new(
        bodies: &[Body],
        boxes: &[Option<(DVec3, DQuat)>],
        pointer: f64,
        settings_for: impl Fn(f64) -> GraspSettings,
    ) -> Self {
        let candidates = bodies
            .iter()
            .zip(boxes)
            .enumerate()
            .filter(|(_, (b, _))| !b.fixed)
            .filter_map(|(i, (b, shape))| {
                let (half, turn) = (*shape)?;
                Some(Candidate {
                    body: i,
                    half: half + DVec3::splat(pointer),
                    turn,
                    model: Grasp::new(settings_for(b.mass)),
                })
            })
            .collect();
        Self {
            candidates,
            held: None,
            felt: [DVec3::ZERO; MAX_FINGERS],
        }
    }

    /// The body held now, if any.
    pub fn held(&self) -> Option<usize> {
        self.held.map(|c| self.candidates[c].body)
    }

    /// The force the grasp puts on pointer `k` (after [`Grasping::before_step`]).
    pub fn felt(&self, k: usize) -> Wrench {
        Wrench::force(self.felt.get(k).copied().unwrap_or(DVec3::ZERO))
    }

    /// [rt] Before a world step of `dt`: follow the pointers (bodies `first_pointer`… of
    /// `world`); for each body they touch, set its load and the pointers' forces from its
    /// grasp model, and leave their contacts out of the step. Allocation-free.
    pub fn before_step(
        &mut self,
        world: &mut World,
        first_pointer: usize,
        pointers: usize,
        dt: f64,
    ) {
        let n = pointers.min(MAX_FINGERS);
        let mut fingers = [DVec3::ZERO; MAX_FINGERS];
        for (k, finger) in fingers.iter_mut().enumerate().take(n) {
            *finger = world.bodies[first_pointer + k].position;
        }
        self.felt = [DVec3::ZERO; MAX_FINGERS];
        self.held = None;
        world.ignored_pairs.clear();
        for (c, candidate) in self.candidates.iter_mut().enumerate() {
            let b = &world.bodies[candidate.body];
            let orientation = b.orientation * candidate.turn;
            let object = Object {
                half: candidate.half,
                mass: b.mass,
                position: b.position,
                orientation,
                velocity: b.velocity,
                spin: orientation.inverse() * b.spin,
            };
            let frame = candidate.model.step(&fingers[..n], &object, dt);
            // Touched or held, the body's contacts with the pointers are the model's: one
            // spring per touching finger, or the grasp (no jump when a grasp starts or ends).
            world.loads[candidate.body] = Wrench {
                force: frame.resultant,
                torque: frame.moment,
            };
            if frame.grasped && self.held.is_none() {
                self.held = Some(c);
            }
            for k in (0..n).filter(|&k| frame.forces[k] != DVec3::ZERO) {
                let (p, q) = (candidate.body, first_pointer + k);
                // Past the room reserved, the penalty contact stays (rather than allocate).
                if world.ignored_pairs.len() < world.ignored_pairs.capacity() {
                    world.ignored_pairs.push((p.min(q), p.max(q)));
                    self.felt[k] += frame.forces[k];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use glam::{DQuat, DVec3};
    use hapticd_core::kinematics::Wrench;

    use crate::coupling::Grip;
    use crate::scene::PenaltyScene;

    /// Two fingers, left and right of the box's centre line at height `y`, `gap` apart
    /// (the grasp scene's box stands on its table with its middle at x = z = 0).
    fn grips(gap: f64, y: f64) -> [Grip; 2] {
        [-1.0, 1.0].map(|side| Grip {
            position: DVec3::new(side * gap / 2.0, y, 0.0),
            orientation: DQuat::IDENTITY,
            velocity: DVec3::ZERO,
            spin: DVec3::ZERO,
        })
    }

    /// Run `seconds` at 1 kHz moving the fingers by `path(t)` (gap, height); the pointers'
    /// mean force over the run.
    fn run(
        scene: &mut PenaltyScene,
        from: f64,
        seconds: f64,
        path: impl Fn(f64) -> (f64, f64),
    ) -> [DVec3; 2] {
        let (mut felt, mut sum) = ([Wrench::default(); 2], [DVec3::ZERO; 2]);
        let steps = (seconds * 1000.0) as usize;
        for step in 0..steps {
            let (gap, y) = path(from + step as f64 * 1e-3);
            assert!(scene.step_pointers(1e-3, &grips(gap, y), &mut felt));
            for (s, f) in sum.iter_mut().zip(&felt) {
                *s += f.force / steps as f64;
            }
        }
        sum
    }

    #[test]
    fn two_fingers_lift_the_box_off_the_table_and_let_it_fall_when_they_open() {
        for method in ["distributed", "conventional"] {
            let path =
                Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../config/scenes/grasp.yaml");
            let text = std::fs::read_to_string(&path)
                .unwrap()
                .replace("method: distributed", &format!("method: {method}"));
            let mut scene = PenaltyScene::parse(&text, &path, 2).unwrap();
            let body = scene.names.iter().position(|n| n == "box").unwrap();
            let rest = scene.world.bodies[body].position.y;
            // The fingers' centres stand off the 6 cm box by the pointer's 5 mm half size;
            // 2.5 mm further in, the 800 N/m springs grip with 2 N.
            let (open, closed) = (0.09, 0.07 - 0.005);
            run(&mut scene, 0.0, 0.3, |t| {
                (open + (closed - open) * (t / 0.3), rest)
            });
            run(&mut scene, 0.3, 0.2, |_| (closed, rest));
            assert_eq!(
                scene.grasping.as_ref().unwrap().held(),
                Some(body),
                "{method}"
            );
            // Lift 3 cm in half a second, hold half a second.
            run(&mut scene, 0.5, 0.5, |t| {
                (closed, rest + 0.03 * (t - 0.5) / 0.5)
            });
            let felt = run(&mut scene, 1.0, 0.5, |_| (closed, rest + 0.03));
            let lifted = scene.world.bodies[body].position.y - rest;
            assert!((0.02..0.031).contains(&lifted), "{method}: lifted {lifted}");
            // The fingers carry the box's weight (2 N) between them, by friction.
            let weight = -(felt[0].y + felt[1].y);
            assert!((weight - 2.0).abs() < 0.2, "{method}: carried {weight} N");
            // Open: it falls back onto the table.
            run(&mut scene, 1.5, 0.8, |_| (open, rest + 0.03));
            assert_eq!(scene.grasping.as_ref().unwrap().held(), None);
            let y = scene.world.bodies[body].position.y - rest;
            assert!(y.abs() < 0.003, "{method}: the box is {y} above its rest");
        }
    }
}
