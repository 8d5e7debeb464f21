//! An element's turn: the rotation nearest its deformation gradient (the rotation of its
//! polar decomposition), found by turning last step's rotation toward the gradient's
//! columns a few times (Müller, Bender, Chentanez and Macklin, 2016). Warm-started, one or
//! two turns suffice; an inverted element still gets a rotation, never a reflection.

use glam::{DMat3, DQuat};

/// Turns that bring a rotation to the polar one from anywhere, at most.
pub const TURNS: usize = 20;

/// Turns smaller than this (rad) are taken to first order.
const SMALL_TURN: f64 = 0.01;

/// Turn `turn` toward the rotation nearest `gradient`, at most `turns` times, and no more
/// once a turn was smaller than `settled` (rad); `rotation` is its matrix before and after
/// (kept, so a turn settled at once costs one matrix, not two).
pub fn follow(
    gradient: &DMat3,
    turn: &mut DQuat,
    rotation: &mut DMat3,
    turns: usize,
    settled: f64,
) {
    for _ in 0..turns {
        let r = *rotation;
        let pull = r.x_axis.cross(gradient.x_axis)
            + r.y_axis.cross(gradient.y_axis)
            + r.z_axis.cross(gradient.z_axis);
        let along = r.x_axis.dot(gradient.x_axis)
            + r.y_axis.dot(gradient.y_axis)
            + r.z_axis.dot(gradient.z_axis);
        let omega = pull * (along.abs() + 1e-9).recip();
        let angle = omega.length();
        if angle < 1e-12 {
            break;
        }
        // A small turn's quaternion to within its angle³/12 (what the next turn corrects),
        // without the sine and cosine of the exact one.
        let step = if angle < SMALL_TURN {
            DQuat::from_xyzw(omega.x / 2.0, omega.y / 2.0, omega.z / 2.0, 1.0)
        } else {
            DQuat::from_axis_angle(omega / angle, angle)
        };
        *turn = (step * *turn).normalize();
        *rotation = DMat3::from_quat(*turn);
        if angle < settled {
            break;
        }
    }
}

/// The rotation nearest `gradient`, from the identity.
pub fn nearest(gradient: &DMat3) -> DQuat {
    let (mut turn, mut rotation) = (DQuat::IDENTITY, DMat3::IDENTITY);
    follow(gradient, &mut turn, &mut rotation, TURNS, 0.0);
    turn
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// A rotation times a stretch along any axes gives back the rotation.
    #[test]
    fn a_turned_stretch_gives_back_its_turn() {
        let turn = DQuat::from_axis_angle(DVec3::new(0.3, -0.5, 0.8).normalize(), 2.5);
        let axes = DMat3::from_quat(DQuat::from_axis_angle(
            DVec3::new(1.0, 1.0, 0.2).normalize(),
            0.7,
        ));
        let stretch = axes * DMat3::from_diagonal(DVec3::new(1.3, 0.6, 0.9)) * axes.transpose();
        let found = nearest(&(DMat3::from_quat(turn) * stretch));
        assert!(found.dot(turn).abs() > 1.0 - 1e-10, "{found:?} vs {turn:?}");
    }
}
