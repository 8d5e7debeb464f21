//! The files that make hapticd a system service: the systemd unit, the sysusers entry and the
//! udev rules, checked with systemd's own tools and against the daemon's device table.

mod support;

use std::process::Command;

use support::{artifact, hapticctl, repo_dir};

fn read(path: &str) -> String {
    std::fs::read_to_string(repo_dir().join(path)).unwrap()
}

/// The value of every `key=value` line of a unit file with this key.
fn values<'a>(unit: &'a str, key: &str) -> Vec<&'a str> {
    unit.lines()
        .filter_map(|l| l.strip_prefix(key)?.strip_prefix('='))
        .collect()
}

#[test]
fn the_shipped_udev_rules_are_those_generated_from_the_device_table() {
    let out = hapticctl().args(["device", "udev-rules"]).output().unwrap();
    assert!(out.status.success());
    let generated = String::from_utf8(out.stdout).unwrap();
    assert_eq!(
        read("udev/70-hapticd.rules"),
        generated,
        "regenerate with: hapticctl device udev-rules > udev/70-hapticd.rules"
    );
    for d in hapticd::device::SUPPORTED_DEVICES {
        let ids = format!(
            "ATTR{{idVendor}}==\"{:04x}\", ATTR{{idProduct}}==\"{:04x}\"",
            d.vendor, d.product
        );
        let rule = generated.lines().find(|l| l.contains(&ids)).expect(d.name);
        assert!(
            rule.contains("ENV{SYSTEMD_WANTS}+=\"hapticd.service\""),
            "{rule}"
        );
    }
}

#[test]
fn the_unit_passes_systemd_analyze_verify_without_a_warning() {
    let unit = read("systemd/hapticd.service");
    assert_eq!(
        values(&unit, "ExecStart"),
        ["/usr/bin/hapticd --bus system"]
    );
    for key in [
        "LimitRTTIME",
        "StateDirectory",
        "ConfigurationDirectory",
        "DeviceAllow",
    ] {
        assert_eq!(values(&unit, key).len(), 1, "{key}= is set once");
    }
    // Only the haptic thread is real-time, and lavapipe compiles shaders at run time.
    for forbidden in [
        "RestrictRealtime",
        "MemoryDenyWriteExecute",
        "CPUSchedulingPolicy",
    ] {
        assert!(
            values(&unit, forbidden).is_empty(),
            "{forbidden}= must not be set"
        );
    }
    // verify checks that the program exists: point it at the one just built.
    let dir = support::scratch_root().join(format!("hapticd-unit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("hapticd.service");
    let built = format!("ExecStart={}", artifact("hapticd").display());
    std::fs::write(&file, unit.replace("ExecStart=/usr/bin/hapticd", &built)).unwrap();
    let out = Command::new("systemd-analyze")
        .arg("verify")
        .arg(&file)
        .output()
        .expect("systemd-analyze (package systemd) is installed by `make check`");
    let diagnostics = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && diagnostics.trim().is_empty(),
        "{diagnostics}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_unit_runs_as_the_user_and_group_that_own_the_devices() {
    let unit = read("systemd/hapticd.service");
    let group = hapticd::device::udev::GROUP;
    assert_eq!(values(&unit, "User"), [group]);
    assert_eq!(values(&unit, "Group"), [group]);
    // hapticd speaks the readiness and watchdog protocol.
    assert_eq!(values(&unit, "Type"), ["notify"]);
    assert_eq!(values(&unit, "WatchdogSec").len(), 1);
    let sysusers = read("systemd/hapticd.sysusers");
    let entry = sysusers
        .lines()
        .find(|l| l.starts_with("u "))
        .expect("a user entry");
    assert_eq!(entry.split_whitespace().nth(1), Some(group));
}
