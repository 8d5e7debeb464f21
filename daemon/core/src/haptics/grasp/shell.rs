//! The shape shell (thesis 4.5.1, 4.6.1): a massless copy of the grasped object's surface,
//! held between the fingers by one spring per finger. Where the springs and the load on the
//! shell balance, the springs give each finger its grip force.
//!
//! Moving the shell by Δt and turning it by a small Δθ about its centre c moves the point
//! pᵢ where finger i holds it to pᵢ′ ≈ pᵢ + Δθ × (pᵢ − c) + Δt (4.15); the spring pulls it
//! toward the finger at xᵢ with k(xᵢ − pᵢ′) (4.16). Balance of force and moment with a load
//! (F, N) on the shell (4.13, 4.14),
//!
//! ```text
//! Σ k(xᵢ − pᵢ′) + F = 0,    Σ (pᵢ − c) × k(xᵢ − pᵢ′) + N = 0,
//! ```
//!
//! is linear in (Δt, Δθ): a 6×6 symmetric system, the shell's stiffness matrix. Two fingers
//! leave the turn about the line through them free; a small rotational stiffness of the shell
//! itself fixes it (the shell does not turn about that line).

use glam::{DQuat, DVec3};

use crate::solver::linalg::{ldlt_factor, ldlt_solve};

/// How stiffly the shell resists turning on its own, relative to the fingers' springs about
/// its size: enough to fix the turn two fingers leave free, far too little to change a grip.
const OWN_ROTATIONAL_STIFFNESS: f64 = 1e-6;

/// A load on the shell: force and moment about its centre where the shell is now, falling
/// linearly as the shell moves (a spring the shell pulls on, such as the inertia spring).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Load {
    /// Force, newtons.
    pub force: DVec3,
    /// Moment about the shell's centre, newton-metres.
    pub torque: DVec3,
    /// How much the force falls per metre the shell moves, N/m.
    pub stiffness: f64,
    /// How much the moment falls per radian the shell turns, N·m/rad.
    pub torsion: f64,
}

/// How the shell moves to balance: translation and rotation vector (small).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Displacement {
    /// Δt, metres.
    pub translation: DVec3,
    /// Δθ, radians (axis × angle).
    pub rotation: DVec3,
}

/// Linearisations the balance takes: each re-linearises about where the last one moved the
/// shell, so turns of a few degrees still balance to well under a millinewton.
const ITERATIONS: usize = 3;

/// The displacement that balances springs of stiffness `k` from the shell's points `held`
/// to the fingers at `fingers` (same order, at most [`super::MAX_FINGERS`]), with `load` on
/// the shell centred at `centre`. None when fewer than two points are held (nothing holds
/// the shell).
pub fn balance(
    held: &[DVec3],
    fingers: &[DVec3],
    k: f64,
    centre: DVec3,
    load: &Load,
) -> Option<Displacement> {
    let n = held.len();
    if !(2..=super::MAX_FINGERS).contains(&n) || n != fingers.len() || k.is_nan() || k <= 0.0 {
        return None;
    }
    let mut points = [DVec3::ZERO; super::MAX_FINGERS];
    points[..n].copy_from_slice(held);
    let (mut moved_centre, mut turn) = (centre, DQuat::IDENTITY);
    for _ in 0..ITERATIONS {
        let now = Load {
            force: load.force - load.stiffness * (moved_centre - centre),
            torque: load.torque - load.torsion * turn.to_scaled_axis(),
            ..*load
        };
        let step = linear_balance(&points[..n], fingers, k, moved_centre, &now)?;
        let rotation = DQuat::from_scaled_axis(step.rotation);
        for p in &mut points[..n] {
            *p = moved_centre + step.translation + rotation * (*p - moved_centre);
        }
        moved_centre += step.translation;
        turn = (rotation * turn).normalize();
    }
    Some(Displacement {
        translation: moved_centre - centre,
        rotation: turn.to_scaled_axis(),
    })
}

/// One linearisation of the balance (4.13–4.16) about the points as they are.
fn linear_balance(
    held: &[DVec3],
    fingers: &[DVec3],
    k: f64,
    centre: DVec3,
    load: &Load,
) -> Option<Displacement> {
    // Rows: force balance (3), moment balance (3); unknowns Δt (3), Δθ (3).
    let mut a = [[0.0; 6]; 6];
    let mut b = [0.0; 6];
    let mut size = 0.0f64;
    for (&p, &x) in held.iter().zip(fingers) {
        let r = p - centre;
        size = size.max(r.length());
        let rx = skew(r);
        let e = k * (x - p);
        // k(Δt + Δθ × r) = k(Δt − [r]× Δθ)
        for i in 0..3 {
            a[i][i] += k;
            for j in 0..3 {
                a[i][3 + j] -= k * rx[i][j];
                a[3 + i][j] += k * rx[i][j];
                // r × (Δθ × r) = −[r]×[r]× Δθ
                let rr: f64 = (0..3).map(|m| rx[i][m] * rx[m][j]).sum();
                a[3 + i][3 + j] -= k * rr;
            }
        }
        let m = r.cross(e);
        for i in 0..3 {
            b[i] += e[i];
            b[3 + i] += m[i];
        }
    }
    let own = OWN_ROTATIONAL_STIFFNESS * k * size * size;
    for i in 0..3 {
        a[i][i] += load.stiffness;
        a[3 + i][3 + i] += own + load.torsion;
    }
    for i in 0..3 {
        b[i] += load.force[i];
        b[3 + i] += load.torque[i];
    }
    if !ldlt_factor(&mut a, 6, 1e-300) {
        return None;
    }
    ldlt_solve(&a, 6, &mut b);
    Some(Displacement {
        translation: DVec3::new(b[0], b[1], b[2]),
        rotation: DVec3::new(b[3], b[4], b[5]),
    })
}

/// The cross-product matrix: skew(r)·v = r × v.
fn skew(r: DVec3) -> [[f64; 3]; 3] {
    [[0.0, -r.z, r.y], [r.z, 0.0, -r.x], [-r.y, r.x, 0.0]]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Net force and moment on the shell after moving by `d`.
    fn residual(
        held: &[DVec3],
        fingers: &[DVec3],
        k: f64,
        c: DVec3,
        load: &Load,
        d: &Displacement,
    ) -> (DVec3, DVec3) {
        let mut force = load.force;
        let mut torque = load.torque;
        let moved_centre = c + d.translation;
        let turn = DQuat::from_scaled_axis(d.rotation);
        for (&p, &x) in held.iter().zip(fingers) {
            let q = moved_centre + turn * (p - c);
            let f = k * (x - q);
            force += f;
            torque += (q - moved_centre).cross(f);
        }
        (force, torque)
    }

    #[test]
    fn two_fingers_squeezing_a_loaded_shell_hold_it_where_the_springs_balance_the_load() {
        // Fingers 4 cm apart squeeze a 6 cm shell; 3 N push it along +x.
        let held = [DVec3::new(-0.03, 0.0, 0.0), DVec3::new(0.03, 0.0, 0.0)];
        let fingers = [DVec3::new(-0.02, 0.0, 0.0), DVec3::new(0.02, 0.0, 0.0)];
        let load = Load {
            force: DVec3::new(3.0, 0.0, 0.0),
            ..Load::default()
        };
        let d = balance(&held, &fingers, 800.0, DVec3::ZERO, &load).unwrap();
        // Linear along x: both springs take 1.5 N more on the same side.
        assert!((d.translation.x - 3.0 / 1600.0).abs() < 1e-12, "{d:?}");
        let (f, t) = residual(&held, &fingers, 800.0, DVec3::ZERO, &load, &d);
        assert!(f.length() < 1e-9 && t.length() < 1e-9, "{f} {t}");
    }

    #[test]
    fn three_fingers_balance_a_force_and_a_moment() {
        let held = [
            DVec3::new(0.03, 0.0, 0.0),
            DVec3::new(-0.015, 0.026, 0.0),
            DVec3::new(-0.015, -0.026, 0.01),
        ];
        let fingers = [
            DVec3::new(0.028, 0.001, 0.0),
            DVec3::new(-0.014, 0.024, 0.001),
            DVec3::new(-0.013, -0.025, 0.009),
        ];
        let load = Load {
            force: DVec3::new(0.2, -0.3, 0.1),
            torque: DVec3::new(0.002, 0.001, -0.003),
            ..Load::default()
        };
        let d = balance(&held, &fingers, 800.0, DVec3::ZERO, &load).unwrap();
        let (f, t) = residual(&held, &fingers, 800.0, DVec3::ZERO, &load, &d);
        // A turn of about two degrees: three linearisations balance it (the moment converges
        // a little slower: the linear model leaves out how the turn swings the springs'
        // own pull, about 1/15 of the error per step here).
        assert!(d.rotation.length() > 0.03, "{d:?}");
        assert!(f.length() < 1e-6 && t.length() < 5e-5, "{f} {t}");
        assert!(balance(&held[..1], &fingers[..1], 800.0, DVec3::ZERO, &load).is_none());
    }
}
