//! Bad values and unprivileged callers: named errors, nothing changed.

use super::*;

#[test]
fn bad_inputs_return_named_errors_and_change_nothing() {
    let dir = support::shared_scratch("dbus", "bad");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let before = bus.get(DEVICE, "Stiffness");
    let set = |property: &str, variant: &str| bus.set_error(property, variant);
    let error = |prefix: &str, reason: &str| format!("{prefix}.{reason}");
    let ours = |reason| error("org.hapticd.Hapticd1.Error", reason);
    let fdo = |reason| error("org.freedesktop.DBus.Error", reason);
    assert_eq!(set("Stiffness", "string:stiff").0, fdo("InvalidArgs"));
    for value in ["nan", "inf", "-inf"] {
        let (name, message) = set("Stiffness", &format!("double:{value}"));
        assert_eq!(name, ours("NotFinite"), "{value}");
        assert!(
            message.contains("Stiffness must be a finite number"),
            "{message}"
        );
    }
    let (name, message) = set("Stiffness", "double:1e9");
    assert_eq!(name, ours("OutOfRange"));
    assert!(message.contains("(0, 100000]"), "{message}");
    assert_eq!(set("MaxForce", "double:-1").0, ours("OutOfRange"));
    assert_eq!(set("DynamicFriction", "double:0.9").0, ours("OutOfRange"));
    assert_eq!(set("Rate", "double:50").0, ours("OutOfRange"));
    assert_eq!(set("Stiffnes", "double:1").0, fdo("UnknownProperty"));
    // zbus answers a write to a read-only property as to an unknown one.
    let (name, message) = set("State", "string:fault");
    assert_eq!(name, fdo("UnknownProperty"));
    assert!(message.contains("State"), "{message}");
    let call = |object: [&str; 3], method: &str, args: &[&str]| {
        bus.error(object[1], &format!("{}.{method}", object[2]), args)
    };
    assert_eq!(
        call(MANAGER, "SwitchScene", &["string:nowhere"]).0,
        ours("UnknownScene")
    );
    // A file of the caller's goes by descriptor; its mistakes come back with their places.
    let broken = dir.join("broken.yaml");
    std::fs::write(&broken, "name: broken\nshapes:\n  - floor: { hieght: 0 }\n").unwrap();
    let out = bus.ctl(&["scene", "switch", broken.to_str().unwrap()]);
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        message.contains("SceneFailed: broken.yaml:3:") && message.contains("hieght"),
        "{message}"
    );
    // A path over the bus is no scene name.
    let (name, _) = call(
        MANAGER,
        "SwitchScene",
        &[&format!("string:{}", broken.display())],
    );
    assert_eq!(name, ours("NameExpected"));
    assert_eq!(
        call(DEVICE, "BindMechanism", &["string:no-such"]).0,
        ours("UnknownMechanism")
    );
    let elsewhere = [DEVICE[0], "/org/hapticd/Hapticd1/device/7", DEVICE[2]];
    assert_eq!(call(elsewhere, "Calibrate", &[]).0, fdo("UnknownObject"));
    assert_eq!(
        call(DEVICE, "Calibrate", &["string:x"]).0,
        fdo("InvalidArgs")
    );
    // Nothing changed, in the daemon or on disk.
    assert_eq!(bus.get(DEVICE, "Stiffness"), before);
    assert_eq!(bus.get(DEVICE, "DynamicFriction"), "d 0.2");
    assert_eq!(bus.get(MANAGER, "ActiveScene"), "s \"static\"");
    assert_eq!(bus.get(DEVICE, "BoundMechanism"), "s \"\"");
    assert!(!setup.state.join("device-sim-spidar-g-1.json").exists());
    // The refusals are in the log too, with who asked.
    let log = daemon.log();
    let uid = nix::unistd::getuid();
    for refused in [
        "refused to set MaxForce of sim-spidar-g-1 to -1".to_string(),
        "refused to switch to scene \"nowhere\"".to_string(),
        "refused to bind sim-spidar-g-1 to mechanism \"no-such\"".to_string(),
    ] {
        assert!(
            log.contains(&format!("{refused}, for uid {uid}")),
            "{refused}: {log}"
        );
    }
}

#[test]
fn an_unprivileged_client_may_read_but_not_change() {
    if !is_root() {
        eprintln!("skipped: switching to an unprivileged uid needs root");
        return;
    }
    let dir = support::shared_scratch("dbus", "unprivileged");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let as_nobody = |args: &[&str]| {
        Command::new("setpriv")
            .args(["--reuid=65534", "--regid=65534", "--clear-groups", "busctl"])
            .arg(format!("--address={}", bus.address))
            .args(args)
            .output()
            .unwrap()
    };
    let read = as_nobody(&["get-property", DEVICE[0], DEVICE[1], DEVICE[2], "Stiffness"]);
    assert!(read.status.success(), "{read:?}");
    assert_eq!(String::from_utf8_lossy(&read.stdout).trim(), "d 2000");
    let denied = |object: [&str; 3], method: &str, args: &[&str]| {
        let mut setpriv = Command::new("setpriv");
        setpriv.args([
            "--reuid=65534",
            "--regid=65534",
            "--clear-groups",
            "dbus-send",
        ]);
        let (name, _) = dbus_send_error(setpriv, &bus.address, NAME, object[1], method, args);
        assert_eq!(name, "org.freedesktop.DBus.Error.AccessDenied", "{method}");
    };
    let set = [
        "string:org.hapticd.Hapticd1.Device",
        "string:Stiffness",
        "variant:double:10",
    ];
    denied(DEVICE, "org.freedesktop.DBus.Properties.Set", &set);
    denied(DEVICE, "org.hapticd.Hapticd1.Device.Calibrate", &[]);
    denied(DEVICE, "org.hapticd.Hapticd1.Device.ResetFault", &[]);
    // Nor may it push on the hand, by a commanded wrench or by a world of its own.
    for method in ["OpenWrenchInput", "OpenWorldLink"] {
        let opened = as_nobody(&[
            "call", DEVICE[0], DEVICE[1], DEVICE[2], method, "a{sv}", "0",
        ]);
        assert!(
            !opened.status.success()
                && String::from_utf8_lossy(&opened.stderr).contains("Access denied"),
            "{method}: {opened:?}"
        );
    }
    denied(
        MANAGER,
        "org.hapticd.Hapticd1.Manager.SwitchScene",
        &["string:static"],
    );
    denied(MANAGER, "org.hapticd.Hapticd1.Manager.ReloadPlugins", &[]);
    denied(MANAGER, "org.hapticd.Hapticd1.Manager.Restart", &[]);
    for method in ["SetMass", "SetFriction"] {
        denied(
            SCENE,
            &format!("org.hapticd.Hapticd1.Scene.{method}"),
            &["string:block", "double:1"],
        );
    }
    denied(
        SCENE,
        "org.hapticd.Hapticd1.Scene.SetForce",
        &["string:block", "array:double:0,1,0"],
    );
    denied(
        SCENE,
        "org.hapticd.Hapticd1.Scene.SetMaterial",
        &["string:block", "double:1e5", "double:0.45", "double:0"],
    );
    for method in ["Pin", "Release"] {
        denied(
            SCENE,
            &format!("org.hapticd.Hapticd1.Scene.{method}"),
            &["string:block", "array:double:0,1,0", "double:0"],
        );
    }
    // Where a body is may be read by anyone: the daemon itself answers (no bodies here).
    let mut setpriv = Command::new("setpriv");
    setpriv.args([
        "--reuid=65534",
        "--regid=65534",
        "--clear-groups",
        "dbus-send",
    ]);
    let method = "org.hapticd.Hapticd1.Scene.Body";
    let (name, _) = dbus_send_error(
        setpriv,
        &bus.address,
        NAME,
        SCENE[1],
        method,
        &["string:block"],
    );
    assert_eq!(name, "org.hapticd.Hapticd1.Error.Unavailable");
    assert_eq!(bus.get(DEVICE, "Stiffness"), "d 2000");
}
