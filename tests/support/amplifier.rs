//! Emulated Cyverse amplifiers for umockdev, the SH4 (0x0CEC:0x0205) and the Simple
//! (0x0CEC:0x0203): their sysfs records and the usbdevfs traffic of SH4 updates, as the kernel
//! would pass them to libusb or hapticd.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Bytes as the hexadecimal text of umockdev records.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect()
}

/// USB product ID of the SH4 amplifier (SPIDAR-G).
pub const SH4: u16 = 0x0205;
/// USB product ID of the Simple amplifier.
pub const SIMPLE: u16 = 0x0203;

/// Device and configuration descriptors of an amplifier: one interface, bulk EP 0x02 OUT
/// and EP 0x86 IN of 512 bytes.
fn amplifier_descriptors(product: u16) -> Vec<u8> {
    let [low, high] = product.to_le_bytes();
    let mut d = vec![
        0x12, 0x01, 0x00, 0x02, 0x00, 0x00, 0x00, 0x40, 0xEC, 0x0C, low, high, 0x00, 0x01, 0x01,
        0x02, 0x00, 0x01,
    ];
    d.extend([0x09, 0x02, 0x20, 0x00, 0x01, 0x01, 0x00, 0x80, 0x32]);
    d.extend([0x09, 0x04, 0x00, 0x00, 0x02, 0xFF, 0x00, 0x00, 0x00]);
    d.extend([0x07, 0x05, 0x02, 0x02, 0x00, 0x02, 0x00]);
    d.extend([0x07, 0x05, 0x86, 0x02, 0x00, 0x02, 0x00]);
    d
}

/// Device and configuration descriptors of the root hub.
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

/// The amplifier `product` in port 2 of bus 1, at USB address `address`.
pub fn amplifier_record(product: u16, address: u8) -> String {
    amplifier_in_port(product, 2, address)
}

/// The amplifier `product` in `port` of bus 1, at USB address `address`.
pub fn amplifier_in_port(product: u16, port: u8, address: u8) -> String {
    let amp = hex(&amplifier_descriptors(product));
    format!(
        "P: /devices/pci0000:00/0000:00:14.0/usb1/1-{port}\nN: bus/usb/001/{address:03}={amp}\n\
         E: BUSNUM=001\nE: DEVNAME=/dev/bus/usb/001/{address:03}\nE: DEVNUM={address:03}\n\
         E: DEVTYPE=usb_device\nE: DRIVER=usb\nE: PRODUCT=cec/{product:x}/100\nE: SUBSYSTEM=usb\n\
         E: TYPE=0/0/0\nA: authorized=1\nA: bConfigurationValue=1\nA: bDeviceClass=00\n\
         A: bNumConfigurations=1\nA: bNumInterfaces= 1\nA: busnum=1\\n\nH: descriptors={amp}\n\
         A: dev=189:{}\nA: devnum={address}\\n\nA: devpath={port}\nA: idProduct={product:04x}\n\
         A: idVendor=0cec\nA: speed=480\nA: version= 2.00\n",
        address - 1
    )
}

/// The root hub of bus 1, alone.
pub fn root_hub_record() -> String {
    let hub = hex(&root_hub_descriptors());
    format!(
        "P: /devices/pci0000:00/0000:00:14.0/usb1\nN: bus/usb/001/001={hub}\n\
         E: BUSNUM=001\nE: DEVNAME=/dev/bus/usb/001/001\nE: DEVNUM=001\nE: DEVTYPE=usb_device\n\
         E: DRIVER=usb\nE: SUBSYSTEM=usb\nA: bConfigurationValue=1\nA: bDeviceClass=09\n\
         A: bNumConfigurations=1\nA: busnum=1\\n\nH: descriptors={hub}\nA: dev=189:0\nA: devnum=1\\n\n\
         A: devpath=0\nA: idProduct=0002\nA: idVendor=1d6b\nA: speed=480\n"
    )
}

/// The amplifier `product` at address 2 behind the root hub of bus 1.
pub fn umockdev_description(product: u16) -> String {
    format!("{}\n{}", amplifier_record(product, 2), root_hub_record())
}

/// Raw counter of channel `i` in update `k`: starts near the top of the 16-bit range and
/// climbs 700·(i + 1) per update, wrapping.
pub fn raw_count(k: usize, i: usize) -> u16 {
    ((65_000 + k * (i + 1) * 700) % 65_536) as u16
}

/// One update of the emulated board: the OUT transfer it expects (these D/A values) and the
/// IN transfer it answers (their echo, `counts`, the rotary switch at 3).
pub fn update_script(dac: &[i16; 8], counts: impl Fn(usize) -> u16) -> String {
    let out = out_packet(dac);
    let mut input = [0u8; 512];
    for (i, v) in dac.iter().enumerate() {
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

/// A whole session of a board whose grip rests: the power-on zeros, then `updates` updates
/// of the resting D/A values ([`resting_dac`]), the counters still.
pub fn resting_session(updates: usize) -> String {
    let dac = resting_dac();
    let mut script = update_script(&[0; 8], |_| 0);
    for _ in 0..updates {
        script += &update_script(&dac, |_| 0);
    }
    script
}

/// The OUT transfer that sets these D/A values.
fn out_packet(dac: &[i16; 8]) -> [u8; 512] {
    let mut out = [0u8; 512];
    out[0] = 0x01;
    out[1] = 0x0E;
    for (i, v) in dac.iter().enumerate() {
        out[2 + 2 * i..4 + 2 * i].copy_from_slice(&v.to_le_bytes());
    }
    out
}

/// An OUT transfer of these D/A values that fails as on a device just unplugged: the URB
/// comes back with status −ENODEV, a disconnection.
pub fn unplugged_update(dac: &[i16; 8]) -> String {
    format!(
        "USBDEVFS_REAPURBNDELAY 0 3 2 -19 0 512 512 0 {}\n",
        hex(&out_packet(dac))
    )
}

/// Files of an amplifier `product` answering `script`, in a scratch directory of its own
/// (`name`): its umockdev record and its ioctl script.
pub fn emulated_amplifier_with(name: &str, product: u16, script: &str) -> (PathBuf, PathBuf) {
    let dir = super::scratch("usb", name);
    let (device, ioctl) = (dir.join("amplifier.umockdev"), dir.join("amplifier.ioctl"));
    std::fs::write(&device, umockdev_description(product)).unwrap();
    std::fs::write(&ioctl, script).unwrap();
    (device, ioctl)
}

/// `program` under `umockdev-run` with the amplifier of `device` answering from `ioctl` at
/// /dev/bus/usb/001/002 (arguments and environment still to be added).
pub fn umockdev_run(device: &Path, ioctl: &Path, program: &Path) -> Command {
    let mut command = Command::new("umockdev-run");
    command
        .arg("--device")
        .arg(device)
        .arg("--ioctl")
        .arg(format!("/dev/bus/usb/001/002={}", ioctl.display()))
        .arg("--")
        .arg(program)
        .env_remove("NOTIFY_SOCKET");
    command
}

/// The D/A values hapticd sends a SPIDAR-G whose grip rests at its calibration pose, out of
/// reach of the static scene: every tick asks for zero force, which the tension solver meets
/// with the same minimal tensions.
pub fn resting_dac() -> [i16; 8] {
    use hapticd_core::solver::geometry::StringGeometry;
    use hapticd_core::transport::dac_for_tension;

    let m = super::shipped("spidar-g");
    let geometry = StringGeometry::at(&m.kinematics(0), &m.effectors[0].calibration);
    let resting = m.tension_solver(0).solve(&geometry, &Default::default());
    let mut dac = [0i16; 8];
    for (i, s) in m.strings.iter().enumerate() {
        dac[i] = dac_for_tension(resting.tensions[i], s.volts_per_newton);
    }
    assert!(dac.iter().all(|d| *d > 0));
    dac
}

/// Where the emulated amplifier sits in sysfs (port 2 of bus 1).
pub const AMPLIFIER_SYSFS: &str = "/sys/devices/pci0000:00/0000:00:14.0/usb1/1-2";

/// What `tests/umockdev/testbed.py` left of a run: the program's standard error, and when
/// each step ended (seconds since the start).
pub struct TestbedRun {
    /// The program's standard error.
    pub stderr: String,
    moments: serde_json::Value,
}

impl TestbedRun {
    /// When `step` ended.
    pub fn at(&self, step: &str) -> f64 {
        self.moments
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["step"] == step)
            .and_then(|m| m["at"].as_f64())
            .unwrap_or_else(|| panic!("no step {step} in {}", self.moments))
    }
}

/// Run `program` with `args` in a umockdev testbed that `steps` drive (see
/// `tests/umockdev/testbed.py`), with its files in `dir`; panics unless every step and the
/// program succeed.
pub fn testbed_run(dir: &Path, steps: &[&str], program: &Path, args: &[String]) -> TestbedRun {
    let out = Command::new("umockdev-wrapper")
        .arg("/usr/bin/python3")
        .arg(super::repo_dir().join("tests/umockdev/testbed.py"))
        .arg(dir)
        .args(steps)
        .arg("--")
        .arg(program)
        .args(args)
        .output()
        .expect(
            "umockdev-wrapper and the umockdev GObject bindings are installed \
             (umockdev, gir1.2-umockdev-1.0, python3-gi; `make check` installs them)",
        );
    let stderr = std::fs::read_to_string(dir.join("program.stderr")).unwrap_or_default();
    assert!(
        out.status.success(),
        "{}\n{stderr}",
        String::from_utf8_lossy(&out.stderr)
    );
    let moments = std::fs::read_to_string(dir.join("moments.json")).unwrap();
    TestbedRun {
        stderr,
        moments: serde_json::from_str(&moments).unwrap(),
    }
}
