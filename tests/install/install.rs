//! Installing hapticd as the operator's guide says: `make install` into a scratch root, under the
//! system prefix and under another, and the installed daemon started from the installed
//! files alone; plugin authors building against the installed header and pkg-config file.

use crate::support;

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use support::bus::{NAME, PrivateBus, RENDERER};
use support::{artifact, repo_dir};

/// `make -s TARGET` of the build under test with `vars`, without cargo (installing only
/// copies); fails the test with make's errors.
fn make(target: &str, vars: &[String]) -> Output {
    let built = artifact("hapticd").parent().unwrap().to_path_buf();
    let out = Command::new("make")
        .current_dir(repo_dir())
        .args(["-s", target])
        .arg(format!("BUILT={}", built.display()))
        .args(vars)
        .env("CARGO", "/nonexistent/cargo")
        // The Makefile's defaults are under test: none may come from the caller's environment.
        .env_remove("PREFIX")
        .env_remove("SYSCONFDIR")
        .env_remove("SYSTEMLIBDIR")
        .env_remove("DBUSPOLICYDIR")
        .env_remove("DESTDIR")
        .output()
        .unwrap();
    support::succeeded(out)
}

/// `make install DESTDIR=dest` with `extra` variables.
fn make_install(dest: &Path, extra: &[&str]) -> Output {
    let mut vars = vec![format!("DESTDIR={}", dest.display())];
    vars.extend(extra.iter().map(|v| v.to_string()));
    make("install", &vars)
}

fn read(path: PathBuf) -> String {
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The command line of the installed unit's `ExecStart` with its `Environment=`, run from
/// the scratch root: the program moved under `dest`, the system bus (absent here) replaced by
/// `bus`. A unit that names the guardian's socket gets the installed guardian service on a
/// scratch socket, served as systemd serves it; the service lives as long as the second value.
fn exec_start(dest: &Path, unit: &str, bus: &str) -> (Command, Option<support::Killed>) {
    let path = dest.join(unit);
    let text = read(path.clone());
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix("ExecStart="))
        .expect("the unit has ExecStart");
    let mut words = line.split_whitespace();
    let program = words.next().unwrap();
    let mut command = Command::new(dest.join(program.trim_start_matches('/')));
    for word in words {
        command.arg(if word == "system" { bus } else { word });
    }
    command.env_remove("NOTIFY_SOCKET");
    let mut guardian = None;
    for setting in text.lines().filter_map(|l| l.strip_prefix("Environment=")) {
        let (name, value) = setting.split_once('=').unwrap();
        if name == hapticd_device::guardian::SOCKET_VARIABLE {
            let (socket, service) = serve_guardian(dest, path.parent().unwrap());
            command.env(name, socket);
            guardian = Some(service);
        } else {
            command.env(name, value);
        }
    }
    (command, guardian)
}

/// The installed guardian service (`units`' `hapticd-guardian@.service`, its program under
/// `dest`) on a new scratch socket, one instance per connection as its socket unit starts it:
/// the socket, and systemd-socket-activate serving it.
fn serve_guardian(dest: &Path, units: &Path) -> (PathBuf, support::Killed) {
    let unit = read(units.join("hapticd-guardian@.service"));
    let line = unit
        .lines()
        .find_map(|l| l.strip_prefix("ExecStart=@"))
        .expect("the guardian's ExecStart names its argv[0]");
    let (program, name) = line.split_once(' ').unwrap();
    static SERVED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = SERVED.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = support::scratch("install", &format!("guardian-{n}"));
    // systemd sets argv[0] from the `@` form; a link of that name does it here.
    let as_named = dir.join(name);
    // A scratch directory of an earlier run with the same process id may hold one already.
    let _ = std::fs::remove_file(&as_named);
    std::os::unix::fs::symlink(dest.join(program.trim_start_matches('/')), &as_named).unwrap();
    let socket = dir.join("guardian.socket");
    let service = Command::new("systemd-socket-activate")
        .args(["--seqpacket", "--accept", "--inetd", "-l"])
        .arg(&socket)
        .arg(&as_named)
        .stderr(std::fs::File::create(dir.join("guardian.log")).unwrap())
        .spawn()
        .expect("systemd-socket-activate (package systemd) is installed by `make check`");
    let service = support::Killed(service);
    let started = std::time::Instant::now();
    while !socket.exists() {
        assert!(
            started.elapsed().as_secs() < 10,
            "the guardian's socket never appeared"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    (socket, service)
}

/// A manager property of the daemon on `bus`, as `busctl` prints it; None until it answers.
fn manager_property(bus: &PrivateBus, property: &str) -> Option<String> {
    let out = Command::new("busctl")
        .arg(format!("--address={}", bus.address))
        .args(["get-property", NAME, "/org/hapticd/Hapticd1"])
        .arg(format!("{NAME}.Manager"))
        .arg(property)
        .output()
        .expect("busctl (package systemd) is installed by `make check`");
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// Start `daemon` serving `bus`, wait until it answers, return its `Scenes` and
/// `ActiveScene`, then stop it with SIGTERM as systemd does; it must exit cleanly.
fn scenes_of_running(mut daemon: Command, bus: &PrivateBus, log: &Path) -> (String, String) {
    let mut child = daemon
        .stderr(std::fs::File::create(log).unwrap())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    let active = loop {
        if let Some(active) = manager_property(bus, "ActiveScene") {
            break active;
        }
        if started.elapsed().as_secs() > 20 || child.try_wait().unwrap().is_some() {
            let _ = child.kill();
            panic!("hapticd did not come up:\n{}", read(log.to_path_buf()));
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    let scenes = manager_property(bus, "Scenes").unwrap();
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    )
    .unwrap();
    let status = child.wait().unwrap();
    assert!(status.success(), "{}", read(log.to_path_buf()));
    (scenes, active)
}

/// The `Scenes` and `ActiveScene` of the daemon installed under `root` with the /usr
/// prefix, started as its unit starts it on a bus (scratch directory `bus`) with its
/// installed policy, less the configuration's place: a binary under ROOT/usr looks for
/// ROOT/usr/etc, and /etc is the system's.
fn scenes_of_installed(root: &Path, bus: &str) -> (String, String) {
    let bus = PrivateBus::start(
        &support::scratch("install", bus),
        &root.join("usr/share/dbus-1/system.d/org.hapticd.Hapticd1.conf"),
    );
    let (mut daemon, _guardian) =
        exec_start(root, "usr/lib/systemd/system/hapticd.service", &bus.address);
    daemon
        .arg("--config")
        .arg(root.join("etc/hapticd/hapticd.yaml"));
    scenes_of_running(daemon, &bus, &root.join("hapticd.log"))
}

/// `make install` of the build under test into a scratch DESTDIR: every file where a
/// distribution puts it, and the installed daemon runs from the installed plugins, scenes and
/// configuration alone.
#[test]
fn make_install_lays_out_a_working_system() {
    let dest = support::scratch("install", "usr");
    make_install(&dest, &[]);
    for file in [
        "usr/bin/hapticd",
        "usr/bin/hapticd-render",
        "usr/bin/hapticd-zenoh",
        "usr/bin/hapticd-world",
        "usr/bin/hapticctl",
        "usr/lib/hapticd/plugins/libhapticd_spidar_g.so",
        "usr/lib/hapticd/plugins/libspidar_desk.so",
        "usr/lib/hapticd/scenes/libhapticd_scene_penalty.so",
        "usr/lib/hapticd/scenes/libhapticd_scene_rapier.so",
        "usr/share/hapticd/scenes/static.yaml",
        "usr/share/hapticd/scenes/robots/arm.urdf",
        "usr/share/hapticd/mechanisms/spidar-6s.yaml",
        "usr/include/hapticd/hapticd_plugin.h",
        "usr/share/pkgconfig/hapticd-plugin.pc",
        "etc/hapticd/hapticd.yaml",
        "etc/hapticd/network.yaml",
        "usr/lib/systemd/system/hapticd.service",
        "usr/lib/systemd/system/hapticd-guardian.socket",
        "usr/lib/systemd/system/hapticd-guardian@.service",
        "usr/lib/systemd/system/hapticd-render.service",
        "usr/lib/systemd/system/hapticd-zenoh.service",
        "usr/lib/systemd/system/hapticd-world.service",
        "usr/lib/sysusers.d/hapticd.conf",
        "usr/lib/udev/rules.d/70-hapticd.rules",
        "usr/share/dbus-1/system.d/org.hapticd.Hapticd1.conf",
        "usr/share/dbus-1/system.d/org.hapticd.Renderer1.conf",
        "usr/share/dbus-1/interfaces/org.hapticd.Hapticd1.Manager.xml",
        "usr/share/dbus-1/interfaces/org.hapticd.Hapticd1.Device.xml",
        "usr/share/dbus-1/interfaces/org.hapticd.Hapticd1.Scene.xml",
        "usr/share/dbus-1/interfaces/org.hapticd.Renderer1.xml",
        "usr/share/doc/hapticd/README.md",
        "usr/share/doc/hapticd/docs/operators-guide.md",
        "usr/share/doc/hapticd/docs/figures/push-phase.png",
        "usr/share/doc/hapticd/LICENSE-MIT",
        "usr/share/doc/hapticd/LICENSE-APACHE",
        "usr/share/doc/hapticd/examples/floor_scene.c",
        "usr/share/doc/hapticd/examples/floor_scene.rs",
        "usr/share/bash-completion/completions/hapticctl",
        "usr/share/zsh/vendor-completions/_hapticctl",
        "usr/share/fish/vendor_completions.d/hapticctl.fish",
        "usr/share/man/man8/hapticd.8",
        "usr/share/man/man8/hapticd-render.8",
        "usr/share/man/man8/hapticd-zenoh.8",
        "usr/share/man/man8/hapticd-world.8",
        "usr/share/man/man1/hapticctl.1",
        "usr/share/man/man1/hapticctl-scene-run.1",
        "usr/share/man/man5/hapticd.yaml.5",
        "usr/share/man/man5/hapticd-mechanism.5",
        "usr/share/man/man5/hapticd-scene.5",
        "usr/share/man/man5/hapticd-hand.5",
    ] {
        assert!(dest.join(file).is_file(), "{file} is not installed");
    }
    // The installed bash completion completes with the installed hapticctl, the manual
    // knows the options.
    let script = dest.join("usr/share/bash-completion/completions/hapticctl");
    let completed = Command::new("bash")
        .arg("-c")
        .arg(format!(
            "source {}; COMP_WORDS=(hapticctl sc); COMP_CWORD=1; \
             _clap_complete_hapticctl hapticctl sc; printf '%s\\n' \"${{COMPREPLY[@]}}\"",
            script.display()
        ))
        .env(
            "PATH",
            format!("{}:/usr/bin:/bin", dest.join("usr/bin").display()),
        )
        .output()
        .unwrap();
    assert_eq!(
        String::from_utf8_lossy(&completed.stdout),
        "scene\n",
        "{completed:?}"
    );
    let page = read(dest.join("usr/share/man/man8/hapticd.8"));
    for option in ["\\-\\-config", "\\-\\-scene", ".SH FILES", ".SH SIGNALS"] {
        assert!(page.contains(option), "hapticd(8) lacks {option}");
    }
    // The renderer's limits are its own options: its page has every one, with its help.
    let page = read(dest.join("usr/share/man/man8/hapticd-render.8"));
    let help = Command::new(dest.join("usr/bin/hapticd-render"))
        .arg("--help")
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    let limits: Vec<&str> = help
        .split_whitespace()
        .filter(|w| w.starts_with("--max-"))
        .collect();
    assert_eq!(limits.len(), 7, "{help}");
    for option in limits {
        let escaped = option.replace('-', "\\-");
        assert!(page.contains(&escaped), "hapticd-render(8) lacks {option}");
    }
    let (scenes, active) = scenes_of_installed(&dest, "usr-bus");
    assert_eq!(active, "s \"static\"");
    for scene in ["static", "blocks", "top"] {
        assert!(scenes.contains(&format!("\"{scene}\"")), "{scenes}");
    }
    let picture = snapshot_of_installed(&dest);
    assert_eq!((picture.width, picture.height), (64, 48));
    std::fs::remove_dir_all(&dest).unwrap();
}

/// A picture from the renderer installed under `root`, started as its unit starts it beside
/// the installed daemon, on a bus with both installed policies.
fn snapshot_of_installed(root: &Path) -> hapticd_render::picture::Picture {
    let policies = root.join("usr/share/dbus-1/system.d");
    let bus = PrivateBus::with_policies(
        &support::scratch("install", "render-bus"),
        &[
            &policies.join("org.hapticd.Hapticd1.conf"),
            &policies.join("org.hapticd.Renderer1.conf"),
        ],
    );
    let (mut daemon, _guardian) =
        exec_start(root, "usr/lib/systemd/system/hapticd.service", &bus.address);
    daemon
        .arg("--config")
        .arg(root.join("etc/hapticd/hapticd.yaml"));
    let _daemon = support::Killed(daemon.stderr(std::process::Stdio::null()).spawn().unwrap());
    let (mut renderer, _) = exec_start(
        root,
        "usr/lib/systemd/system/hapticd-render.service",
        &bus.address,
    );
    let _renderer = support::Killed(
        renderer
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap(),
    );
    let started = std::time::Instant::now();
    loop {
        let out = Command::new("busctl")
            .arg(format!("--address={}", bus.address))
            .args([
                "--json=short",
                "call",
                RENDERER,
                "/org/hapticd/Renderer1",
                RENDERER,
            ])
            .args([
                "Snapshot", "a{sv}", "2", "width", "u", "64", "height", "u", "48",
            ])
            .output()
            .unwrap();
        if out.status.success() {
            return support::bus::snapshot_of_busctl_json(&out.stdout).unwrap();
        }
        assert!(
            started.elapsed().as_secs() < 30,
            "no picture from the installed renderer: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
}

/// `make install PREFIX=/opt/hapticd`: the unit, rules and user go where systemd and udev
/// read an administrator's files, and the daemon started as the unit starts it finds its
/// configuration, mechanisms, scenes and scene plugins under the prefix, with no flag.
#[test]
fn an_install_under_another_prefix_runs_from_its_own_tree() {
    let dest = support::scratch("install", "opt");
    make_install(&dest, &["PREFIX=/opt/hapticd"]);
    for file in [
        "etc/systemd/system/hapticd.service",
        "etc/sysusers.d/hapticd.conf",
        "etc/udev/rules.d/70-hapticd.rules",
        "etc/dbus-1/system.d/org.hapticd.Hapticd1.conf",
        "opt/hapticd/etc/hapticd/hapticd.yaml",
        "opt/hapticd/lib/hapticd/plugins/libhapticd_spidar_g.so",
        "opt/hapticd/share/man/man8/hapticd.8",
    ] {
        assert!(dest.join(file).is_file(), "{file} is not installed");
    }
    assert!(!dest.join("usr").exists(), "nothing lands under /usr");
    let unit = read(dest.join("etc/systemd/system/hapticd.service"));
    assert!(
        unit.contains("\nExecStart=/opt/hapticd/bin/hapticd --bus system\n"),
        "{unit}"
    );
    assert!(unit.contains("file:///opt/hapticd/share/doc/hapticd/docs/operators-guide.md"));
    let guardian = read(dest.join("etc/systemd/system/hapticd-guardian@.service"));
    assert!(
        guardian.contains("\nExecStart=@/opt/hapticd/bin/hapticd hapticd-guardian\n"),
        "{guardian}"
    );
    let bridge = read(dest.join("etc/systemd/system/hapticd-zenoh.service"));
    assert!(
        bridge.contains(
            "\nExecStart=/opt/hapticd/bin/hapticd-zenoh --config \
             /opt/hapticd/etc/hapticd/network.yaml --bus system\n"
        ),
        "{bridge}"
    );
    let world = read(dest.join("etc/systemd/system/hapticd-world.service"));
    assert!(
        world.contains(
            "\nExecStart=/opt/hapticd/bin/hapticd-world --config \
             /opt/hapticd/etc/hapticd/network.yaml /opt/hapticd/etc/hapticd/world.yaml\n"
        ) && world.contains("\nConditionPathExists=/opt/hapticd/etc/hapticd/world.yaml\n"),
        "{world}"
    );
    assert!(dest.join("opt/hapticd/etc/hapticd/network.yaml").is_file());
    let pc = read(dest.join("opt/hapticd/share/pkgconfig/hapticd-plugin.pc"));
    assert!(pc.starts_with("prefix=/opt/hapticd\n"), "{pc}");
    // The installed hapticctl takes installed scenes by name, as the daemon does.
    let ctl = dest.join("opt/hapticd/bin/hapticctl");
    let picture = dest.join("static.png");
    let picture_arg = picture.display().to_string();
    for args in [
        &["scene", "run", "cube-drop", "--duration", "0.05"][..],
        &[
            "render",
            "static",
            "--width",
            "32",
            "--height",
            "24",
            "--out",
            &picture_arg,
        ],
    ] {
        let out = Command::new(&ctl).args(args).output().unwrap();
        assert!(out.status.success(), "{args:?}: {out:?}");
    }
    assert!(picture.is_file());
    // A physics scene by name needs the scene directories and the engine's plugin.
    let bus = PrivateBus::start(
        &support::scratch("install", "opt-bus"),
        &dest.join("etc/dbus-1/system.d/org.hapticd.Hapticd1.conf"),
    );
    let (mut daemon, _guardian) =
        exec_start(&dest, "etc/systemd/system/hapticd.service", &bus.address);
    daemon.args(["--scene", "blocks"]);
    let (scenes, active) = scenes_of_running(daemon, &bus, &dest.join("hapticd.log"));
    assert_eq!(active, "s \"blocks\"");
    assert!(scenes.contains("\"static\""), "{scenes}");
    std::fs::remove_dir_all(&dest).unwrap();
}

/// A reinstall keeps an edited configuration; the shipped one stays in the documentation.
#[test]
fn reinstalling_keeps_an_edited_configuration() {
    let dest = support::scratch("install", "reinstall");
    make_install(&dest, &[]);
    let config = dest.join("etc/hapticd/hapticd.yaml");
    let edited = read(config.clone()).replace("rate: 1000 ", "rate: 2000 ");
    std::fs::write(&config, &edited).unwrap();
    let out = make_install(&dest, &[]);
    assert_eq!(read(config), edited);
    assert!(String::from_utf8_lossy(&out.stdout).contains("keeping"));
    assert_eq!(
        read(dest.join("usr/share/doc/hapticd/hapticd.yaml")),
        read(repo_dir().join("config/hapticd.yaml"))
    );
    std::fs::remove_dir_all(&dest).unwrap();
}

/// Plugin authors build the C examples against the installed header with pkg-config alone,
/// and the installed hapticd runs the scene example: its floor holds the simulated hand.
#[test]
fn the_c_examples_build_against_the_installed_header_and_run() {
    let dest = support::scratch("install", "c");
    make_install(&dest, &[]);
    let cflags = Command::new("pkg-config")
        .args(["--cflags", "hapticd-plugin"])
        .env("PKG_CONFIG_PATH", dest.join("usr/share/pkgconfig"))
        .env("PKG_CONFIG_SYSROOT_DIR", &dest)
        .output()
        .expect("pkg-config is installed (make check installs it)");
    assert!(cflags.status.success());
    let cflags = String::from_utf8(cflags.stdout).unwrap();
    assert_eq!(
        cflags.trim(),
        format!("-I{}/usr/include/hapticd", dest.display())
    );
    let examples = dest.join("usr/share/doc/hapticd/examples");
    for example in ["spidar_desk", "floor_scene"] {
        let status = Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()))
            .args([
                "-shared", "-fPIC", "-O2", "-Wall", "-Wextra", "-Werror", "-std=c11",
            ])
            .args(cflags.split_whitespace())
            .arg(examples.join(format!("{example}.c")))
            .arg("-o")
            .arg(dest.join(format!("lib{example}.so")))
            .status()
            .unwrap();
        assert!(status.success(), "{example}.c does not build");
    }
    let csv = dest.join("floor.csv");
    let bus = PrivateBus::start(
        &support::scratch("install", "c-bus"),
        &dest.join("usr/share/dbus-1/system.d/org.hapticd.Hapticd1.conf"),
    );
    let run = Command::new(dest.join("usr/bin/hapticd"))
        .arg("--config")
        .arg(dest.join("etc/hapticd/hapticd.yaml"))
        .arg("--scene")
        .arg(dest.join("libfloor_scene.so"))
        .arg("--hand")
        .arg(dest.join("usr/share/hapticd/hands/press-floor.yaml"))
        .arg(format!("--bus={}", bus.address))
        .args(["--duration", "1.6", "--record"])
        .arg(&csv)
        .env_remove("NOTIFY_SOCKET")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    // Pressed down from 1.0 s on, the grip rests on the spring floor at y = −0.03 m,
    // sunk by the hand's push over the 1000 N/m spring.
    let text = read(csv);
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let (t, y, fy) = (
        header.iter().position(|c| *c == "time").unwrap(),
        header.iter().position(|c| *c == "pose_y").unwrap(),
        header.iter().position(|c| *c == "force_y").unwrap(),
    );
    let row: Vec<&str> = text.lines().last().unwrap().split(',').collect();
    let last = |column: usize| -> f64 { row[column].parse().unwrap() };
    let (t, y, fy) = (last(t), last(y), last(fy));
    assert!(t > 1.5);
    let depth = -0.03 - y;
    assert!((0.0..0.01).contains(&depth), "grip at y = {y}");
    assert!(
        (fy - 1000.0 * depth).abs() < 0.5,
        "force {fy} N at depth {depth} m"
    );
    std::fs::remove_dir_all(&dest).unwrap();
}

/// The ELF build id of `file`.
fn build_id(file: &Path) -> String {
    let out = Command::new("readelf")
        .arg("-n")
        .arg(file)
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .find_map(|l| l.trim().strip_prefix("Build ID: "))
        .unwrap_or_else(|| panic!("{} has no build id", file.display()))
        .to_string()
}

/// `make deb`: lintian finds nothing to say, the binaries are stripped with their debug
/// information in the dbgsym package under their build ids, the configuration is a
/// conffile, and the daemon unpacked into a scratch root runs as the unit starts it.
#[test]
fn the_debian_package_is_lintian_clean_and_runs_unpacked() {
    let dir = support::scratch("install", "deb");
    make(
        "deb-from-built",
        &[format!("DEB={}", dir.join("deb").display())],
    );
    let version = env!("CARGO_PKG_VERSION");
    let arch = String::from_utf8(
        Command::new("dpkg")
            .arg("--print-architecture")
            .output()
            .unwrap()
            .stdout,
    )
    .unwrap();
    let package = dir.join(format!("deb/hapticd_{version}_{}.deb", arch.trim()));
    let dbgsym = dir.join(format!("deb/hapticd-dbgsym_{version}_{}.deb", arch.trim()));

    let lintian = Command::new("lintian")
        .args([
            "--pedantic",
            "--display-info",
            "--fail-on",
            "error,warning,info,pedantic",
        ])
        .arg(&package)
        .arg(&dbgsym)
        // Its ELF caches (`mldbm-elf-…`) stay behind: in the test's directory, not /tmp.
        .env("TMPDIR", &dir)
        .output()
        .expect("lintian is installed (make check installs it)");
    let said = String::from_utf8_lossy(&lintian.stdout);
    // The spelling overrides are of hints that depend on how the linker lays out read-only
    // data (see lintian-overrides): some builds need them, the others report them unused (or
    // mismatched, when the file has another of the hints).
    let layout = |l: &str| {
        ["unused-override", "mismatched-override"]
            .iter()
            .any(|o| l.contains(&format!("{o} spelling-error-in-binary ")))
    };
    let findings: Vec<&str> = said
        .lines()
        .filter(|l| !layout(l) && !l.starts_with("N: "))
        .collect();
    assert!(findings.is_empty(), "{said}");
    assert!(
        lintian.status.success() || said.lines().any(layout),
        "{said}"
    );

    let field = |deb: &Path, name: &str| {
        let out = Command::new("dpkg-deb")
            .arg("--field")
            .arg(deb)
            .arg(name)
            .output()
            .unwrap();
        String::from_utf8(out.stdout).unwrap().trim().to_string()
    };
    assert!(field(&package, "Depends").contains("libc6"));
    assert_eq!(field(&dbgsym, "Depends"), format!("hapticd (= {version})"));
    let root = dir.join("root");
    let dbg = dir.join("dbg");
    for (deb, into) in [(&package, &root), (&dbgsym, &dbg)] {
        let status = Command::new("dpkg-deb")
            .arg("-x")
            .arg(deb)
            .arg(into)
            .status()
            .unwrap();
        assert!(status.success());
    }
    let control = dir.join("control");
    let status = Command::new("dpkg-deb")
        .arg("-e")
        .arg(&package)
        .arg(&control)
        .status()
        .unwrap();
    assert!(status.success());
    assert_eq!(
        read(control.join("conffiles")),
        "/etc/hapticd/hapticd.yaml\n/etc/hapticd/network.yaml\n"
    );
    for script in ["postinst", "prerm", "postrm"] {
        let check = Command::new("sh")
            .arg("-n")
            .arg(control.join(script))
            .status()
            .unwrap();
        assert!(check.success(), "{script} is not valid sh");
    }
    // A first installation enables the unit whether or not systemd runs (a chroot, an image
    // being built): the system tools it calls are recorded, not run.
    let tools = dir.join("tools");
    std::fs::create_dir_all(&tools).unwrap();
    let calls = dir.join("calls");
    for tool in [
        "deb-systemd-helper",
        "deb-systemd-invoke",
        "systemctl",
        "systemd-sysusers",
        "udevadm",
    ] {
        let stub = tools.join(tool);
        std::fs::write(
            &stub,
            format!("#!/bin/sh\necho \"{tool} $*\" >> {}\n", calls.display()),
        )
        .unwrap();
        std::fs::set_permissions(&stub, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let path = format!(
        "{}:{}",
        tools.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let configured = Command::new("sh")
        .arg(control.join("postinst"))
        .arg("configure")
        .env("PATH", path)
        .status()
        .unwrap();
    assert!(configured.success());
    let calls = read(calls);
    assert!(
        calls.contains("deb-systemd-helper enable hapticd.service"),
        "{calls}"
    );
    assert!(calls.contains("systemd-sysusers hapticd.conf"), "{calls}");
    // Stripped, and the debug information is where gdb looks for it.
    for file in [
        "usr/bin/hapticd",
        "usr/bin/hapticctl",
        "usr/lib/hapticd/plugins/libhapticd_spidar_g.so",
    ] {
        let path = root.join(file);
        let sections = Command::new("readelf")
            .arg("-S")
            .arg(&path)
            .output()
            .unwrap();
        let sections = String::from_utf8_lossy(&sections.stdout);
        // (.debug_gdb_scripts is loaded with the program: it stays.)
        assert!(
            !sections.contains(".debug_info") && !sections.contains(".symtab"),
            "{file} is not stripped"
        );
        let id = build_id(&path);
        let debug = dbg.join(format!(
            "usr/lib/debug/.build-id/{}/{}.debug",
            &id[..2],
            &id[2..]
        ));
        assert!(debug.is_file(), "no debug information for {file}");
    }
    assert!(root.join("usr/share/man/man8/hapticd.8.gz").is_file());
    assert!(root.join("usr/share/doc/hapticd/copyright").is_file());

    let (scenes, active) = scenes_of_installed(&root, "deb-bus");
    assert_eq!(active, "s \"static\"");
    assert!(scenes.contains("\"blocks\""), "{scenes}");
    std::fs::remove_dir_all(&dir).unwrap();
}
