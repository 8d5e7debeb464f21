//! Surface materials on the simulated SPIDAR-G, against their formulas: a body's contact
//! transient in either engine, and a texture a hand beats on.

use super::*;

use super::effects::{on_sim, ticks};

/// Least squares: the coefficients of the `columns` that best fit `signal`, by the normal
/// equations and Gaussian elimination.
fn fit(columns: &[Vec<f64>], signal: &[f64]) -> Vec<f64> {
    let n = columns.len();
    let mut a = vec![vec![0.0; n + 1]; n];
    for (k, &y) in signal.iter().enumerate() {
        let row: Vec<f64> = columns.iter().map(|c| c[k]).collect();
        for i in 0..n {
            for j in 0..n {
                a[i][j] += row[i] * row[j];
            }
            a[i][n] += row[i] * y;
        }
    }
    for c in 0..n {
        let pivot = (c..n)
            .max_by(|x, y| a[*x][c].abs().total_cmp(&a[*y][c].abs()))
            .unwrap();
        a.swap(c, pivot);
        let row = a[c].clone();
        for (r, other) in a.iter_mut().enumerate() {
            if r != c {
                let k = other[c] / row[c];
                for (x, p) in other.iter_mut().zip(&row).skip(c) {
                    *x -= k * p;
                }
            }
        }
    }
    (0..n).map(|i| a[i][n] / a[i][i]).collect()
}

/// A finger tapped twice onto a table whose material rings (gain 12 N·s/m, 300 Hz, 15 ms),
/// in the penalty engine and in rapier at 60 Hz: after each impact the force holds a ringing
/// e^(−t/τ)·sin(2πft) (fitted beside a slow cubic for the contact's own force) whose
/// amplitude follows the speed the loop measured at the touch: the two taps' amplitudes are
/// in the ratio of their speeds within 5 %, and each within 20 % of gain × speed. The
/// ringing shakes the finger, and a contact pressed by a shaking finger rings with it: that
/// adds 4 % in the penalty engine and 15 % in rapier (measured), in proportion.
#[test]
fn a_tap_rings_in_proportion_to_its_speed_in_either_engine() {
    let dir = support::shared_scratch("dbus", "materials-tap");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let (gain, frequency, decay) = (12.0, 300.0, 0.015);
    let hand = dir.join("tap.yaml");
    std::fs::write(
        &hand,
        "hands:\n  grip:\n    - hold: { at: [0, 0, 0], seconds: 0.8 }\n    \
         - move: { to: [0, -0.04, 0], seconds: 0.25 }\n    - hold: { seconds: 0.4 }\n    \
         - move: { to: [0, 0, 0], seconds: 0.4 }\n    - hold: { seconds: 0.3 }\n    \
         - move: { to: [0, -0.04, 0], seconds: 0.6 }\n    - hold: { seconds: 30 }\n",
    )
    .unwrap();
    for engine in [
        "engine: penalty\ndt: 0.00025\nmaterial: { stiffness: 2.0e7, damping: 1.0e4, \
         static_friction: 0.5, friction: 0.4, friction_stiffness: 2.0e7, friction_damping: \
         1.0e4, slip_speed: 0.02 }",
        "engine: rapier\nrate: 60\nmaterial: { static_friction: 0.5, friction: 0.4 }",
    ] {
        let scene = dir.join("bell.yaml");
        std::fs::write(
            &scene,
            format!(
                "name: bell\n{engine}\nbodies:\n  - {{ name: table, box: [0.3, 0.04, 0.3], \
                 position: [0, -0.05, 0], fixed: true,\n      transient: {{ gain: {gain}, \
                 frequency: {frequency}, decay: {decay} }} }}\npointer: {{ sphere: 0.005 }}\n"
            ),
        )
        .unwrap();
        let daemon = on_sim(&bus, &setup, &scene, &hand);
        let samples = ticks(&bus, 3.6);
        daemon.stop();
        let onsets: Vec<usize> = (1..samples.len() - 90)
            .filter(|&k| samples[k].contacts > 0 && samples[k - 1].contacts == 0)
            .collect();
        assert_eq!(onsets.len(), 2, "two taps: {onsets:?}");
        let w = std::f64::consts::TAU * frequency;
        let taps: Vec<(f64, f64)> = onsets
            .iter()
            .map(|&onset| {
                let window = &samples[onset..onset + 90];
                let times: Vec<f64> = window.iter().map(|s| s.time - window[0].time).collect();
                let force: Vec<f64> = window.iter().map(|s| s.wrenches[0].force[1]).collect();
                let of = |f: &dyn Fn(f64) -> f64| times.iter().map(|&t| f(t)).collect();
                let columns = [
                    of(&|t| (-t / decay).exp() * (w * t).sin()),
                    of(&|t| (-t / decay).exp() * (w * t).cos()),
                    of(&|_| 1.0),
                    of(&|t| t),
                    of(&|t| t * t),
                    of(&|t| t * t * t),
                ];
                (-samples[onset].velocities[0][1], fit(&columns, &force)[0])
            })
            .collect();
        let [(v1, a1), (v2, a2)] = [taps[0], taps[1]];
        println!(
            "{}: taps at {v1:.4} and {v2:.4} m/s ring at {a1:.4} and {a2:.4} N (gain × speed \
             {:.4} and {:.4} N); amplitude ratio {:.4}, speed ratio {:.4}",
            engine.lines().next().unwrap(),
            gain * v1,
            gain * v2,
            a1 / a2,
            v1 / v2
        );
        assert!(v1 > 0.05 && v2 > 0.03 && v1 > 1.3 * v2, "{v1} and {v2} m/s");
        assert!(((a1 / a2) / (v1 / v2) - 1.0).abs() < 0.05);
        for (v, a) in taps {
            assert!((a - gain * v).abs() < 0.2 * gain * v, "{a} N at {v} m/s");
        }
    }
}

/// A hand beating on a rough floor (a roughness of 1 N, 0.5 to 8 mm) while sliding across
/// it, and on a grating: the energy the device gives the hand, ∫F·v dt over every tick,
/// never goes below zero (the unit tests of `hapticd_core::haptics::surface` show the
/// texture felt all the while).
#[test]
fn a_texture_beaten_on_gives_the_hand_no_energy() {
    let dir = support::shared_scratch("dbus", "materials-beat");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let mut beats =
        String::from("hands:\n  grip:\n    - hold: { at: [-0.04, -0.02, 0], seconds: 0.5 }\n");
    for k in 0..12 {
        let x = -0.04 + 0.006 * k as f64;
        beats += &format!(
            "    - move: {{ to: [{:.3}, -0.036, 0], seconds: 0.09 }}\n    \
             - move: {{ to: [{:.3}, -0.024, 0], seconds: 0.07 }}\n",
            x + 0.003,
            x + 0.006
        );
    }
    beats += "    - hold: { seconds: 30 }\n";
    let hand = dir.join("beats.yaml");
    std::fs::write(&hand, beats).unwrap();
    for texture in [
        "{ kind: roughness, amplitude: 1.0, shortest: 0.0005, longest: 0.008, seed: 4 }",
        "{ kind: grating, amplitude: 1.0, period: 0.003, direction: [1, 0, 0] }",
    ] {
        let scene = dir.join("rough.yaml");
        std::fs::write(
            &scene,
            format!(
                "name: rough\nshapes:\n  - floor: {{ height: -0.03 }}\n    texture: {texture}\n"
            ),
        )
        .unwrap();
        let daemon = on_sim(&bus, &setup, &scene, &hand);
        let samples = ticks(&bus, 2.4);
        daemon.stop();
        let (mut energy, mut lowest) = (0.0f64, 0.0f64);
        for s in &samples {
            let f = DVec3::from(s.wrenches[0].force);
            energy -= f.dot(DVec3::from(s.velocities[0])) * 1e-3;
            lowest = lowest.min(energy);
        }
        let touching = samples.iter().filter(|s| s.contacts > 0).count();
        println!("{texture}: {touching} ticks on the floor, energy at least {lowest:.2e} J");
        assert!(
            touching > 500,
            "the hand beat on the floor: {touching} ticks"
        );
        assert!(lowest > -1e-4, "the texture gave the hand {lowest} J");
    }
}

/// An octagonal bar (radius 2 cm, 10 cm long along y) as OBJ text, wound outward: its sides
/// from the bottom rim to the top, its caps as fans from their centres.
fn octagonal_bar() -> String {
    let (r, h) = (0.02, 0.05);
    let mut obj = String::new();
    for y in [-h, h] {
        for k in 0..8 {
            let a = k as f64 * std::f64::consts::FRAC_PI_4;
            obj += &format!("v {} {y} {}\n", r * a.cos(), r * a.sin());
        }
    }
    obj += &format!("v 0 {} 0\nv 0 {h} 0\n", -h);
    // Vertices 1-8 the bottom rim, 9-16 the top, 17 and 18 the caps' centres.
    for k in 0..8 {
        let (b0, b1, t0, t1) = (k + 1, (k + 1) % 8 + 1, k + 9, (k + 1) % 8 + 9);
        obj += &format!("f {b0} {t0} {t1}\nf {b0} {t1} {b1}\nf 17 {b0} {b1}\nf 18 {t1} {t0}\n");
    }
    obj
}

/// A finger pressed into a fixed octagonal bar a quarter of the way across a side, in either
/// engine: flat, it is pushed along the side's normal; smoothly shaded (`shading: smooth`),
/// along the blend of the side's corners' normals where it touches, which at the bar's
/// mid-height (where the caps' tilts cancel) lean along the radii at the side's two edges in
/// proportion to how far across the touch is.
#[test]
fn a_smoothly_shaded_body_pushes_along_its_blended_normals_in_either_engine() {
    let dir = support::shared_scratch("dbus", "materials-shading");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    std::fs::write(dir.join("bar.obj"), octagonal_bar()).unwrap();
    let radial = |a: f64| DVec3::new(a.cos(), 0.0, a.sin());
    let (first, second) = (radial(0.0), radial(std::f64::consts::FRAC_PI_4));
    let side = radial(std::f64::consts::FRAC_PI_8);
    // The finger comes in along the normal of side 0 (from 0° to 45°), to a quarter of the
    // way across it, from 1.5 cm out.
    let quarter = (first * 0.75 + second * 0.25) * 0.02;
    let axis = -side * 0.015 - quarter;
    // Pressed 2 mm into the side: the penalty engine's finger is a ball of 5 mm, rapier's a
    // point.
    for (engine, depth) in [
        (
            "engine: penalty\ndt: 0.00025\nmaterial: { stiffness: 2.0e7, damping: 1.0e4, \
             static_friction: 0, friction: 0, friction_stiffness: 2.0e7, friction_damping: \
             1.0e4, slip_speed: 0.02 }",
            0.002 - 0.005,
        ),
        (
            "engine: rapier\nrate: 60\nmaterial: { static_friction: 0, friction: 0 }",
            0.002,
        ),
    ] {
        let pressed = axis + quarter - side * depth;
        let hand = dir.join("press.yaml");
        std::fs::write(
            &hand,
            format!(
                "hands:\n  grip:\n    - hold: {{ at: [0, 0, 0], seconds: 0.5 }}\n    \
                 - move: {{ to: [{:.5}, 0, {:.5}], seconds: 0.5 }}\n    \
                 - hold: {{ seconds: 30 }}\n",
                pressed.x, pressed.z
            ),
        )
        .unwrap();
        let press = |shading: &str| {
            let scene = dir.join("bar.yaml");
            std::fs::write(
                &scene,
                format!(
                    "name: bar\n{engine}\nbodies:\n  - {{ name: bar, mesh: bar.obj, position: \
                     [{:.5}, 0, {:.5}], fixed: true, shading: {shading} }}\npointer: {{ sphere: \
                     0.005 }}\n",
                    axis.x, axis.z
                ),
            )
            .unwrap();
            let daemon = on_sim(&bus, &setup, &scene, &hand);
            // Rapier's finger rests on a proxy, which holds a finger pushed along the shaded
            // normal where friction would.
            for friction in ["DynamicFriction", "StaticFriction"] {
                support::succeeded(bus.set(friction, "d", "0"));
            }
            let samples = ticks(&bus, 1.6);
            daemon.stop();
            // The last 0.3 s, held still in the bar.
            let held = &samples[samples.len() - 300..];
            assert!(held.iter().all(|s| s.contacts == 1), "{shading}: touching");
            let mean = |f: &dyn Fn(&hapticd_core::telemetry::Sample) -> DVec3| {
                held.iter().map(f).sum::<DVec3>() / held.len() as f64
            };
            (
                mean(&|s| DVec3::from(s.wrenches[0].force)),
                mean(&|s| DVec3::from(s.touch_points[0])),
            )
        };
        let (flat, _) = press("flat");
        let (smooth, point) = press("smooth");
        let (c0, c1) = (axis + first * 0.02, axis + second * 0.02);
        let u = (point - c0).dot(c1 - c0) / (c1 - c0).length_squared();
        let expected = (first * (1.0 - u) + second * u).normalize();
        println!(
            "{}: flat {flat} N, smooth {smooth} N, touched {u:.3} across; smooth off the blend \
             by {:.2e} rad, {:.4} times as hard",
            engine.lines().next().unwrap(),
            smooth.normalize().angle_between(expected),
            smooth.length() / flat.length()
        );
        assert!(flat.normalize().angle_between(side) < 1e-3, "{flat}");
        assert!((u - 0.25).abs() < 0.05, "{u}");
        assert!(
            smooth.normalize().angle_between(expected) < 1e-3,
            "{smooth} against {expected}"
        );
        // As hard, but for where the hand (a spring following its path) settles when pushed
        // along another direction: 0.3 mm aside, 2.7 % harder in either engine (measured).
        assert!((smooth.length() / flat.length() - 1.0).abs() < 0.05);
    }
}
