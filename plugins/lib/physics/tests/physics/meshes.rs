//! Bodies of mesh files under the penalty engine: the mass of the closed volume, convex
//! pieces from the cache, and a decomposed mug that settles upright on its base.

use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3};
use hapticd_mesh::cache::Cache;
use hapticd_physics::scene::{PenaltyScene, SceneFile};

/// A directory of this test's own, holding the scene (beside the shipped meshes' copies)
/// and the cache.
fn workspace(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../config/scenes/meshes");
    for mesh in ["mug.obj", "bracket.gltf"] {
        std::fs::copy(shipped.join(mesh), dir.join("meshes").join(mesh)).unwrap();
    }
    dir
}

const MATERIAL: &str = "material: { stiffness: 2.0e7, damping: 2.0e4, static_friction: 0.6, \
    friction: 0.5, friction_stiffness: 2.0e7, friction_damping: 2.0e4, slip_speed: 0.001 }";

fn penalty(dir: &Path, bodies: &str) -> Result<PenaltyScene, String> {
    let text = format!(
        "name: meshes\ndt: 0.0002\ngravity: [0, -9.81, 0]\n{MATERIAL}\nbodies:\n  - {{ name: floor, box: [0.4, 0.02, 0.4], position: [0, -0.01, 0], fixed: true }}\n{bodies}"
    );
    let path = dir.join("scene.yaml");
    match SceneFile::parse_cached(&text, &path, 0, &Cache::at(dir.join("cache"))) {
        Ok(SceneFile::Penalty(scene)) => Ok(*scene),
        Ok(SceneFile::Rapier(_)) => Err("a rapier scene".into()),
        Err(e) => Err(e.to_string()),
    }
}

/// The lowest point of mesh body `i` where it is now: its surface's lowest corner.
fn lowest(scene: &PenaltyScene, i: usize) -> f64 {
    let body = &scene.world.bodies[i];
    scene.surfaces[i]
        .as_ref()
        .unwrap()
        .iter()
        .flatten()
        .map(|c| (body.orientation * *c + body.position).y)
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_mesh_body_weighs_what_its_closed_volume_does_and_its_pieces_are_cached() {
    let dir = workspace("mesh-mass");
    let body =
        "  - { name: mug, mesh: meshes/mug.obj, scale: 2, position: [0, 0.1, 0], density: 1000 }\n";
    let scene = penalty(&dir, body).unwrap();
    let mug = &scene.world.bodies[1];
    // hapticctl mesh inspect: 1.157665755e-4 m³ at scale 1; eight times that at scale 2.
    let volume = 8.0 * 1.157665755e-4;
    assert!(
        (mug.mass / (1000.0 * volume) - 1.0).abs() < 1e-8,
        "{}",
        mug.mass
    );
    // Its centre: the mesh's (0.002895, 0.036194, 0) doubled, placed at y = 0.1.
    let centre = DVec3::new(0.002895, 0.036194, 0.0) * 2.0 + DVec3::new(0.0, 0.1, 0.0);
    assert!(mug.position.distance(centre) < 2e-6, "{}", mug.position);
    assert!(mug.pieces.len() > 2, "{} pieces", mug.pieces.len());
    assert!(std::fs::read_dir(dir.join("cache/meshes")).unwrap().count() == 1);
    // Read again: the same pieces, from the cache.
    let again = penalty(&dir, body).unwrap();
    assert_eq!(again.world.bodies[1].pieces, mug.pieces);
    // What is wrong with a mesh is said at its key.
    for (body, expected) in [
        (
            "  - { name: m, mesh: meshes/none.obj, position: [0, 0.1, 0] }\n",
            "bodies[1].mesh: ",
        ),
        (
            "  - { name: m, mesh: ../../etc/passwd.obj, position: [0, 0.1, 0] }\n",
            "bodies[1].mesh: ",
        ),
        (
            "  - { name: m, mesh: meshes/mug.obj, scale: -1, position: [0, 0.1, 0] }\n",
            "bodies[1].scale: ",
        ),
        (
            "  - { name: m, mesh: meshes/mug.obj, scale: 1.0e5, position: [0, 0.1, 0] }\n",
            "m across once scaled",
        ),
        (
            "  - { name: m, box: [0.1, 0.1, 0.1], scale: 2, position: [0, 0.1, 0] }\n",
            "bodies[1].scale: only with mesh:",
        ),
        (
            "  - { name: m, mesh: meshes/mug.obj, sphere: 0.1, position: [0, 0.1, 0] }\n",
            "exactly one of",
        ),
    ] {
        let e = penalty(&dir, body).err().unwrap();
        assert!(e.contains(expected), "{body}: {e}");
    }
}

#[test]
fn a_tilted_mug_dropped_on_the_floor_settles_upright_on_its_base() {
    let dir = workspace("mesh-drop");
    let tilt = DQuat::from_rotation_z(0.3);
    let body = format!(
        "  - {{ name: mug, mesh: meshes/mug.obj, position: [0, 0.03, 0], orientation: [{}, {}, {}, {}], density: 800 }}\n",
        tilt.w, tilt.x, tilt.y, tilt.z
    );
    let mut scene = penalty(&dir, &body).unwrap();
    assert!(lowest(&scene, 1) > 0.005, "starts above the floor");
    for _ in 0..1500 {
        assert!(scene.step_pointers(1e-3, &[], &mut []));
    }
    let mug = &scene.world.bodies[1];
    assert!(mug.velocity.length() < 1e-3, "at rest: {}", mug.velocity);
    // Upright: its axis (tilted as placed; the body's frame starts as the world's) up within
    // 2°, its base (the lowest point) on the floor within the springs' sub-millimetre give.
    let axis = mug.orientation * (tilt * DVec3::Y);
    assert!(axis.angle_between(DVec3::Y) < 2f64.to_radians(), "{axis}");
    let low = lowest(&scene, 1);
    assert!(low.abs() < 5e-4, "lowest point at {low} m");
}
