//! The renderer on the bus: snapshots, a renderer killed and back, no Vulkan driver, and
//! hapticctl view on X11.

use super::*;

/// Share of `picture`'s pixels that are not the sky it is drawn over.
fn drawn_share(picture: &Picture) -> f64 {
    let sky = [237, 242, 250];
    let drawn = picture
        .rgba
        .chunks(4)
        .filter(|p| {
            p[..3]
                .iter()
                .zip(sky)
                .any(|(&c, s): (&u8, i32)| (i32::from(c) - s).abs() > 8)
        })
        .count();
    drawn as f64 / (picture.rgba.len() / 4) as f64
}

#[test]
fn a_snapshot_is_a_picture_of_the_running_scene_and_bad_options_are_refused() {
    let dir = support::shared_scratch("dbus", "snapshot");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g", "--scene", "blocks"]);
    let _renderer = Renderer::start(&bus, &dir, &[]);
    assert_eq!(bus.get(PICTURES, "Available"), "b true");
    assert!(bus.get(PICTURES, "Driver").len() > 4);
    assert_eq!(bus.get(PICTURES, "UnavailableReason"), "s \"\"");
    assert!(
        bus.get(MANAGER, "ActiveSceneFile")
            .ends_with("config/scenes/blocks.yaml\""),
        "{}",
        bus.get(MANAGER, "ActiveSceneFile")
    );
    let picture = bus
        .snapshot(&["width", "u", "320", "height", "u", "240"])
        .unwrap();
    assert_eq!((picture.width, picture.height), (320, 240));
    let drawn = drawn_share(&picture);
    assert!((0.2..0.95).contains(&drawn), "{drawn} of the picture drawn");
    // Seen from the other side the scene is another picture; the defaults are 640 × 480.
    let behind = bus.snapshot(&["azimuth", "d", "3.6"]).unwrap();
    assert_eq!((behind.width, behind.height), (640, 480));
    // hapticctl asks the same renderer.
    let file = dir.join("snapshot.png");
    let out = hapticctl()
        .arg(format!("--bus={}", bus.address))
        .args(["snapshot", "--width", "200", "--height", "100"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let written = Picture::read_png(&file).unwrap();
    assert_eq!((written.width, written.height), (200, 100));
    use zbus::Variant;
    for (key, value, error) in [
        ("width", Variant::from(0u32), "OutOfRange"),
        ("height", Variant::from(100_000u32), "OutOfRange"),
        ("distance", Variant::from(f64::NAN), "NotFinite"),
        ("azimuth", Variant::from(f64::INFINITY), "NotFinite"),
        (
            "target",
            Variant::from(vec![0.0, f64::NAN, 0.0]),
            "NotFinite",
        ),
        ("zoom", Variant::from(2.0), "InvalidOption"),
        ("width", Variant::from("wide"), "InvalidOption"),
    ] {
        let (name, message) = bus.snapshot_error(&[(key, value)]);
        assert_eq!(
            name,
            format!("org.hapticd.Renderer1.Error.{error}"),
            "{key}: {message}"
        );
        assert!(message.contains(key), "{message}");
    }
    // A camera aimed far off sees sky; a target of two numbers is refused by the renderer.
    let aimed = dir.join("aimed.png");
    let out = hapticctl()
        .arg(format!("--bus={}", bus.address))
        .args([
            "snapshot", "--width", "200", "--height", "100", "--target", "0,60,-60",
        ])
        .arg(&aimed)
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let (here, away) = (
        drawn_share(&written),
        drawn_share(&Picture::read_png(&aimed).unwrap()),
    );
    assert!(
        away < 0.5 * here,
        "drawn {here} at the scene, {away} aimed away"
    );
    let two = hapticctl()
        .arg(format!("--bus={}", bus.address))
        .args(["snapshot", "--target", "1,2"])
        .arg(dir.join("none.png"))
        .output()
        .unwrap();
    assert_eq!(two.status.code(), Some(2), "{two:?}");
    assert!(String::from_utf8_lossy(&two.stderr).contains("target is three numbers"));
    for args in [&["--width", "0"][..], &["--distance", "-1"]] {
        let refused = hapticctl()
            .arg(format!("--bus={}", bus.address))
            .arg("snapshot")
            .args(args)
            .arg(dir.join("none.png"))
            .output()
            .unwrap();
        assert_eq!(refused.status.code(), Some(2), "{refused:?}");
        // The renderer's reason, not the argument parser's.
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(stderr.contains("OutOfRange"), "{args:?}: {stderr}");
        assert!(!dir.join("none.png").exists());
    }
}

#[test]
fn a_renderer_killed_comes_back_and_the_haptic_loop_never_notices() {
    let unit = std::fs::read_to_string(repo_dir().join("systemd/hapticd-render.service")).unwrap();
    assert!(
        unit.contains("\nRestart=always\n"),
        "systemd brings it back"
    );
    let dir = support::shared_scratch("dbus", "kill-renderer");
    // It counts overruns: no other test's daemons run meanwhile.
    let bus = Bus::start_alone(&dir);
    let setup = Setup::new(&dir);
    // The static scene: a debug build's tick leaves room for the machine's own hiccups.
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let _off = support::haptic_cpu::KeptOff::new();
    // The loop's own: a kill that disturbed the loop would make its ticks compute too long,
    // where the host's stalls only wake them late (one such stall, 1.4 ms, cost a kill's
    // window 8 overruns).
    let overruns = || own_overruns(&bus);
    let ticks = || entry(&bus.get(DEVICE, "Statistics"), "ticks");
    let mut renderer = Renderer::start(&bus, &dir, &[]);
    // A viewer's stream keeps the renderer drawing when it is killed.
    let (_viewer, ring) = stream_frames(&bus);
    let started = Instant::now();
    while ring.latest() < 10 {
        assert!(
            started.elapsed() < Duration::from_secs(10),
            "no frames drawn"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    bus.snapshot(&[]).unwrap();
    // Statistics reach the bus at 10 Hz: count from a snapshot no older than this moment.
    std::thread::sleep(Duration::from_millis(300));
    // What the machine alone costs the loop in a window as long as the kill's (a virtual
    // machine's host steals ticks now and then, in bursts): the worst of six windows before
    // the kill. Statistics reach the bus up to 0.2 s late, so each window is read that much
    // after its end: overruns the kill caused late in its window are its own, not the
    // next window's.
    const WINDOW: Duration = Duration::from_millis(350);
    const LATE: Duration = Duration::from_millis(250);
    let window = || {
        let from = overruns();
        std::thread::sleep(WINDOW + LATE);
        overruns() - from
    };
    let quiet: Vec<f64> = (0..6).map(|_| window()).collect();
    let worst = quiet.iter().copied().fold(0.0, f64::max);
    let (before, ticked) = (overruns(), ticks());
    let force = bus.get(DEVICE, "Force");
    renderer.kill_9();
    let error = bus.snapshot(&[]).unwrap_err();
    assert!(error.contains("org.hapticd.Renderer1"), "{error}");
    std::thread::sleep(WINDOW + LATE);
    assert!(ticks() > ticked, "the loop stopped");
    let during = overruns() - before;
    assert_eq!(bus.get(DEVICE, "State"), "s \"running\"");
    assert_eq!(bus.get(DEVICE, "Force"), force, "the force changed");
    println!("overruns: {during} while the renderer died, {quiet:?} in windows before");
    // A kill that disturbed the loop would cost ticks beyond the machine's own worst. The
    // bound is not zero because windows in which nothing happens lose ticks too: measured
    // with the test's load off the haptic CPU, 0 to 2 overruns in each of 18 quiet windows
    // of three runs (and 0, 1, 0 in their kills' windows).
    assert!(
        during <= 2.0 * worst + 2.0,
        "{during} overruns while the renderer died, {quiet:?} in windows without: {}",
        daemon.log()
    );
    // Started again as systemd's Restart= does: it finds hapticd's world by itself.
    let _again = Renderer::start(&bus, &dir, &[]);
    let picture = bus
        .snapshot(&["width", "u", "64", "height", "u", "48"])
        .unwrap();
    assert_eq!((picture.width, picture.height), (64, 48));
    assert_eq!(bus.get(DEVICE, "State"), "s \"running\"");
}

#[test]
fn without_a_vulkan_driver_the_renderer_says_why_once_and_hapticd_runs_on() {
    let dir = support::shared_scratch("dbus", "no-driver");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let none = "/nonexistent/icd.json";
    let renderer = Renderer::start(
        &bus,
        &dir,
        &[("VK_DRIVER_FILES", none), ("VK_ICD_FILENAMES", none)],
    );
    assert_eq!(bus.get(PICTURES, "Available"), "b false");
    assert_eq!(bus.get(PICTURES, "Driver"), "s \"\"");
    assert!(bus.get(PICTURES, "UnavailableReason").len() > 10);
    for _ in 0..3 {
        let (name, _) = bus.snapshot_error(&[]);
        assert_eq!(name, "org.hapticd.Renderer1.Error.Unavailable");
    }
    let log = renderer.log();
    assert_eq!(
        log.matches("no pictures on this machine").count(),
        1,
        "{log}"
    );
    assert_eq!(bus.get(DEVICE, "State"), "s \"running\"");
}

/// An X server without a screen (Xvfb) whose framebuffer is a file to read screenshots
/// from; stopped when dropped.
struct Xvfb {
    child: Child,
    display: String,
    framebuffer: PathBuf,
}

impl Xvfb {
    /// A `width × height` screen.
    fn start(dir: &Path, width: u32, height: u32) -> Xvfb {
        let fbdir = dir.join("xvfb");
        std::fs::create_dir_all(&fbdir).unwrap();
        // A display number of this process's own (a few, for its tests at once), clear of a
        // desktop's :0 and :1.
        static STARTED: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let nth = STARTED.fetch_add(1, std::sync::atomic::Ordering::Relaxed) % 8;
        let display = format!(":{}", 100 + (std::process::id() % 5_000) * 8 + nth);
        let child = Command::new("Xvfb")
            .arg(&display)
            .args([
                "-screen",
                "0",
                &format!("{width}x{height}x24"),
                "-nolisten",
                "tcp",
            ])
            .arg("-fbdir")
            .arg(&fbdir)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb (package xvfb) is installed by `make check`");
        let framebuffer = fbdir.join("Xvfb_screen0");
        // Xvfb makes the file before it writes the XWD header into it: wait for the header's
        // bits per pixel (its twelfth word), not for the file alone.
        let written = |file: &Path| {
            std::fs::read(file)
                .is_ok_and(|bytes| bytes.len() >= 48 && bytes[44..48] != [0, 0, 0, 0])
        };
        let started = Instant::now();
        while !written(&framebuffer) {
            assert!(
                started.elapsed() < Duration::from_secs(10),
                "Xvfb did not start"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        Xvfb {
            child,
            display,
            framebuffer,
        }
    }

    /// The screen now, from the XWD file Xvfb keeps it in (32-bit pixels, masks in the
    /// header).
    fn screenshot(&self) -> Picture {
        let file = std::fs::read(&self.framebuffer).unwrap();
        let word = |k: usize| u32::from_be_bytes(file[4 * k..4 * k + 4].try_into().unwrap());
        let (header, width, height) = (word(0) as usize, word(4), word(5));
        let (little_endian, bits, stride) = (word(7) == 0, word(11), word(12) as usize);
        let masks = [word(14), word(15), word(16)];
        let colours = word(19) as usize;
        assert_eq!(bits, 32, "a 24-bit screen keeps 32-bit pixels");
        let pixels = &file[header + 12 * colours..];
        let mut rgba = Vec::with_capacity((width * height * 4) as usize);
        for y in 0..height as usize {
            for x in 0..width as usize {
                let bytes: [u8; 4] = pixels[y * stride + 4 * x..][..4].try_into().unwrap();
                let value = if little_endian {
                    u32::from_le_bytes(bytes)
                } else {
                    u32::from_be_bytes(bytes)
                };
                for mask in masks {
                    rgba.push(((value & mask) >> mask.trailing_zeros()) as u8);
                }
                rgba.push(255);
            }
        }
        Picture {
            width,
            height,
            rgba,
        }
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        // Asked to stop, not killed: it then removes its lock file and socket from /tmp.
        let pid = nix::unistd::Pid::from_raw(self.child.id() as i32);
        let _ = nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM);
        let _ = self.child.wait();
    }
}

/// `view --fullscreen` fills the screen even where no window manager runs (a kiosk's bare X
/// server): the frames, scaled, reach its far corner.
#[test]
fn hapticctl_view_fills_a_screen_without_a_window_manager() {
    let dir = support::shared_scratch("dbus", "view-fullscreen");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let _renderer = Renderer::start(&bus, &dir, &[]);
    let screen = Xvfb::start(&dir, 640, 480);
    let mut viewer = hapticctl()
        .arg(format!("--bus={}", bus.address))
        .args(["view", "--fullscreen", "--width", "160", "--height", "120"])
        .env("DISPLAY", &screen.display)
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Share of the bottom-right quarter of the screen (outside a window of the frames' own
    // size) that is still the bare screen's black.
    let black_corner = |shot: &Picture| {
        let (w, h) = (shot.width as usize, shot.height as usize);
        let corner: Vec<&[u8]> = shot
            .rgba
            .chunks(4)
            .enumerate()
            .filter(|(i, _)| i % w >= w / 2 && i / w >= h / 2)
            .map(|(_, p)| p)
            .collect();
        let black = corner.iter().filter(|p| p[..3] == [0, 0, 0]).count();
        black as f64 / corner.len() as f64
    };
    let started = Instant::now();
    while black_corner(&screen.screenshot()) > 0.5 {
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "the window never reached the screen's far corner"
        );
        assert!(
            viewer.try_wait().unwrap().is_none(),
            "hapticctl view exited"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    let _ = viewer.kill();
    let _ = viewer.wait();
}

#[test]
fn hapticctl_view_shows_the_daemons_frames_in_an_x11_window() {
    let dir = support::shared_scratch("dbus", "view");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    // The static scene with the grip at rest: every frame is the same but for the clock.
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let mut renderer = Renderer::start(&bus, &dir, &[]);
    let (width, height) = (320, 240);
    let screen = Xvfb::start(&dir, width, height);
    let mut viewer = hapticctl()
        .arg(format!("--bus={}", bus.address))
        .args(["view", "--width", "320", "--height", "240"])
        .env("DISPLAY", &screen.display)
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let mut shot = screen.screenshot();
    while !(0.2..0.95).contains(&drawn_share(&shot)) {
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "the window never showed the scene ({} drawn)",
            drawn_share(&shot)
        );
        assert!(
            viewer.try_wait().unwrap().is_none(),
            "hapticctl view exited"
        );
        std::thread::sleep(Duration::from_millis(100));
        shot = screen.screenshot();
    }
    let snapshot = bus
        .snapshot(&["width", "u", "320", "height", "u", "240"])
        .unwrap();
    // Above the status line (whose clock moves on) the window shows what Snapshot draws.
    let band = 15 * width as usize * 4;
    let above = shot.rgba.len() - band;
    let worst = |shot: &Picture, expected: &dyn Fn(u8) -> u8, rows: std::ops::Range<usize>| {
        // Colours only: the window has no alpha to show.
        shot.rgba[rows.clone()]
            .chunks(4)
            .zip(snapshot.rgba[rows].chunks(4))
            .flat_map(|(a, b)| (0..3).map(move |k| a[k].abs_diff(expected(b[k]))))
            .max()
            .unwrap()
    };
    let same = worst(&shot, &|c| c, 0..above);
    assert!(same <= 2, "the window differs from Snapshot by {same} LSB");
    // SPIDAR-G's eight strings, at their least tension, are drawn in the tension palette's
    // blue, which nothing else in the static scene is.
    let blue = snapshot
        .rgba
        .chunks(4)
        .filter(|p| {
            i32::from(p[2]) > i32::from(p[0]) + 80 && i32::from(p[2]) > i32::from(p[1]) + 60
        })
        .count();
    assert!(blue > 50, "the strings are not drawn ({blue} blue pixels)");
    // With the renderer gone, the last frame stays, dimmed, its age written over it.
    let _ = renderer.child.kill();
    let _ = renderer.child.wait();
    std::thread::sleep(Duration::from_millis(1500));
    let stale = screen.screenshot();
    let _ = viewer.kill();
    let _ = viewer.wait();
    let dimmed = worst(&stale, &|c| c / 2 + 64, band..above);
    assert!(
        dimmed <= 2,
        "the stale frame is not dimmed ({dimmed} LSB off)"
    );
    let letters = stale.rgba[..band]
        .chunks(4)
        .filter(|p| p[..3] == [255, 255, 255])
        .count();
    assert!(letters > 50, "no note over the stale frame");
    let line = |p: &Picture| {
        drawn_share(&Picture {
            width,
            height: 13,
            rgba: p.rgba[above..].to_vec(),
        })
    };
    assert!(line(&shot) > 0.3, "no status line in the window");
}

/// The shipped jelly pressed by the simulated hand's fingertip (a ball of 8 mm radius
/// lowered from above its top at y = -0.01 to 2 mm into where the top stood; the hand gives
/// as the jelly pushes back): the world the daemon shares holds its surface's corners where
/// they stand, the one under the finger's middle on the finger's solid, the block's far
/// ends where they stood; and the renderer draws it from them. Over the bus the jelly is
/// a body after the table, its state its centre of mass and its mass.
#[test]
fn a_soft_body_pressed_by_the_hand_is_shared_and_drawn_as_it_bends() {
    use hapticd_ipc::proxies::DeviceProxy;
    use hapticd_ipc::world_share::MappedWorld;
    let dir = support::shared_scratch("dbus", "soft");
    let hand = dir.join("press-jelly.yaml");
    std::fs::write(
        &hand,
        "hands:\n  grip:\n    - hold: { seconds: 0.3 }\n    - move: { to: [0, -0.012, 0], \
         seconds: 0.5 }\n    - hold: { seconds: 30 }\n",
    )
    .unwrap();
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let hand = hand.to_str().unwrap();
    let _daemon = Hapticd::start(
        &bus,
        &setup,
        &["--sim", "spidar-g", "--scene", "jelly", "--hand", hand],
    );
    let _renderer = Renderer::start(&bus, &dir, &[]);
    let connection = bus.connect();
    let (rest, moved, finger) = zbus::block_on(async {
        let device = DeviceProxy::builder(&connection)
            .path(hapticd_ipc::device_path(0))
            .build()
            .await
            .unwrap();
        let (fd, _) = device.open_geometry().await.unwrap();
        let (_, geometry) = hapticd_ipc::geometry_share::read(&fd.into()).unwrap();
        let world = MappedWorld::open(&device.open_world().await.unwrap().into()).unwrap();
        let mut frame = Box::new(hapticd_core::world_state::WorldFrame::empty());
        // Pressed from 0.8 s on; settled well before 2 s.
        while world.read(&mut frame).is_none_or(|_| frame.time < 2.0) {
            std::thread::sleep(Duration::from_millis(50));
        }
        let deforming: Vec<_> = geometry
            .solids
            .iter()
            .filter(|s| s.flags & hapticd_plugin_api::HAPTICD_SOLID_DEFORMING != 0)
            .collect();
        assert_eq!(deforming.len(), 1, "{:?}", geometry.solids);
        let rest: Vec<[f64; 3]> = geometry
            .triangles_of(deforming[0])
            .iter()
            .flat_map(|t| t.corners)
            .collect();
        // The finger's solid where it stands: its faces' outward planes.
        let finger = geometry
            .solids
            .iter()
            .find(|s| s.flags & hapticd_plugin_api::HAPTICD_SOLID_POINTER != 0)
            .unwrap();
        let at = hapticd_core::world_state::pose_of(&frame.bodies[finger.body as usize]);
        let faces: Vec<(DVec3, DVec3)> = geometry
            .triangles_of(finger)
            .iter()
            .map(|t| {
                let [a, b, c] = t.corners.map(|c| at.transform_point(DVec3::from(c)));
                ((b - a).cross(c - a).normalize(), a)
            })
            .collect();
        let renderer = hapticd_ipc::proxies::RendererProxy::new(&connection)
            .await
            .unwrap();
        let size = std::collections::HashMap::from([
            ("width", zbus::Variant::U32(160)),
            ("height", zbus::Variant::U32(120)),
        ]);
        let picture = Picture::from_png(&renderer.snapshot(size).await.unwrap()).unwrap();
        // The device's frame, the table and the jelly: 0.19 of the picture here.
        assert!(drawn_share(&picture) > 0.1, "{}", drawn_share(&picture));
        (rest, frame.deformed_corners().to_vec(), faces)
    });
    assert_eq!(moved.len(), rest.len());
    assert!(moved.iter().flatten().all(|c| c.is_finite()));
    let bodies = bus.get(SCENE, "Bodies");
    assert_eq!(bodies, "a(sb) 2 \"table\" true \"jelly\" false");
    // The jelly's 4.5 × 2.25 × 3 cm of density 1100, its centre of mass pressed down from
    // where it stood by less than a millimetre.
    let jelly = bus.drive("Body", "s", &["jelly"]).unwrap();
    assert!(
        (jelly.mass - 0.045 * 0.0225 * 0.03 * 1100.0).abs() < 1e-12,
        "{jelly:?}"
    );
    let stood = DVec3::new(0.0, -0.02125, 0.0);
    assert!(
        jelly.position.y < stood.y && (jelly.position - stood).length() < 1e-3,
        "{jelly:?}"
    );
    let middle: Vec<DVec3> = rest
        .iter()
        .zip(&moved)
        .filter(|(r, _)| r[0].abs() < 1e-6 && (r[1] + 0.01).abs() < 1e-6 && r[2].abs() < 1e-6)
        .map(|(_, m)| glam::Vec3::from(*m).as_dvec3())
        .collect();
    assert!(!middle.is_empty());
    for corner in middle {
        // Pressed, and on the finger's solid (its nearest face) within 50 µm.
        assert!(corner.y < -0.012, "{corner}");
        let outside = finger
            .iter()
            .map(|(normal, on)| normal.dot(corner - *on))
            .fold(f64::MIN, f64::max);
        assert!(
            outside.abs() < 5e-5,
            "{corner} is {outside} m off the finger"
        );
    }
    // The block's far ends, 22.5 mm from the finger's middle, stay put.
    for (r, m) in rest.iter().zip(&moved) {
        if r[0].abs() > 0.022 && (r[1] + 0.01).abs() < 1e-6 {
            let moved = (0..3).map(|i| f64::from(m[i]) - r[i]);
            let distance = moved.map(|d| d * d).sum::<f64>().sqrt();
            assert!(distance < 1e-3, "{r:?} moved {distance} m");
        }
    }
}
