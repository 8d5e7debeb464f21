//! Hostile descriptors, physics scenes, static scenes, hand scripts and configurations, each
//! refused at its place.

use super::*;

#[test]
fn descriptors_absurd_for_the_amplifier_or_the_bus_are_refused_at_their_place() {
    let good = shipped_text("config/mechanisms/spidar-6s.yaml");
    let corpus = [
        (
            "volts_per_newton: 0.3653",
            "volts_per_newton: 1.0e308",
            "volts_per_newton: must be a finite number of size",
        ),
        (
            "tension_max: 20.0",
            "tension_max: 1.0e308",
            "asks the amplifier for",
        ),
        (
            "tension_min: 0.5",
            "tension_min: 1.0e308",
            "exceeds tension_max",
        ),
        // The plausible typo: 100 N of pretension on a 120 N string is 43.8 V.
        (
            "tension_min: 0.5\n    tension_max: 20.0",
            "tension_min: 100\n    tension_max: 120",
            "its current drive cannot be commanded above 24 V",
        ),
        (
            "volts_per_newton: 0.3653",
            "volts_per_newton: 2.0",
            "asks the amplifier for 40.0 V",
        ),
        (
            "metres_per_pulse: 2.924e-5",
            "metres_per_pulse: 1.0e300",
            "metres_per_pulse: must be a finite number of size",
        ),
        (
            "metres_per_pulse: 2.924e-5",
            "metres_per_pulse: 0",
            "metres_per_pulse: must be a finite number of size",
        ),
        (
            "motor: [0.2, 0.2, 0.0]",
            "motor: [1.0e17, 0.2, 0.0]",
            "within ±10 m",
        ),
        (
            "name: spidar-6s",
            "name: \"spidar\\0six\"",
            "is not a usable name",
        ),
        (
            "description: Six-string 6-DOF test mechanism of the thesis (Fig. 3.23 c)",
            "description: \"Six strings\\u0007\"",
            "without control characters",
        ),
        (
            "  - name: grip\n",
            "  - name: \"gr\\0ip\"\n",
            "effector names are at most 31 bytes, without NUL",
        ),
        ("name: spidar-6s", "name: \"\"", "is not a usable name"),
    ];
    for (from, to, expected) in corpus {
        let text = mutated(&good, from, to);
        assert_refused(descriptor::parse(&text, Path::new("m.yaml")), expected, to);
    }
}

#[test]
fn descriptors_others_could_have_written_are_refused_like_plugins() {
    use std::os::unix::fs::PermissionsExt;
    let dir = support::scratch("bad-input", "writable");
    let file = dir.join("spidar-6s.yaml");
    std::fs::write(&file, shipped_text("config/mechanisms/spidar-6s.yaml")).unwrap();
    std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o644)).unwrap();
    assert!(hapticd_config::catalog::load(&file).is_ok());
    std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o666)).unwrap();
    let e = hapticd_config::catalog::load(&file)
        .unwrap_err()
        .to_string();
    assert!(e.contains("writable by group or others (mode 0666)"), "{e}");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn physics_scenes_that_cannot_run_safely_are_refused_at_their_place() {
    let blocks = shipped_text("config/scenes/blocks.yaml");
    let drop = shipped_text("config/scenes/cube-drop.yaml");
    let corpus = [
        (
            &blocks,
            "dt: 0.00025",
            "dt: 1.0e-12",
            "dt: must be a number from 1e-6 to 0.1 s",
        ),
        (
            &blocks,
            "gravity: [0, -9.81, 0]",
            "gravity: [.nan, 0, 0]",
            "gravity: must be a finite number",
        ),
        (
            &blocks,
            "gravity: [0, -9.81, 0]",
            "gravity: [0, -1.0e6, 0]",
            "gravity: must be at most",
        ),
        (
            &drop,
            "box: [2, 2, 2]",
            "box: [2, 1.0e-300, 2]",
            "box[1]: must be a number from 0.0001 to 1000 m",
        ),
        (
            &drop,
            "density: 0.125",
            "density: 1.0e308",
            "density: must be a number from 0.001",
        ),
        (
            &drop,
            "position: [0, 2, 0]",
            "position: [1.0e17, 2, 0]",
            "position: must be finite, each within ±1000 m",
        ),
        (
            &drop,
            "position: [0, 2, 0]",
            "position: [0, 2, 0]\n    velocity: [0, -1.0e9, 0]",
            "velocity: must be finite",
        ),
        (
            &drop,
            "stiffness: 1000 ",
            "stiffness: 1.0e10 ",
            "material.stiffness: too stiff",
        ),
        (
            &drop,
            "box: [2, 2, 2]",
            "hull: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1.0e-6]]",
            "thin",
        ),
        (
            &drop,
            "name: cube-drop",
            "name: \"cube\\0drop\"",
            "is not a usable name",
        ),
    ];
    for (good, from, to, expected) in corpus {
        let text = mutated(good, from, to);
        let parsed = PenaltyScene::parse(&text, Path::new("s.yaml"), 0);
        assert_refused(parsed, expected, to);
    }
    // A hull of too many points is refused before its cubic construction starts.
    let points: Vec<String> = (0..1000)
        .map(|k| {
            let a = k as f64 * 0.1;
            format!("[{}, {}, {}]", a.cos(), a.sin(), (k % 7) as f64 * 0.1)
        })
        .collect();
    let text = mutated(
        &drop,
        "box: [2, 2, 2]",
        &format!("hull: [{}]", points.join(", ")),
    );
    assert_refused(
        PenaltyScene::parse(&text, Path::new("s.yaml"), 0),
        "a hull takes at most 64",
        "1000-point hull",
    );
    // Ten thousand bodies: refused before the pair tables are laid out.
    let many: String = (0..10_000)
        .map(|k| {
            format!(
                "  - {{ box: [0.1, 0.1, 0.1], position: [{}, 1, 0] }}\n",
                k as f64 * 0.2
            )
        })
        .collect();
    let text = format!("{}bodies:\n{many}", drop.split("bodies:").next().unwrap());
    assert_refused(
        PenaltyScene::parse(&text, Path::new("s.yaml"), 0),
        "a world holds at most 256",
        "10 000 bodies",
    );
}

#[test]
fn static_scenes_hand_scripts_and_configurations_are_checked_to_their_place() {
    let scene = shipped_text("config/scenes/static.yaml");
    for (from, to, expected) in [
        (
            "stiffness: 2000",
            "stiffness: 1.0e160",
            "Stiffness must be in (0, 100000]",
        ),
        (
            "radius: 0.015",
            "radius: 1.0e-300",
            "radius: must be a number from 0.0001",
        ),
        (
            "name: static",
            "name: \"sta\\0tic\"",
            "is not a usable name",
        ),
        ("height: -0.03", "height: 1.0e17", "within ±1000 m"),
    ] {
        let text = mutated(&scene, from, to);
        assert_refused(
            StaticSceneSpec::parse(&text, Path::new("s.yaml")),
            expected,
            to,
        );
    }
    let hand = shipped_text("config/hands/press-floor.yaml");
    for (from, to, expected) in [
        ("to: [0, -0.05, 0]", "to: [.nan, 0, 0]", "must be finite"),
        (
            "- hold: { seconds: 0.5 }",
            "- trace: { centre: [0, 0, 0], radius: 0.1, normal: [0, 0, 0], period: 0, seconds: 1 }",
            "normal: must not be zero",
        ),
        (
            "- hold: { seconds: 0.5 }",
            "- shake: { amplitude: [0.01, 0, 0], frequency: 1.0e308, seconds: 1 }",
            "frequency: must be a number from 0 to 1000 Hz, not 1e308",
        ),
        (
            "- hold: { seconds: 0.5 }",
            "- hold: { seconds: 0.5, colour: red }",
            "colour: unknown key",
        ),
        (
            "- hold: { seconds: 0.5 }",
            "- push: { force: [0, -1.0e9, 0], seconds: 1 }",
            "within ±1000 N",
        ),
    ] {
        let text = mutated(&hand, from, to);
        assert_refused(Script::parse(&text, Path::new("h.yaml")), expected, to);
    }
    let config = shipped_text("config/hapticd.yaml");
    for (from, to, expected) in [
        (
            "max_force: 10 ",
            "max_force: 500 ",
            "MaxForce must be in (0, 50]",
        ),
        ("rate: 1000 ", "rate: 50 ", "Rate must be in [100, 10000]"),
        ("priority: 80 ", "priority: 0 ", "must be 1–99"),
    ] {
        let text = mutated(&config, from, to);
        assert_refused(Config::parse(&text, Path::new("c.yaml")), expected, to);
    }
    // The rate the bus accepts, the configuration accepts.
    let text = mutated(&config, "rate: 1000 ", "rate: 100 ");
    assert!(Config::parse(&text, Path::new("c.yaml")).is_ok());
}
