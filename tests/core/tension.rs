//! Tension QP (thesis 3.5, eq. 3.16) against Clarabel, a general-purpose conic solver, and
//! the complete-presentation region against exact references.

use crate::support;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, ZeroConeT,
};
use glam::{DQuat, DVec3};
use hapticd_core::kinematics::{Pose, Wrench};
use hapticd_core::mechanism::Mechanism;
use hapticd_core::mechanism::analysis::tension_sweep;
use hapticd_core::solver::closure::is_force_closed;
use hapticd_core::solver::geometry::StringGeometry;
use hapticd_core::solver::tension::TensionSettings;
use support::qp::{clarabel_tensions, w_rows};
use support::{Rng, frame_half, shipped, shipped_mechanisms};

fn quiet_settings() -> clarabel::solver::DefaultSettings<f64> {
    DefaultSettingsBuilder::default()
        .verbose(false)
        .tol_gap_abs(1e-12)
        .tol_gap_rel(1e-12)
        .tol_feas(1e-12)
        .tol_ktratio(1e-10)
        .max_iter(400)
        .build()
        .expect("valid Clarabel settings")
}

/// Eq. 3.16 as written, solved by Clarabel, which must report it solved.
fn reference_tensions(
    g: &StringGeometry,
    f: &[f64],
    lambda: f64,
    lo: &[f64],
    hi: &[f64],
) -> Vec<f64> {
    reference_solution(g, f, lambda, lo, hi, &[SolverStatus::Solved])
}

/// Clarabel's solution, which must end in one of `accepted`.
fn reference_solution(
    g: &StringGeometry,
    f: &[f64],
    lambda: f64,
    lo: &[f64],
    hi: &[f64],
    accepted: &[SolverStatus],
) -> Vec<f64> {
    let (status, x) = clarabel_tensions(g, f, lambda, (lo, hi), quiet_settings());
    assert!(accepted.contains(&status), "{status:?}");
    x
}

fn objective(g: &StringGeometry, t: &[f64], f: &[f64], lambda: f64) -> f64 {
    let achieved = g.wrench(t).to_array();
    let err: f64 = (0..g.dof()).map(|r| (achieved[r] - f[r]).powi(2)).sum();
    err + lambda * t.iter().map(|x| x * x).sum::<f64>()
}

fn limits(m: &Mechanism, index: usize) -> (Vec<f64>, Vec<f64>) {
    m.effectors[index]
        .strings
        .iter()
        .map(|&s| (m.strings[s].tension_min, m.strings[s].tension_max))
        .unzip()
}

/// A random pose anywhere in the frame (complete region or not) and a random wrench.
fn random_case(m: &Mechanism, index: usize, rng: &mut Rng) -> (StringGeometry, [f64; 6]) {
    let half = frame_half(m, index);
    let six = m.effectors[index].dof.count() == 6;
    let pose = Pose {
        position: rng.cube(0.8 * half),
        orientation: if six {
            rng.rotation(0.5)
        } else {
            DQuat::IDENTITY
        },
    };
    let force = rng.unit() * rng.range(0.0, 15.0);
    let torque = if six {
        rng.unit() * rng.range(0.0, 0.3)
    } else {
        DVec3::ZERO
    };
    (
        StringGeometry::at(&m.kinematics(index), &pose),
        [force.x, force.y, force.z, torque.x, torque.y, torque.z],
    )
}

#[test]
fn tensions_match_a_general_qp_solver_on_random_problems() {
    let mut rng = Rng::new(10);
    for m in shipped_mechanisms() {
        for index in 0..m.effectors.len() {
            let (lo, hi) = limits(&m, index);
            let mut solver = m.tension_solver(index);
            let mut worst: f64 = 0.0;
            for _ in 0..1000 {
                let (g, f) = random_case(&m, index, &mut rng);
                let lambda = 10f64.powf(rng.range(-4.0, 0.0));
                solver.set_settings(TensionSettings {
                    lambda,
                    torque_weight: 1.0,
                });
                let ours = solver.solve(&g, &Wrench::from_array(f));
                assert!(ours.converged);
                let reference = reference_tensions(&g, &f, lambda, &lo, &hi);
                for (i, (t, r)) in ours.tensions().iter().zip(&reference).enumerate() {
                    assert!(lo[i] <= *t && *t <= hi[i], "{}: bound broken: {t}", m.name);
                    worst = worst.max((t - r).abs());
                }
            }
            assert!(
                worst < 1e-5,
                "{} effector {index}: largest difference {worst:.2e} N",
                m.name
            );
        }
    }
}

#[test]
fn at_lambda_zero_the_objective_matches_the_general_solver() {
    // Without λ the optimum may be a whole segment of tensions; compare optimal values.
    let mut rng = Rng::new(11);
    for m in shipped_mechanisms() {
        let (lo, hi) = limits(&m, 0);
        let mut solver = m.tension_solver(0);
        solver.set_settings(TensionSettings {
            lambda: 0.0,
            torque_weight: 1.0,
        });
        for _ in 0..300 {
            let (g, f) = random_case(&m, 0, &mut rng);
            let ours = solver.solve(&g, &Wrench::from_array(f));
            // Without λ the problem is only semidefinite; interior points may stop short.
            let accepted = [SolverStatus::Solved, SolverStatus::AlmostSolved];
            let reference = reference_solution(&g, &f, 0.0, &lo, &hi, &accepted);
            let (a, b) = (
                objective(&g, ours.tensions(), &f, 0.0),
                objective(&g, &reference, &f, 0.0),
            );
            assert!(
                a <= b + 1e-6 * (1.0 + b),
                "{}: ours {a}, reference {b}",
                m.name
            );
        }
    }
}

#[test]
fn warm_and_cold_starts_agree() {
    let mut rng = Rng::new(12);
    let m = shipped("spidar-g");
    let mut warm = m.tension_solver(0);
    for _ in 0..300 {
        let (g, f) = random_case(&m, 0, &mut rng);
        let a = warm.solve(&g, &Wrench::from_array(f));
        let b = m.tension_solver(0).solve(&g, &Wrench::from_array(f));
        for (x, y) in a.tensions().iter().zip(b.tensions()) {
            assert!((x - y).abs() < 1e-9);
        }
    }
}

#[test]
fn with_lambda_tensions_are_continuous_across_the_region_boundary_and_without_they_jump() {
    // Thesis Fig. 3.15: f = (5, 5, 5) N along the frame diagonal of the 4-string SPIDAR,
    // starting clear of the motor at (−h, −h, −h) where a string's direction is undefined.
    let m = shipped("spidar");
    let wrench = Wrench::force(DVec3::splat(5.0));
    let path = (DVec3::splat(-0.2), DVec3::splat(0.27));
    let lambdas = [0.0, 0.01, 0.1];
    let coarse = tension_sweep(&m, 0, path, DQuat::IDENTITY, &wrench, &lambdas, 1001);
    let fine = tension_sweep(&m, 0, path, DQuat::IDENTITY, &wrench, &lambdas, 4001);
    assert!(coarse.closed.iter().any(|c| *c) && coarse.closed.iter().any(|c| !*c));
    let (jc, jf) = (coarse.largest_jumps(), fine.largest_jumps());
    // λ = 0: a step from near the maximum to the minimum tension, whatever the sampling.
    assert!(jc[0] > 15.0 && jf[0] > 15.0, "λ = 0 jumps: {jc:?} {jf:?}");
    // λ > 0: the largest step shrinks with the sample spacing (Lipschitz continuity).
    for l in 1..lambdas.len() {
        assert!(
            jf[l] < 0.4 * jc[l],
            "λ = {}: {} → {}",
            lambdas[l],
            jc[l],
            jf[l]
        );
        assert!(jf[l] < 0.5, "λ = {}: step {}", lambdas[l], jf[l]);
    }
}

/// Barycentric test: strictly inside the tetrahedron of the four motors.
fn inside_tetrahedron(p: DVec3, v: &[DVec3]) -> bool {
    let det = |a: DVec3, b: DVec3, c: DVec3| a.dot(b.cross(c));
    let total = det(v[1] - v[0], v[2] - v[0], v[3] - v[0]);
    (0..4).all(|k| {
        let mut w = [v[0], v[1], v[2], v[3]];
        w[k] = p;
        det(w[1] - w[0], w[2] - w[0], w[3] - w[0]) / total > 0.0
    })
}

#[test]
fn the_complete_region_of_a_four_string_spidar_is_the_motor_tetrahedron() {
    let m = shipped("spidar");
    let k = m.kinematics(0);
    let mut rng = Rng::new(13);
    let (mut inside, mut outside) = (0, 0);
    for _ in 0..5000 {
        let position = rng.cube(0.3);
        let g = StringGeometry::at(
            &k,
            &Pose {
                position,
                orientation: DQuat::IDENTITY,
            },
        );
        let expected = inside_tetrahedron(position, k.motors());
        assert_eq!(is_force_closed(&g), expected, "at {position}");
        if expected { inside += 1 } else { outside += 1 }
    }
    assert!(inside > 500 && outside > 500);
}

/// Clarabel feasibility of {α ≥ 1, Wα = 0}: a strictly positive null combination.
fn positive_null_combination(g: &StringGeometry) -> Option<bool> {
    let (n, m) = (g.dof(), g.count());
    let mut a = w_rows(g);
    let mut b = vec![0.0; n];
    for i in 0..m {
        let mut row = vec![0.0; m];
        row[i] = -1.0;
        a.push(row);
        b.push(-1.0);
    }
    let p = CscMatrix::<f64>::zeros((m, m));
    let q = vec![0.0; m];
    let cones = [ZeroConeT(n), NonnegativeConeT(m)];
    let mut solver = DefaultSolver::new(&p, &q, &CscMatrix::from(&a), &b, &cones, quiet_settings())
        .expect("LP set up");
    solver.solve();
    match solver.solution.status {
        SolverStatus::Solved => Some(true),
        SolverStatus::PrimalInfeasible => Some(false),
        _ => None,
    }
}

#[test]
fn force_closure_of_rigid_grips_matches_a_linear_program() {
    let mut rng = Rng::new(14);
    for name in ["spidar-g", "spidar-6s"] {
        let m = shipped(name);
        let (mut agreed, mut closed) = (0, 0);
        for _ in 0..400 {
            let (g, _) = random_case(&m, 0, &mut rng);
            if let Some(reference) = positive_null_combination(&g) {
                assert_eq!(is_force_closed(&g), reference, "{name}");
                agreed += 1;
                closed += usize::from(reference);
            }
        }
        assert!(agreed > 350, "{name}: only {agreed} decided cases");
        if name == "spidar-g" {
            assert!(closed > 20, "spidar-g: {closed} closed cases");
        } else {
            assert_eq!(
                closed, 0,
                "six strings can never be force-closed in six DOF"
            );
        }
    }
}
