//! Rigid bodies of convex polyhedra, or of several (a compound, for a body that is not
//! convex): mass properties from shape and density, and semi-implicit integration with a
//! unit quaternion for orientation.

use glam::{DMat3, DQuat, DVec3};

use super::mass::{mass_properties, moved_inertia};
use super::polyhedron::Polyhedron;

/// A rigid body.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    /// The convex pieces in the body's frame, the centroid of the whole at the origin.
    pub pieces: Vec<Polyhedron>,
    /// Mass, kg.
    pub mass: f64,
    /// Volume of the solid, m³ (a mesh's own, however its pieces overfill it).
    pub volume: f64,
    /// Inertia tensor about the centroid, body frame, kg·m².
    pub inertia: DMat3,
    /// Position of the centroid, metres.
    pub position: DVec3,
    /// Orientation.
    pub orientation: DQuat,
    /// Velocity of the centroid, m/s.
    pub velocity: DVec3,
    /// Angular velocity, world frame, rad/s.
    pub spin: DVec3,
    /// Fixed bodies are not moved by forces (floors, walls, pointers).
    pub fixed: bool,
    /// A fixed body that is moved from outside (a pointer following the grip); it still
    /// touches other fixed bodies.
    pub kinematic: bool,
    world: Vec<Polyhedron>,
    /// The inverse inertia tensor in the world frame, at the pose of the world pieces.
    world_inverse_inertia: DMat3,
}

impl Body {
    /// A body of `shape` (given where it is in the world) and `density` kg/m³.
    pub fn new(shape: &Polyhedron, density: f64, fixed: bool) -> Self {
        Self::compound(std::slice::from_ref(shape), density, fixed)
    }

    /// A body made of the convex `pieces` (given where they are in the world; they may
    /// touch but should not overlap) and `density` kg/m³.
    pub fn compound(pieces: &[Polyhedron], density: f64, fixed: bool) -> Self {
        let properties: Vec<_> = pieces.iter().map(mass_properties).collect();
        let volume: f64 = properties.iter().map(|p| p.0).sum();
        let centroid = properties.iter().map(|p| p.0 * p.1).sum::<DVec3>() / volume;
        // Each piece's inertia moved to the common centroid (parallel axes).
        let inertia = properties
            .iter()
            .map(|&(v, c, i)| moved_inertia(i, v, c - centroid))
            .fold(DMat3::ZERO, |sum, i| sum + i);
        let solid = (volume, volume * density);
        Self::from_parts(pieces, solid, centroid, inertia * density, fixed)
    }

    /// A body touching through the convex `pieces` (given where they are in the world) whose
    /// volume and mass (`solid`), `centroid` and `inertia` about it (world frame) are given: a
    /// mesh's, whose pieces stand for it in contact only.
    pub fn from_parts(
        pieces: &[Polyhedron],
        (volume, mass): (f64, f64),
        centroid: DVec3,
        inertia: DMat3,
        fixed: bool,
    ) -> Self {
        Self {
            world: pieces.to_vec(),
            world_inverse_inertia: inertia.inverse(),
            pieces: pieces
                .iter()
                .map(|p| p.transformed(DQuat::IDENTITY, -centroid))
                .collect(),
            mass,
            volume,
            inertia,
            position: centroid,
            orientation: DQuat::IDENTITY,
            velocity: DVec3::ZERO,
            spin: DVec3::ZERO,
            fixed,
            kinematic: false,
        }
    }

    /// The pieces where the body is now.
    pub fn world_pieces(&self) -> &[Polyhedron] {
        &self.world
    }

    /// Bring the world pieces (and the world-frame inertia) up to date with the pose.
    pub fn update_world_shape(&mut self) {
        let rotation = DMat3::from_quat(self.orientation);
        self.world_inverse_inertia = rotation * self.inertia.inverse() * rotation.transpose();
        for (world, local) in self.world.iter_mut().zip(&self.pieces) {
            for (v, l) in world.vertices.iter_mut().zip(&local.vertices) {
                *v = self.orientation * *l + self.position;
            }
            for (plane, l) in world.planes.iter_mut().zip(&local.planes) {
                plane.normal = self.orientation * l.normal;
                plane.offset = l.offset + plane.normal.dot(self.position);
            }
        }
    }

    /// The inverse inertia tensor in the world frame, at the body's pose.
    pub fn world_inverse_inertia(&self) -> DMat3 {
        self.world_inverse_inertia
    }

    /// Make the mass `mass`, the inertia scaled with it (the same shape of another density).
    pub fn set_mass(&mut self, mass: f64) {
        let scale = mass / self.mass;
        (self.mass, self.inertia) = (mass, self.inertia * scale);
        self.world_inverse_inertia *= 1.0 / scale;
    }

    /// Put a fixed body at a pose, moving with the given velocities (a pointer that follows
    /// the user's grip).
    pub fn place(&mut self, position: DVec3, orientation: DQuat, velocity: DVec3, spin: DVec3) {
        (self.position, self.orientation, self.velocity, self.spin) =
            (position, orientation, velocity, spin);
        self.kinematic = true;
        self.update_world_shape();
    }

    /// How readily the body's material point at `x` moves along the unit `direction` under
    /// a force there: 1/m + (r × d)·I⁻¹(r × d), zero for a body contacts cannot move.
    pub fn inverse_mass_at(&self, x: DVec3, direction: DVec3) -> f64 {
        if self.fixed {
            return 0.0;
        }
        let arm = (x - self.position).cross(direction);
        1.0 / self.mass + arm.dot(self.world_inverse_inertia * arm)
    }

    /// How readily the body turns about the unit `axis` through its centroid under a
    /// torque: a·I⁻¹a, zero for a body contacts cannot move.
    pub fn inverse_inertia_about(&self, axis: DVec3) -> f64 {
        if self.fixed {
            return 0.0;
        }
        axis.dot(self.world_inverse_inertia * axis)
    }

    /// The moment of inertia about the line through `point` along the unit `axis`
    /// (infinite for a body contacts cannot move).
    pub fn inertia_about_line(&self, point: DVec3, axis: DVec3) -> f64 {
        let arm = (self.position - point).cross(axis);
        1.0 / self.inverse_inertia_about(axis) + self.mass * arm.length_squared()
    }

    /// Velocity of the body's material point at `x`.
    pub fn velocity_at(&self, x: DVec3) -> DVec3 {
        self.velocity + self.spin.cross(x - self.position)
    }

    /// Advance by `dt` under `force` and `torque` (about the centroid), semi-implicitly:
    /// velocities first, then the pose with the new velocities.
    pub fn integrate(&mut self, force: DVec3, torque: DVec3, dt: f64) {
        if self.fixed {
            return;
        }
        let rotation = DMat3::from_quat(self.orientation);
        let inertia = rotation * self.inertia * rotation.transpose();
        // Euler's equations in the world frame: I ω̇ = τ − ω × Iω.
        let gyroscopic = self.spin.cross(inertia * self.spin);
        self.velocity += force / self.mass * dt;
        self.spin += self.world_inverse_inertia * (torque - gyroscopic) * dt;
        self.position += self.velocity * dt;
        self.orientation = (DQuat::from_scaled_axis(self.spin * dt) * self.orientation).normalize();
        self.update_world_shape();
    }
}
