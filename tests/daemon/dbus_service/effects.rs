//! Haptic effects over the bus, on the simulated SPIDAR-G, against their formulas: every
//! tick's displayed force read back from the telemetry ring.

use super::*;

use hapticd_core::telemetry::Sample;

/// `AddEffect` with `yaml`: the new id, or the error's name and text.
fn add(bus: &Bus, yaml: &str) -> Result<u32, (String, String)> {
    let out = bus.busctl(&[
        "call",
        DEVICE[0],
        DEVICE[1],
        DEVICE[2],
        "AddEffect",
        "s",
        yaml,
    ]);
    if out.status.success() {
        Ok(number(&String::from_utf8_lossy(&out.stdout)) as u32)
    } else {
        let text = String::from_utf8_lossy(&out.stderr).trim().to_string();
        Err((text.clone(), text))
    }
}

/// Call effect method `method` with busctl's `signature` and `args`.
fn call(bus: &Bus, method: &str, signature: &str, args: &[&str]) {
    let mut all = vec!["call", DEVICE[0], DEVICE[1], DEVICE[2], method, signature];
    all.extend(args);
    let out = bus.busctl(&all);
    assert!(out.status.success(), "{method}: {out:?}");
}

/// Every tick of the first device for `seconds`.
pub(super) fn ticks(bus: &Bus, seconds: f64) -> Vec<Sample> {
    let client =
        hapticd_ipc::client::Hapticd::connect(&hapticd_ipc::bus::Bus::Address(bus.address.clone()))
            .unwrap();
    client.devices().unwrap()[0]
        .telemetry(seconds)
        .unwrap()
        .collect()
}

/// hapticd on the simulated SPIDAR-G with scene file `scene`, its hand following `hand`.
pub(super) fn on_sim(bus: &Bus, setup: &Setup, scene: &Path, hand: &Path) -> Hapticd {
    Hapticd::start(
        bus,
        setup,
        &[
            "--sim",
            "spidar-g",
            "--scene",
            scene.to_str().unwrap(),
            "--hand",
            hand.to_str().unwrap(),
        ],
    )
}

/// The amplitude of `signal` (sampled at `rate`) at each frequency bin of its length, by a
/// plain discrete Fourier transform: 2|X_k|/N.
pub(super) fn spectrum(signal: &[f64]) -> Vec<f64> {
    let n = signal.len();
    (0..n / 2)
        .map(|k| {
            let (mut re, mut im) = (0.0, 0.0);
            for (t, x) in signal.iter().enumerate() {
                let angle = std::f64::consts::TAU * (k * t) as f64 / n as f64;
                re += x * angle.cos();
                im -= x * angle.sin();
            }
            2.0 * (re * re + im * im).sqrt() / n as f64
        })
        .collect()
}

/// A sine of f Hz and A N shows its spectrum's peak at f, its amplitude within 1 %; a
/// square cross-faded into its opposite, then removed, never changes faster than the
/// force-rate limit; bad effects are refused by name and place, and start nothing.
#[test]
fn a_vibration_has_its_frequency_and_amplitude_and_changes_never_step_faster_than_the_limit() {
    let dir = support::shared_scratch("dbus", "effects-vibration");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let (frequency, amplitude) = (37.0, 1.5);
    let id = add(
        &bus,
        &format!(
            "{{kind: sine, direction: [0, 0, 1], frequency: {frequency}, amplitude: {amplitude}}}"
        ),
    )
    .unwrap();
    std::thread::sleep(Duration::from_millis(300));
    // One second of whole periods at 1 kHz: 37 Hz is bin 37.
    let samples = ticks(&bus, 1.0);
    let forces: Vec<f64> = samples.iter().map(|s| s.wrenches[0].force[2]).collect();
    let amplitudes = spectrum(&forces);
    let peak = (1..amplitudes.len())
        .max_by(|a, b| amplitudes[*a].total_cmp(&amplitudes[*b]))
        .unwrap();
    println!(
        "sine: peak at bin {peak} of {} ticks, amplitude {:.4} N",
        forces.len(),
        amplitudes[peak]
    );
    assert_eq!(peak, frequency as usize);
    assert!(
        (amplitudes[peak] - amplitude).abs() < 0.01 * amplitude,
        "{}",
        amplitudes[peak]
    );
    assert_eq!(bus.get(DEVICE, "Effects").matches("sine").count(), 1);

    // A square of 8 N turned into its opposite, then removed: cross-faded and faded.
    call(&bus, "RemoveEffect", "u", &[&id.to_string()]);
    let square = add(
        &bus,
        "{kind: square, direction: [1, 0, 0], frequency: 2, amplitude: 8}",
    )
    .unwrap();
    let watched = std::thread::scope(|scope| {
        let watching = scope.spawn(|| ticks(&bus, 1.5));
        std::thread::sleep(Duration::from_millis(400));
        call(
            &bus,
            "ChangeEffect",
            "us",
            &[
                &square.to_string(),
                "{kind: square, direction: [-1, 0, 0], frequency: 2, amplitude: 8}",
            ],
        );
        std::thread::sleep(Duration::from_millis(400));
        call(&bus, "RemoveEffect", "u", &[&square.to_string()]);
        watching.join().unwrap()
    });
    let steepest = watched
        .windows(2)
        .map(|w| {
            let (a, b) = (
                DVec3::from(w[0].wrenches[0].force),
                DVec3::from(w[1].wrenches[0].force),
            );
            (b - a).length() / (w[1].time - w[0].time)
        })
        .fold(0.0, f64::max);
    let strongest = watched
        .iter()
        .map(|s| DVec3::from(s.wrenches[0].force).length())
        .fold(0.0, f64::max);
    println!("square: {strongest:.2} N at most, changing {steepest:.0} N/s at most");
    // The configured limit, 5000 N/s (a float's rounding over a tick aside).
    assert!(steepest <= 5000.0 * (1.0 + 1e-9), "{steepest} N/s");
    assert!((strongest - 8.0).abs() < 1e-6, "{strongest} N");
    assert_eq!(watched.last().unwrap().wrenches[0].force, [0.0; 3]);

    // hapticctl starts, lists, changes and stops them, and says a mistake by its place.
    let said = |args: &[&str]| {
        let out = bus.ctl(args);
        assert!(out.status.success(), "{args:?}: {out:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    let id = said(&["effect", "add", "{kind: damper, damping: 2}"]);
    assert!(said(&["effect", "list"]).contains(&format!("{}  {{kind: damper", id.trim())));
    said(&["effect", "change", id.trim(), "{kind: damper, damping: 4}"]);
    let listed: serde_json::Value =
        serde_json::from_str(&said(&["effect", "list", "--json"])).unwrap();
    assert_eq!(
        listed[0]["effect"], "{kind: damper, damping: 4}",
        "{listed}"
    );
    said(&["effect", "remove", id.trim()]);
    let wrong = bus.ctl(&["effect", "add", "{kind: damper, damping: -1}"]);
    assert_eq!(wrong.status.code(), Some(1), "{wrong:?}");
    assert!(
        String::from_utf8_lossy(&wrong.stderr)
            .contains("effect:1:25: error: damping: must be a number from 0 to 500 N·s/m, not -1"),
        "{wrong:?}"
    );

    // Mistakes: every one named with its place, nothing started.
    for (yaml, said) in [
        ("{kind: wobble}", "\"wobble\" is no kind of effect"),
        (
            "{kind: sine, direction: [0, 0, 1], frequency: 900, amplitude: 1}",
            "frequency: must be a number from 0 to 500 Hz, not 900",
        ),
        (
            "{kind: spring, anchor: [0, 0, 0], stiffness: .nan}",
            "stiffness: must be a number from 0 to 100000 N/m, not NaN",
        ),
        (
            "{kind: constant, force: [0, 50, 0]}",
            "force: must be finite and at most MaxForce, 10 N, long",
        ),
        (
            "{kind: damper, damping: 3, frequency: 4}",
            "frequency: is no key of a damper effect",
        ),
        (
            "{kind: damper, damping: 3, effector: thumb}",
            "no effector \"thumb\": the device has [\"grip\"]",
        ),
        ("{kind: damper, dampng: 3}", "dampng"),
    ] {
        let (error, _) = add(&bus, yaml).unwrap_err();
        assert!(
            error.contains("InvalidEffect") || error.contains(said),
            "{yaml}: {error}"
        );
        assert!(error.contains(said), "{yaml}: {error}");
    }
    assert_eq!(bus.get(DEVICE, "Effects"), "a(us) 0");
    daemon.stop();
}

/// A spring's force is k·x within 1 % over a hand's sweep, a damper's −b·v within 2 %, and
/// the passivity observer's energy of a hand beating on them never goes negative.
#[test]
fn a_spring_and_a_damper_follow_their_laws_and_give_the_hand_no_energy() {
    let dir = support::shared_scratch("dbus", "effects-spring");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let hand = dir.join("sweep.yaml");
    std::fs::write(
        &hand,
        "hands:\n  grip:\n    - hold: { seconds: 0.5 }\n    \
         - move: { to: [0.03, 0, 0], seconds: 0.5 }\n    \
         - move: { to: [-0.03, 0, 0], seconds: 0.3 }\n    \
         - move: { to: [0.03, 0, 0], seconds: 0.2 }\n    \
         - move: { to: [-0.03, 0, 0], seconds: 0.15 }\n    \
         - move: { to: [0, 0, 0], seconds: 0.5 }\n    - hold: { seconds: 30 }\n",
    )
    .unwrap();
    let daemon = Hapticd::start(
        &bus,
        &setup,
        &["--sim", "spidar-g", "--hand", hand.to_str().unwrap()],
    );
    for (yaml, law) in [
        (
            "{kind: spring, anchor: [0, 0, 0], stiffness: 150}",
            "spring",
        ),
        ("{kind: damper, damping: 8}", "damper"),
    ] {
        let id = add(&bus, yaml).unwrap();
        let samples = ticks(&bus, 2.0);
        call(&bus, "RemoveEffect", "u", &[&id.to_string()]);
        let (mut worst, mut energy, mut lowest) = (0.0f64, 0.0f64, 0.0f64);
        for s in &samples[100..] {
            let (x, v) = (
                DVec3::from(s.poses[0].position),
                DVec3::from(s.velocities[0]),
            );
            let f = DVec3::from(s.wrenches[0].force);
            let expected = match law {
                "spring" => -x * 150.0,
                _ => -v * 8.0,
            };
            if expected.length() > 0.5 {
                worst = worst.max((f - expected).length() / expected.length());
            }
            energy -= f.dot(v) * 1e-3;
            lowest = lowest.min(energy);
        }
        println!(
            "{law}: worst error {:.3} %, energy at least {lowest:.2e} J",
            worst * 100.0
        );
        let bound = if law == "spring" { 0.01 } else { 0.02 };
        assert!(worst < bound, "{law}: {worst}");
        assert!(lowest > -1e-4, "{law} gave the hand {lowest} J");
    }
    daemon.stop();
}

/// A scene file's `effects:` come with the scene and go with it, listed among the device's
/// effects; a scene file with a wrong effect is refused by its place in the file, and the
/// running scene and its effects stay.
#[test]
fn a_scene_files_effects_come_and_go_with_the_scene() {
    let dir = support::shared_scratch("dbus", "effects-scene");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let said = |args: &[&str]| {
        let out = bus.ctl(args);
        assert!(out.status.success(), "{args:?}: {out:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    // One of the user's own, which stays across switches.
    let own = add(&bus, "{kind: damper, damping: 1}").unwrap();
    said(&["scene", "switch", "effects"]);
    let listed = said(&["effect", "list"]);
    for kind in ["damper", "magnet", "spring", "sine"] {
        assert!(
            listed.contains(&format!("\"kind\":\"{kind}\"")),
            "{kind}: {listed}"
        );
    }
    assert_eq!(listed.lines().count(), 5, "{listed}");
    // A file of the caller's with a wrong effect: refused by its place, nothing changed.
    let wrong = dir.join("wrong.yaml");
    std::fs::write(
        &wrong,
        "name: wrong\nshapes:\n  - floor: { height: -0.03 }\neffects:\n  - kind: sine\n    \
         direction: [0, 1, 0]\n    frequency: 40\n    amplitude: 80\n",
    )
    .unwrap();
    let out = bus.ctl(&["scene", "switch", wrong.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let error = String::from_utf8_lossy(&out.stderr);
    assert!(
        error.contains(
            "wrong.yaml:8:16: error: effects[0].amplitude: must be a number from 0 to 10 N, not 80"
        ),
        "{error}"
    );
    assert_eq!(bus.get(MANAGER, "ActiveScene"), "s \"effects\"");
    assert_eq!(said(&["effect", "list"]).lines().count(), 5);
    // Back to a scene without: only the user's own is left.
    said(&["scene", "switch", "static"]);
    let left = said(&["effect", "list"]);
    assert_eq!(left.lines().count(), 1, "{left}");
    assert!(
        left.starts_with(&format!("{own:>4}  {{kind: damper")),
        "{left}"
    );
    daemon.stop();
}

/// A floor with a grating of 2 mm, slid over: the force along the floor's normal beats at
/// the sliding speed over the period, within one bin of the spectrum.
#[test]
fn a_grating_slid_over_is_felt_at_the_speed_over_its_period() {
    let dir = support::shared_scratch("dbus", "effects-grating");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let period = 0.002;
    let scene = dir.join("grating.yaml");
    std::fs::write(
        &scene,
        format!(
            "name: grating\nshapes:\n  - floor: {{ height: -0.03 }}\n\
             texture: {{ kind: grating, period: {period}, amplitude: 0.4, direction: [1, 0, 0] }}\n"
        ),
    )
    .unwrap();
    // Pressed 1 cm into the floor, slid 4 cm along x in 2 s.
    let hand = dir.join("slide.yaml");
    std::fs::write(
        &hand,
        "hands:\n  grip:\n    - move: { to: [-0.02, -0.04, 0], seconds: 1.0 }\n    \
         - hold: { seconds: 0.3 }\n    - move: { to: [0.02, -0.04, 0], seconds: 2.0 }\n    \
         - hold: { seconds: 30 }\n",
    )
    .unwrap();
    let daemon = on_sim(&bus, &setup, &scene, &hand);
    // The middle of the slide: from 1.6 s to 2.8 s of the script.
    let started = Instant::now();
    std::thread::sleep(Duration::from_secs_f64(1.6).saturating_sub(started.elapsed()));
    let samples = ticks(&bus, 1.0);
    daemon.stop();
    let proxy_speed = {
        let (first, last) = (&samples[0], &samples[samples.len() - 1]);
        (last.touch_points[0][0] - first.touch_points[0][0]) / (last.time - first.time)
    };
    let normal: Vec<f64> = samples.iter().map(|s| s.wrenches[0].force[1]).collect();
    let mean = normal.iter().sum::<f64>() / normal.len() as f64;
    let centred: Vec<f64> = normal.iter().map(|f| f - mean).collect();
    let amplitudes = spectrum(&centred);
    let peak = (1..amplitudes.len())
        .max_by(|a, b| amplitudes[*a].total_cmp(&amplitudes[*b]))
        .unwrap();
    let expected = proxy_speed / period;
    println!(
        "grating: slid at {proxy_speed:.4} m/s, felt at {peak} Hz (v/period {expected:.1} Hz), \
         {:.3} N",
        amplitudes[peak]
    );
    assert!(samples.iter().all(|s| s.contacts > 0), "slid in contact");
    assert!(
        (peak as f64 - expected).abs() <= 1.0,
        "{peak} Hz against {expected} Hz"
    );
}

/// A magnet on a body of a physics scene (its box in the body's frame, the body 5 cm along
/// x): the force on a hand held near it is the magnet's law at each tick's grip (the pull
/// toward the box's nearest face, F·s²(3 − 2s) with s = 1 − distance/reach); a magnet on a
/// body the world lacks is refused by name.
#[test]
fn a_magnet_on_a_body_pulls_toward_where_the_body_is() {
    let dir = support::shared_scratch("dbus", "effects-body-magnet");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let scene = dir.join("magnet.yaml");
    std::fs::write(
        &scene,
        "name: magnet\nengine: penalty\ndt: 0.00025\ngravity: [0, 0, 0]\n\
         material: { stiffness: 2.0e7, damping: 1.0e4, static_friction: 0.5, friction: 0.4, \
         friction_stiffness: 2.0e7, friction_damping: 1.0e4, slip_speed: 0.02 }\n\
         bodies:\n  - { name: block, box: [0.03, 0.03, 0.03], position: [0.05, 0, 0], fixed: true }\n\
         pointer: { sphere: 0.002 }\n\
         effects:\n  - { kind: magnet, body: block, shape: { box: [0.03, 0.03, 0.03] }, reach: 0.02, \
         friction: 1 }\n",
    )
    .unwrap();
    let hand = dir.join("near.yaml");
    std::fs::write(
        &hand,
        "hands:\n  grip:\n    - move: { to: [0.025, 0, 0], seconds: 0.5 }\n    \
         - hold: { seconds: 30 }\n",
    )
    .unwrap();
    let daemon = on_sim(&bus, &setup, &scene, &hand);
    std::thread::sleep(Duration::from_millis(800));
    let samples = ticks(&bus, 1.0);
    let mut worst = 0.0f64;
    for s in &samples {
        let x = s.poses[0].position[0];
        let distance = (0.05 - 0.015) - x;
        let expected = if distance > 0.0 && distance < 0.02 {
            let s = 1.0 - distance / 0.02;
            s * s * (3.0 - 2.0 * s)
        } else {
            0.0
        };
        worst = worst.max((s.wrenches[0].force[0] - expected).abs());
    }
    let last = &samples[samples.len() - 1];
    println!(
        "magnet on a body: grip at x = {:.4} m, pulled {:.4} N; worst departure from the law \
         {worst:.2e} N",
        last.poses[0].position[0], last.wrenches[0].force[0]
    );
    // Held 1 cm from the block's face by the arm (300 N/m), pulled nearer.
    assert!(last.wrenches[0].force[0] > 0.3, "pulled toward the block");
    assert!(worst < 1e-6, "{worst} N from the law");
    let (_, said) = add(
        &bus,
        "{kind: magnet, body: ghost, shape: {sphere: 0.01}, reach: 0.01, friction: 1}",
    )
    .unwrap_err();
    assert!(said.contains("body: no body \"ghost\""), "{said}");
    daemon.stop();
}
