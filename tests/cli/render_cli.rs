//! `hapticctl render` on the machine's Vulkan device (Mesa's lavapipe in CI): every shipped
//! scene against its golden picture, and pictures that must show what moved.
//!
//! Goldens are 320 × 240 and compared within 2 levels per channel (lavapipe draws the same
//! bytes on every run; the margin covers another CPU's rounding). A mismatch leaves the
//! actual picture and the difference in `target/tmp/`. `HAPTICD_BLESS=1` rewrites the
//! goldens from the current drawing.

use crate::support;

use std::path::{Path, PathBuf};

use hapticd_render::picture::Picture;
use support::{hapticctl, repo_dir, scratch_root};

fn read_png(path: &Path) -> Picture {
    Picture::read_png(path).unwrap()
}

fn write_png(path: &Path, picture: &Picture) {
    picture.write_png(path).unwrap();
}

/// The shipped mechanisms, staged as an install would have them.
fn mechanisms() -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = scratch_root().join(format!("render-mechanisms-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
        for krate in ["hapticd-spidar", "hapticd-spidar-g", "hapticd-spidar-ii"] {
            let plugin = support::plugin_path(krate);
            std::fs::copy(&plugin, dir.join(plugin.file_name().unwrap())).unwrap();
        }
        let yaml = repo_dir().join("config/mechanisms/spidar-6s.yaml");
        std::fs::copy(yaml, dir.join("spidar-6s.yaml")).unwrap();
        dir
    })
    .clone()
}

/// Render `scene` (a file of config/scenes) to a scratch PNG with `extra` arguments.
fn render(scene: &str, name: &str, extra: &[&str]) -> PathBuf {
    let out = scratch_root().join(format!("render-{name}.png"));
    let output = hapticctl()
        .arg("--mechanism-dir")
        .arg(mechanisms())
        .arg("render")
        .arg(repo_dir().join("config/scenes").join(scene))
        .arg("--out")
        .arg(&out)
        .args(extra)
        .output()
        .unwrap();
    support::succeeded(output);
    out
}

#[test]
fn every_shipped_scene_and_mechanism_matches_its_golden_picture() {
    let mut scenes: Vec<String> = std::fs::read_dir(repo_dir().join("config/scenes"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".yaml"))
        .collect();
    scenes.sort();
    assert!(scenes.len() >= 9, "{scenes:?}");
    // Each scene, then the strings of each mechanism over the static scene, one grip
    // pulled up and to the right so that their colours differ.
    let mut pictures: Vec<(String, String, Vec<&str>)> = scenes
        .iter()
        .map(|s| (s.clone(), s.trim_end_matches(".yaml").to_string(), vec![]))
        .collect();
    for mechanism in ["spidar", "spidar-g", "spidar-ii", "spidar-6s"] {
        pictures.push((
            "static.yaml".into(),
            format!("strings-{mechanism}"),
            vec!["--mechanism", mechanism, "--force", "4,6,0"],
        ));
    }
    let bless = std::env::var_os("HAPTICD_BLESS").is_some();
    let mut failures = Vec::new();
    for (scene, name, extra) in &pictures {
        let name = name.as_str();
        let mut args = vec!["--width", "320", "--height", "240"];
        args.extend(extra);
        let actual = read_png(&render(scene, name, &args));
        let golden_path = repo_dir().join(format!("tests/golden/{name}.png"));
        if bless {
            write_png(&golden_path, &actual);
            continue;
        }
        let golden = read_png(&golden_path);
        assert_eq!((actual.width, actual.height), (320, 240), "{name}");
        let diff: Vec<u8> = actual
            .rgba
            .iter()
            .zip(&golden.rgba)
            .map(|(a, g)| a.abs_diff(*g))
            .collect();
        let worst = diff.iter().copied().max().unwrap_or(0);
        if worst > 2 || golden.rgba.len() != actual.rgba.len() {
            // The difference, opaque and scaled so one level shows.
            let shown: Vec<u8> = diff
                .chunks(4)
                .flat_map(|p| {
                    let d = p[..3].iter().copied().max().unwrap().saturating_mul(16);
                    [d, d, d, 255]
                })
                .collect();
            let dir = scratch_root();
            write_png(&dir.join(format!("render-{name}-actual.png")), &actual);
            write_png(
                &dir.join(format!("render-{name}-difference.png")),
                &Picture {
                    rgba: shown,
                    ..golden
                },
            );
            failures.push(format!(
                "{name}: off by up to {worst} (see {})",
                dir.display()
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The share of the picture's rows, top to bottom, at which its blue pixels lie on average;
/// None when there are hardly any.
fn mean_blue_row(image: &Picture) -> Option<f64> {
    let (mut sum, mut count) = (0.0, 0usize);
    for (k, p) in image.rgba.chunks(4).enumerate() {
        let (r, g, b) = (i32::from(p[0]), i32::from(p[1]), i32::from(p[2]));
        if b > r + 60 && b > g + 30 {
            sum += (k as u32 / image.width) as f64;
            count += 1;
        }
    }
    (count > 50).then(|| sum / count as f64 / f64::from(image.height))
}

/// The dropped cube of thesis Fig. 5.12, drawn at its start and after a second: lower in
/// the picture once it has fallen.
#[test]
fn a_dropped_cube_is_drawn_lower_after_it_falls() {
    let before = read_png(&render("cube-drop.yaml", "drop-0", &[]));
    let after = read_png(&render("cube-drop.yaml", "drop-1", &["--at", "1"]));
    // The cube is the scenery's second colour, blue; nothing else is.
    let (high, low) = (mean_blue_row(&before), mean_blue_row(&after));
    let (Some(high), Some(low)) = (high, low) else {
        panic!("the cube is not in the picture: {high:?} {low:?}");
    };
    assert!(low > high + 0.05, "before at {high:.3}, after at {low:.3}");
}

/// SPIDAR-G drawn over the blocks: pulled upward, its upper strings carry more tension and
/// turn from blue toward red; nothing else changes.
#[test]
fn a_strings_colour_follows_its_tension() {
    let dir = mechanisms();
    let draw = |force: &str| {
        let out = scratch_root().join(format!("render-strings-{force}.png"));
        let output = hapticctl()
            .arg("--mechanism-dir")
            .arg(&dir)
            .arg("render")
            .arg(repo_dir().join("config/scenes/blocks.yaml"))
            .args(["--mechanism", "spidar-g", "--force", force, "--out"])
            .arg(&out)
            .output()
            .unwrap();
        support::succeeded(output);
        read_png(&out)
    };
    let (slack, pulled) = (draw("0,0,0"), draw("0,15,0"));
    // Red less blue, over the pixels that differ.
    let (mut before, mut after, mut count) = (0i64, 0i64, 0i64);
    for (a, b) in slack.rgba.chunks(4).zip(pulled.rgba.chunks(4)) {
        if a != b {
            before += i64::from(a[0]) - i64::from(a[2]);
            after += i64::from(b[0]) - i64::from(b[2]);
            count += 1;
        }
    }
    assert!(count > 100, "only {count} pixels changed");
    assert!(
        after > before + 30 * count,
        "red less blue {} before, {} after, over {count} pixels",
        before / count,
        after / count
    );
}

#[test]
fn bad_render_options_are_refused() {
    for (scene, args) in [
        ("blocks.yaml", vec!["--width", "0"]),
        ("blocks.yaml", vec!["--height", "100000"]),
        ("blocks.yaml", vec!["--at", "NaN"]),
        ("blocks.yaml", vec!["--at", "-1"]),
        // A static scene does not move.
        ("static.yaml", vec!["--at", "1"]),
        // A force needs a mechanism to present it.
        ("static.yaml", vec!["--force", "1,0,0"]),
    ] {
        let output = hapticctl()
            .arg("render")
            .arg(repo_dir().join("config/scenes").join(scene))
            .args(["--out", "/nonexistent/x.png"])
            .args(&args)
            .output()
            .unwrap();
        assert_eq!(output.status.code(), Some(2), "{scene} {args:?}");
    }
}

/// With no Vulkan driver to be found, render says so and writes nothing.
#[test]
fn without_a_vulkan_driver_render_says_why_and_writes_nothing() {
    let out = scratch_root().join(format!("render-no-driver-{}.png", std::process::id()));
    let output = hapticctl()
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .arg("render")
        .arg(repo_dir().join("config/scenes/static.yaml"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("cannot render") && stderr.contains("Vulkan"),
        "{stderr}"
    );
    assert!(!out.exists());
}

/// Without a display `view` says what to set (and how to get a picture instead), before it
/// asks a renderer for anything, and names no place in a library's source.
#[test]
fn without_a_display_view_says_what_to_set() {
    let out = hapticctl()
        .args(["--bus", "unix:path=/nonexistent/bus", "view"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("no display to open a window on: set WAYLAND_DISPLAY or DISPLAY"),
        "{stderr}"
    );
    assert!(!stderr.contains(".rs:"), "{stderr}");
}

/// A scene file given by its bare name, from its own directory, as a user there types it:
/// its mesh (the bracket, drawn in the scenery's blue) is found beside it and drawn.
#[test]
fn a_scene_given_by_its_bare_name_draws_its_meshes() {
    let dir = support::dir_with_mesh(
        "render-bare",
        "config/scenes/meshes/bracket.obj",
        "bracket.obj",
    );
    std::fs::write(
        dir.join("my.yaml"),
        "name: my\nshapes:\n  - floor: { height: -0.05 }\n  - mesh: { file: bracket.obj, centre: [0, -0.02, 0] }\n",
    )
    .unwrap();
    let output = hapticctl()
        .current_dir(&dir)
        .args(["render", "my.yaml", "--out", "my.png"])
        .output()
        .unwrap();
    support::succeeded(output);
    let picture = read_png(&dir.join("my.png"));
    assert!(
        mean_blue_row(&picture).is_some(),
        "the bracket is not in the picture"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A scene of fixed solids alone (a public model, the open Utah teapot, on a table) is
/// framed on the model: the fingertip, which used to be the only thing framed (a close-up
/// of a yellow ball), is a speck, and the model fills the middle of the picture.
#[test]
fn a_scene_of_fixed_solids_frames_the_model_not_the_fingertip() {
    let dir = support::dir_with_mesh("render-fixed", "tests/corpus/teapot.obj", "teapot.obj");
    std::fs::write(
        dir.join("pot.yaml"),
        "name: pot\nengine: rapier\nrate: 100\nmaterial: { static_friction: 0.5, friction: 0.4 }\n\
         bodies:\n\
         \x20 - { name: table, box: [0.4, 0.02, 0.4], position: [0, -0.04, 0], fixed: true }\n\
         \x20 - { name: pot, mesh: teapot.obj, scale: 0.003, position: [0, -0.00637, 0], fixed: true }\n\
         pointer: { sphere: 0.005 }\n",
    )
    .unwrap();
    let out = dir.join("pot.png");
    let output = hapticctl()
        .arg("render")
        .arg(dir.join("pot.yaml"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    support::succeeded(output);
    let picture = read_png(&out);
    let pixels = picture.rgba.len() / 4;
    let yellow = picture
        .rgba
        .chunks(4)
        .filter(|p| p[0] > 180 && p[1] > 150 && p[2] < 110)
        .count();
    assert!(
        yellow * 100 < pixels,
        "the fingertip fills {yellow} of {pixels} pixels"
    );
    // The teapot's shaded body is darker than the table's lit top: its darkest pixels sit
    // in the middle third of the picture, where a framed model is.
    let (w, h) = (picture.width as usize, picture.height as usize);
    let dark: Vec<(usize, usize)> = picture
        .rgba
        .chunks(4)
        .enumerate()
        .filter(|(_, p)| p[0] < 90 && p[1] < 90 && p[2] < 100)
        .map(|(k, _)| (k % w, k / w))
        .collect();
    assert!(dark.len() * 50 > pixels, "{} dark pixels", dark.len());
    let (mx, my) = dark.iter().fold((0, 0), |(x, y), p| (x + p.0, y + p.1));
    let (mx, my) = (mx / dark.len(), my / dark.len());
    assert!(
        (w / 3..2 * w / 3).contains(&mx) && (h / 3..2 * h / 3).contains(&my),
        "{mx}, {my}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
