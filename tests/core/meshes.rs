//! A static scene that names a mesh file: the shipped bracket (a plate with a hole), read by
//! hapticd-mesh, placed by the scene, touched by the proxy: its plate holds the finger, its
//! hole lets it through to the floor below; a mesh the scene may not read is an error at its
//! place.

use std::path::{Path, PathBuf};

use glam::DVec3;
use hapticd_core::haptics::obstacle::Shape;
use hapticd_core::haptics::proxy::{Proxy, ProxyParameters};
use hapticd_core::scene::static_scene::StaticSceneSpec;
use hapticd_mesh::scene_triangles;

use crate::support::{repo_dir, scratch_root};

const SCENE: &str = "\
name: bracket
shapes:
  - floor: { height: -0.05 }
  - mesh: { file: bracket.obj, centre: [0, -0.02, 0] }
";

/// A scene directory with the bracket's mesh beside its scene file.
fn scene_dir(name: &str) -> PathBuf {
    let dir = scratch_root().join(format!("meshes-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::copy(
        repo_dir().join("config/scenes/meshes/bracket.obj"),
        dir.join("bracket.obj"),
    )
    .unwrap();
    dir
}

fn parse(dir: &Path, text: &str) -> Result<StaticSceneSpec, String> {
    StaticSceneSpec::parse_with_meshes(text, &dir.join("scene.yaml"), &scene_triangles)
        .map_err(|e| e.to_string())
}

/// Where the proxy rests after the grip comes straight down at (`x`, `z`) to `depth` below
/// the plate's top, a millimetre a tick.
fn pressed(spec: &StaticSceneSpec, x: f64, z: f64, depth: f64) -> (DVec3, DVec3) {
    let top = -0.02 + 0.006;
    let mut proxy = Proxy::new(DVec3::new(x, 0.02, z));
    let parameters = ProxyParameters {
        stiffness: 1000.0,
        damping: 0.0,
        static_friction: 0.0,
        dynamic_friction: 0.0,
    };
    let mut out = None;
    let mut y = 0.02;
    while y > top - depth {
        y = (y - 0.001).max(top - depth);
        out = Some(proxy.update(
            DVec3::new(x, y, z),
            DVec3::ZERO,
            &spec.shapes,
            &parameters,
            1e-3,
        ));
    }
    let out = out.unwrap();
    (out.proxy, out.force)
}

#[test]
fn the_plate_holds_the_finger_and_its_hole_lets_it_through() {
    let dir = scene_dir("touch");
    let spec = parse(&dir, SCENE).unwrap();
    let faces = spec
        .shapes
        .iter()
        .filter(|s| matches!(s, Shape::Triangle { .. }))
        .count();
    assert_eq!(faces, 256, "the bracket's triangles, placed");
    // On the plate, 15 mm from the hole's axis: held on its top, pushed back 5 N at 5 mm.
    let (proxy, force) = pressed(&spec, 0.015, 0.0, 0.005);
    assert!((proxy.y - (-0.014)).abs() < 1e-9, "{proxy}");
    assert!(
        (force - DVec3::new(0.0, 5.0, 0.0)).length() < 1e-9,
        "{force}"
    );
    // Over the hole: through it, down to the floor 3.6 cm below the plate's top.
    let (proxy, force) = pressed(&spec, 0.0, 0.0, 0.04);
    assert!((proxy.y - (-0.05)).abs() < 1e-9, "{proxy}");
    assert!((force.y - 1000.0 * 0.004).abs() < 1e-9, "{force}");
}

#[test]
fn a_mesh_the_scene_may_not_read_is_an_error_at_its_place() {
    let dir = scene_dir("errors");
    let outside = scratch_root().join(format!("meshes-{}-outside.obj", std::process::id()));
    std::fs::copy(dir.join("bracket.obj"), &outside).unwrap();
    let escaping = format!(
        "name: bracket\nshapes:\n  - mesh: {{ file: ../{}, scale: 2 }}\n  - mesh: {{ file: missing.obj }}\n  - mesh: {{ file: bracket.obj, scale: -1 }}\n",
        outside.file_name().unwrap().to_string_lossy()
    );
    let e = parse(&dir, &escaping).unwrap_err();
    let lines: Vec<_> = e.lines().collect();
    assert_eq!(lines.len(), 3, "{e}");
    assert!(
        lines[0].contains(":3:")
            && lines[0].contains("shapes[0].mesh.file")
            && lines[0].contains("outside"),
        "{e}"
    );
    assert!(
        lines[1].contains("shapes[1].mesh.file") && lines[1].contains("missing.obj"),
        "{e}"
    );
    assert!(lines[2].contains("shapes[2].mesh.scale"), "{e}");
    // A program that reads no meshes says so.
    let e = StaticSceneSpec::parse(SCENE, &dir.join("scene.yaml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("reads no mesh files"), "{e}");
}
