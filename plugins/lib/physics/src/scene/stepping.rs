//! [rt] A penalty scene stepped in the haptic thread: pointers placed at (or coupled to)
//! their grips, grasping, the world's steps, and the wrench each pointer feels.

use hapticd_core::kinematics::{Wrench, rotation_vector};

use super::MAX_STEPS_PER_CALL;
use super::penalty::PenaltyScene;
use crate::coupling::Grip;
use crate::soft::{SoftPart, pushed_load};
use crate::world::ContactModel;

impl PenaltyScene {
    /// [rt] Step the world through `dt` (in steps no longer than the scene's) with pointer k
    /// following `grips[k]`; `felt[k]` gets the wrench the user feels there (force, then
    /// torque about the pointer), averaged over `dt`. Allocates nothing: the world sized its
    /// clipping buffers for its largest pieces when it was made.
    ///
    /// Returns false, and steps nothing, when `dt` is not a positive time or would take more
    /// than [`MAX_STEPS_PER_CALL`] steps; and false when a wrench came out non-finite.
    pub fn step_pointers(&mut self, dt: f64, grips: &[Grip], felt: &mut [Wrench]) -> bool {
        felt.fill(Wrench::default());
        let steps = (dt / self.dt).ceil().max(1.0);
        if !(dt > 0.0 && steps <= MAX_STEPS_PER_CALL as f64) {
            return false;
        }
        let steps = steps as usize;
        let first = self.first_pointer;
        for (k, grip) in grips.iter().enumerate() {
            // A held part goes where its god-object lets it, as a body moved by hand.
            if k == 0
                && let Some(held) = &mut self.held
            {
                held.follow(grip, dt, &self.world.bodies);
                let (at, turn) = held.body_pose();
                let body = &mut self.world.bodies[first];
                let (velocity, spin) = (
                    (at - body.position) / dt,
                    rotation_vector(turn * body.orientation.inverse()) / dt,
                );
                body.place(at, turn, velocity, spin);
                continue;
            }
            let body = &mut self.world.bodies[first + k];
            let coupled = self.couplings[k].is_some();
            // A coupled pointer starts at its grip, then moves on its own.
            if !coupled || !self.pointers_placed {
                body.place(grip.position, grip.orientation, grip.velocity, grip.spin);
                body.kinematic = !coupled;
            }
        }
        self.pointers_placed = true;
        let step = dt / steps as f64;
        // A body that holds a soft body's nodes, or that a soft body pressed on, is pushed
        // over the tick by what they gave it over the last (the soft bodies step after the
        // world), besides its own load (see `pushed_load`).
        self.pushed.fill((Wrench::default(), (0.0, 0.0)));
        for soft in &self.soft {
            if let Some(a) = &soft.attached {
                self.pushed[a.body].0 = self.pushed[a.body].0 + a.pull;
            }
            for (i, push, (inertia, turning)) in soft.pushes() {
                let (sum, (added, turned)) = &mut self.pushed[i];
                (*sum, *added, *turned) = (*sum + push, *added + inertia, *turned + turning);
            }
        }
        self.own_loads.copy_from_slice(&self.world.loads);
        let gravity = self.world.gravity;
        for (((load, own), &(push, added)), body) in (self.world.loads.iter_mut())
            .zip(&self.own_loads)
            .zip(&self.pushed)
            .zip(&self.world.bodies)
        {
            *load = pushed_load(*own, push, added, body, gravity);
        }
        for _ in 0..steps {
            for (k, grip) in grips.iter().enumerate() {
                if let Some(c) = &self.couplings[k] {
                    let body = &self.world.bodies[first + k];
                    let (push, added) = self.pushed[first + k];
                    let coupling = c.load(grip, body, step);
                    self.coupled[k] = coupling;
                    self.world.loads[first + k] = pushed_load(coupling, push, added, body, gravity);
                }
            }
            if let Some(g) = &mut self.grasping {
                g.before_step(&mut self.world, first, grips.len(), step);
            }
            self.world.step(step);
            for (k, out) in felt.iter_mut().enumerate().take(grips.len()) {
                *out = *out
                    + match self.couplings[k] {
                        None => self.world.contact_wrench(first + k),
                        Some(_) => self.coupled[k] * -1.0,
                    };
                if let Some(g) = &self.grasping {
                    *out = *out + g.felt(k);
                }
                if let (0, Some(held)) = (k, &self.held) {
                    *out = *out + held.felt;
                }
            }
        }
        for out in felt.iter_mut() {
            *out = *out * (1.0 / steps as f64);
        }
        for (k, own) in self.own_loads.iter().enumerate() {
            // A coupled pointer's load is its coupling's, set anew each step.
            if !(k >= first && self.couplings[k - first].is_some()) {
                self.world.loads[k] = *own;
            }
        }
        for soft in &mut self.soft {
            soft.step(dt, gravity, &self.world.bodies, first, felt);
        }
        felt.iter().all(Wrench::is_finite)
            && self.world.is_finite()
            && self.soft.iter().all(SoftPart::is_finite)
    }

    /// Use `model` for contacts, with the material the file gives for it.
    pub fn set_model(&mut self, model: ContactModel) {
        self.world.material = self.materials[match model {
            ContactModel::Volume => 0,
            ContactModel::Point => 1,
        }];
    }
}

#[cfg(test)]
mod pointer_tests {
    use super::*;
    use glam::DQuat;
    use glam::DVec3;
    use std::path::Path;

    #[test]
    fn a_pointer_pressed_into_the_table_is_pushed_out_by_its_depth() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../config/scenes/blocks.yaml");
        let mut scene = PenaltyScene::load(&path, 1).unwrap();
        let k = scene.first_pointer;
        // The 1 cm pointer cube 3 mm into the table top (y = −0.03), away from the blocks.
        scene.world.bodies[k].place(
            DVec3::new(0.0, -0.028, -0.1),
            DQuat::IDENTITY,
            DVec3::ZERO,
            DVec3::ZERO,
        );
        scene.world.step(1e-4);
        let w = scene.world.contact_wrench(k);
        // 2·10⁷ N/m³ × 1 cm² × 3 mm = 6 N, straight up through the contact.
        assert!(
            (w.force - DVec3::new(0.0, 6.0, 0.0)).length() < 1e-6,
            "{w:?}"
        );
        assert!(w.torque.length() < 1e-9, "{w:?}");
    }
}

#[cfg(test)]
mod coupling_tests {
    use super::*;
    use glam::DQuat;
    use glam::DVec3;
    use std::path::Path;

    const SCENE: &str = "name: coupled
dt: 0.0001
material: { stiffness: 1.0e7, damping: 2.0e4, static_friction: 0.5, friction: 0.4,
            friction_stiffness: 1.0e7, friction_damping: 2.0e4, slip_speed: 0.001 }
bodies:
  - { name: floor, box: [1, 0.1, 1], position: [0, -0.05, 0], fixed: true }
pointer:
  box: [0.02, 0.02, 0.02]
  density: 1000
  coupling: { stiffness: 400, damping: 5, rotational_stiffness: 0.5, rotational_damping: 0.01 }
";

    #[test]
    fn a_coupled_pointer_stays_on_the_floor_and_the_user_feels_the_stretch() {
        let mut scene = PenaltyScene::parse(SCENE, Path::new("coupled.yaml"), 1).unwrap();
        // The grip pushes 1 cm below where the 2 cm cube would rest on the floor (y = 0).
        let grip = Grip {
            position: DVec3::new(0.0, 0.0, 0.0),
            orientation: DQuat::IDENTITY,
            velocity: DVec3::ZERO,
            spin: DVec3::ZERO,
        };
        let mut felt = [Wrench::default()];
        for _ in 0..3000 {
            scene.step_pointers(1e-3, &[grip], &mut felt);
        }
        let body = &scene.world.bodies[scene.first_pointer];
        let (k, m, g) = (400.0, body.mass, 9.81);
        // The user feels the spring's stretch, and nothing else (to the friction springs'
        // micro-motion within the tick).
        let stretch = body.position - grip.position;
        let error = (felt[0].force - k * stretch).length();
        assert!(
            error < 1e-3 * felt[0].force.length(),
            "{felt:?}, {}",
            k * stretch
        );
        // The floor carries the weight and the spring's pull: depth = (m·g + k·s)/(k_N·A).
        let depth = 0.01 - body.position.y;
        let expected = (m * g + k * stretch.y) / (1.0e7 * 0.02 * 0.02);
        assert!(
            (depth / expected - 1.0).abs() < 5e-3,
            "{depth} m, {expected} m"
        );
        assert!(
            stretch.y > 0.009,
            "the pointer went into the floor: {stretch}"
        );
    }

    #[test]
    fn a_coupling_damped_far_past_the_step_still_settles() {
        // Explicitly, 1000 N·s/m on 8 g and 1 N·m·s on 5·10⁻⁷ kg·m² would reverse the pointer's
        // motion 12 and 190 times over in each 0.1 ms step.
        let scene = SCENE.replace(
            "damping: 5, rotational_stiffness: 0.5, rotational_damping: 0.01",
            "damping: 1000, rotational_stiffness: 0.5, rotational_damping: 1.0",
        );
        let mut scene = PenaltyScene::parse(&scene, Path::new("coupled.yaml"), 1).unwrap();
        let grip = Grip {
            position: DVec3::new(0.0, 0.02, 0.0),
            orientation: DQuat::from_rotation_z(0.5),
            velocity: DVec3::ZERO,
            spin: DVec3::ZERO,
        };
        let mut felt = [Wrench::default()];
        for _ in 0..1000 {
            assert!(scene.step_pointers(1e-3, &[grip], &mut felt));
        }
        let body = &scene.world.bodies[scene.first_pointer];
        assert!(body.spin.length() < 1e-3 && body.velocity.length() < 1e-3);
        assert!(body.orientation.angle_between(grip.orientation) < 0.02);
    }
}
