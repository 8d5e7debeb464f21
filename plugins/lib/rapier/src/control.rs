//! A running rapier world changed from outside (the scene-control extension of the plugin
//! ABI): the scene file's bodies, by id, moved, pushed, made heavier or more slippery
//! between two physics steps.

use glam::DVec3;
use hapticd_core::kinematics::{quat_from_wxyz, quat_to_wxyz};
use hapticd_plugin_api::*;
use rapier3d::prelude::{CoefficientCombineRule, MassProperties};

use hapticd_physics::scene::DENSITY_RANGE;

use crate::convert::{dvec, rotation, vector};
use crate::world::RapierWorld;

impl RapierWorld {
    /// Body `i` of the scene file as the control extension lists it (None past the last):
    /// its rigid bodies, then its soft ones.
    pub fn body_info(&self, i: usize) -> Option<HapticdBodyInfo> {
        if let Some(soft) = self.soft_body(i) {
            return Some(HapticdBodyInfo::new(&soft.name, false));
        }
        let handle = self.bodies.get(i)?;
        let fixed = !self.physics.bodies[*handle].is_dynamic();
        Some(HapticdBodyInfo::new(&self.names[i], fixed))
    }

    /// Body `i`'s state now (`i` a body of the file).
    pub fn body_state(&self, i: usize) -> HapticdBodyState {
        if let Some(soft) = self.soft_body(i) {
            return soft.state();
        }
        let state = self.body(i);
        let b = &self.physics.bodies[self.bodies[i]];
        let friction = b
            .colliders()
            .iter()
            .map(|c| f64::from(self.physics.colliders[*c].friction()))
            .fold(f64::INFINITY, f64::min);
        HapticdBodyState {
            position: state.position.to_array(),
            orientation: quat_to_wxyz(state.orientation),
            velocity: state.velocity.to_array(),
            spin: state.spin.to_array(),
            mass: if b.is_dynamic() {
                f64::from(b.mass())
            } else {
                f64::INFINITY
            },
            friction,
            force: dvec(b.user_force()).to_array(),
        }
    }

    /// Carry out `command` on a body of the file; its state after, or None for a command
    /// it cannot take (no such body, a value not finite, a push on a fixed body, an unknown
    /// kind).
    pub fn control(&mut self, command: &HapticdSceneCommand) -> Option<HapticdBodyState> {
        let i = command.body as usize;
        if !command.is_finite() {
            return None;
        }
        if let Some(soft) = self.soft_body_mut(i) {
            soft.apply(command)?;
            return Some(soft.state());
        }
        let handle = *self.bodies.get(i)?;
        let b = &mut self.physics.bodies[handle];
        let free = b.is_dynamic();
        let (light, dense) = DENSITY_RANGE;
        let v = vector(DVec3::from(command.vector));
        match command.kind {
            HAPTICD_COMMAND_QUERY => {}
            HAPTICD_COMMAND_SET_POSE => {
                let orientation = quat_from_wxyz(command.orientation);
                if orientation.length() < 0.5 {
                    return None;
                }
                let orientation = orientation.normalize();
                // The centre of mass goes where it is asked; the body's origin follows it.
                let offset = orientation * dvec(b.mass_properties().local_mprops.local_com);
                b.set_rotation(rotation(orientation), false);
                b.set_translation(vector(DVec3::from(command.position) - offset), true);
            }
            HAPTICD_COMMAND_SET_VELOCITY if free => {
                b.set_linvel(v, false);
                b.set_angvel(vector(DVec3::from(command.spin)), true);
            }
            HAPTICD_COMMAND_IMPULSE if free => {
                b.apply_impulse_at_point(v, vector(DVec3::from(command.position)), true);
            }
            HAPTICD_COMMAND_IMPULSE_AT_CENTRE if free => b.apply_impulse(v, true),
            HAPTICD_COMMAND_SET_FORCE if free => {
                b.reset_forces(false);
                b.add_force(v, true);
            }
            // A scene file's rule for its bodies: a density within its range.
            HAPTICD_COMMAND_SET_MASS
                if free && (light..=dense).contains(&(command.value / self.volumes[i])) =>
            {
                let own = b.mass_properties().local_mprops;
                let scale = command.value / f64::from(own.mass());
                let inertia = own.reconstruct_inertia_matrix() * scale as f32;
                let props = MassProperties::with_inertia_matrix(
                    own.local_com,
                    command.value as f32,
                    inertia,
                );
                // The colliders' share set to nothing: the whole mass is the body's own.
                for c in b.colliders().to_vec() {
                    self.physics.colliders[c].set_density(0.0);
                }
                let b = &mut self.physics.bodies[handle];
                b.set_additional_mass_properties(props, true);
                b.recompute_mass_properties_from_colliders(&self.physics.colliders);
                let (moment, mass) = &mut self.inertia[i];
                (*moment, *mass) = (*moment * scale, command.value);
            }
            HAPTICD_COMMAND_SET_FRICTION if command.value >= 0.0 => {
                for c in b.colliders().to_vec() {
                    let collider = &mut self.physics.colliders[c];
                    collider.set_friction(command.value as f32);
                    collider.set_friction_combine_rule(CoefficientCombineRule::Min);
                }
            }
            _ => return None,
        }
        Some(self.body_state(i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;
    use hapticd_physics::scene::SceneFile;

    const SCENE: &str = "name: control
engine: rapier
rate: 50
material: { static_friction: 0.5, friction: 0.4 }
bodies:
  - { name: floor, box: [0.4, 0.1, 0.4], position: [0, -0.05, 0], fixed: true }
  - { name: block, box: [0.04, 0.02, 0.06], position: [0, 0.3, 0], density: 1000 }
";

    fn world() -> RapierWorld {
        match SceneFile::parse(SCENE, std::path::Path::new("c.yaml"), 0).unwrap() {
            SceneFile::Rapier(spec) => RapierWorld::new(&spec, 0),
            SceneFile::Penalty(_) => unreachable!("an engine: rapier scene"),
        }
    }

    #[test]
    fn a_body_set_to_a_pose_is_there_at_the_next_physics_step() {
        let mut w = world();
        let to = DVec3::new(0.1, 0.2, -0.05);
        let turn = DQuat::from_rotation_z(0.4);
        let set = w
            .control(&HapticdSceneCommand {
                position: to.to_array(),
                orientation: quat_to_wxyz(turn),
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_POSE, 1)
            })
            .unwrap();
        assert!((DVec3::from(set.position) - to).length() < 1e-6);
        assert!(w.advance(0.02));
        // One step of falling from rest: x = g·dt² (semi-implicit), nothing more.
        let fall = 9.81 * 0.02 * 0.02;
        let now = w.body(1);
        assert!(
            (now.position - to).length() <= fall * 1.001,
            "{}",
            now.position
        );
        assert!(now.orientation.angle_between(turn) < 1e-3);
    }

    #[test]
    fn an_impulse_changes_momentum_by_exactly_itself_at_any_mass() {
        let mut w = world();
        let mass = 0.04 * 0.02 * 0.06 * 1000.0;
        let j = DVec3::new(0.002, -0.001, 0.0005);
        for m in [mass, 0.5] {
            if m != mass {
                let heavier = w
                    .control(&HapticdSceneCommand {
                        value: m,
                        ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_MASS, 1)
                    })
                    .unwrap();
                assert!((heavier.mass - m).abs() < 1e-6 * m, "{}", heavier.mass);
            }
            let before = w.body_state(1);
            assert!((before.mass - m).abs() < 1e-6 * m);
            let after = w
                .control(&HapticdSceneCommand {
                    vector: j.to_array(),
                    position: before.position,
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_IMPULSE, 1)
                })
                .unwrap();
            let dp = (DVec3::from(after.velocity) - DVec3::from(before.velocity)) * m;
            assert!((dp - j).length() < 1e-6 * j.length(), "{dp} vs {j}");
            assert_eq!(after.spin, before.spin, "at the centre: no turn");
            let through = w
                .control(&HapticdSceneCommand {
                    vector: j.to_array(),
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_IMPULSE_AT_CENTRE, 1)
                })
                .unwrap();
            let dp = (DVec3::from(through.velocity) - DVec3::from(after.velocity)) * m;
            assert!((dp - j).length() < 1e-6 * j.length(), "{dp} vs {j}");
            assert_eq!(through.spin, after.spin, "through the centre: no turn");
        }
    }

    #[test]
    fn a_held_force_accelerates_the_body_until_it_is_taken_away() {
        let mut w = world();
        let mass = w.body_state(1).mass;
        // Gravity balanced and one newton sideways: a = F/m along x only.
        let force = DVec3::new(1.0, 9.81 * mass, 0.0);
        w.control(&HapticdSceneCommand {
            vector: force.to_array(),
            ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_FORCE, 1)
        })
        .unwrap();
        for _ in 0..5 {
            assert!(w.advance(0.02));
        }
        let v = w.body(1).velocity;
        assert!((v.x - 0.1 / mass).abs() < 1e-3 * v.x, "{v}");
        assert!(v.y.abs() < 1e-4, "{v}");
        let off = w
            .control(&HapticdSceneCommand {
                vector: [0.0; 3],
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_FORCE, 1)
            })
            .unwrap();
        assert_eq!(off.force, [0.0; 3]);
    }

    #[test]
    fn refusals_change_nothing() {
        let mut w = world();
        let slippery = w
            .control(&HapticdSceneCommand {
                value: 0.1,
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_FRICTION, 1)
            })
            .unwrap();
        assert!((slippery.friction - 0.1).abs() < 1e-7);
        assert_eq!(w.body_info(0).unwrap().flags, HAPTICD_SOLID_FIXED);
        assert_eq!(w.body_info(1).unwrap().name_str(), Some("block"));
        assert!(w.body_info(2).is_none());
        let before = w.body_state(1);
        for refused in [
            HapticdSceneCommand {
                vector: [f64::INFINITY, 0.0, 0.0],
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_VELOCITY, 1)
            },
            HapticdSceneCommand {
                value: 0.0,
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_MASS, 1)
            },
            HapticdSceneCommand {
                vector: [1.0, 0.0, 0.0],
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_FORCE, 0)
            },
            HapticdSceneCommand::new(HAPTICD_COMMAND_QUERY, 2),
            HapticdSceneCommand::new(42, 1),
        ] {
            assert!(w.control(&refused).is_none(), "{refused:?}");
        }
        assert_eq!(w.body_state(1), before);
    }
}
