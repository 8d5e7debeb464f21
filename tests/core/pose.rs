//! Pose solver (thesis 3.4) on every shipped mechanism: exact recovery, accuracy under
//! encoder quantisation, and the two-iteration claim of 3.4.7.

use crate::support;

use glam::{DQuat, DVec3};
use hapticd_core::kinematics::{MAX_STRINGS_PER_EFFECTOR, Pose};
use hapticd_core::mechanism::Mechanism;
use hapticd_core::solver::calibration::lengths_from_counts;
use hapticd_core::solver::geometry::StringGeometry;
use hapticd_core::solver::pose::PoseSolver;
use support::{Rng, pose_inside, shipped_mechanisms};

fn lengths_at(m: &Mechanism, index: usize, pose: &Pose) -> Vec<f64> {
    let mut l = [0.0; MAX_STRINGS_PER_EFFECTOR];
    let k = m.kinematics(index);
    k.lengths(pose, &mut l);
    l[..k.count()].to_vec()
}

fn errors(a: &Pose, b: &Pose) -> (f64, f64) {
    let d = (a.position - b.position).length();
    let r = (a.orientation * b.orientation.inverse()).normalize();
    (d, 2.0 * r.xyz().length().atan2(r.w.abs()))
}

#[test]
fn exact_lengths_give_the_exact_pose_within_three_iterations() {
    let mut rng = Rng::new(1);
    for m in shipped_mechanisms() {
        for index in 0..m.effectors.len() {
            for _ in 0..300 {
                let truth = pose_inside(&m, index, &mut rng);
                let six = m.effectors[index].dof.count() == 6;
                let start = Pose {
                    position: truth.position + rng.unit() * 0.005,
                    orientation: if six {
                        DQuat::from_axis_angle(rng.unit(), 0.05) * truth.orientation
                    } else {
                        DQuat::IDENTITY
                    },
                };
                let mut solver = PoseSolver::new(m.kinematics(index), start);
                let estimate = solver.solve(&lengths_at(&m, index, &truth), 3);
                let (d, r) = errors(&estimate.pose, &truth);
                assert!(
                    d < 1e-6 && r < 1e-6,
                    "{} {}: error {d:.2e} m, {r:.2e} rad",
                    m.name,
                    index
                );
                assert!(estimate.residual < 1e-9);
            }
        }
    }
}

/// ‖W⁺‖₂ ≤ √trace((W Wᵀ)⁻¹), computed by Gauss–Jordan inversion.
fn pseudo_inverse_norm_bound(g: &StringGeometry) -> f64 {
    let n = g.dof();
    let mut a = [[0.0; 6]; 6];
    for i in 0..g.count() {
        let w = g.column(i);
        for r in 0..n {
            for c in 0..n {
                a[r][c] += w[r] * w[c];
            }
        }
    }
    let mut m = [[0.0; 12]; 6];
    for r in 0..n {
        m[r][..n].copy_from_slice(&a[r][..n]);
        m[r][n + r] = 1.0;
    }
    for c in 0..n {
        let p = (c..n)
            .max_by(|&x, &y| m[x][c].abs().total_cmp(&m[y][c].abs()))
            .unwrap();
        m.swap(c, p);
        let d = m[c][c];
        for v in &mut m[c] {
            *v /= d;
        }
        for r in 0..n {
            if r != c {
                let (f, pivot_row) = (m[r][c], m[c]);
                for (v, p) in m[r].iter_mut().zip(pivot_row) {
                    *v -= f * p;
                }
            }
        }
    }
    (0..n).map(|i| m[i][n + i]).sum::<f64>().sqrt()
}

/// First-order bound on the pose error (metres and radians together) when every length is
/// off by at most half an encoder count: ‖W⁺‖₂ · √m · mpp / 2.
fn resolution_bound(m: &Mechanism, index: usize, pose: &Pose) -> f64 {
    let strings = &m.effectors[index].strings;
    let mpp_max = strings
        .iter()
        .map(|&s| m.strings[s].metres_per_pulse.abs())
        .fold(0.0, f64::max);
    pseudo_inverse_norm_bound(&StringGeometry::at(&m.kinematics(index), pose))
        * (strings.len() as f64).sqrt()
        * mpp_max
        / 2.0
}

#[test]
fn quantised_counts_bound_the_error_by_the_encoder_resolution() {
    let mut rng = Rng::new(2);
    for m in shipped_mechanisms() {
        for index in 0..m.effectors.len() {
            for _ in 0..200 {
                let truth = pose_inside(&m, index, &mut rng);
                let exact = lengths_at(&m, index, &truth);
                let strings = &m.effectors[index].strings;
                let quantised: Vec<f64> = exact
                    .iter()
                    .zip(strings)
                    .map(|(l, &s)| {
                        let mpp = m.strings[s].metres_per_pulse;
                        (l / mpp).round() * mpp
                    })
                    .collect();
                let mut solver = PoseSolver::new(m.kinematics(index), truth);
                let estimate = solver.solve(&quantised, 10);
                let bound = resolution_bound(&m, index, &truth);
                let (d, r) = errors(&estimate.pose, &truth);
                let total = (d * d + r * r).sqrt();
                assert!(
                    total <= 1.01 * bound,
                    "{}: error {total:.3e} exceeds resolution bound {bound:.3e}",
                    m.name
                );
            }
        }
    }
}

#[test]
fn two_iterations_follow_a_one_metre_per_second_hand_at_one_kilohertz() {
    let mut rng = Rng::new(3);
    let mut worst: f64 = 0.0;
    for m in shipped_mechanisms() {
        for index in 0..m.effectors.len() {
            let six = m.effectors[index].dof.count() == 6;
            for _ in 0..300 {
                let previous = pose_inside(&m, index, &mut rng);
                // 1 m/s for 1 ms; a rigid grip also turns at one revolution per second.
                let now = Pose {
                    position: previous.position + rng.unit() * 1e-3,
                    orientation: if six {
                        DQuat::from_axis_angle(rng.unit(), std::f64::consts::TAU * 1e-3)
                            * previous.orientation
                    } else {
                        DQuat::IDENTITY
                    },
                };
                let mut solver = PoseSolver::new(m.kinematics(index), previous);
                let estimate = solver.solve(&lengths_at(&m, index, &now), 2);
                let (d, r) = errors(&estimate.pose, &now);
                worst = worst.max(d).max(r);
            }
        }
    }
    // Below a tenth of an encoder count of the finest encoder shipped (1.67e-5 m).
    assert!(
        worst < 1.5e-6,
        "worst error after 2 iterations: {worst:.2e}"
    );
}

#[test]
fn zero_iterations_leave_the_error_of_the_move() {
    // The test above can fail: without iterating, the 1 mm move is the error.
    let m = &shipped_mechanisms()[0];
    let previous = Pose::IDENTITY;
    let now = Pose {
        position: DVec3::new(1e-3, 0.0, 0.0),
        ..previous
    };
    let mut solver = PoseSolver::new(m.kinematics(0), previous);
    let estimate = solver.solve(&lengths_at(m, 0, &now), 0);
    assert!((errors(&estimate.pose, &now).0 - 1e-3).abs() < 1e-12);
}

#[test]
fn calibrated_encoder_counts_track_the_grip() {
    let mut rng = Rng::new(4);
    for mut m in shipped_mechanisms() {
        for reversed in [false, true] {
            if reversed {
                // Encoders wired to count backwards: a negative metres-per-pulse undoes it.
                for s in &mut m.strings {
                    s.metres_per_pulse = -s.metres_per_pulse;
                }
            }
            // Whatever the counters read at power-on, calibration anchors them.
            let at_power_on: Vec<i64> = (0..m.strings.len() as i64)
                .map(|i| (i * 7919) % 5000 - 2500)
                .collect();
            let offsets = m.offsets(&at_power_on);
            let calibration_lengths = m.calibration_lengths();
            let metres_per_pulse = m.metres_per_pulse();
            for index in 0..m.effectors.len() {
                let truth = pose_inside(&m, index, &mut rng);
                // What the encoders read once the grip has moved to `truth`.
                let counts: Vec<i64> = m
                    .strings
                    .iter()
                    .enumerate()
                    .map(|(i, s)| {
                        let pose = if s.effector == index {
                            truth
                        } else {
                            m.effectors[s.effector].calibration
                        };
                        let length = (s.motor - pose.transform_point(s.knot)).length();
                        at_power_on[i]
                            + ((length - calibration_lengths[i]) / s.metres_per_pulse).round()
                                as i64
                    })
                    .collect();
                let mut lengths = vec![0.0; m.strings.len()];
                lengths_from_counts(&offsets, &metres_per_pulse, &counts, &mut lengths);
                let own: Vec<f64> = m.effectors[index]
                    .strings
                    .iter()
                    .map(|&s| lengths[s])
                    .collect();
                let mut solver =
                    PoseSolver::new(m.kinematics(index), m.effectors[index].calibration);
                let estimate = solver.solve(&own, 20);
                let (d, r) = errors(&estimate.pose, &truth);
                let bound = resolution_bound(&m, index, &truth);
                assert!(
                    (d * d + r * r).sqrt() <= 1.01 * bound,
                    "{} reversed={reversed}: {d:.2e} m, {r:.2e} rad, bound {bound:.2e}",
                    m.name
                );
            }
        }
    }
}
