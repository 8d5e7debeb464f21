//! The real USB path (rusb on the system's libusb) against an emulated SH4 amplifier,
//! 0x0CEC:0x0205, under umockdev: `hapticctl device` finds it, and 120 update cycles carry
//! exactly the D/A bytes the emulated board expects and decode the counters it sends,
//! across the 16-bit wrap.

mod support;

use std::path::{Path, PathBuf};
use std::process::Command;

use support::{artifact, scratch_root};

const UPDATES: usize = 120;
const DAC: [i16; 8] = [1, -1, 300, -300, 1000, 0, i16::MAX, i16::MIN];

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect()
}

/// Device and configuration descriptors of the amplifier: one interface, bulk EP 0x02 OUT
/// and EP 0x86 IN of 512 bytes.
fn amplifier_descriptors() -> Vec<u8> {
    let mut d = vec![
        0x12, 0x01, 0x00, 0x02, 0x00, 0x00, 0x00, 0x40, 0xEC, 0x0C, 0x05, 0x02, 0x00, 0x01, 0x01,
        0x02, 0x00, 0x01,
    ];
    d.extend([0x09, 0x02, 0x20, 0x00, 0x01, 0x01, 0x00, 0x80, 0x32]);
    d.extend([0x09, 0x04, 0x00, 0x00, 0x02, 0xFF, 0x00, 0x00, 0x00]);
    d.extend([0x07, 0x05, 0x02, 0x02, 0x00, 0x02, 0x00]);
    d.extend([0x07, 0x05, 0x86, 0x02, 0x00, 0x02, 0x00]);
    d
}

fn root_hub_descriptors() -> Vec<u8> {
    let mut d = vec![
        0x12, 0x01, 0x00, 0x02, 0x09, 0x00, 0x01, 0x40, 0x6B, 0x1D, 0x02, 0x00, 0x05, 0x06, 0x03,
        0x02, 0x01, 0x01,
    ];
    d.extend([0x09, 0x02, 0x19, 0x00, 0x01, 0x01, 0x00, 0xE0, 0x00]);
    d.extend([0x09, 0x04, 0x00, 0x00, 0x01, 0x09, 0x00, 0x00, 0x00]);
    d.extend([0x07, 0x05, 0x81, 0x03, 0x04, 0x00, 0x0C]);
    d
}

fn umockdev_description() -> String {
    let (amp, hub) = (hex(&amplifier_descriptors()), hex(&root_hub_descriptors()));
    format!(
        "P: /devices/pci0000:00/0000:00:14.0/usb1/1-2\nN: bus/usb/001/002={amp}\n\
         E: BUSNUM=001\nE: DEVNAME=/dev/bus/usb/001/002\nE: DEVNUM=002\nE: DEVTYPE=usb_device\n\
         E: DRIVER=usb\nE: PRODUCT=cec/205/100\nE: SUBSYSTEM=usb\nE: TYPE=0/0/0\n\
         A: authorized=1\nA: bConfigurationValue=1\nA: bDeviceClass=00\nA: bNumConfigurations=1\n\
         A: bNumInterfaces= 1\nA: busnum=1\\n\nH: descriptors={amp}\nA: dev=189:1\nA: devnum=2\\n\n\
         A: devpath=2\nA: idProduct=0205\nA: idVendor=0cec\nA: speed=480\nA: version= 2.00\n\n\
         P: /devices/pci0000:00/0000:00:14.0/usb1\nN: bus/usb/001/001={hub}\n\
         E: BUSNUM=001\nE: DEVNAME=/dev/bus/usb/001/001\nE: DEVNUM=001\nE: DEVTYPE=usb_device\n\
         E: DRIVER=usb\nE: SUBSYSTEM=usb\nA: bConfigurationValue=1\nA: bDeviceClass=09\n\
         A: bNumConfigurations=1\nA: busnum=1\\n\nH: descriptors={hub}\nA: dev=189:0\nA: devnum=1\\n\n\
         A: devpath=0\nA: idProduct=0002\nA: idVendor=1d6b\nA: speed=480\n"
    )
}

/// Raw counter of channel `i` in update `k`: starts near the top of the 16-bit range and
/// climbs 700·(i + 1) per update, wrapping.
fn raw_count(k: usize, i: usize) -> u16 {
    ((65_000 + k * (i + 1) * 700) % 65_536) as u16
}

/// One update of the emulated board: the OUT transfer it expects (these D/A values) and the
/// IN transfer it answers (their echo, `counts`, the rotary switch at 3).
fn update_script(dac: &[i16; 8], counts: impl Fn(usize) -> u16) -> String {
    let mut out = [0u8; 512];
    out[0] = 0x01;
    out[1] = 0x0E;
    let mut input = [0u8; 512];
    for (i, v) in dac.iter().enumerate() {
        out[2 + 2 * i..4 + 2 * i].copy_from_slice(&v.to_le_bytes());
        input[2 * i..2 * i + 2].copy_from_slice(&v.to_le_bytes());
        input[16 + 2 * i..18 + 2 * i].copy_from_slice(&counts(i).to_le_bytes());
    }
    input[48..50].copy_from_slice(&0x0030u16.to_le_bytes());
    format!(
        "USBDEVFS_REAPURBNDELAY 0 3 2 0 0 512 512 0 {}\n USBDEVFS_REAPURBNDELAY 0 3 134 0 0 512 512 0 {}\n",
        hex(&out),
        hex(&input)
    )
}

/// The bulk traffic of the exchange tests: fixed D/A values, climbing counters.
fn ioctl_script() -> String {
    (0..UPDATES)
        .map(|k| update_script(&DAC, |i| raw_count(k, i)))
        .collect()
}

fn emulated_amplifier_with(name: &str, script: &str) -> (PathBuf, PathBuf) {
    let dir = scratch_root().join(format!("usb-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (device, ioctl) = (dir.join("amplifier.umockdev"), dir.join("amplifier.ioctl"));
    std::fs::write(&device, umockdev_description()).unwrap();
    std::fs::write(&ioctl, script).unwrap();
    (device, ioctl)
}

fn emulated_amplifier() -> (PathBuf, PathBuf) {
    emulated_amplifier_with("exchange", &ioctl_script())
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
    Command::new("umockdev-run")
        .arg("--device")
        .arg(device)
        .arg("--ioctl")
        .arg(format!("/dev/bus/usb/001/002={}", ioctl.display()))
        .arg("--")
        .arg(program)
        .args(args)
        .env_remove("NOTIFY_SOCKET")
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

#[test]
fn hapticd_drives_the_usb_amplifier_and_leaves_it_at_zero() {
    use hapticd::device::dac_for_tension;
    use hapticd::device::replay::{Direction, read_recording};
    use hapticd::solver::geometry::StringGeometry;
    use hapticd::solver::tension::TensionSolver;

    // The grip rests at its calibration pose and the scene does not touch it: every tick
    // asks for zero force, which the tension solver meets with the same minimal tensions.
    let m = support::shipped("spidar-g");
    let geometry = StringGeometry::at(&m.kinematics(0), &m.effectors[0].calibration);
    let resting = TensionSolver::for_effector(&m, 0).solve(&geometry, &[0.0; 6]);
    let mut dac = [0i16; 8];
    for (i, s) in m.strings.iter().enumerate() {
        dac[i] = dac_for_tension(resting.tensions[i], s.volts_per_newton);
    }
    assert!(dac.iter().all(|d| *d > 0));
    // First the power-on D/A values (zero), then the resting ones, counters still.
    let mut script = update_script(&[0; 8], |_| 0);
    for _ in 0..600 {
        script += &update_script(&dac, |_| 0);
    }
    let (device, ioctl) = emulated_amplifier_with("hapticd", &script);
    let dir = ioctl.parent().unwrap().to_path_buf();
    std::fs::copy(
        support::plugin_path("hapticd-spidar-g"),
        dir.join("libhapticd_spidar_g.so"),
    )
    .unwrap();
    let traffic = dir.join("session.traffic");
    let scene = support::repo_dir().join("config/scenes/static.yaml");
    let out = run_under_umockdev(
        &device,
        &ioctl,
        &artifact("hapticd"),
        &[
            "--mechanism-dir",
            dir.to_str().unwrap(),
            "--scene",
            scene.to_str().unwrap(),
            "--duration",
            "0.5",
            "--record-traffic",
            traffic.to_str().unwrap(),
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("spidar-g on usb:1-2"), "{stderr}");
    let outs: Vec<[i16; 8]> = read_recording(&traffic)
        .unwrap()
        .iter()
        .filter(|t| t.direction == Direction::Out)
        .map(|t| {
            hapticd::device::sh4::Command::decode(t.bytes())
                .unwrap()
                .dac
        })
        .collect();
    // 500 ticks at 1 kHz; the emulation is slow on a loaded machine, so ask for 40 % of them.
    assert!(outs.len() > 200, "{} updates", outs.len());
    assert_eq!(outs[0], [0; 8]);
    assert!(outs[1..outs.len() - 1].iter().all(|d| *d == dac));
    assert_eq!(
        *outs.last().unwrap(),
        [0; 8],
        "the last command must be zero current"
    );
}
