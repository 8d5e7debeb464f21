//! How a multibody's link answers the hand through its joints (local dynamics of a jointed
//! body, thesis 6.5.4): its articulated mobility `J·M⁻¹·Jᵀ` for the haptic side to move it
//! with, and the hand's change on it taken back into the joints' coordinates.
//!
//! `J` is the link's Jacobian (its centre's velocity and its spin from the multibody's
//! generalized velocities) and `M` the multibody's mass matrix, both as rapier's last step
//! left them. A change of the link's motion goes into the coordinates as the impulse that
//! would make it: `Δq = M⁻¹·Jᵀ·Λ·Δx`, with `Λ` the link's articulated inertia (the
//! pseudo-inverse of its mobility). For a door that is its change of angle, exactly; for a
//! link down a chain the whole chain moves as the push would move it.

use hapticd_plugin_api::HapticdMobility;
use rapier3d::na::{DVector, Matrix6, Matrix6xX, MatrixXx6, Vector6};
use rapier3d::prelude::{MultibodyIndex, PhysicsWorld, RigidBodyHandle, Vector};

use crate::convert::dvec;

/// A link's Jacobian and `M⁻¹·Jᵀ`, in `f64`.
struct Link {
    jacobian: Matrix6xX<f64>,
    /// `M⁻¹·Jᵀ`: the generalized velocities each unit impulse on the link gives.
    response: MatrixXx6<f64>,
}

/// Link `body`'s Jacobian and response; None for a body that is no link, or a link of a
/// multibody with kinematic links (whose mass matrix rapier keeps reordered).
fn link(physics: &PhysicsWorld, body: RigidBodyHandle) -> Option<(Link, MultibodyIndex)> {
    let id = physics.multibody_joints.rigid_body_link(body)?;
    let multibody = physics.multibody_joints.get_multibody(id.multibody)?;
    let n = multibody.ndofs();
    let lu = multibody.inv_augmented_mass();
    if n == 0 || lu.u().nrows() != n {
        return None;
    }
    let jacobian = multibody.body_jacobian(id.id);
    if jacobian.ncols() != n {
        return None;
    }
    let response = lu.solve(&jacobian.transpose())?;
    Some((
        Link {
            jacobian: jacobian.map(f64::from),
            response: response.map(f64::from),
        },
        id.multibody,
    ))
}

/// Link `body`'s articulated mobility and its acceleration under the gravity of its whole
/// multibody; None for a body that is no link.
pub fn mobility(physics: &PhysicsWorld, body: RigidBodyHandle) -> Option<HapticdMobility> {
    let (link, index) = link(physics, body)?;
    let m = &link.jacobian * &link.response;
    let multibody = physics.multibody_joints.get_multibody(index)?;
    let n = multibody.ndofs();
    // Gravity on every link, as generalized forces.
    let gravity = dvec(physics.gravity);
    let mut forces = DVector::<f32>::zeros(n);
    for l in multibody.links() {
        let b = &physics.bodies[l.rigid_body_handle()];
        if !b.is_dynamic() {
            continue;
        }
        let weight = gravity * f64::from(b.mass() * b.gravity_scale());
        let wrench = Vector6::new(
            weight.x as f32,
            weight.y as f32,
            weight.z as f32,
            0.0,
            0.0,
            0.0,
        );
        forces += multibody.body_jacobian(l.link_id()).transpose() * wrench;
    }
    let accelerations = multibody.inv_augmented_mass().solve(&forces)?;
    let acceleration = &link.jacobian * accelerations.map(f64::from);
    let mut out = HapticdMobility::default();
    for (r, row) in out.mobility.iter_mut().enumerate() {
        for (c, x) in row.iter_mut().enumerate() {
            // Symmetric as the ABI says, whatever `f32` left of it.
            *x = 0.5 * (m[(r, c)] + m[(c, r)]);
        }
    }
    out.acceleration.copy_from_slice(acceleration.as_slice());
    Some(out)
}

/// Move link `body` by `displacement` (its centre's, then a rotation vector) and change its
/// velocity by `velocity` (the centre's, then the spin's), through its joints. False for a
/// body that is no link.
pub fn take_in(
    physics: &mut PhysicsWorld,
    body: RigidBodyHandle,
    displacement: Vector6<f64>,
    velocity: Vector6<f64>,
) -> bool {
    let Some((link, multibody)) = link(physics, body) else {
        return false;
    };
    let mobility: Matrix6<f64> = &link.jacobian * &link.response;
    let Ok(inertia) = mobility.pseudo_inverse(1e-9 * mobility.diagonal().amax()) else {
        return false;
    };
    let coordinates = |change: Vector6<f64>| -> DVector<f32> {
        (&link.response * (inertia * change)).map(|x| x as f32)
    };
    let (moved, sped) = (coordinates(displacement), coordinates(velocity));
    if moved.iter().chain(sped.iter()).any(|x| !x.is_finite()) {
        return false;
    }
    let Some(mb) = physics.multibody_joints.get_multibody_mut(multibody) else {
        return false;
    };
    mb.apply_displacements(moved.as_slice());
    let mut rates = mb.generalized_velocity_mut();
    rates += sped;
    mb.forward_kinematics(&physics.bodies, false);
    mb.update_rigid_bodies(&mut physics.bodies, true);
    // And each link's velocities, which rapier sets from the joints' only in a step.
    let rates = mb.generalized_velocity().clone_owned();
    for l in mb.links() {
        let twist = mb.body_jacobian(l.link_id()) * &rates;
        let b = &mut physics.bodies[l.rigid_body_handle()];
        if b.is_dynamic() {
            b.set_linvel(Vector::new(twist[0], twist[1], twist[2]), true);
            b.set_angvel(Vector::new(twist[3], twist[4], twist[5]), true);
        }
    }
    true
}
