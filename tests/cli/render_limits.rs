//! hapticd-render's limits, tried by an unprivileged user (`nobody`) on a private
//! `dbus-daemon` with the shipped policies, against the real renderer on lavapipe drawing
//! the real hapticd on the simulated SPIDAR-G: streams beyond a connection's, a user's and
//! everyone's limit, a pixel rate or a frame too large are refused by name and change
//! nothing; identical streams are drawn once; a Snapshot goes before the streams of a
//! caller that fills the drawing thread.
//!
//! The tests run as root and need it to be someone else: without root they say so and pass.

use crate::support;

use std::collections::HashMap;
use std::os::fd::OwnedFd;
use std::os::unix::net::UnixStream;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use hapticd_ipc::frame_ring::FrameRingReader;
use support::bus::{NAME, PrivateBus, RENDERER};
use support::{Killed, artifact, is_root, plugin_path, repo_dir};
use zbus::Variant;

const PATH: &str = "/org/hapticd/Renderer1";
/// The unprivileged user the limits are tried as.
const NOBODY: u32 = 65534;

/// A private bus with hapticd, and hapticd-render started with `limits` (its command line's
/// `--max-…` options); all stopped when dropped.
struct Setup {
    bus: PrivateBus,
    socket: PathBuf,
    _hapticd: Killed,
    _renderer: Killed,
    log: PathBuf,
}

impl Setup {
    fn start(name: &str, limits: &[&str]) -> Setup {
        let dir = support::shared_scratch("limits", name);
        let bus = PrivateBus::with_policies(
            &dir,
            &[
                &repo_dir().join("config/dbus/org.hapticd.Hapticd1.conf"),
                &repo_dir().join("config/dbus/org.hapticd.Renderer1.conf"),
            ],
        );
        let mechanisms = dir.join("mechanisms");
        std::fs::create_dir_all(&mechanisms).unwrap();
        let plugin = plugin_path("hapticd-spidar-g");
        std::fs::copy(&plugin, mechanisms.join(plugin.file_name().unwrap())).unwrap();
        let config = dir.join("hapticd.yaml");
        let scenes = repo_dir().join("config/scenes");
        std::fs::write(
            &config,
            format!("scene_dirs: [{}]\nscene: static\n", scenes.display()),
        )
        .unwrap();
        let hapticd = support::daemon::command(&config, &bus.address)
            .arg("--mechanism-dir")
            .arg(&mechanisms)
            .arg("--state-dir")
            .arg(dir.join("state"))
            .args(["--sim", "spidar-g"])
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(dir.join("hapticd.log")).unwrap())
            .spawn()
            .unwrap();
        let log = dir.join("render.log");
        let renderer = Command::new(artifact("hapticd-render"))
            .arg(format!("--bus={}", bus.address))
            .args(limits)
            .env_remove("NOTIFY_SOCKET")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .unwrap();
        let socket = dir.join("bus");
        let setup = Setup {
            bus,
            socket,
            _hapticd: Killed(hapticd),
            _renderer: Killed(renderer),
            log,
        };
        let root = setup.connect_as(0);
        let started = Instant::now();
        while get::<bool>(&root, RENDERER, PATH, RENDERER, "Available").is_err()
            || get::<String>(
                &root,
                NAME,
                "/org/hapticd/Hapticd1/device/0",
                DEVICE,
                "State",
            )
            .is_err()
        {
            assert!(
                started.elapsed() < Duration::from_secs(30),
                "{}",
                setup.log()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        setup
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// A connection the bus sees as user `uid`. The kernel records a Unix socket's peer
    /// credentials when it connects, so the socket is connected from a thread of its own
    /// that has become `uid` (credentials are per thread to the kernel; the raw system
    /// calls change this thread's alone, not the test process's), and the EXTERNAL
    /// handshake names the same user.
    fn connect_as(&self, uid: u32) -> zbus::Connection {
        let socket = self.socket.clone();
        let stream = std::thread::spawn(move || {
            if uid != 0 {
                // SAFETY: plain system calls on this thread's credentials, which ends here.
                let dropped = unsafe {
                    nix::libc::syscall(nix::libc::SYS_setgroups, 0, std::ptr::null::<u32>()) == 0
                        && nix::libc::syscall(nix::libc::SYS_setresgid, uid, uid, uid) == 0
                        && nix::libc::syscall(nix::libc::SYS_setresuid, uid, uid, uid) == 0
                };
                assert!(dropped, "{}", std::io::Error::last_os_error());
            }
            UnixStream::connect(socket).unwrap()
        })
        .join()
        .unwrap();
        zbus::block_on(
            zbus::connection::Builder::unix_stream(stream)
                .user_id(uid)
                .build(),
        )
        .unwrap()
    }

    /// The renderer's `Statistics`.
    fn statistics(&self) -> HashMap<String, u64> {
        get(&self.connect_as(0), RENDERER, PATH, RENDERER, "Statistics").unwrap()
    }

    /// `busctl` on this bus as `nobody`, with `args`.
    fn busctl_as_nobody(&self, args: &[&str]) -> std::process::Output {
        Command::new("setpriv")
            .args(["--reuid=65534", "--regid=65534", "--clear-groups", "busctl"])
            .arg(format!("--address={}", self.bus.address))
            .args(args)
            .output()
            .expect("setpriv (package util-linux) and busctl (package systemd)")
    }
}

const DEVICE: &str = "org.hapticd.Hapticd1.Device";

/// Property `name` of `interface` at `path` of `destination`.
fn get<T>(
    connection: &zbus::Connection,
    destination: &str,
    path: &str,
    interface: &str,
    name: &str,
) -> zbus::Result<T>
where
    T: TryFrom<zbus::OwnedVariant>,
    T::Error: Into<zbus::Error>,
{
    let reply = zbus::block_on(connection.call_method(
        Some(destination),
        path,
        Some("org.freedesktop.DBus.Properties"),
        "Get",
        &(interface, name),
    ))?;
    let value: zbus::OwnedVariant = reply.body().deserialize()?;
    T::try_from(value).map_err(Into::into)
}

/// Open a frame stream on `connection` with `options`: its ring's descriptor, or the
/// error's name and message.
fn open_stream(
    connection: &zbus::Connection,
    options: &[(&str, Variant<'_>)],
) -> Result<OwnedFd, (String, String)> {
    let options: HashMap<&str, &Variant<'_>> = options.iter().map(|(k, v)| (*k, v)).collect();
    let reply = zbus::block_on(connection.call_method(
        Some(RENDERER),
        PATH,
        Some(RENDERER),
        "OpenFrameStream",
        &(options,),
    ));
    match reply {
        Ok(m) => Ok(m.body().deserialize::<zbus::OwnedFd>().unwrap().into()),
        Err(zbus::Error::MethodError(name, message, _)) => {
            Err((name.to_string(), message.unwrap_or_default()))
        }
        Err(other) => panic!("OpenFrameStream failed otherwise: {other}"),
    }
}

/// The options of a `width × height` stream at `rate`, seen from `azimuth`.
fn stream(
    width: u32,
    height: u32,
    rate: f64,
    azimuth: f64,
) -> Vec<(&'static str, Variant<'static>)> {
    vec![
        ("width", Variant::from(width)),
        ("height", Variant::from(height)),
        ("rate", Variant::from(rate)),
        ("azimuth", Variant::from(azimuth)),
    ]
}

/// Assert `refused` is the error `reason` and its message names `limit`.
fn assert_refused(refused: Result<OwnedFd, (String, String)>, reason: &str, limit: &str) {
    let (name, message) = refused.expect_err("a stream beyond the limit was opened");
    assert_eq!(
        name,
        format!("org.hapticd.Renderer1.Error.{reason}"),
        "{message}"
    );
    assert!(message.contains(limit), "{message}");
}

/// Wait (up to `within`) until `done`.
fn wait_until(within: Duration, what: &str, mut done: impl FnMut() -> bool) {
    let started = Instant::now();
    while !done() {
        assert!(started.elapsed() < within, "never {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn an_unprivileged_user_gets_its_streams_and_no_more_however_many_connections_it_opens() {
    if !is_root() {
        eprintln!("skipped: connecting as an unprivileged user needs root");
        return;
    }
    // The shipped limits of a connection (4) and a user (8), and room for one more stream
    // of another user's in all.
    let setup = Setup::start("streams", &["--max-streams=9"]);
    let small = stream(32, 24, 1.0, 0.0);
    // A pixel rate or a frame beyond the limits is refused, whoever asks.
    let first = setup.connect_as(NOBODY);
    assert_refused(
        open_stream(&first, &stream(3840, 2160, 30.0, 0.0)),
        "PixelRateTooHigh",
        "max-pixel-rate-per-user = 124416000",
    );
    assert_refused(
        open_stream(&first, &stream(8192, 8192, 1.0, 0.0)),
        "FrameTooLarge",
        "max-frame-pixels = 8294400",
    );
    let snapshot = setup.busctl_as_nobody(&[
        "call", RENDERER, PATH, RENDERER, "Snapshot", "a{sv}", "2", "width", "u", "8192", "height",
        "u", "8192",
    ]);
    assert!(!snapshot.status.success());
    let said = String::from_utf8_lossy(&snapshot.stderr);
    assert!(said.contains("max-frame-pixels = 8294400"), "{said}");
    assert_eq!(
        setup.statistics()["streams"],
        0,
        "a refusal opened a stream"
    );
    // A connection gets four streams.
    let mut rings: Vec<OwnedFd> = (0..4)
        .map(|_| open_stream(&first, &small).unwrap())
        .collect();
    assert_refused(
        open_stream(&first, &small),
        "TooManyStreams",
        "max-streams-per-caller = 4",
    );
    // Another connection of the same user gets four more, then the user has its eight.
    let second = setup.connect_as(NOBODY);
    rings.extend((0..4).map(|_| open_stream(&second, &small).unwrap()));
    let third = setup.connect_as(NOBODY);
    assert_refused(
        open_stream(&third, &small),
        "TooManyStreams",
        "max-streams-per-user = 8",
    );
    // busctl, a connection of its own, is refused too and says why.
    let refused = setup.busctl_as_nobody(&[
        "call",
        RENDERER,
        PATH,
        RENDERER,
        "OpenFrameStream",
        "a{sv}",
        "0",
    ]);
    assert!(!refused.status.success());
    let said = String::from_utf8_lossy(&refused.stderr);
    assert!(said.contains("user 65534 has 8 streams open"), "{said}");
    // Another user gets the last stream the renderer holds in all.
    let root = setup.connect_as(0);
    rings.push(open_stream(&root, &small).unwrap());
    assert_refused(
        open_stream(&root, &small),
        "TooManyStreams",
        "max-streams = 9",
    );
    let counted = setup.statistics();
    assert_eq!(counted["streams"], 9, "{counted:?}");
    // Identical streams: one drawing for them all.
    assert_eq!(counted["drawings"], 1, "{counted:?}");
    // A connection that leaves takes its streams along: the user may open again.
    let name = first.unique_name().unwrap().to_string();
    drop(first);
    wait_until(Duration::from_secs(10), "left the bus", || {
        let asked = zbus::block_on(root.call_method(
            Some("org.freedesktop.DBus"),
            "/org/freedesktop/DBus",
            Some("org.freedesktop.DBus"),
            "NameHasOwner",
            &(name.as_str(),),
        ));
        !asked.unwrap().body().deserialize::<bool>().unwrap()
    });
    rings.push(open_stream(&third, &small).unwrap());
    assert_eq!(setup.statistics()["streams"], 6);
}

/// The identity of the file behind `fd`.
fn file_of(fd: &OwnedFd) -> (u64, u64) {
    let stat = nix::sys::stat::fstat(fd).unwrap();
    (stat.st_dev, stat.st_ino)
}

#[test]
fn identical_streams_of_several_callers_are_drawn_once() {
    if !is_root() {
        eprintln!("skipped: connecting as an unprivileged user needs root");
        return;
    }
    let setup = Setup::start("shared", &[]);
    let options = stream(64, 48, 20.0, 0.3);
    let viewers = [
        setup.connect_as(NOBODY),
        setup.connect_as(NOBODY),
        setup.connect_as(0),
    ];
    let rings: Vec<OwnedFd> = viewers
        .iter()
        .map(|v| open_stream(v, &options).unwrap())
        .collect();
    // One ring, handed to each of them.
    assert!(rings.iter().all(|r| file_of(r) == file_of(&rings[0])));
    let ring = FrameRingReader::open(&rings[0]).unwrap();
    wait_until(Duration::from_secs(20), "drew 10 frames", || {
        ring.latest() >= 10
    });
    let before = ring.latest();
    let counted = setup.statistics();
    let after = ring.latest();
    // Drawn three times, the frames would be three times the ring's.
    assert!(
        (before - 1..=after + 1).contains(&counted["frames_drawn"]),
        "{counted:?}, ring at {before}..{after}"
    );
    assert_eq!((counted["streams"], counted["drawings"]), (3, 1));
    assert_eq!(
        counted["pixel_rate"],
        320 * 240 * 20,
        "a small frame's floor"
    );
    // Another camera is another drawing.
    let other = open_stream(&viewers[0], &stream(64, 48, 20.0, 0.4)).unwrap();
    assert_ne!(file_of(&other), file_of(&rings[0]));
    assert_eq!(setup.statistics()["drawings"], 2);
}

#[test]
fn a_snapshot_goes_before_the_streams_of_a_caller_that_fills_the_drawing_thread() {
    if !is_root() {
        eprintln!("skipped: connecting as an unprivileged user needs root");
        return;
    }
    // Pixel rates without limit, so that one caller's four streams ask for more than the
    // thread can draw (four different pictures of 1280 × 720 at 120 frames a second).
    let unlimited = [
        "--max-pixel-rate-per-user=1000000000000",
        "--max-pixel-rate=1000000000000",
    ];
    let setup = Setup::start("fair", &unlimited);
    let hog = setup.connect_as(NOBODY);
    let rings: Vec<OwnedFd> = (0..4)
        .map(|k| open_stream(&hog, &stream(1280, 720, 120.0, 0.2 * k as f64)).unwrap())
        .collect();
    assert_refused(
        open_stream(&hog, &stream(1280, 720, 120.0, 1.0)),
        "TooManyStreams",
        "max-streams-per-caller = 4",
    );
    let ring = FrameRingReader::open(&rings[0]).unwrap();
    wait_until(Duration::from_secs(30), "drew a frame", || {
        ring.latest() > 0
    });
    // The thread is overloaded: its frames come late.
    wait_until(Duration::from_secs(30), "fell behind", || {
        setup.statistics()["frames_late"] >= 8
    });
    let viewer = setup.connect_as(0);
    for k in 0..6 {
        let options = HashMap::from([
            ("width", Variant::from(160u32)),
            ("height", Variant::from(120u32)),
        ]);
        let started = Instant::now();
        let reply = zbus::block_on(viewer.call_method(
            Some(RENDERER),
            PATH,
            Some(RENDERER),
            "Snapshot",
            &(options,),
        ));
        let png: Vec<u8> = reply.unwrap().body().deserialize().unwrap();
        assert!(png.starts_with(b"\x89PNG"), "snapshot {k}");
        // Loose: a frame of the streams and the snapshot on a busy debug build.
        assert!(started.elapsed() < Duration::from_secs(5), "snapshot {k}");
    }
    let counted = setup.statistics();
    assert_eq!(counted["snapshots"], 6, "{counted:?}");
    // Each snapshot waited at most for the frame being drawn when it came; drawn after
    // every due stream frame, it would wait for up to three more.
    assert!(counted["snapshot_wait_frames_max"] <= 1, "{counted:?}");
    assert!(counted["frames_late"] >= 8, "{counted:?}");
}
