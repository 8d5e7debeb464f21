//! The real USB path (libusb finding the device, usbfs moving its transfers) against an
//! emulated SH4 amplifier, 0x0CEC:0x0205, under umockdev: `hapticctl device` finds it, 120
//! update cycles carry exactly the D/A bytes the emulated board expects and decode the
//! counters it sends across the 16-bit wrap, hapticd drives it and leaves it at zero, and an
//! unplug under the running daemon faults it to zero force until the amplifier is back. The
//! Simple amplifier (0x0CEC:0x0203) is driven the same way across its 24-bit wrap.

use crate::support;

use std::path::{Path, PathBuf};

use support::amplifier::{
    AMPLIFIER_SYSFS, SH4, SIMPLE, amplifier_in_port, amplifier_record, emulated_amplifier_with,
    hex, raw_count, resting_dac, resting_session, root_hub_record, testbed_run,
    umockdev_description, umockdev_run, unplugged_update, update_script,
};
use support::artifact;
use support::bus::PrivateBus;

const UPDATES: usize = 120;
const DAC: [i16; 8] = [1, -1, 300, -300, 1000, 0, i16::MAX, i16::MIN];

/// The bulk traffic of the exchange tests: fixed D/A values, climbing counters.
fn ioctl_script() -> String {
    (0..UPDATES)
        .map(|k| update_script(&DAC, |i| raw_count(k, i)))
        .collect()
}

fn emulated_amplifier() -> (PathBuf, PathBuf) {
    emulated_amplifier_with("exchange", SH4, &ioctl_script())
}

fn under_umockdev(device: &Path, ioctl: &Path, args: &[&str]) -> std::process::Output {
    run_under_umockdev(device, ioctl, &artifact("hapticctl"), args)
}

fn run_under_umockdev(
    device: &Path,
    ioctl: &Path,
    program: &Path,
    args: &[&str],
) -> std::process::Output {
    umockdev_run(device, ioctl, program)
        .args(args)
        .output()
        .expect("umockdev-run is installed (Debian package umockdev; `make check` installs it)")
}

fn dac_argument(dac: &[i16]) -> String {
    dac.iter().map(i16::to_string).collect::<Vec<_>>().join(",")
}

#[test]
fn the_emulated_amplifier_is_found() {
    let (device, ioctl) = emulated_amplifier();
    let out = under_umockdev(&device, &ioctl, &["device", "list", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let list: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(list[0]["usb"], "0cec:0205");
    assert_eq!(list[0]["identity"], "usb:1-2");
}

/// A user the udev rules give no access to the amplifier's node is told so, with the
/// node and what to do, instead of an empty list.
#[test]
fn a_user_without_access_to_the_amplifier_is_told_so() {
    let (device, ioctl) = emulated_amplifier();
    let hapticctl = artifact("hapticctl");
    // The emulation opened to everyone but its node, left as the udev rules leave it
    // (its owner's alone: root here, the hapticd user on a real system); hapticctl run by
    // nobody.
    let script = format!(
        "chmod -R a+rwX \"$UMOCKDEV_DIR\" && chmod 600 \"$UMOCKDEV_DIR/dev/bus/usb/001/002\" && \
         exec setpriv --reuid=65534 --regid=65534 --clear-groups {} device list --json",
        hapticctl.display()
    );
    let out = umockdev_run(&device, &ioctl, Path::new("/bin/sh"))
        .args(["-c", &script])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let list: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(list[0]["identity"], "usb:1-2");
    assert_eq!(list[0]["usable"], false);
    let problem = list[0]["problem"].as_str().unwrap();
    assert!(
        problem.starts_with(
            "no access to /dev/bus/usb/001/002: the udev rules give it to the hapticd user"
        ),
        "{problem}"
    );
}

#[test]
fn a_hundred_and_twenty_updates_carry_the_right_bytes_both_ways() {
    let (device, ioctl) = emulated_amplifier();
    let count = UPDATES.to_string();
    let dac = dac_argument(&DAC);
    let out = under_umockdev(
        &device,
        &ioctl,
        &[
            "device", "exchange", "--count", &count, "--dac", &dac, "--json",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let result: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let updates = result["updates"].as_array().unwrap();
    assert_eq!(updates.len(), UPDATES);
    for (k, update) in updates.iter().enumerate() {
        assert_eq!(update["board_channel"], 3);
        for i in 0..8 {
            // Unwrapped: the first read (65000) is −536, then +700·(i + 1) per update.
            let expected = -536 + (k * (i + 1) * 700) as i64;
            assert_eq!(
                update["counts"][i].as_i64().unwrap(),
                expected,
                "update {k} channel {i}"
            );
        }
    }
}

/// One update of the emulated Simple board, written from its documented bytes: the D/A set
/// (`52` + 8 × int16) and the latch (`51`) it expects, and its 32-byte reply (8 × 24-bit
/// counters, then the input bits with the rotary switch at 5).
fn simple_update_script(dac: &[i16; 8], counts: impl Fn(usize) -> u32) -> String {
    let (mut set, mut latch, mut reply) = ([0u8; 32], [0u8; 32], [0u8; 32]);
    set[0] = 0x52;
    for (i, v) in dac.iter().enumerate() {
        set[1 + 2 * i..3 + 2 * i].copy_from_slice(&v.to_le_bytes());
        reply[3 * i..3 * i + 3].copy_from_slice(&counts(i).to_le_bytes()[..3]);
    }
    latch[0] = 0x51;
    reply[24] = 0x50;
    format!(
        "USBDEVFS_REAPURBNDELAY 0 3 2 0 0 32 32 0 {}\n USBDEVFS_REAPURBNDELAY 0 3 2 0 0 32 32 0 {}\n \
         USBDEVFS_REAPURBNDELAY 0 3 134 0 0 32 32 0 {}\n",
        hex(&set),
        hex(&latch),
        hex(&reply)
    )
}

#[test]
fn the_simple_amplifier_unwraps_its_24_bit_counters_over_usb() {
    // Counters start 77 216 below the top of the 24-bit range and climb 5000·(i + 1) per
    // update: every channel wraps within the first 16 updates.
    let raw = |k: usize, i: usize| ((16_700_000 + k * (i + 1) * 5000) % (1 << 24)) as u32;
    let script: String = (0..UPDATES)
        .map(|k| simple_update_script(&DAC, |i| raw(k, i)))
        .collect();
    let (device, ioctl) = emulated_amplifier_with("simple", SIMPLE, &script);
    let dac = dac_argument(&DAC);
    let count = UPDATES.to_string();
    let args = [
        "device", "exchange", "--count", &count, "--dac", &dac, "--json",
    ];
    let out = under_umockdev(&device, &ioctl, &args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let result: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(result["model"], "Cyverse USB 2.0 Simple amplifier");
    let updates = result["updates"].as_array().unwrap();
    assert_eq!(updates.len(), UPDATES);
    for (k, update) in updates.iter().enumerate() {
        assert_eq!(update["board_channel"], 5);
        for i in 0..8 {
            // The first read, 16 700 000, is −77 216 as 24-bit two's complement.
            let expected = -77_216 + (k * (i + 1) * 5000) as i64;
            assert_eq!(update["counts"][i], expected, "update {k} channel {i}");
        }
    }
    // Any other D/A value is not what the board expects: the set fails.
    let mut other = DAC;
    other[7] = 0;
    let args = [
        "device",
        "exchange",
        "--count",
        "1",
        "--dac",
        &dac_argument(&other),
    ];
    assert!(!under_umockdev(&device, &ioctl, &args).status.success());
}

#[test]
fn different_dac_bytes_are_refused_by_the_emulated_board() {
    // The board expects exactly the recorded OUT bytes: other D/A values fail the transfer.
    let (device, ioctl) = emulated_amplifier();
    let mut dac = DAC;
    dac[0] = 2;
    let out = under_umockdev(
        &device,
        &ioctl,
        &[
            "device",
            "exchange",
            "--count",
            "3",
            "--dac",
            &dac_argument(&dac),
        ],
    );
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("update 0"));
}

/// A private bus for the hapticd of a test in `dir`.
fn private_bus(dir: &Path) -> PrivateBus {
    let at = dir.join("bus");
    std::fs::create_dir_all(&at).unwrap();
    PrivateBus::start(
        &at,
        &support::repo_dir().join("config/dbus/org.hapticd.Hapticd1.conf"),
    )
}

/// The arguments that run hapticd from `dir` (which gets the SPIDAR-G plugin and a
/// configuration of its own, scene plugins from `dir/scene-plugins`) on `bus`, on the static
/// scene, recording its USB traffic to `dir/session.traffic`.
fn hapticd_arguments(dir: &Path, bus: &PrivateBus) -> Vec<String> {
    std::fs::copy(
        support::plugin_path("hapticd-spidar-g"),
        dir.join("libhapticd_spidar_g.so"),
    )
    .unwrap();
    let config = dir.join("hapticd.yaml");
    std::fs::write(
        &config,
        format!(
            "scene_dirs: [{}]\nscene_plugin_dirs: [{}]\nscene: static\n",
            support::repo_dir().join("config/scenes").display(),
            dir.join("scene-plugins").display()
        ),
    )
    .unwrap();
    let scene = support::repo_dir().join("config/scenes/static.yaml");
    [
        "--config".as_ref(),
        config.as_os_str(),
        "--bus".as_ref(),
        bus.address.as_ref(),
        "--mechanism-dir".as_ref(),
        dir.as_os_str(),
        "--scene".as_ref(),
        scene.as_os_str(),
        "--record-traffic".as_ref(),
        dir.join("session.traffic").as_os_str(),
    ]
    .iter()
    .map(|a| a.to_str().unwrap().to_string())
    .collect()
}

/// The D/A values of every OUT transfer hapticd recorded in `dir/session.traffic`.
fn dac_written(dir: &Path) -> Vec<[i16; 8]> {
    use hapticd_device::replay::{Direction, Recording};
    Recording::read(&dir.join("session.traffic"))
        .unwrap()
        .transfers()
        .filter(|(direction, _)| *direction == Direction::Out)
        .map(|(_, bytes)| hapticd_device::sh4::Command::decode(bytes).unwrap().dac)
        .collect()
}

/// `outs` are the D/A values of a session at rest: power-on zeros, the resting values, and
/// zero current as the last command.
fn assert_resting_session(outs: &[[i16; 8]], dac: &[i16; 8]) {
    assert_eq!(outs[0], [0; 8]);
    assert!(outs[1..outs.len() - 1].iter().all(|d| d == dac));
    assert_eq!(
        outs[outs.len() - 1],
        [0; 8],
        "the last command must be zero current"
    );
}

#[test]
fn hapticd_drives_the_usb_amplifier_and_leaves_it_at_zero() {
    let dac = resting_dac();
    // First the power-on D/A values (zero), then the resting ones, counters still.
    let script = resting_session(600);
    let (device, ioctl) = emulated_amplifier_with("hapticd", SH4, &script);
    let dir = ioctl.parent().unwrap().to_path_buf();
    let bus = private_bus(&dir);
    let mut args = hapticd_arguments(&dir, &bus);
    args.extend(["--duration".into(), "0.5".into()]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = run_under_umockdev(&device, &ioctl, &artifact("hapticd"), &args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("spidar-g on usb:1-2"), "{stderr}");
    let outs = dac_written(&dir);
    // 500 ticks at 1 kHz; the emulation is slow on a loaded machine, so ask for 40 % of them.
    assert!(outs.len() > 200, "{} updates", outs.len());
    assert_resting_session(&outs, &dac);
}

#[test]
fn an_amplifier_unplugged_mid_run_is_driven_to_zero_and_resumes_when_plugged_back() {
    let dac = resting_dac();
    // Before the unplug: power-on zeros, then resting tensions for 1.5 s at 1 kHz.
    let mut first = resting_session(1500);
    // The unplug: from here every transfer fails with ENODEV, whatever the loop sends while
    // its forces ramp down (the resting values) and after (zeros), for longer than the test
    // leaves the amplifier away.
    for _ in 0..50 {
        first += &unplugged_update(&dac);
    }
    for _ in 0..4000 {
        first += &unplugged_update(&[0; 8]);
    }
    // Plugged back, the board answers again: zeros first (what a disconnected loop sends),
    // then the resting tensions.
    let second = resting_session(3000);
    let dir = support::scratch("usb", "replug");
    std::fs::write(dir.join("first.umockdev"), umockdev_description(SH4)).unwrap();
    std::fs::write(dir.join("first.ioctl"), first).unwrap();
    std::fs::write(dir.join("second.umockdev"), amplifier_record(SH4, 3)).unwrap();
    std::fs::write(dir.join("second.ioctl"), second).unwrap();
    let frames = dir.join("frames.csv");
    let bus = private_bus(&dir);
    let mut args = hapticd_arguments(&dir, &bus);
    args.extend(["--record".into(), frames.to_str().unwrap().into()]);
    let unplug = format!("unplug={AMPLIFIER_SYSFS}");
    let run = testbed_run(
        &dir,
        &[
            "add=first.umockdev",
            "ioctl=/dev/bus/usb/001/002=first.ioctl",
            "start",
            "wait=spidar-g on usb:1-2",
            &unplug,
            "wait=device Disconnected",
            // Long enough for hapticd to look for it (every 0.5 s) and find nothing.
            "sleep=1.2",
            "add=second.umockdev",
            "ioctl=/dev/bus/usb/001/003=second.ioctl",
            "wait=is back: reconnected",
            "sleep=0.6",
        ],
        &artifact("hapticd"),
        &args,
    );
    let stderr = &run.stderr;
    // It came back only once the amplifier was on the bus again, not by itself.
    assert!(
        run.at("add=second.umockdev") < run.at("wait=is back: reconnected"),
        "{stderr}"
    );
    assert!(
        stderr.contains("device Disconnected: device disconnected"),
        "{stderr}"
    );

    // Frame by frame: running, then disconnected with the tensions down to zero within the
    // 5 ms fault ramp, then running again on the same calibration until SIGTERM.
    let csv = std::fs::read_to_string(&frames).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (state, first_tension) = (column("state"), column("tension_1"));
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let tensions = |row: &Vec<&str>| -> Vec<f64> {
        row[first_tension..first_tension + 8]
            .iter()
            .map(|t| t.parse().unwrap())
            .collect()
    };
    let lost = rows
        .iter()
        .position(|r| r[state] == "disconnected")
        .unwrap();
    let back = lost
        + rows[lost..]
            .iter()
            .position(|r| r[state] == "running")
            .unwrap();
    assert!(rows[..lost].iter().all(|r| r[state] == "running"));
    assert!(back - lost > 500, "away for {} ticks", back - lost);
    for row in &rows[lost + 10..back] {
        assert_eq!(row[state], "disconnected");
        assert!(tensions(row).iter().all(|t| *t == 0.0), "{row:?}");
    }
    assert!(rows[back..].iter().all(|r| r[state] == "running"));
    assert!(
        rows.len() - back > 100,
        "{} ticks after the re-plug",
        rows.len() - back
    );
    let (before, after) = (&rows[lost - 1], rows.last().unwrap());
    assert!(tensions(after).iter().all(|t| *t > 0.0));
    assert_eq!(tensions(before), tensions(after));
    assert_eq!(
        before[2..5],
        after[2..5],
        "the grip's position is unchanged"
    );

    // On the wire: zeros at power-on, resting values, the gap (nothing gets through), zeros
    // again from the disconnected loop on the new address, resting values, zeros at exit.
    let outs = dac_written(&dir);
    let zeros: Vec<usize> = (0..outs.len()).filter(|&k| outs[k] == [0; 8]).collect();
    assert_eq!(zeros.len(), 3, "{zeros:?} of {}", outs.len());
    assert_eq!((zeros[0], zeros[2]), (0, outs.len() - 1));
    assert!(outs.iter().all(|d| *d == [0; 8] || *d == dac));
}

#[test]
fn an_amplifier_plugged_in_while_simulating_is_taken_over() {
    let dac = resting_dac();
    let script = resting_session(3000);
    let dir = support::scratch("usb", "arrival");
    std::fs::write(dir.join("hub.umockdev"), root_hub_record()).unwrap();
    std::fs::write(dir.join("amplifier.umockdev"), amplifier_record(SH4, 2)).unwrap();
    std::fs::write(dir.join("amplifier.ioctl"), script).unwrap();
    let run = testbed_run(
        &dir,
        &[
            "add=hub.umockdev",
            "ioctl=/dev/bus/usb/001/002=amplifier.ioctl",
            "start",
            "wait=spidar-g on sim-spidar-g-1,",
            "add=amplifier.umockdev",
            "wait=plugged in: starting again on it",
            "wait=spidar-g on usb:1-2",
            "sleep=0.5",
        ],
        &artifact("hapticd"),
        &hapticd_arguments(&dir, &private_bus(&dir)),
    );
    assert!(
        run.at("add=amplifier.umockdev") < run.at("wait=plugged in: starting again on it"),
        "{}",
        run.stderr
    );
    // The simulator's motors were zeroed before hapticd started again; the traffic file is
    // the new run's: the amplifier's power-on zeros, resting tensions, zeros at SIGTERM.
    assert_eq!(
        run.stderr.matches("motors at zero").count(),
        2,
        "{}",
        run.stderr
    );
    let outs = dac_written(&dir);
    assert!(outs.len() > 100, "{} updates", outs.len());
    assert_resting_session(&outs, &dac);
}

#[test]
fn each_amplifier_gets_a_haptic_loop_of_its_own_and_a_failing_one_disturbs_no_other() {
    let dac = resting_dac();
    let good = resting_session(3000);
    let dir = support::scratch("usb", "two");
    std::fs::write(dir.join("hub.umockdev"), root_hub_record()).unwrap();
    std::fs::write(dir.join("a.umockdev"), amplifier_in_port(SH4, 2, 2)).unwrap();
    std::fs::write(dir.join("b.umockdev"), amplifier_in_port(SH4, 3, 3)).unwrap();
    std::fs::write(dir.join("good.ioctl"), &good).unwrap();
    let run = testbed_run(
        &dir,
        &[
            "add=hub.umockdev",
            "add=a.umockdev",
            "add=b.umockdev",
            "ioctl=/dev/bus/usb/001/002=good.ioctl",
            // The second board fails every transfer with EIO.
            "refuse=/dev/bus/usb/001/003",
            "start",
            "wait=ready: driving",
            "sleep=0.8",
        ],
        &artifact("hapticd"),
        &hapticd_arguments(&dir, &private_bus(&dir)),
    );
    let stderr = &run.stderr;
    let mut ticks = Vec::new();
    for identity in ["usb:1-2", "usb:1-3"] {
        assert!(
            stderr.contains(&format!("spidar-g on {identity}")),
            "{stderr}"
        );
        // Each loop ran on its own thread and ended at zero current.
        let stopped = stderr
            .lines()
            .find(|l| l.contains(&format!("{identity}: stopped after")))
            .unwrap_or_else(|| panic!("{identity} never stopped: {stderr}"));
        assert!(stopped.contains("motors at zero"), "{stopped}");
        let count: u64 = stopped
            .split("stopped after ")
            .nth(1)
            .and_then(|rest| rest.split(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap();
        ticks.push(count);
    }
    assert!(ticks.iter().all(|t| *t > 300), "{ticks:?}");
    assert!(
        stderr.contains("usb:1-3: 0.001 s: device Disconnected: I/O error"),
        "{stderr}"
    );
    // The good one never left the running state.
    assert!(
        !stderr
            .lines()
            .any(|l| l.contains("usb:1-2: ") && l.contains(" s: device ")),
        "{stderr}"
    );
    // The traffic recording is the first amplifier's, untroubled: zeros, resting tensions,
    // zeros.
    let outs = dac_written(&dir);
    assert!(outs.len() > 300, "{} updates", outs.len());
    assert_resting_session(&outs, &dac);
}

#[test]
fn an_amplifier_plugged_in_while_driving_another_joins_it() {
    let dir = support::scratch("usb", "joining");
    std::fs::write(dir.join("hub.umockdev"), root_hub_record()).unwrap();
    std::fs::write(dir.join("a.umockdev"), amplifier_in_port(SH4, 2, 2)).unwrap();
    std::fs::write(dir.join("b.umockdev"), amplifier_in_port(SH4, 3, 3)).unwrap();
    std::fs::write(dir.join("good.ioctl"), resting_session(6000)).unwrap();
    let run = testbed_run(
        &dir,
        &[
            "add=hub.umockdev",
            "add=a.umockdev",
            "ioctl=/dev/bus/usb/001/002=good.ioctl",
            "refuse=/dev/bus/usb/001/003",
            "start",
            "wait=ready: driving usb:1-2",
            "add=b.umockdev",
            "wait=usb:1-3 (Cyverse USB 2.0 SH4 amplifier (SPIDAR-G)) plugged in",
            "wait=ready: driving usb:1-2, usb:1-3",
            "sleep=0.3",
        ],
        &artifact("hapticd"),
        &hapticd_arguments(&dir, &private_bus(&dir)),
    );
    // The first amplifier was stopped at zero current before hapticd started again with both.
    let stderr = &run.stderr;
    let stops: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("stopped after"))
        .collect();
    assert_eq!(stops.len(), 3, "{stderr}");
    assert!(
        stops.iter().all(|l| l.contains("motors at zero")),
        "{stderr}"
    );
    assert!(stops[0].contains("usb:1-2: "), "{stderr}");
}

/// What the emulated board of testbed.py's `amplifier=` step saw: per client, the D/A values
/// of every OUT transfer, in order across clients.
fn amplifier_log(dir: &Path) -> Vec<(u32, [i16; 8])> {
    std::fs::read_to_string(dir.join("amp.log"))
        .unwrap()
        .lines()
        .filter_map(|line| {
            let words: Vec<&str> = line.split_whitespace().collect();
            (words.len() == 11 && words[0] == "client" && words[2] == "dac").then(|| {
                let client = words[1].parse().unwrap();
                let dac: Vec<i16> = words[3..].iter().map(|w| w.parse().unwrap()).collect();
                (client, dac.try_into().unwrap())
            })
        })
        .collect()
}

/// hapticd driving the emulated SH4 board from `dir` on a private bus, with scene plugins
/// from `dir/scene-plugins`, after the testbed's `setup` steps (where its guardian runs,
/// its control group); once it is ready and has driven the board a moment, `ending`
/// ends it some way other than its own stop (ADDRESS and CONFIG in a step are the bus's
/// address and the configuration file), and the steps
/// wait for the guardian's zero. Returns how hapticd ended, what the board saw, and the
/// board's log followed by the commands' and hapticd's own.
fn ended_under_the_guardian(
    name: &str,
    setup: &[String],
    ending: &[String],
) -> (String, Vec<(u32, [i16; 8])>, String) {
    let dir = support::scratch("usb", name);
    std::fs::write(dir.join("amplifier.umockdev"), umockdev_description(SH4)).unwrap();
    let plugins = dir.join("scene-plugins");
    std::fs::create_dir_all(&plugins).unwrap();
    std::fs::copy(
        support::plugin_path("hapticd-test-exiting-scene"),
        plugins.join("libhapticd_scene_exiting.so"),
    )
    .unwrap();
    let bus = private_bus(&dir);
    let args = hapticd_arguments(&dir, &bus);
    let config = dir.join("hapticd.yaml");
    let mut steps: Vec<String> = setup.to_vec();
    steps.extend(
        [
            "add=amplifier.umockdev",
            "amplifier=/dev/bus/usb/001/002=amp.log",
            "start",
            "wait=ready: driving",
            "sleep=0.3",
        ]
        .map(String::from),
    );
    steps.extend(ending.iter().map(|s| {
        s.replace("ADDRESS", &bus.address)
            .replace("CONFIG", &config.display().to_string())
    }));
    steps.extend(["exited".into(), "wait-log=amp.log=client 2 dac".into()]);
    let steps: Vec<&str> = steps.iter().map(String::as_str).collect();
    testbed_run(&dir, &steps, &artifact("hapticd"), &args);
    let status = std::fs::read_to_string(dir.join("program.status")).unwrap();
    let log = ["amp.log", "run.log", "program.stderr", "guardian.log"]
        .iter()
        .map(|f| std::fs::read_to_string(dir.join(f)).unwrap_or_default())
        .collect::<String>();
    (status.trim().to_string(), amplifier_log(&dir), log)
}

/// The board was driven at the resting tensions by hapticd (client 1), and the last OUT
/// transfer it saw is zero current, from the guardian (another client).
fn assert_zeroed_by_the_guardian(seen: &[(u32, [i16; 8])]) {
    let dac = resting_dac();
    let driven = seen.iter().filter(|(c, d)| *c == 1 && *d == dac).count();
    assert!(driven > 20, "{driven} resting updates: {seen:?}");
    let (client, last) = *seen.last().unwrap();
    assert_eq!(
        last, [0; 8],
        "the last command must be zero current: {seen:?}"
    );
    assert_ne!(client, 1, "the zero came from hapticd itself: {seen:?}");
    // hapticd itself never got to send its zero.
    assert_eq!(seen[seen.len() - 2].1, dac, "{seen:?}");
}

#[test]
fn a_daemon_killed_while_driving_leaves_the_amplifier_at_zero_current() {
    // A second hapticd on the same bus learns that the name is taken before it opens the
    // amplifier the first one drives.
    let second = format!(
        "run={} --bus=ADDRESS --mechanism-dir {} --config CONFIG",
        artifact("hapticd").display(),
        support::repo_dir().join("config/mechanisms").display()
    );
    let (status, seen, log) = ended_under_the_guardian("kill-9", &[], &[second, "kill=9".into()]);
    assert_eq!(status, "signal 9");
    assert_zeroed_by_the_guardian(&seen);
    assert!(log.contains("is already owned"), "{log}");
    assert_eq!(log.matches(" open (pid").count(), 2, "{log}");
}

/// Stopped, not dead (SIGSTOP, as a debugger or a hang would leave it), hapticd still holds
/// the board with its last command applied: its loop's beat stops, and the guardian ends it
/// and zeroes the board within a tenth of a second, where before it stayed driven for good.
#[test]
fn a_daemon_stopped_while_driving_is_ended_and_the_amplifier_zeroed() {
    let (status, seen, log) = ended_under_the_guardian("sigstop", &[], &["kill=STOP".into()]);
    assert_eq!(status, "signal 9", "{log}");
    assert_zeroed_by_the_guardian(&seen);
    let said = log
        .lines()
        .find(|l| l.contains("made no haptic tick"))
        .unwrap_or_else(|| panic!("{log}"));
    assert!(said.contains("its process is stopped"), "{said}");
    // Quiet for the stall's length and one look more (10 ms), not longer.
    let quiet: u64 = said
        .split(" for ")
        .nth(1)
        .and_then(|rest| rest.split(" ms").next())
        .and_then(|ms| ms.parse().ok())
        .unwrap_or_else(|| panic!("{said}"));
    assert!((100..150).contains(&quiet), "{said}");
}

#[test]
fn a_plugin_whose_constructor_exits_leaves_the_amplifier_at_zero_current() {
    let call = "run=busctl --address=ADDRESS call org.hapticd.Hapticd1 /org/hapticd/Hapticd1 \
                org.hapticd.Hapticd1.Manager SwitchScene s exiting";
    let (status, seen, _) = ended_under_the_guardian("exiting-plugin", &[], &[call.into()]);
    assert_eq!(status, "exit 1");
    assert_zeroed_by_the_guardian(&seen);
}

/// A kill of hapticd's whole control group (systemd's stop timeout, `systemctl kill -s KILL
/// hapticd`) ends every process in it at the same instant. The guardian is not among them:
/// it runs as systemd runs it, started on its socket for hapticd's connection, so it zeroes
/// the board. A guardian that is hapticd's child (as when HAPTICD_GUARDIAN_SOCKET is unset)
/// dies with it and the board stays driven.
#[test]
fn a_kill_of_the_daemons_whole_control_group_leaves_the_amplifier_at_zero_current() {
    let cgroup = format!("cgroup=hapticd-test-{}", std::process::id());
    let setup = ["guardian=guardian.socket".to_string(), cgroup];
    let (status, seen, log) =
        ended_under_the_guardian("cgroup-kill", &setup, &["kill-cgroup".into()]);
    assert_eq!(status, "signal 9", "{log}");
    assert_zeroed_by_the_guardian(&seen);
    assert!(
        log.contains("hapticd-guardian: hapticd (pid ") && log.contains("sent zero current"),
        "{log}"
    );
}
