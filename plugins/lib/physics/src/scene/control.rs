//! A running penalty world changed from outside (the scene-control extension of the plugin
//! ABI): the scene file's bodies, by id, moved, pushed, made heavier or more slippery
//! between two steps. The pointers' bodies are the hand's, not the caller's.

use glam::DVec3;
use hapticd_core::kinematics::{Wrench, quat_from_wxyz, quat_to_wxyz};
use hapticd_plugin_api::*;

use super::PenaltyScene;
use super::checks::{DENSITY_RANGE, DIVERGENT_OMEGA_DT, contact_springs, omega_dt};
use crate::joint::{DrivenJoints, Joint, JointState, Motor};
use crate::soft::SoftPart;
use crate::world::ContactModel;

impl PenaltyScene {
    /// Body `i` of the scene file as the control extension lists it (None past the last):
    /// its rigid bodies, then its soft ones.
    pub fn body_info(&self, i: usize) -> Option<HapticdBodyInfo> {
        if i < self.first_pointer {
            return Some(HapticdBodyInfo::new(
                &self.names[i],
                self.world.bodies[i].fixed,
            ));
        }
        self.soft_of(i)
            .map(|soft| HapticdBodyInfo::new(&soft.name, false))
    }

    /// Body `i`'s state now (`i` a body of the file): a soft one's taken whole, its
    /// orientation the turn of its rest shape that best fits it.
    pub fn body_state(&self, i: usize) -> HapticdBodyState {
        if let Some(soft) = self.soft_of(i) {
            return soft.state();
        }
        let b = &self.world.bodies[i];
        HapticdBodyState {
            position: b.position.to_array(),
            orientation: quat_to_wxyz(b.orientation),
            velocity: b.velocity.to_array(),
            spin: b.spin.to_array(),
            mass: if b.fixed { f64::INFINITY } else { b.mass },
            friction: self.world.friction_of(i),
            force: self.world.loads[i].force.to_array(),
        }
    }

    /// The soft body of id `i` (ids after the rigid bodies of the file), if it is one.
    pub(super) fn soft_of(&self, i: usize) -> Option<&SoftPart> {
        self.soft.get(i.checked_sub(self.first_pointer)?)
    }

    /// Carry out `command` on a body of the file; its state after, or None for a command
    /// it cannot take (no such body, a value not finite, a push on a fixed body, an unknown
    /// kind). Allocates nothing: it runs in the haptic tick.
    pub fn apply(&mut self, command: &HapticdSceneCommand) -> Option<HapticdBodyState> {
        let i = command.body as usize;
        if !command.is_finite() {
            return None;
        }
        if let Some(soft) = i
            .checked_sub(self.first_pointer)
            .and_then(|k| self.soft.get_mut(k))
        {
            soft.apply(command)?;
            return Some(self.body_state(i));
        }
        if i >= self.first_pointer {
            return None;
        }
        let fixed = self.world.bodies[i].fixed;
        let vector = DVec3::from(command.vector);
        match command.kind {
            HAPTICD_COMMAND_QUERY => {}
            HAPTICD_COMMAND_SET_POSE => {
                let orientation = quat_from_wxyz(command.orientation);
                if orientation.length() < 0.5 {
                    return None;
                }
                self.world
                    .teleport(i, DVec3::from(command.position), orientation);
            }
            HAPTICD_COMMAND_SET_VELOCITY if !fixed => {
                let b = &mut self.world.bodies[i];
                (b.velocity, b.spin) = (vector, DVec3::from(command.spin));
            }
            HAPTICD_COMMAND_IMPULSE if !fixed => {
                let b = &mut self.world.bodies[i];
                let arm = DVec3::from(command.position) - b.position;
                let (dv, dw) = (
                    vector / b.mass,
                    b.world_inverse_inertia() * arm.cross(vector),
                );
                b.velocity += dv;
                b.spin += dw;
            }
            HAPTICD_COMMAND_IMPULSE_AT_CENTRE if !fixed => {
                let b = &mut self.world.bodies[i];
                b.velocity += vector / b.mass;
            }
            HAPTICD_COMMAND_SET_FORCE if !fixed => {
                self.world.loads[i] = Wrench {
                    force: vector,
                    torque: DVec3::ZERO,
                };
            }
            HAPTICD_COMMAND_SET_MASS if !fixed && self.mass_fits(i, command.value) => {
                self.world.bodies[i].set_mass(command.value);
            }
            HAPTICD_COMMAND_SET_FRICTION if command.value >= 0.0 => {
                self.world.friction[i] = Some(command.value);
            }
            _ => return None,
        }
        Some(self.body_state(i))
    }

    /// Whether body `i` may weigh `mass` kg, by the scene file's rules for its bodies: a
    /// density within [`DENSITY_RANGE`], and contact springs the step integrates without
    /// diverging (a 1 µg block under a pressing finger was flung kilometres).
    fn mass_fits(&self, i: usize, mass: f64) -> bool {
        let body = &self.world.bodies[i];
        let (light, dense) = DENSITY_RANGE;
        if !(light..=dense).contains(&(mass / body.volume)) {
            return false;
        }
        let material = &self.world.material;
        if material.scaling.is_some() {
            return true; // Springs scaled by mass and step: stable by construction.
        }
        // The spring of the contact model in use.
        let [(_, volume), (_, point)] =
            contact_springs(material.stiffness, material.stiffness, body);
        let k = match material.model {
            ContactModel::Volume => volume,
            ContactModel::Point => point,
        };
        omega_dt(k, mass, self.dt) < DIVERGENT_OMEGA_DT
    }
}

impl DrivenJoints for PenaltyScene {
    fn joint_count(&self) -> usize {
        self.world.joints.len()
    }

    fn joint(&self, k: usize) -> &Joint {
        &self.world.joints[k].joint
    }

    fn set_motor(&mut self, k: usize, motor: Option<Motor>) {
        // A world with joints does not sleep: the change takes at the next step.
        self.world.joints[k].joint.motor = motor;
    }

    fn joint_state(&self, k: usize) -> JointState {
        self.world.joint_state(k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;
    use std::path::Path;

    const SCENE: &str = "name: control
dt: 0.001
material: { stiffness: 1.0e5, damping: 50, static_friction: 0.5, friction: 0.4,
            friction_stiffness: 1.0e5, friction_damping: 50, slip_speed: 0.001 }
bodies:
  - { name: floor, box: [0.4, 0.1, 0.4], position: [0, -0.05, 0], fixed: true }
  - { name: block, box: [0.04, 0.02, 0.06], position: [0, 0.01, 0], density: 1000 }
pointer: { box: [0.01, 0.01, 0.01], density: 1000 }
";

    fn scene() -> PenaltyScene {
        PenaltyScene::parse(SCENE, Path::new("control.yaml"), 1).expect("the scene parses")
    }

    #[test]
    fn the_files_bodies_are_listed_by_name_and_the_pointers_are_not() {
        let mut scene = scene();
        let names: Vec<_> = (0..4)
            .map_while(|i| scene.body_info(i))
            .map(|b| (b.name_str().unwrap().to_string(), b.flags))
            .collect();
        assert_eq!(
            names,
            [
                ("floor".to_string(), HAPTICD_SOLID_FIXED),
                ("block".to_string(), 0)
            ]
        );
        assert!(
            scene
                .apply(&HapticdSceneCommand::new(HAPTICD_COMMAND_QUERY, 2))
                .is_none(),
            "the pointer"
        );
    }

    #[test]
    fn an_impulse_changes_momentum_by_itself_and_angular_momentum_by_its_moment() {
        let mut scene = scene();
        let before = scene.body_state(1);
        let mass = before.mass;
        assert!((mass - 0.04 * 0.02 * 0.06 * 1000.0).abs() < 1e-12);
        let j = DVec3::new(0.003, 0.001, -0.002);
        let at = DVec3::new(0.01, 0.02, 0.005);
        let after = scene
            .apply(&HapticdSceneCommand {
                vector: j.to_array(),
                position: at.to_array(),
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_IMPULSE, 1)
            })
            .expect("a free body takes an impulse");
        let dp = (DVec3::from(after.velocity) - DVec3::from(before.velocity)) * mass;
        assert!((dp - j).length() < 1e-15, "{dp} vs {j}");
        // The box's own inertia, from its edges: I = m/12 · (b² + c², …).
        let (a, b, c) = (0.04_f64, 0.02_f64, 0.06_f64);
        let inertia = DVec3::new(b * b + c * c, a * a + c * c, a * a + b * b) * mass / 12.0;
        let moment = (at - DVec3::from(before.position)).cross(j);
        let dl = (DVec3::from(after.spin) - DVec3::from(before.spin)) * inertia;
        assert!((dl - moment).length() < 1e-15, "{dl} vs {moment}");
        // Through the centre, wherever it is now: the momentum alone.
        let through = scene
            .apply(&HapticdSceneCommand {
                vector: j.to_array(),
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_IMPULSE_AT_CENTRE, 1)
            })
            .expect("a free body takes an impulse through its centre");
        let dp = (DVec3::from(through.velocity) - DVec3::from(after.velocity)) * mass;
        assert!((dp - j).length() < 1e-15, "{dp} vs {j}");
        assert_eq!(through.spin, after.spin, "through the centre: no turn");
    }

    #[test]
    fn a_body_set_to_a_pose_is_there_at_the_next_step_and_starts_its_contacts_afresh() {
        let mut scene = scene();
        for _ in 0..200 {
            scene.world.step(0.001);
        }
        let turn = DQuat::from_rotation_y(0.5);
        let to = DVec3::new(0.1, 0.05, -0.02);
        scene
            .apply(&HapticdSceneCommand {
                position: to.to_array(),
                orientation: quat_to_wxyz(turn),
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_POSE, 1)
            })
            .expect("a body takes a pose");
        let (v, w) = (scene.world.bodies[1].velocity, scene.world.bodies[1].spin);
        scene.world.step(0.001);
        let b = &scene.world.bodies[1];
        // It kept its velocity and fell for one step, touching nothing: x = (v + g·dt)·dt.
        let expected = to + (v + DVec3::new(0.0, -9.81, 0.0) * 0.001) * 0.001;
        assert!(
            (b.position - expected).length() < 1e-12,
            "{} vs {expected}",
            b.position
        );
        let turned = DQuat::from_scaled_axis(b.spin * 0.001) * turn;
        assert!(b.orientation.angle_between(turned) < 1e-7, "{w}");
    }

    #[test]
    fn a_held_force_mass_and_friction_change_the_body_and_refusals_change_nothing() {
        let mut scene = scene();
        let pushed = scene
            .apply(&HapticdSceneCommand {
                vector: [0.0, 1.0, 0.0],
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_FORCE, 1)
            })
            .unwrap();
        assert_eq!(pushed.force, [0.0, 1.0, 0.0]);
        let heavier = scene
            .apply(&HapticdSceneCommand {
                value: 2.0,
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_MASS, 1)
            })
            .unwrap();
        assert_eq!(heavier.mass, 2.0);
        let slippery = scene
            .apply(&HapticdSceneCommand {
                value: 0.05,
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_FRICTION, 1)
            })
            .unwrap();
        assert_eq!(slippery.friction, 0.05);
        let before = scene.body_state(1);
        for refused in [
            HapticdSceneCommand {
                vector: [f64::NAN, 0.0, 0.0],
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_VELOCITY, 1)
            },
            HapticdSceneCommand {
                value: -1.0,
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_MASS, 1)
            },
            // The block's volume spring on its 4 × 6 cm face, 1e5 N/m³ × 2.4e-3 m² = 240 N/m,
            // diverges at dt = 1 ms below 240 · 1e-6 / 4 = 6e-5 kg.
            HapticdSceneCommand {
                value: 5.9e-5,
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_MASS, 1)
            },
            HapticdSceneCommand {
                value: 1e-300,
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_MASS, 1)
            },
            // Densities past 1e5 kg/m³ (the block holds 4.8e-5 m³).
            HapticdSceneCommand {
                value: 4.9,
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_MASS, 1)
            },
            HapticdSceneCommand {
                vector: [1.0, 0.0, 0.0],
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_IMPULSE, 0)
            },
            HapticdSceneCommand {
                orientation: [0.0; 4],
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_POSE, 1)
            },
            HapticdSceneCommand::new(99, 1),
            HapticdSceneCommand::new(HAPTICD_COMMAND_QUERY, 7),
        ] {
            assert!(scene.apply(&refused).is_none(), "{refused:?}");
        }
        assert_eq!(scene.body_state(1), before);
        let light = HapticdSceneCommand {
            value: 6.1e-5,
            ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_MASS, 1)
        };
        assert_eq!(scene.apply(&light).unwrap().mass, 6.1e-5);
    }
}
