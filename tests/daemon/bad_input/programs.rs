//! The programs refuse what one board or one tick cannot do, without panicking.

use super::*;

#[test]
fn programs_refuse_what_one_board_or_one_tick_cannot_do_without_panicking() {
    // Ten strings on one point grip: a valid mechanism that no single amplifier board drives.
    let motors = [
        [1, 1, 1],
        [1, 1, -1],
        [1, -1, 1],
        [1, -1, -1],
        [-1, 1, 1],
        [-1, 1, -1],
        [-1, -1, 1],
        [-1, -1, -1],
        [0, 1, 0],
        [0, -1, 0],
    ];
    let strings: String = motors
        .iter()
        .map(|[x, y, z]| {
            format!(
                "  - {{ effector: grip, motor: [{}, {}, {}], metres_per_pulse: 2.5e-5, \
                 volts_per_newton: 0.3653, tension_min: 0.5, tension_max: 20 }}\n",
                0.2 * f64::from(*x),
                0.2 * f64::from(*y),
                0.2 * f64::from(*z)
            )
        })
        .collect();
    let ten = format!(
        "name: spidar-10s\nend_effectors:\n  - {{ name: grip, dof: 3 }}\nstrings:\n{strings}"
    );
    let dir = mechanisms("ten", &[("spidar-10s.yaml", &ten)]);
    let dir_arg = dir.to_str().unwrap();
    let scene = repo_dir().join("config/scenes/static.yaml");
    let scene_arg = scene.to_str().unwrap();
    // hapticd on the simulated `mechanism` of `dir`, for a moment, on a bus of its own.
    let isolated = support::daemon::Isolated::on_private_bus(
        &support::scratch("bad-input", "ten-daemon"),
        &dir,
    );
    let simulate = |mechanism: &str, args: &[&str]| {
        let common = ["--sim", mechanism, "--duration", "0.3"];
        isolated
            .hapticd(&[&common[..], args].concat())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .output()
            .unwrap()
    };
    let out = simulate("spidar-10s", &["--scene", scene_arg]);
    assert_exit_1(&out, "one amplifier board drives at most 8");
    let out = run(
        "hapticctl",
        &[
            "--mechanism-dir",
            dir_arg,
            "experiment",
            "stiffness",
            "spidar-10s",
            "--rates",
            "1000",
            "--plot",
            dir.join("stiffness.png").to_str().unwrap(),
        ],
    );
    assert_exit_1(&out, "one amplifier board drives at most 8");

    // A penalty scene whose step makes a tick take far longer than the tick.
    let slow = mutated(
        &shipped_text("config/scenes/blocks.yaml"),
        "dt: 0.00025",
        "dt: 2.0e-6",
    );
    let slow_file = dir.join("slow.yaml");
    std::fs::write(&slow_file, slow).unwrap();
    let plugin = dir.join("libhapticd_scene_penalty.so");
    std::fs::copy(plugin_path("hapticd-scene-penalty"), &plugin).unwrap();
    let out = simulate(
        "spidar-g",
        &[
            "--scene",
            plugin.to_str().unwrap(),
            "--scene-file",
            slow_file.to_str().unwrap(),
        ],
    );
    assert_exit_1(
        &out,
        "to compute a tick, more than half of the 1000 µs tick",
    );

    // A hand script with a NaN target, refused at its place before anything runs.
    let hand = mutated(
        &shipped_text("config/hands/press-floor.yaml"),
        "to: [0, -0.05, 0]",
        "to: [.nan, 0, 0]",
    );
    let hand_file = dir.join("nan-hand.yaml");
    std::fs::write(&hand_file, hand).unwrap();
    let out = simulate(
        "spidar-g",
        &["--scene", scene_arg, "--hand", hand_file.to_str().unwrap()],
    );
    assert_exit_1(
        &out,
        &format!(
            "{}:6:19: error: hands.grip[1].move.to: must be finite",
            hand_file.display()
        ),
    );

    // A material too stiff for its step never runs to NaN with success.
    let stiff = mutated(
        &shipped_text("config/scenes/cube-drop.yaml"),
        "stiffness: 1000 ",
        "stiffness: 1.0e10 ",
    );
    let stiff_file = dir.join("stiff.yaml");
    std::fs::write(&stiff_file, stiff).unwrap();
    let out = run("hapticctl", &["scene", "run", stiff_file.to_str().unwrap()]);
    assert_exit_1(&out, "material.stiffness: too stiff");
    std::fs::remove_dir_all(dir).ok();
}
