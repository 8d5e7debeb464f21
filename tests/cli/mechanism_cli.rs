//! `hapticctl mechanism` as a user runs it: real binary, real plugins, JSON checked against
//! independent computations.

use crate::support;

use std::os::unix::fs::PermissionsExt;
use std::path::PathBuf;
use std::process::Output;

use glam::{DQuat, DVec3};
use serde_json::Value;
use support::{hapticctl, plugin_path, repo_dir};

/// A directory holding the shipped plugins and the YAML example, as an installed system would.
fn installed() -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(install).clone()
}

fn install() -> PathBuf {
    let dir = support::scratch_root().join(format!("hapticd-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
    for krate in ["hapticd-spidar", "hapticd-spidar-g", "hapticd-spidar-ii"] {
        let from = plugin_path(krate);
        std::fs::copy(&from, dir.join(from.file_name().unwrap())).unwrap();
    }
    let yaml = repo_dir().join("config/mechanisms/spidar-6s.yaml");
    std::fs::copy(yaml, dir.join("spidar-6s.yaml")).unwrap();
    dir
}

fn run(args: &[&str]) -> Output {
    hapticctl()
        .arg("--mechanism-dir")
        .arg(installed())
        .args(args)
        .output()
        .expect("hapticctl runs")
}

fn json(args: &[&str]) -> Value {
    let out = run(args);
    assert!(
        out.status.success(),
        "{args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

/// Exit status and stderr of a command that must fail.
fn failure(args: &[&str]) -> (i32, String) {
    let out = run(args);
    assert!(!out.status.success(), "{args:?} should fail");
    (
        out.status.code().unwrap(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn joined(values: &[f64]) -> String {
    values
        .iter()
        .map(|v| format!("{v:.17e}"))
        .collect::<Vec<_>>()
        .join(",")
}

#[test]
fn list_shows_every_installed_mechanism() {
    let list = json(&["mechanism", "list", "--json"]);
    let mut names: Vec<&str> = list
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["spidar", "spidar-6s", "spidar-g", "spidar-ii"]);
}

#[test]
fn inspect_reports_validity_and_warnings() {
    let six = json(&["mechanism", "inspect", "spidar-6s", "--json"]);
    assert_eq!(six["valid"], true);
    let warnings = six["warnings"].as_array().unwrap();
    assert!(
        warnings[0]
            .as_str()
            .unwrap()
            .contains("can never present force in every direction")
    );
    assert_eq!(six["effectors"][0]["force_closed_at_calibration"], false);
    let g = json(&["mechanism", "inspect", "spidar-g", "--json"]);
    assert_eq!(g["effectors"][0]["force_closed_at_calibration"], true);

    let broken =
        support::scratch_root().join(format!("hapticd-broken-{}.yaml", std::process::id()));
    std::fs::write(
        &broken,
        "name: broken\nend_effectors: []\nstrings: []\nspeed: 3\n",
    )
    .unwrap();
    let (code, stderr) = failure(&["mechanism", "inspect", broken.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(
        stderr.contains(&format!(
            "{}:4:1: error: speed: unknown key",
            broken.display()
        )),
        "{stderr}"
    );
    std::fs::remove_file(broken).ok();
}

#[test]
fn pose_recovers_a_known_grip_pose_from_its_lengths() {
    let m = support::shipped("spidar-g");
    let truth = hapticd_core::kinematics::Pose {
        position: DVec3::new(0.012, -0.008, 0.005),
        orientation: DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.2),
    };
    // Lengths from geometry alone: |motor − (p + R·knot)|.
    let lengths: Vec<f64> = m
        .strings
        .iter()
        .map(|s| (s.motor - (truth.position + truth.orientation * s.knot)).length())
        .collect();
    let out = json(&[
        "mechanism",
        "pose",
        "spidar-g",
        "--lengths",
        &joined(&lengths),
        "--json",
    ]);
    let effector = &out["effectors"][0];
    assert_eq!(effector["name"], "grip");
    let p = numbers(&effector["position"]);
    assert!(
        (DVec3::new(p[0], p[1], p[2]) - truth.position).length() < 1e-9,
        "{p:?}"
    );
    let q = numbers(&effector["orientation"]);
    let q = DQuat::from_xyzw(q[1], q[2], q[3], q[0]);
    assert!(q.angle_between(truth.orientation) < 1e-9);
    assert!(out["residual"].as_f64().unwrap() < 1e-9);
    assert!(out["iterations"].as_u64().unwrap() <= 10);
}

#[test]
fn pose_of_two_fingers_solves_each() {
    let m = support::shipped("spidar-ii");
    let fingers = [DVec3::new(0.03, 0.01, 0.0), DVec3::new(-0.02, 0.0, 0.01)];
    let lengths: Vec<f64> = m
        .strings
        .iter()
        .map(|s| (s.motor - fingers[s.effector]).length())
        .collect();
    let out = json(&[
        "mechanism",
        "pose",
        "spidar-ii",
        "--lengths",
        &joined(&lengths),
        "--json",
    ]);
    for (i, finger) in fingers.iter().enumerate() {
        let p = numbers(&out["effectors"][i]["position"]);
        assert!((DVec3::new(p[0], p[1], p[2]) - *finger).length() < 1e-9);
    }
}

#[test]
fn tension_produces_the_requested_force_inside_the_region() {
    let position = DVec3::new(0.02, -0.03, 0.01);
    let out = json(&[
        "mechanism",
        "tension",
        "spidar",
        "--position",
        "0.02,-0.03,0.01",
        "--force",
        "1,-2,3",
        "--lambda",
        "0",
        "--json",
    ]);
    let tensions = numbers(&out["tensions"]);
    assert_eq!(tensions.len(), 4);
    // W τ from the motor positions alone must give the requested force.
    let m = support::shipped("spidar");
    let mut force = DVec3::ZERO;
    for (s, t) in m.strings.iter().zip(&tensions) {
        assert!((0.5..=20.0).contains(t));
        force += (s.motor - position).normalize() * *t;
    }
    assert!(
        (force - DVec3::new(1.0, -2.0, 3.0)).length() < 1e-6,
        "{force}"
    );
    let wrench = numbers(&out["wrench"]);
    assert!((DVec3::new(wrench[0], wrench[1], wrench[2]) - force).length() < 1e-9);
}

#[test]
fn bad_arguments_exit_with_status_two_and_say_why() {
    let cases: [(&[&str], &str); 7] = [
        (
            &["mechanism", "pose", "spidar", "--lengths", "0.4,0.4,0.4"],
            "has 4 strings, but 3 lengths were given",
        ),
        (
            &[
                "mechanism",
                "pose",
                "spidar",
                "--lengths",
                "0.4,NaN,0.4,0.4",
            ],
            "\"NaN\" is not a finite number",
        ),
        (
            &["mechanism", "pose", "spidar", "--lengths", "0.4,x,0.4,0.4"],
            "\"x\" is not a number",
        ),
        (
            &[
                "mechanism",
                "tension",
                "spidar-ii",
                "--effector",
                "pinky",
                "--position",
                "0,0,0",
                "--force",
                "0,0,1",
            ],
            "has no effector \"pinky\" (effectors: index, thumb)",
        ),
        (
            &[
                "mechanism",
                "tension",
                "spidar",
                "--position",
                "0,0,0",
                "--force",
                "0,0,1",
                "--torque",
                "0,0,1",
            ],
            "point grip (3 DOF)",
        ),
        (
            &[
                "mechanism",
                "tension",
                "spidar",
                "--position",
                "0,0",
                "--force",
                "0,0,1",
            ],
            "--position needs 3 numbers",
        ),
        (
            &["mechanism", "inspect", "nonexistent"],
            "no installed mechanism of this name",
        ),
    ];
    for (args, message) in cases {
        let (code, stderr) = failure(args);
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(stderr.contains(message), "{args:?}: {stderr}");
    }
}

fn assert_png(path: &std::path::Path) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert!(bytes.len() > 2000);
}

#[test]
fn sweep_reproduces_the_jump_at_lambda_zero() {
    let plot = support::scratch_root().join(format!("hapticd-sweep-{}.png", std::process::id()));
    let out = json(&[
        "mechanism",
        "sweep",
        "spidar",
        "--plot",
        plot.to_str().unwrap(),
        "--lambdas",
        "0,0.01,0.1",
        "--json",
    ]);
    assert_png(&plot);
    let jumps = numbers(&out["largest_jump"]);
    assert!(jumps[0] > 15.0 && jumps[2] < 0.2 * jumps[0], "{jumps:?}");
    std::fs::remove_file(plot).ok();
}

#[test]
fn workspace_slice_of_spidar_is_the_tetrahedron_section() {
    let plot =
        support::scratch_root().join(format!("hapticd-workspace-{}.png", std::process::id()));
    let out = json(&[
        "mechanism",
        "workspace",
        "spidar",
        "--plot",
        plot.to_str().unwrap(),
        "--json",
    ]);
    assert_png(&plot);
    // At y = 0 the motor tetrahedron's section is the square with corners (±h, 0, 0),
    // (0, 0, ±h): area 2h² of the (2.2h)² slice.
    let fraction = out["complete_fraction"].as_f64().unwrap();
    assert!((fraction - 2.0 / 4.84).abs() < 0.01, "{fraction}");
    std::fs::remove_file(plot).ok();
}
