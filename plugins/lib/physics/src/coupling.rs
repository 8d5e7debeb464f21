//! The virtual coupling of thesis 4.1.2: a pointer that is a body of the world, tied to the
//! user's grip by a 6-DOF spring and damper instead of being placed at it. The world keeps
//! the pointer out of other bodies however hard the user pushes; the user feels the
//! coupling's stretch, so the force displayed is bounded by its stiffness and stays passive
//! at any physics step that keeps the coupled body stable.

use glam::{DQuat, DVec3};

use crate::body::Body;
use hapticd_core::kinematics::{Wrench, rotation_vector};

/// Where the user's grip is and how it moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grip {
    /// Position, metres.
    pub position: DVec3,
    /// Orientation.
    pub orientation: DQuat,
    /// Velocity, m/s.
    pub velocity: DVec3,
    /// Angular velocity, rad/s.
    pub spin: DVec3,
}

/// Stiffness and damping of a coupling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coupling {
    /// Translational spring, N/m.
    pub stiffness: f64,
    /// Translational damper, N·s/m.
    pub damping: f64,
    /// Rotational spring, N·m/rad.
    pub rotational_stiffness: f64,
    /// Rotational damper, N·m·s/rad.
    pub rotational_damping: f64,
}

impl Coupling {
    /// The load the coupling puts on `body` (its centroid is the coupled point) with the grip
    /// at `grip`, for a step of `dt`; the user feels the opposite. Each damper is held to
    /// what implicit Euler would apply over the step (c/(1 + c·dt/m)), so that however it is
    /// set it can at most stop the body's motion relative to the grip, never reverse it.
    pub fn load(&self, grip: &Grip, body: &Body, dt: f64) -> Wrench {
        // The smallest rotation taking the body's orientation to the grip's.
        let error = rotation_vector(grip.orientation * body.orientation.inverse());
        let stable = |c: f64, mobility: f64| c / (1.0 + c * dt * mobility);
        let turning = grip.spin - body.spin;
        let turning_mobility = body.inverse_inertia_about(turning.normalize_or_zero());
        Wrench {
            force: self.stiffness * (grip.position - body.position)
                + stable(self.damping, 1.0 / body.mass) * (grip.velocity - body.velocity),
            torque: self.rotational_stiffness * error
                + stable(self.rotational_damping, turning_mobility) * turning,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::polyhedron::Polyhedron;

    #[test]
    fn the_load_pulls_the_body_towards_the_grip_and_turns_it_the_short_way() {
        let body = Body::new(&Polyhedron::cuboid(DVec3::splat(0.01)), 1000.0, false);
        let coupling = Coupling {
            stiffness: 400.0,
            damping: 2.0,
            rotational_stiffness: 0.5,
            rotational_damping: 0.0,
        };
        let turn = DQuat::from_rotation_y(0.3);
        let grip = Grip {
            position: DVec3::new(0.01, 0.0, 0.0),
            orientation: -turn, // the same rotation, other sign
            velocity: DVec3::new(0.0, 0.1, 0.0),
            spin: DVec3::ZERO,
        };
        let dt = 1e-4;
        let load = coupling.load(&grip, &body, dt);
        let damping = 2.0 / (1.0 + 2.0 * dt / body.mass);
        assert!((load.force - DVec3::new(4.0, 0.1 * damping, 0.0)).length() < 1e-12);
        assert!((load.torque - DVec3::new(0.0, 0.15, 0.0)).length() < 1e-12);
    }
}
