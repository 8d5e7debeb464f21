//! Loading real plugins through the C ABI: the Rust plugins, the C example compiled here,
//! and every refusal the loader owes the user, each with its message.

use crate::support;

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::Command;

use glam::DVec3;
use hapticd::plugin_scene::{ExtensionFault, LoadError, SceneFault};
use hapticd_config::catalog;
use hapticd_config::plugin;
use hapticd_core::kinematics::Wrench;
use hapticd_core::solver::geometry::StringGeometry;
use hapticd_plugin_api::{HAPTICD_ABI_MAJOR, HAPTICD_ABI_MINOR};
use support::{plugin_path, repo_dir};

/// Compile C `source` into `dir/name.so` against the generated header.
fn compile_c(dir: &Path, name: &str, source: &str) -> PathBuf {
    let c_file = dir.join(format!("{name}.c"));
    std::fs::write(&c_file, source).unwrap();
    let out = dir.join(format!("{name}.so"));
    let compiler = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let status = Command::new(compiler)
        .args([
            "-shared", "-fPIC", "-O2", "-Wall", "-Wextra", "-Werror", "-std=c11", "-I",
        ])
        .arg(repo_dir().join("plugin-api/include"))
        .arg(&c_file)
        .arg("-o")
        .arg(&out)
        .status()
        .expect("a C compiler (cc) is installed");
    assert!(status.success(), "compiling {name}.c failed");
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o755)).unwrap();
    out
}

/// A minimal C plugin whose descriptor says ABI `major`.`minor`.
fn c_plugin_with_abi(major: u32, minor: u32) -> String {
    format!(
        r#"#include <stddef.h>
#include "hapticd_plugin.h"
static const HapticdPluginDescriptor d = {{ {major}, {minor}, HAPTICD_KIND_MECHANISM,
    "old", "0", "built for another ABI", NULL, NULL }};
const HapticdPluginDescriptor *hapticd_plugin_entry(const HapticdHost *h) {{ (void)h; return &d; }}
"#
    )
}

fn refusal(path: &Path) -> String {
    plugin::load(path)
        .expect_err("the plugin should be refused")
        .to_string()
}

#[test]
fn the_rust_plugins_load_with_their_descriptors() {
    for (krate, name, effectors, strings) in [
        ("hapticd-spidar", "spidar", 1, 4),
        ("hapticd-spidar-g", "spidar-g", 1, 8),
        ("hapticd-spidar-ii", "spidar-ii", 2, 8),
    ] {
        let path = plugin_path(krate);
        let loaded = plugin::load(&path).unwrap();
        assert_eq!(loaded.name, name);
        assert_eq!(loaded.version, env!("CARGO_PKG_VERSION"));
        assert_eq!(loaded.abi, (HAPTICD_ABI_MAJOR, HAPTICD_ABI_MINOR));
        assert!(loaded.is_mechanism());
        let m = catalog::load(&path).unwrap();
        assert_eq!((m.effectors.len(), m.strings.len()), (effectors, strings));
        assert!(m.warnings.is_empty(), "{name}: {:?}", m.warnings);
    }
    let g = catalog::load(&plugin_path("hapticd-spidar-g")).unwrap();
    // G6X3L: motor (0.0849, 0.076, 0) holds knot (0.0159, 0, −0.0159); motors 4–7 mirror 0–3 in y.
    assert_eq!(g.strings[0].motor, DVec3::new(0.0849, 0.076, 0.0));
    assert_eq!(g.strings[0].knot, DVec3::new(0.0159, 0.0, -0.0159));
    for i in 0..4 {
        assert_eq!(
            g.strings[i + 4].motor,
            g.strings[i].motor * DVec3::new(1.0, -1.0, 1.0)
        );
    }
    // SPIDAR-II: the two fingers use complementary corners of the 0.53 m cube.
    let ii = catalog::load(&plugin_path("hapticd-spidar-ii")).unwrap();
    for i in 0..4 {
        assert_eq!(ii.strings[i + 4].motor, -ii.strings[i].motor);
        assert_eq!(ii.strings[i].motor.abs(), DVec3::splat(0.265));
    }
}

#[test]
fn the_c_example_plugin_compiles_loads_and_solves() {
    let dir = support::scratch("plugin-test", "c-example");
    let source =
        std::fs::read_to_string(repo_dir().join("plugins/c-example/spidar_desk.c")).unwrap();
    let path = compile_c(&dir, "libspidar_desk", &source);
    let loaded = plugin::load(&path).unwrap();
    assert_eq!(
        (loaded.name.as_str(), loaded.version.as_str()),
        ("spidar-desk", "1.0.0")
    );
    let m = catalog::load(&path).unwrap();
    assert_eq!(m.effectors[0].name, "finger");
    assert_eq!(m.strings.len(), 4);
    assert_eq!(m.strings[1].motor, DVec3::new(0.15, 0.15, -0.15));
    assert_eq!(
        (m.strings[3].tension_min, m.strings[3].tension_max),
        (0.3, 6.0)
    );
    // The base part works on it unchanged: at the centre a small force is met exactly.
    let g = StringGeometry::at(&m.kinematics(0), &m.effectors[0].calibration);
    let solution = m
        .tension_solver(0)
        .solve(&g, &Wrench::force(-2.0 * glam::DVec3::Y));
    assert!(
        (solution.wrench.force.y + 2.0).abs() < 0.05,
        "{:?}",
        solution.wrench
    );
    // What the plugin says as it loads is for the daemon's log: hapticctl's commands print
    // their answer alone.
    for args in [
        &["mechanism", "list"][..],
        &["mechanism", "inspect", "spidar-desk"],
    ] {
        let out = support::hapticctl()
            .arg("--mechanism-dir")
            .arg(&dir)
            .args(args)
            .output()
            .unwrap();
        assert!(out.status.success(), "{args:?}: {out:?}");
        assert!(String::from_utf8_lossy(&out.stdout).contains("spidar-desk"));
        assert_eq!(String::from_utf8_lossy(&out.stderr), "", "{args:?}");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_plugin_for_another_abi_major_is_refused() {
    let dir = support::scratch("plugin-test", "abi-major");
    let path = compile_c(&dir, "old", &c_plugin_with_abi(2, 0));
    let e = refusal(&path);
    assert!(e.starts_with(&path.display().to_string()), "{e}");
    let speaks = format!("this hapticd speaks ABI {HAPTICD_ABI_MAJOR}.{HAPTICD_ABI_MINOR}");
    assert!(
        e.contains(&format!("built for plugin ABI 2.0, but {speaks}")),
        "{e}"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_plugin_for_a_newer_abi_minor_loads_and_finds_no_unknown_extension() {
    let dir = support::scratch("plugin-test", "abi-minor");
    // A plugin from a later 1.x asks for a service this host does not have, and is told so.
    let source = c_plugin_with_abi(1, 7).replace(
        "hapticd_plugin_entry(const HapticdHost *h) {",
        "hapticd_plugin_entry(const HapticdHost *h) {\n\
         if (h->abi_minor < 1 || h->get_extension == NULL) return NULL;\n\
         if (h->get_extension(h->context, \"hapticd.from-the-future/1\") != NULL) return NULL;\n",
    );
    assert!(source.contains("from-the-future"), "{source}");
    let path = compile_c(&dir, "new", &source);
    let loaded = plugin::load(&path).expect("a newer minor loads");
    assert_eq!(loaded.abi, (1, 7));
    std::fs::remove_dir_all(dir).ok();
}

/// A scene plugin built against ABI 1.1, whose vtable ends before `poses` (1.2): the host
/// reads no function past its end (here a poisoned word lies there) and runs the scene
/// with no bodies to show.
#[test]
fn a_scene_plugin_of_an_older_minor_runs_without_what_came_later() {
    let dir = support::scratch("plugin-test", "older-scene");
    let source = r#"#include <stddef.h>
#include <stdint.h>
#include "hapticd_plugin.h"
static int made;
static int32_t create(const char *path, uint32_t n, void **instance, HapticdSceneInfo *info) {
    (void)path; (void)n; *instance = &made; info->style = HAPTICD_SCENE_DIRECT; return 0;
}
static void destroy(void *instance) { (void)instance; }
static int32_t step(void *instance, double dt, const HapticdPointer *p, uint32_t n,
                    HapticdWrench *w) {
    (void)instance; (void)dt; (void)p;
    for (uint32_t k = 0; k < n; k++) { w[k] = (HapticdWrench){ { 0, 1, 0 }, { 0, 0, 0 } }; }
    return 0;
}
/* The vtable of ABI 1.1, and after it a word that is no function. */
struct Older {
    uint32_t struct_size;
    void *create, *destroy, *step_direct, *step_physics;
};
static const struct { struct Older vtable; uintptr_t poison; } table = {
    { sizeof(struct Older), (void *)create, (void *)destroy, (void *)step, NULL }, 1 };
static const HapticdPluginDescriptor d = { 1, 1, HAPTICD_KIND_SCENE, "older", "0",
    "a scene of ABI 1.1", NULL, (const HapticdSceneVtable *)&table };
const HapticdPluginDescriptor *hapticd_plugin_entry(const HapticdHost *h) { (void)h; return &d; }
"#;
    let path = compile_c(&dir, "older", source);
    let pointers = [hapticd_core::scene::Pointer {
        pose: Default::default(),
        velocity: Default::default(),
    }];
    let mut scene = hapticd::plugin_scene::load(&path, None, &pointers).unwrap();
    let mut wrenches = [Wrench::ZERO];
    assert!(scene.render(&pointers, 1e-3, &mut wrenches));
    assert_eq!(wrenches[0].force.y, 1.0);
    let mut poses = [hapticd_plugin_api::HapticdBodyPose::default(); 4];
    assert_eq!(scene.write_bodies(&mut poses), 0);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_library_without_the_entry_symbol_is_refused() {
    let dir = support::scratch("plugin-test", "no-entry");
    let path = compile_c(&dir, "plain", "int answer(void) { return 42; }\n");
    let e = refusal(&path);
    assert!(
        e.contains("not a hapticd plugin: it exports no hapticd_plugin_entry"),
        "{e}"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn an_entry_that_returns_nothing_is_refused() {
    let dir = support::scratch("plugin-test", "null-entry");
    let source = "#include \"hapticd_plugin.h\"\n#include <stddef.h>\n\
        const HapticdPluginDescriptor *hapticd_plugin_entry(const HapticdHost *h) { (void)h; return NULL; }\n";
    let path = compile_c(&dir, "null", source);
    assert!(refusal(&path).contains("returned no descriptor"));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_file_that_is_not_a_library_is_refused() {
    let dir = support::scratch("plugin-test", "not-elf");
    let path = dir.join("text.so");
    std::fs::write(&path, "not a shared object").unwrap();
    assert!(refusal(&path).contains("cannot load"));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn files_and_directories_others_could_modify_are_refused() {
    let dir = support::scratch("plugin-test", "permissions");
    let path = dir.join("libhapticd_spidar.so");
    std::fs::copy(plugin_path("hapticd-spidar"), &path).unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    assert!(plugin::check_permissions(&path).is_ok());

    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o775)).unwrap();
    let e = refusal(&path);
    assert!(
        e.contains("unsafe permissions: the file")
            && e.contains("writable by group or others (mode 0775)"),
        "{e}"
    );
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();

    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o777)).unwrap();
    let e = refusal(&path);
    assert!(
        e.contains(&format!(
            "directory {} is writable by group or others (mode 0777)",
            dir.display()
        )),
        "{e}"
    );
    // A sticky world-writable directory (like /tmp) is safe: others cannot replace entries.
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o1777)).unwrap();
    assert!(plugin::check_permissions(&path).is_ok());
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();

    if nix::unistd::geteuid().is_root() {
        nix::unistd::chown(&path, Some(nix::unistd::Uid::from_raw(65534)), None).unwrap();
        let e = refusal(&path);
        assert!(e.contains("is owned by uid 65534, not by root"), "{e}");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_panicking_plugin_is_disabled_and_the_host_lives_on() {
    let path = plugin_path("hapticd-test-panicking-mechanism");
    let loaded = plugin::load(&path).unwrap();
    let e = loaded.mechanism_spec().unwrap_err().to_string();
    assert!(
        e.contains("the plugin panicked in info(); it is disabled"),
        "{e}"
    );
    // Calling it again is answered the same way, without running the builder again.
    assert!(loaded.mechanism_spec().is_err());
    // The host is unharmed: other plugins still load and work.
    let m = catalog::load(&plugin_path("hapticd-spidar")).unwrap();
    assert_eq!(m.name, "spidar");
}

/// One pointer at the frame centre.
fn one_pointer() -> [hapticd_core::scene::Pointer; 1] {
    [hapticd_core::scene::Pointer {
        pose: Default::default(),
        velocity: Default::default(),
    }]
}

/// The physics plugins hand the host, through their geometry extension, the solids the
/// physics crate finds in their files (computed here, in this process), and pose every body.
#[test]
fn the_physics_plugins_describe_their_worlds_as_their_files_do() {
    use hapticd_physics::scene::SceneFile;
    let pointers = one_pointer();
    for (krate, file) in [
        ("hapticd-scene-penalty", "blocks"),
        ("hapticd-scene-rapier", "balls"),
    ] {
        let file = repo_dir().join(format!("config/scenes/{file}.yaml"));
        let mut scene =
            hapticd::plugin_scene::load(&plugin_path(krate), Some(&file), &pointers).unwrap();
        let expected = SceneFile::load(&file, 1).unwrap().geometry();
        assert!(!expected.solids.is_empty());
        assert_eq!(
            *scene.geometry(),
            expected,
            "{krate} with {}",
            file.display()
        );
        let mut poses = vec![hapticd_plugin_api::HapticdBodyPose::default(); 64];
        assert_eq!(scene.write_bodies(&mut poses), expected.body_count as usize);
    }
}

/// The rapier plugin hands its held peg to the host through the held extension: the host
/// builds the god-object from the plugin's surfaces and renders it in the tick, so the peg
/// lowered into its hole stands on the hole's floor, where the pictures show it, and the hand
/// feels the spring's stiffness times how far the grip went past.
#[test]
fn the_rapier_plugin_hands_its_held_peg_to_the_haptic_side() {
    use hapticd_core::kinematics::{Pose, pose_of};
    use hapticd_core::scene::Pointer;
    let file = repo_dir().join("config/scenes/peg-and-blocks.yaml");
    let grip = |y: f64| Pointer {
        pose: Pose {
            position: DVec3::new(0.0, y, 0.0),
            ..Pose::IDENTITY
        },
        velocity: DVec3::ZERO,
    };
    let mut scene = hapticd::plugin_scene::load(
        &plugin_path("hapticd-scene-rapier"),
        Some(&file),
        &[grip(0.0)],
    )
    .unwrap();
    // Down from where the peg rests, 2 cm over the block's top, to 5 mm past the hole's
    // floor (the peg's middle stops 10 mm over it, at y = -0.035), in 1 ms ticks of real
    // time (the world steps in its own thread), then held.
    let mut felt = [Wrench::ZERO];
    let (ticks, mut rendered) = (2500, 0);
    for tick in 0..ticks {
        let y = -0.04 * (tick as f64 / 1500.0).min(1.0);
        rendered += usize::from(scene.render(&[grip(y)], 1e-3, &mut felt));
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    assert!(rendered > ticks / 2, "{rendered} of {ticks} ticks rendered");
    assert!((felt[0].force.y - 2000.0 * 0.005).abs() < 0.05, "{felt:?}");
    let mut poses = vec![hapticd_plugin_api::HapticdBodyPose::default(); 8];
    let count = scene.write_bodies(&mut poses);
    let peg = pose_of(&poses[count - 1]).position;
    assert!(peg.distance(DVec3::new(0.0, -0.035, 0.0)) < 1e-5, "{peg}");
}

/// The rapier plugin says which of its pieces are exactly boxes (the held extension's
/// surfaces), and the host's haptic side touches them as such: a finger slid off a block's
/// top in a 10 Hz world, through the daemon's loader and physics thread, drops off the edge
/// as it passes it instead of riding on the top's plane until the next step.
#[test]
fn a_finger_slid_off_a_rapier_blocks_top_drops_off_its_edge() {
    use hapticd_core::kinematics::Pose;
    use hapticd_core::scene::Pointer;
    let dir = support::scratch("plugin-test", "edge");
    let file = dir.join("edge.yaml");
    std::fs::write(&file, support::BLOCK_AT_10_HZ).unwrap();
    let grip = |at: DVec3| Pointer {
        pose: Pose {
            position: at,
            ..Pose::IDENTITY
        },
        velocity: DVec3::ZERO,
    };
    let way = |tick: usize| match tick {
        0..300 => DVec3::new(0.0, 0.07, 0.0),
        300..600 => DVec3::new(0.0, 0.07 - 0.021 * (tick - 300) as f64 / 300.0, 0.0),
        _ => DVec3::new(0.08 * ((tick - 600) as f64 / 600.0).min(1.0), 0.049, 0.0),
    };
    let mut scene = hapticd::plugin_scene::load(
        &plugin_path("hapticd-scene-rapier"),
        Some(&file),
        &[grip(way(0))],
    )
    .unwrap();
    let mut felt = [Wrench::ZERO];
    let mut bodies = vec![hapticd_plugin_api::HapticdBodyPose::default(); 2];
    let (mut on_top, mut beyond, mut pressed_beyond) = (0, 0, 0);
    for tick in 0..1400 {
        let fresh = scene.render(&[grip(way(tick))], 1e-3, &mut felt);
        std::thread::sleep(std::time::Duration::from_millis(1));
        if !fresh {
            continue;
        }
        scene.write_bodies(&mut bodies);
        let edge = bodies[1].position[0] + 0.05;
        let (x, force) = (way(tick).x, felt[0].force.length());
        if tick > 600 && x < edge - 0.005 {
            on_top += usize::from(force > 1.0);
        }
        if x > edge + 1e-3 {
            beyond += 1;
            pressed_beyond += usize::from(force > 0.1);
        }
    }
    assert!(
        on_top > 300 && beyond > 300,
        "{on_top} pressed on top, {beyond} past"
    );
    assert_eq!(pressed_beyond, 0, "of {beyond} ticks past the edge");
    std::fs::remove_dir_all(dir).ok();
}

/// The C example answers the geometry extension by hand: its floor, one plane of no body.
#[test]
fn the_c_example_describes_its_floor() {
    use hapticd_plugin_api::*;
    let dir = support::scratch("plugin-test", "c-geometry");
    let source =
        std::fs::read_to_string(repo_dir().join("plugins/c-example/floor_scene.c")).unwrap();
    let path = compile_c(&dir, "floor_scene", &source);
    let scene = hapticd::plugin_scene::load(&path, None, &one_pointer()).unwrap();
    let geometry = scene.geometry();
    assert_eq!((geometry.body_count, geometry.solids.len()), (0, 1));
    let floor = geometry.solids[0];
    assert_eq!(
        (floor.body, floor.shape, floor.flags),
        (HAPTICD_NO_BODY, HAPTICD_SHAPE_PLANE, HAPTICD_SOLID_FIXED)
    );
    assert_eq!(floor.offset.position, [0.0, -0.03, 0.0]);
    std::fs::remove_dir_all(dir).ok();
}

/// The start of a direct C scene that pushes nothing: its includes, `create`, `destroy` and
/// `step`.
const DIRECT_SCENE: &str = r#"#include <stddef.h>
#include <string.h>
#include "hapticd_plugin.h"
static int made;
static int32_t create(const char *path, uint32_t n, void **instance, HapticdSceneInfo *info) {
    (void)path; (void)n; *instance = &made; info->style = HAPTICD_SCENE_DIRECT; return 0;
}
static void destroy(void *instance) { (void)instance; }
static int32_t step(void *instance, double dt, const HapticdPointer *p, uint32_t n,
                    HapticdWrench *w) {
    (void)instance; (void)dt; (void)p; memset(w, 0, n * sizeof *w); return 0;
}"#;

/// A C scene whose one solid is `solid` (a C initialiser of HapticdSolid).
fn c_scene_with_solid(solid: &str) -> String {
    format!(
        r#"{DIRECT_SCENE}
static int32_t counts(void *instance, HapticdGeometryCounts *out) {{
    (void)instance; out->bodies = 1; out->solids = 1; out->triangles = 0; return 0;
}}
static int32_t solid(void *instance, uint32_t index, HapticdSolid *out) {{
    (void)instance; (void)index; *out = (HapticdSolid){{ {solid} }}; return 0;
}}
static int32_t triangles(void *instance, uint32_t first, uint32_t count, HapticdTriangle *out) {{
    (void)instance; (void)first; (void)count; (void)out; return 0;
}}
static const HapticdSceneGeometry geometry = {{ sizeof geometry, counts, solid, triangles }};
static const void *get_extension(const char *id) {{
    return strcmp(id, HAPTICD_EXT_SCENE_GEOMETRY) == 0 ? &geometry : NULL;
}}
static const HapticdSceneVtable vtable = {{ .struct_size = sizeof vtable, .create = create,
    .destroy = destroy, .step_direct = step, .get_extension = get_extension }};
static const HapticdPluginDescriptor d = {{ HAPTICD_ABI_MAJOR, HAPTICD_ABI_MINOR,
    HAPTICD_KIND_SCENE, "drawn", "0", "one solid", NULL, &vtable }};
const HapticdPluginDescriptor *hapticd_plugin_entry(const HapticdHost *h) {{ (void)h; return &d; }}
"#
    )
}

/// Solids no picture can show are refused when the scene is opened, each with its fault;
/// a sound one opens.
#[test]
fn a_scene_whose_solids_cannot_be_drawn_is_refused() {
    let dir = support::scratch("plugin-test", "bad-geometry");
    let frame = ".offset = { { 0, 0, 0 }, { 1, 0, 0, 0 } }";
    for (name, solid, fault) in [
        (
            "nan",
            format!(".shape = HAPTICD_SHAPE_SPHERE, .size = {{ __builtin_nan(\"\") }}, {frame}"),
            Some("solid 0: size"),
        ),
        (
            "body",
            format!(".body = 3, .shape = HAPTICD_SHAPE_BOX, .size = {{ 1, 1, 1 }}, {frame}"),
            Some("body 3 of a world of 1"),
        ),
        (
            "shape",
            format!(".shape = 77, {frame}"),
            Some("unknown shape 77"),
        ),
        (
            "triangles",
            format!(".shape = HAPTICD_SHAPE_TRIANGLES, .triangle_count = 5, {frame}"),
            Some("triangles 0 .. 5 of 0"),
        ),
        (
            "good",
            format!(".shape = HAPTICD_SHAPE_SPHERE, .size = {{ 0.01 }}, {frame}"),
            None,
        ),
    ] {
        let path = compile_c(&dir, name, &c_scene_with_solid(&solid));
        let opened = hapticd::plugin_scene::load(&path, None, &one_pointer());
        match (opened, fault) {
            (Ok(scene), None) => assert_eq!(scene.geometry().solids.len(), 1),
            (Err(error), Some(fault)) => {
                assert!(
                    matches!(
                        &error,
                        LoadError::Scene {
                            fault: SceneFault::Geometry(ExtensionFault::Solids(_)),
                            ..
                        }
                    ),
                    "{error}"
                );
                let text = error.to_string();
                assert!(text.contains("cannot draw its world"), "{text}");
                assert!(text.contains(fault), "{name}: {text} lacks {fault:?}");
            }
            (Ok(_), Some(fault)) => panic!("{name}: opened, despite {fault}"),
            (Err(error), None) => panic!("{name}: refused: {error}"),
        }
    }
    std::fs::remove_dir_all(dir).ok();
}

/// A scene file's `engine:` picks the plugin that declares it; a plugin that declares no
/// such engine, a missing one, or an engine that is no name are refused with the reason,
/// and the plugin's own check reports the file's mistakes at their places.
#[test]
fn a_scene_file_runs_on_the_plugin_that_declares_its_engine() {
    use hapticd::scenes::{OpenError, Places, open};
    let dir = support::scratch("plugin-test", "engines");
    for (krate, file) in [
        ("hapticd-scene-penalty", "libhapticd_scene_penalty.so"),
        ("hapticd-scene-floor", "libhapticd_scene_floor.so"),
    ] {
        std::fs::copy(plugin_path(krate), dir.join(file)).unwrap();
    }
    let scene = |name: &str, text: &str| {
        let path = dir.join(format!("{name}.yaml"));
        std::fs::write(&path, text).unwrap();
        path
    };
    let blocks = std::fs::read_to_string(repo_dir().join("config/scenes/blocks.yaml")).unwrap();
    let plugin_dirs = [dir.clone()];
    let places = Places {
        dirs: &[],
        plugin_dirs: &plugin_dirs,
        world_link: None,
    };
    let pointers = one_pointer();
    let opened = |path: &Path| {
        open(path.to_str().unwrap(), None, places, &pointers, 1000.0).map(|s| s.name().to_string())
    };
    assert_eq!(opened(&scene("blocks", &blocks)).unwrap(), "blocks");
    let invalid = |path: PathBuf| match opened(&path) {
        Err(OpenError::Refused(why)) => why,
        other => panic!("{}: {other:?}", path.display()),
    };
    let floor = invalid(scene("floor", &format!("engine: floor\n{blocks}")));
    assert!(floor.contains("declares no engine floor"), "{floor}");
    let missing = invalid(scene("missing", &format!("engine: rapier\n{blocks}")));
    assert!(
        missing.contains("no scene plugin libhapticd_scene_rapier.so"),
        "{missing}"
    );
    let climbing = invalid(scene("climbing", &format!("engine: ../floor\n{blocks}")));
    assert!(climbing.contains("is not a name"), "{climbing}");
    let typo = invalid(scene(
        "typo",
        &blocks.replace("density: 500", "densty: 500"),
    ));
    assert!(
        typo.contains("typo.yaml:") && typo.contains("densty"),
        "{typo}"
    );
    std::fs::remove_dir_all(dir).ok();
}

/// A remote scene (`engine: remote`) through the daemon's loader and a real world link, the
/// bridge's side played here: nothing is felt before the world speaks; a world update with
/// a floor under the pointer is felt as the floor's push, and the scene tells the world where
/// its grip is; an update that is no update disables it, with the reason. Without a link the
/// file is refused, saying why.
#[test]
fn a_remote_scene_renders_the_world_its_link_delivers() {
    use hapticd::scenes::{OpenError, Places, open};
    use hapticd_core::scene::multirate::PlaneSet;
    use hapticd_core::scene::remote::{decode_host, encode_world};
    use hapticd_core::wire::Encoder;
    use hapticd_ipc::world_link_share::WorldLinkFile;
    use hapticd_plugin_api::HapticdPlane;
    let dir = support::scratch("plugin-test", "remote");
    let file = dir.join("far.yaml");
    std::fs::write(&file, "engine: remote\nrate: 50\n").unwrap();
    let pointers = one_pointer();
    let opened = |link| {
        let places = Places {
            dirs: &[],
            plugin_dirs: &[],
            world_link: link,
        };
        open(file.to_str().unwrap(), None, places, &pointers, 1000.0)
    };
    match opened(None) {
        Err(OpenError::Refused(why)) => assert!(why.contains("no link"), "{why}"),
        other => panic!("{:?}", other.map(|s| s.name().to_string())),
    }
    let link = WorldLinkFile::create().unwrap();
    let mut scene = opened(Some(link.link())).unwrap();
    assert_eq!(scene.name(), "far");
    // A floor rising from 1 mm under the grip (a grip that starts inside a solid feels
    // nothing until out) to 1 mm over it.
    let mut wrenches = [Wrench::ZERO];
    let tick = |scene: &mut Box<dyn hapticd_core::scene::Scene>, w: &mut [Wrench; 1]| {
        let felt = scene.render(&pointers, 1e-3, w);
        std::thread::sleep(std::time::Duration::from_millis(1));
        felt
    };
    assert!(!tick(&mut scene, &mut wrenches), "nothing before the world");
    let mut set = PlaneSet::default();
    set.planes[0].count = 1;
    set.planes[0].planes[0] = HapticdPlane {
        object: 0,
        point: [0.0; 3],
        normal: [0.0, 1.0, 0.0],
        velocity: [0.0; 3],
    };
    let mut update = Encoder::default();
    let mut felt = None;
    for step in 1..200u64 {
        set.planes[0].planes[0].point[1] = -0.001 + 1e-4 * step.min(20) as f64;
        update.clear();
        encode_world(&mut update, step, &set, 1, &[]);
        link.link().deliver(step, update.bytes());
        if tick(&mut scene, &mut wrenches) && wrenches[0].force.y > 0.0 {
            felt = Some(wrenches[0].force);
            break;
        }
    }
    let felt = felt.expect("the floor is felt");
    assert!(felt.x.abs() < 1e-9 && felt.z.abs() < 1e-9, "{felt}");
    let mut message = Vec::new();
    let sent = link.link().sent();
    assert!(sent > 0 && link.link().message(sent, &mut message));
    let told = decode_host(&message).expect("a host message");
    assert_eq!(told.pointers.len(), 1);
    assert!(told.seen > 0, "it says which step it rendered");
    link.link().deliver(1000, b"no update");
    let started = std::time::Instant::now();
    while tick(&mut scene, &mut wrenches) || scene.fault().is_none() {
        assert!(started.elapsed().as_secs() < 5, "still rendering");
    }
    assert!(
        scene
            .fault()
            .unwrap()
            .to_string()
            .contains("no whole update")
    );
    assert_eq!(wrenches[0], Wrench::ZERO);
}

/// A direct C scene of ABI minor `minor` with one body under the control extension: a query
/// finds its centre at (0.1, 0.2, 0.3); an impulse answers with the point it was given, an
/// impulse through the centre (1.7) with a velocity of 1 along x and its own mark.
fn c_scene_with_control(minor: u32) -> String {
    format!(
        r#"{DIRECT_SCENE}
static int32_t body(void *instance, uint32_t index, HapticdBodyInfo *out) {{
    (void)instance;
    if (index > 0) return HAPTICD_ERROR_ARGUMENT;
    memset(out, 0, sizeof *out); strcpy(out->name, "block"); return 0;
}}
static int32_t apply(void *instance, const HapticdSceneCommand *c, HapticdBodyState *s) {{
    (void)instance;
    memset(s, 0, sizeof *s); s->orientation[0] = 1; s->mass = 1;
    double centre[3] = {{ 0.1, 0.2, 0.3 }};
    switch (c->kind) {{
    case HAPTICD_COMMAND_QUERY: memcpy(s->position, centre, sizeof centre); return 0;
    case HAPTICD_COMMAND_IMPULSE: memcpy(s->position, c->position, sizeof centre); return 0;
    case HAPTICD_COMMAND_IMPULSE_AT_CENTRE: s->velocity[0] = 1; s->position[0] = 9; return 0;
    default: return HAPTICD_ERROR_ARGUMENT;
    }}
}}
static const HapticdSceneControl control = {{ sizeof control, body, apply }};
static const void *get_extension(const char *id) {{
    return strcmp(id, HAPTICD_EXT_SCENE_CONTROL) == 0 ? &control : NULL;
}}
static const HapticdSceneVtable vtable = {{ .struct_size = sizeof vtable, .create = create,
    .destroy = destroy, .step_direct = step, .get_extension = get_extension }};
static const HapticdPluginDescriptor d = {{ HAPTICD_ABI_MAJOR, {minor},
    HAPTICD_KIND_SCENE, "driven", "0", "one body", NULL, &vtable }};
const HapticdPluginDescriptor *hapticd_plugin_entry(const HapticdHost *h) {{ (void)h; return &d; }}
"#
    )
}

/// An impulse through a body's centre reaches a plugin of ABI 1.7 as that command; a plugin
/// of 1.6 gets an impulse at the centre it reports between the same two steps.
#[test]
fn an_impulse_through_the_centre_reaches_older_plugins_at_the_centre_they_report() {
    use hapticd_plugin_api::{HAPTICD_COMMAND_IMPULSE_AT_CENTRE, HapticdSceneCommand};
    let dir = support::scratch("plugin-test", "impulse-at-centre");
    for minor in [6, 7] {
        let path = compile_c(
            &dir,
            &format!("driven{minor}"),
            &c_scene_with_control(minor),
        );
        let pointers = one_pointer();
        let mut scene = hapticd::plugin_scene::load(&path, None, &pointers).unwrap();
        let mut control = scene.take_control().expect("the control extension");
        let sender = std::thread::spawn(move || {
            control.send(HapticdSceneCommand {
                vector: [0.0, 0.0, 1.0],
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_IMPULSE_AT_CENTRE, 0)
            })
        });
        let mut wrenches = [Wrench::ZERO];
        while !sender.is_finished() {
            scene.render(&pointers, 1e-3, &mut wrenches);
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        let state = sender.join().unwrap().unwrap();
        match minor {
            6 => assert_eq!(
                (state.position, state.velocity),
                ([0.1, 0.2, 0.3], [0.0; 3]),
                "1.6: an impulse at the centre the query found"
            ),
            _ => assert_eq!(
                (state.position, state.velocity),
                ([9.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
                "1.7: the command itself"
            ),
        }
    }
    std::fs::remove_dir_all(dir).ok();
}

/// A soft body through the real ABI: the rapier plugin, a world of a soft block, draws it
/// deforming and names its body for its object; pressed with 0.5 N, it answers the
/// compliance extension for the block's plane as the physics crate's own world (built
/// here, in this process) says, the press it stands under included, and rigid for the
/// floor's.
#[test]
fn a_soft_bodys_plane_gives_through_the_compliance_extension_as_its_world_says() {
    use hapticd_core::scene::shared_world::Stepped;
    use hapticd_physics::scene::SceneFile;
    use hapticd_plugin_api::export::{PhysicsInput, PhysicsOutput};
    use hapticd_plugin_api::*;
    let dir = support::scratch("plugin-test", "compliance");
    let file = dir.join("pressed.yaml");
    std::fs::write(
        &file,
        "name: pressed\nengine: rapier\nrate: 60\ngravity: [0, 0, 0]\nmaterial: { static_friction: \
         0.4, friction: 0.3 }\nbodies:\n  \
         - { name: floor, box: [0.1, 0.01, 0.1], position: [0, -0.005, 0], fixed: true }\n  \
         - { name: block, box: [0.04, 0.02, 0.04], position: [0, 0.01, 0], density: 1100, \
         soft: { young: 1.0e5, poisson: 0.45, damping: 0.002, resolution: 0.005 }, pinned: \
         { body: floor } }\n",
    )
    .unwrap();
    let mut plugin =
        hapticd::plugin_scene::load_world(&plugin_path("hapticd-scene-rapier"), Some(&file), 1)
            .unwrap()
            .expect("a multi-rate world");
    let SceneFile::Rapier(spec) = SceneFile::load(&file, 1).unwrap() else {
        unreachable!("a rapier scene");
    };
    // Drawn as the file says (the block a deforming solid), its object the block's body
    // (the floor is body 0, the block 1), its pose among the bodies.
    assert_eq!(plugin.geometry, spec.geometry());
    assert_eq!(plugin.object_bodies, [0, 1]);
    let mut poses = [HapticdBodyPose::default(); 4];
    assert_eq!(plugin.poses(&mut poses), 2);
    let mut here = hapticd_rapier::world::RapierWorld::new(&spec, 1);
    // The finger half a millimetre above the block's top, which it pressed with 0.5 N over
    // the last period (the block is object 1: the floor's one collider is 0).
    let finger = [HapticdPointer {
        position: [0.0012, 0.0205, 0.0021],
        ..HapticdPointer::default()
    }];
    let dt = 1.0 / 60.0;
    let pressed = [HapticdImpulse {
        object: 1,
        point: [0.0012, 0.02, 0.0021],
        impulse: [0.0, -0.5 * dt, 0.0],
    }];
    let mut answers = Vec::new();
    for world in [&mut plugin as &mut dyn Stepped, &mut here] {
        let mut planes = [HapticdPlanes::default()];
        let input = PhysicsInput {
            dt,
            pointers: &finger,
            proxies: &finger,
            impulses: &pressed,
            locals: &[],
        };
        let mut output = PhysicsOutput {
            planes: &mut planes,
            bodies: &mut [],
            body_count: &mut 0,
        };
        assert!(world.step(&input, &mut output));
        let mut gives = [[HapticdPlaneCompliance::default(); HAPTICD_MAX_PLANES]];
        world.compliances(&planes, &mut gives);
        answers.push((planes[0], gives[0]));
    }
    assert_eq!(answers[0], answers[1]);
    let (planes, gives) = answers[0];
    let block = (0..planes.count as usize)
        .find(|&k| planes.planes[k].object == 1)
        .expect("the block's plane");
    println!(
        "the block's plane: {:?}, {:?}",
        planes.planes[block], gives[block]
    );
    assert!(gives[block].compliance > 1e-5, "{:?}", gives[block]);
    // The press along the plane's normal, which the step has tilted.
    let along = 0.5 * planes.planes[block].normal[1];
    assert!(
        (gives[block].load - along).abs() < 1e-9,
        "{:?}",
        gives[block]
    );
    for k in (0..planes.count as usize).filter(|&k| k != block) {
        assert_eq!(gives[k], HapticdPlaneCompliance::default(), "plane {k}");
    }
    std::fs::remove_dir_all(dir).ok();
}
