//! The files that make hapticd a system service: the systemd unit, the sysusers entry and the
//! udev rules, checked with systemd's own tools and against the daemon's device table.

use crate::support;

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

/// The units `make install` ships.
const UNITS: [&str; 6] = [
    "hapticd.service",
    "hapticd-guardian.socket",
    "hapticd-guardian@.service",
    "hapticd-render.service",
    "hapticd-zenoh.service",
    "hapticd-world.service",
];

/// `systemd-analyze verify` of `checked` beside every shipped unit, each program pointed at
/// the one just built (verify checks that it exists): whether it passed, and what systemd
/// said that is not about restart steps. The shipped units hide any of the same name installed
/// on the host, and systemd reads no administrator's directory (/etc, /run) here: what is
/// checked is this tree alone, whatever hapticd the machine runs.
fn verify(checked: &[&str]) -> (bool, String) {
    let dir = support::scratch_root().join(format!("unit-{}-{}", std::process::id(), checked[0]));
    std::fs::create_dir_all(&dir).unwrap();
    let built = artifact("hapticd").parent().unwrap().display().to_string();
    for name in UNITS {
        let text = read(&format!("systemd/{name}"))
            .replace("ExecStart=/usr/bin/", &format!("ExecStart={built}/"))
            .replace("ExecStart=@/usr/bin/", &format!("ExecStart=@{built}/"));
        std::fs::write(dir.join(name), text).unwrap();
    }
    let out = Command::new("systemd-analyze")
        .arg("verify")
        .args(checked)
        .current_dir(&dir)
        .env(
            "SYSTEMD_UNIT_PATH",
            format!(
                "{}:/usr/lib/systemd/system:/lib/systemd/system",
                dir.display()
            ),
        )
        .output()
        .expect("systemd-analyze (package systemd) is installed by `make check`");
    std::fs::remove_dir_all(&dir).unwrap();
    let said = String::from_utf8_lossy(&out.stderr);
    (
        out.status.success(),
        not_about_restart_steps(&said).join("\n"),
    )
}

/// What systemd before 254 says of a growing restart delay (it names the two settings and
/// restarts every second instead) left out; anything else is a mistake.
fn not_about_restart_steps(diagnostics: &str) -> Vec<&str> {
    diagnostics
        .lines()
        .filter(|l| !l.contains("RestartSteps") && !l.contains("RestartMaxDelaySec"))
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
    for d in hapticd_device::SUPPORTED_DEVICES {
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
    for key in ["LimitRTTIME", "StateDirectory", "ConfigurationDirectory"] {
        assert_eq!(values(&unit, key).len(), 1, "{key}= is set once");
    }
    // Only the haptic thread is real-time (set by the daemon, not the unit) and it needs
    // SCHED_FIFO; nothing in the process compiles code, so it may not write and execute.
    assert_eq!(values(&unit, "MemoryDenyWriteExecute"), ["yes"]);
    assert_eq!(values(&unit, "CapabilityBoundingSet"), [""]);
    for forbidden in ["RestrictRealtime", "CPUSchedulingPolicy", "PrivateNetwork"] {
        assert!(
            values(&unit, forbidden).is_empty(),
            "{forbidden}= must not be set"
        );
    }
    let (passed, diagnostics) = verify(&["hapticd.service"]);
    assert!(passed && diagnostics.is_empty(), "{diagnostics}");
}

/// The renderer's unit: beside hapticd's, wanted by it, restarted when its driver crashes,
/// free to compile shaders, and as sandboxed as that allows.
#[test]
fn the_renderer_unit_is_wanted_by_hapticd_and_restarts_with_back_off() {
    let haptic = read("systemd/hapticd.service");
    assert_eq!(values(&haptic, "Wants"), ["hapticd-render.service"]);
    assert_eq!(values(&haptic, "MemoryDenyWriteExecute"), ["yes"]);
    let unit = read("systemd/hapticd-render.service");
    assert_eq!(values(&unit, "PartOf"), ["hapticd.service"]);
    assert_eq!(values(&unit, "Restart"), ["always"]);
    assert_eq!(values(&unit, "RestartSteps").len(), 1);
    assert_eq!(values(&unit, "User"), ["hapticd-render"]);
    assert!(values(&unit, "MemoryDenyWriteExecute").is_empty());
    assert_eq!(values(&unit, "CapabilityBoundingSet"), [""]);
    // Bounded, so that a renderer asked for too much is killed alone (and restarted).
    assert_eq!(values(&unit, "MemoryHigh"), ["640M"]);
    assert_eq!(values(&unit, "MemoryMax"), ["768M"]);
    let sysusers = read("systemd/hapticd.sysusers");
    assert!(sysusers.lines().any(|l| l.starts_with("u hapticd-render ")));
    let dir = support::scratch_root().join(format!("render-unit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // On a host without them, systemd-sysusers makes every supplementary group of the unit
    // and puts the renderer's user in it.
    let root = dir.join("root");
    std::fs::create_dir_all(root.join("etc")).unwrap();
    let made = Command::new("systemd-sysusers")
        .arg(format!("--root={}", root.display()))
        .arg(repo_dir().join("systemd/hapticd.sysusers"))
        .output()
        .unwrap();
    assert!(made.status.success(), "{made:?}");
    let groups = std::fs::read_to_string(root.join("etc/group")).unwrap();
    for group in values(&unit, "SupplementaryGroups")[0].split_whitespace() {
        let line = groups
            .lines()
            .find(|l| l.starts_with(&format!("{group}:")))
            .unwrap_or_else(|| panic!("no group {group}: {groups}"));
        assert!(line.ends_with(":hapticd-render"), "{line}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
    let (passed, diagnostics) = verify(&["hapticd-render.service"]);
    assert!(passed && diagnostics.is_empty(), "{diagnostics}");
}

/// The network bridge's unit: started with hapticd once enabled, as a user of its own that
/// holds no rights over the devices, sandboxed but for the network it serves.
#[test]
fn the_bridge_unit_runs_as_its_own_user_beside_hapticd() {
    let unit = read("systemd/hapticd-zenoh.service");
    assert_eq!(
        values(&unit, "ExecStart"),
        ["/usr/bin/hapticd-zenoh --bus system"]
    );
    assert_eq!(values(&unit, "PartOf"), ["hapticd.service"]);
    assert_eq!(values(&unit, "WantedBy"), ["hapticd.service"]);
    assert_eq!(values(&unit, "Type"), ["notify"]);
    assert_eq!(values(&unit, "User"), ["hapticd-zenoh"]);
    // No group of hapticd's: commands need the administrator's drop-in.
    assert!(values(&unit, "SupplementaryGroups").is_empty());
    assert_eq!(values(&unit, "CapabilityBoundingSet"), [""]);
    assert_eq!(values(&unit, "MemoryDenyWriteExecute"), ["yes"]);
    assert_eq!(
        values(&unit, "RestrictAddressFamilies"),
        ["AF_UNIX AF_INET AF_INET6"]
    );
    let sysusers = read("systemd/hapticd.sysusers");
    assert!(sysusers.lines().any(|l| l.starts_with("u hapticd-zenoh ")));
    assert!(!sysusers.lines().any(|l| l.starts_with("m hapticd-zenoh ")));
    let (passed, diagnostics) = verify(&["hapticd-zenoh.service"]);
    assert!(passed && diagnostics.is_empty(), "{diagnostics}");
}

/// The world host's unit: started only where enabled and given a world, as a user made for
/// it, touching no device and no bus.
#[test]
fn the_world_unit_runs_sandboxed_only_where_a_world_is_given() {
    let unit = read("systemd/hapticd-world.service");
    assert_eq!(
        values(&unit, "ExecStart"),
        ["/usr/bin/hapticd-world /etc/hapticd/world.yaml"]
    );
    assert_eq!(
        values(&unit, "ConditionPathExists"),
        ["/etc/hapticd/world.yaml"]
    );
    assert_eq!(values(&unit, "Type"), ["notify"]);
    assert_eq!(values(&unit, "DynamicUser"), ["yes"]);
    assert_eq!(values(&unit, "PrivateDevices"), ["yes"]);
    assert_eq!(values(&unit, "CapabilityBoundingSet"), [""]);
    assert_eq!(values(&unit, "WantedBy"), ["multi-user.target"]);
    assert!(
        values(&unit, "PartOf").is_empty(),
        "it serves others' hapticd"
    );
    let (passed, diagnostics) = verify(&["hapticd-world.service"]);
    assert!(passed && diagnostics.is_empty(), "{diagnostics}");
}

#[test]
fn the_unit_runs_as_the_user_that_alone_owns_the_devices() {
    let unit = read("systemd/hapticd.service");
    let user = hapticd_device::udev::USER;
    assert_eq!(values(&unit, "User"), [user]);
    assert_eq!(values(&unit, "Group"), [user]);
    // The device nodes are the user's alone: the group tunes over the bus, never the motors.
    let rules = read("udev/70-hapticd.rules");
    for rule in rules.lines().filter(|l| l.contains("MODE=")) {
        assert!(
            rule.contains(&format!("OWNER=\"{user}\"")) && rule.contains("MODE=\"0600\""),
            "{rule}"
        );
        assert!(!rule.contains("GROUP="), "{rule}");
    }
    let policy = read("config/dbus/org.hapticd.Hapticd1.conf");
    assert!(
        policy.contains(&format!("<policy group=\"{user}\">")),
        "{policy}"
    );
    // hapticd speaks the readiness and watchdog protocol.
    assert_eq!(values(&unit, "Type"), ["notify"]);
    assert_eq!(values(&unit, "WatchdogSec").len(), 1);
    let sysusers = read("systemd/hapticd.sysusers");
    let entry = sysusers
        .lines()
        .find(|l| l.starts_with("u "))
        .expect("a user entry");
    assert_eq!(entry.split_whitespace().nth(1), Some(user));
}

/// Every `/dev/…` path named in the sources of `dir`, outside unit tests.
fn device_paths(dir: &std::path::Path, found: &mut Vec<String>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            device_paths(&path, found);
        } else if path.extension().is_some_and(|e| e == "rs") && !path.ends_with("tests.rs") {
            // A `tests.rs` holds a module's unit tests (`#[cfg(test)] mod tests;`).
            let text = std::fs::read_to_string(&path).unwrap();
            let code = text.split("#[cfg(test)]").next().unwrap_or_default();
            for literal in code.split('"').skip(1).step_by(2) {
                if literal.starts_with("/dev/") {
                    found.push(literal.to_string());
                }
            }
        }
    }
}

#[test]
fn every_device_node_the_daemon_opens_is_allowed_by_the_unit() {
    let unit = read("systemd/hapticd.service");
    assert_eq!(values(&unit, "DevicePolicy"), ["closed"]);
    let allowed = values(&unit, "DeviceAllow");
    let mut paths = Vec::new();
    for dir in ["daemon/hapticd/src", "daemon/device/src", "daemon/core/src"] {
        device_paths(&repo_dir().join(dir), &mut paths);
    }
    assert!(
        paths.iter().any(|p| p == "/dev/cpu_dma_latency"),
        "{paths:?}"
    );
    for path in &paths {
        // USB device nodes are allowed by their class; anything else by its path.
        let rule = if path.starts_with("/dev/bus/usb/") {
            "char-usb_device rw".to_string()
        } else {
            format!("{path} rw")
        };
        assert!(
            allowed.contains(&rule.as_str()),
            "{path} is opened but the unit allows only {allowed:?}"
        );
    }
}

/// The guardian runs where a kill of hapticd's control group cannot reach: its own unit, one
/// instance per connection to a socket hapticd.service pulls in and names to hapticd.
#[test]
fn the_guardian_is_a_unit_of_its_own_started_by_a_socket_hapticd_requires() {
    let haptic = read("systemd/hapticd.service");
    let socket = read("systemd/hapticd-guardian.socket");
    let guardian = read("systemd/hapticd-guardian@.service");
    let user = hapticd_device::udev::USER;
    assert_eq!(values(&haptic, "Requires"), ["hapticd-guardian.socket"]);
    assert_eq!(values(&haptic, "After"), ["hapticd-guardian.socket"]);
    let [path] = values(&socket, "ListenSequentialPacket")[..] else {
        panic!("{socket}");
    };
    assert_eq!(
        values(&haptic, "Environment"),
        [format!(
            "{}={path}",
            hapticd_device::guardian::SOCKET_VARIABLE
        )]
    );
    assert_eq!(values(&socket, "Accept"), ["yes"]);
    assert_eq!(values(&socket, "SocketUser"), [user]);
    assert_eq!(values(&socket, "SocketMode"), ["0600"]);
    assert_eq!(
        values(&guardian, "ExecStart"),
        [format!(
            "@/usr/bin/hapticd {}",
            hapticd_device::guardian::PROGRAM
        )]
    );
    assert_eq!(values(&guardian, "StandardInput"), ["socket"]);
    assert_eq!(values(&guardian, "User"), [user]);
    assert_eq!(values(&guardian, "DeviceAllow"), ["char-usb_device rw"]);
    // Nothing ties it to hapticd.service: a stop or kill of that unit must not reach it.
    for key in ["PartOf", "BindsTo", "Requires", "Wants"] {
        assert!(
            values(&guardian, key).is_empty(),
            "{key}= ties it to hapticd"
        );
    }
    // An instance, so that the template itself is read and checked.
    let (passed, said) = verify(&["hapticd-guardian.socket", "hapticd-guardian@1.service"]);
    assert!(passed && said.is_empty(), "{said}");
}
