//! One hapticd driving two devices: names, CPUs, and two hands in one world.

use super::*;

use hapticd_core::telemetry::Sample;

/// Every tick of device `index` of the daemon on `address` for `seconds` of its ticks.
fn ticks(address: &str, index: usize, seconds: f64) -> Vec<Sample> {
    let client =
        hapticd_ipc::client::Hapticd::connect(&hapticd_ipc::bus::Bus::Address(address.into()))
            .unwrap();
    let device = &client.devices().unwrap()[index];
    device.telemetry(seconds).unwrap().collect()
}

/// Thesis 5.4.7 with two devices, as one hapticd runs it: two simulated SPIDAR-G (`--sim`
/// twice), each on a haptic thread of its own CPU, each its own object on the bus with a
/// name of its own, both in one world of the shipped `two-hands` scene. The left hand pushes
/// the block 1.5 cm toward the right hand, which waits clear of it; the right hand then
/// comes and meets the block where the push left it (in worlds of their own it would meet
/// it where it started), and both press it from their sides: each feels it pushing back,
/// neither is pushed harder than MaxForce, and neither device gives the hand energy.
#[test]
fn two_simulated_spidars_press_one_block_from_both_sides_in_one_world() {
    let dir = support::shared_scratch("dbus", "two-devices");
    // Two loops on both CPUs: alone.
    let bus = Bus::start_alone(&dir);
    let setup = Setup::new(&dir);
    let hands = repo_dir().join("config/hands");
    let (left, right) = (
        hands.join("two-hands-left.yaml"),
        hands.join("two-hands-right.yaml"),
    );
    let daemon = Hapticd::start(
        &bus,
        &setup,
        &[
            "--sim",
            "spidar-g",
            "--sim",
            "spidar-g",
            "--scene",
            "two-hands",
            "--hand",
            left.to_str().unwrap(),
            "--hand",
            right.to_str().unwrap(),
        ],
    );
    let client =
        hapticd_ipc::client::Hapticd::connect(&hapticd_ipc::bus::Bus::Address(bus.address.clone()))
            .unwrap();
    let names: Vec<String> = client
        .devices()
        .unwrap()
        .iter()
        .map(|d| d.identity().unwrap())
        .collect();
    assert_eq!(names, ["sim-spidar-g-1", "sim-spidar-g-2"]);
    // The hands' scripts end 4.5 s after the start, which took a few tenths of a second.
    let seconds = 4.2;
    let [left, right]: [Vec<Sample>; 2] = std::thread::scope(|scope| {
        let followers = [0, 1].map(|k| {
            let address = &bus.address;
            scope.spawn(move || ticks(address, k, seconds))
        });
        followers.map(|f| f.join().unwrap())
    });
    let log = daemon.log();
    daemon.stop();
    assert!(
        log.contains("2 devices share one world of scene two-hands"),
        "{log}"
    );
    // Each loop on a CPU of its own, where there are two.
    let cpus: Vec<&str> = names
        .iter()
        .filter_map(|name| {
            let said = format!("the haptic thread of {name} runs on CPU ");
            let line = log.lines().find(|l| l.contains(&said))?;
            line.split(&said).nth(1)?.split_whitespace().next()
        })
        .collect();
    if hapticd_service::cpus::allowed().unwrap().len() >= 2 {
        assert_eq!(cpus.len(), 2, "{log}");
        assert_ne!(cpus[0], cpus[1], "{log}");
    }
    for (name, samples) in names.iter().zip([&left, &right]) {
        assert!(samples.len() > 3500, "{name}: {} ticks", samples.len());
        let dt = 1e-3;
        let (mut given, mut strongest) = (0.0f64, 0.0f64);
        for s in samples {
            let force = DVec3::from(s.wrenches[0].force);
            given += force.dot(DVec3::from(s.velocities[0])) * dt;
            strongest = strongest.max(force.length());
        }
        // The configured MaxForce (10 N), at most.
        assert!(strongest <= 10.0 + 1e-9, "{name}: {strongest} N");
        // The force on a hand that pushes does negative work on it; a passive world never
        // gives back more than it took (a millijoule: the spring's stored energy).
        assert!(given < 1e-3, "{name} gave the hand {given} J");
    }
    // Where the right finger first touches: the block's right face, moved from x = 0.03 m
    // to about 0.047 m by the left hand's push.
    let first = right
        .iter()
        .find(|s| s.contacts > 0)
        .expect("the right hand met the block");
    let met = first.touch_points[0][0];
    assert!(
        (0.04..0.055).contains(&met),
        "the right finger met the block at x = {met} m"
    );
    // Pressed from both sides for the last half second: each feels the block push back.
    let mean_x = |samples: &[Sample]| {
        let last = &samples[samples.len() - 500..];
        last.iter().map(|s| s.wrenches[0].force[0]).sum::<f64>() / last.len() as f64
    };
    let (from_left, from_right) = (mean_x(&left), mean_x(&right));
    println!(
        "right finger met the block at x = {met:.4} m; pressed: {from_left:.2} N on the left, \
         {from_right:.2} N on the right"
    );
    assert!(from_left < -0.3, "left: {from_left} N");
    assert!(from_right > 0.3, "right: {from_right} N");
}

/// Two devices of one hapticd from the configuration's `devices:` list, one named there and
/// one by default, on the network: each is a ROS 2 node of its own name with topics of its
/// own, and a subscriber to one device's grip hears that device alone (before names, both
/// simulators were node `/hapticd_sim` and one subscriber heard both streams interleaved).
#[test]
fn two_devices_are_nodes_of_their_own_names_on_the_network() {
    let dir = support::shared_scratch("dbus", "two-devices-network");
    // Two loops on both CPUs: alone.
    let bus = Bus::start_alone(&dir);
    let setup = Setup::new(&dir);
    let hands = dir.join("hands");
    std::fs::create_dir_all(&hands).unwrap();
    // Each hand holds its grip somewhere else, so that their streams tell them apart.
    for (name, x) in [("left", -0.03), ("right", 0.03)] {
        std::fs::write(
            hands.join(format!("{name}.yaml")),
            format!(
                "hands:\n  grip:\n    - move: {{ to: [{x}, 0, 0], seconds: 0.5 }}\n    \
                 - hold: {{ seconds: 30 }}\n"
            ),
        )
        .unwrap();
    }
    let config = format!(
        "{}devices:\n  - sim: spidar-g\n    name: left\n    hand: {}\n  - sim: spidar-g\n    \
         hand: {}\n",
        std::fs::read_to_string(&setup.config).unwrap(),
        hands.join("left.yaml").display(),
        hands.join("right.yaml").display(),
    );
    std::fs::write(&setup.config, config).unwrap();
    let daemon = Hapticd::start(&bus, &setup, &[]);
    let (mut bridge, endpoint) = zenoh_bridge(&bus, &dir, "", None, None);
    let follow = "xs = {}\n\
        def taken(sample):\n\
        \x20   device = str(sample.key_expr).split('/')[2]\n\
        \x20   # PoseStamped: 4 bytes of encapsulation, the stamp, the frame, then x.\n\
        \x20   data = sample.payload.to_bytes()\n\
        \x20   frame = struct.unpack_from('<I', data, 12)[0]\n\
        \x20   at = 16 + frame\n\
        \x20   at += (-at + 4) % 8\n\
        \x20   xs.setdefault(device, []).append(struct.unpack_from('<d', data, at)[0])\n\
        subscribers = [session.declare_subscriber(f'0/hapticd/{d}/grip/pose/**', taken) for d in ['left', 'sim_spidar_g_1']]\n\
        time.sleep(2)\n\
        for s in subscribers:\n\
        \x20   s.undeclare()\n\
        nodes = sorted(str(r.ok.key_expr).split('/')[-1] for r in session.liveliness().get('@ros2_lv/0/*/*/*/NN/**', timeout=3.0) if r.ok)\n\
        print(json.dumps({'nodes': nodes, 'x': {d: [min(v), max(v), len(v)] for d, v in xs.items()}}), flush=True)\n\
        session.close()\n";
    let said = zenoh_client(follow, &endpoint, &[], None);
    let _ = bridge.kill();
    let _ = bridge.wait();
    daemon.stop();
    println!("two devices on the network: {said}");
    assert_eq!(
        said["nodes"],
        serde_json::json!(["hapticd_left", "hapticd_sim_spidar_g_1"]),
        "{said}"
    );
    // Each stream its own device's grip: the left one at x = -0.03, the other at +0.03.
    for (device, x) in [("left", -0.03), ("sim_spidar_g_1", 0.03)] {
        let seen = &said["x"][device];
        let (low, high) = (seen[0].as_f64().unwrap(), seen[1].as_f64().unwrap());
        assert!(seen[2].as_u64().unwrap() > 100, "{device}: {said}");
        assert!(
            (low - x).abs() < 0.005 && (high - x).abs() < 0.005,
            "{device}: {said}"
        );
    }
}
