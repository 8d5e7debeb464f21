//! Mesh bodies in rapier's world: a fixed mesh keeps its triangles, so a ring's hole is a
//! hole and a hole takes a peg that fits; a decomposed mug settles upright on its base.

use std::f64::consts::TAU;
use std::fmt::Write;
use std::path::Path;

use glam::{DQuat, DVec3};

use crate::support;
use hapticd_mesh::cache::Cache;
use hapticd_physics::scene::{RapierScene, SceneFile};
use hapticd_rapier::world::RapierWorld;

/// Write `triangles` as an OBJ file, each wound so that its normal points along `outward`
/// of its centre.
fn write_obj(path: &Path, triangles: &[[DVec3; 3]], outward: impl Fn(DVec3) -> DVec3) {
    let mut text = String::new();
    for (k, t) in triangles.iter().enumerate() {
        let [a, mut b, mut c] = *t;
        if (b - a).cross(c - a).dot(outward((a + b + c) / 3.0)) < 0.0 {
            std::mem::swap(&mut b, &mut c);
        }
        for v in [a, b, c] {
            writeln!(text, "v {} {} {}", v.x, v.y, v.z).unwrap();
        }
        let n = 3 * k;
        writeln!(text, "f {} {} {}", n + 1, n + 2, n + 3).unwrap();
    }
    std::fs::write(path, text).unwrap();
}

/// Two triangles of the quad `a b c d`.
fn quad(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> [[DVec3; 3]; 2] {
    [[a, b, c], [a, c, d]]
}

/// A ring lying flat about the y axis: a torus of radius `major` around a tube of radius
/// `minor`.
fn ring(path: &Path, major: f64, minor: f64) {
    let (around, across) = (48, 16);
    let at = |i: usize, j: usize| {
        let (u, v) = (
            TAU * i as f64 / around as f64,
            TAU * j as f64 / across as f64,
        );
        let r = major + minor * v.cos();
        DVec3::new(r * u.cos(), minor * v.sin(), r * u.sin())
    };
    let mut triangles = Vec::new();
    for i in 0..around {
        for j in 0..across {
            let (i1, j1) = ((i + 1) % around, (j + 1) % across);
            triangles.extend(quad(at(i, j), at(i1, j), at(i1, j1), at(i, j1)));
        }
    }
    write_obj(path, &triangles, |p| {
        p - DVec3::new(p.x, 0.0, p.z).normalize() * major
    });
}

/// A block `2·outer` square and `height` tall from y = 0 with a square hole `2·inner` across
/// through it along y.
fn holed_block(path: &Path, outer: f64, inner: f64, height: f64) {
    let corners = |h: f64, y: f64| {
        [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]
            .map(|(x, z)| DVec3::new(x * h, y, z * h))
    };
    let (ob, ot, ib, it) = (
        corners(outer, 0.0),
        corners(outer, height),
        corners(inner, 0.0),
        corners(inner, height),
    );
    let mut faces: Vec<([DVec3; 3], DVec3)> = Vec::new();
    for k in 0..4 {
        let n = (k + 1) % 4;
        let side = ((ob[k] + ob[n]) / 2.0 * DVec3::new(1.0, 0.0, 1.0)).normalize();
        for (quad, outward) in [
            (quad(ob[k], ob[n], ot[n], ot[k]), side),
            (quad(ib[k], ib[n], it[n], it[k]), -side),
            (quad(ot[k], ot[n], it[n], it[k]), DVec3::Y),
            (quad(ob[k], ob[n], ib[n], ib[k]), -DVec3::Y),
        ] {
            faces.extend(quad.map(|t| (t, outward)));
        }
    }
    let triangles: Vec<[DVec3; 3]> = faces.iter().map(|f| f.0).collect();
    write_obj(path, &triangles, |centre| {
        faces
            .iter()
            .find(|f| ((f.0[0] + f.0[1] + f.0[2]) / 3.0).distance(centre) < 1e-12)
            .expect("a face of the block")
            .1
    });
}

/// The rapier scene of `bodies` over a floor whose top is y = 0, in `dir`.
fn scene(dir: &Path, bodies: &str) -> RapierScene {
    let text = format!(
        "name: meshes\nengine: rapier\nrate: 200\ngravity: [0, -9.81, 0]\n\
         material: {{ static_friction: 0.4, friction: 0.4 }}\nbodies:\n  \
         - {{ name: floor, box: [0.5, 0.02, 0.5], position: [0, -0.01, 0], fixed: true }}\n{bodies}"
    );
    let cache = Cache::at(dir.join("cache"));
    match SceneFile::parse_cached(&text, &dir.join("scene.yaml"), 0, &cache) {
        Ok(SceneFile::Rapier(scene)) => *scene,
        Ok(SceneFile::Penalty(_)) => panic!("a penalty scene"),
        Err(e) => panic!("{e}"),
    }
}

/// Where body `i` of `spec` comes to rest after `seconds`.
fn settle(spec: &RapierScene, i: usize, seconds: f64) -> DVec3 {
    let mut world = RapierWorld::new(spec, 0);
    for _ in 0..(seconds * spec.rate) as usize {
        assert!(world.advance(1.0 / spec.rate));
    }
    let state = world.body(i);
    assert!(
        state.velocity.length() < 0.01,
        "at rest: {}",
        state.velocity
    );
    state.position
}

#[test]
fn a_ball_falls_through_a_rings_hole_and_rests_on_the_ring_when_larger() {
    let dir = support::scratch("rapier", "rapier-ring");
    ring(&dir.join("ring.obj"), 0.05, 0.01);
    let ring = "  - { name: ring, mesh: ring.obj, position: [0, 0.1, 0], fixed: true }\n";
    let ball = |radius: f64| {
        let ball = format!("  - {{ name: ball, sphere: {radius}, position: [0, 0.2, 0] }}\n");
        scene(&dir, &format!("{ring}{ball}"))
    };
    // The hole is 4 cm across its radius: a 2 cm ball falls through to the floor …
    let y = settle(&ball(0.02), 2, 2.0).y;
    assert!((y - 0.02).abs() < 1e-3, "on the floor: {y}");
    // … a 5 cm one rests on the tube, its centre √((R + r)² − R²) above the ring's plane
    // (of the 48-sided ring, within a millimetre).
    let rest = 0.1 + (0.06f64.powi(2) - 0.05f64.powi(2)).sqrt();
    let y = settle(&ball(0.05), 2, 2.0).y;
    assert!((y - rest).abs() < 1e-3, "on the ring: {y} vs {rest}");
}

#[test]
fn a_peg_fits_a_hole_with_a_millimetre_to_spare_and_sticks_in_one_too_small() {
    let dir = support::scratch("rapier", "rapier-peg");
    holed_block(&dir.join("block.obj"), 0.04, 0.01, 0.04);
    let block = "  - { name: block, mesh: block.obj, position: [0, 0, 0], fixed: true }\n";
    let peg = |side: f64| {
        let peg = format!(
            "  - {{ name: peg, box: [{side}, 0.06, {side}], position: [0, 0.08, 0], density: 2000 }}\n"
        );
        scene(&dir, &format!("{block}{peg}"))
    };
    // 19 mm in a 20 mm hole: down to the floor.
    let y = settle(&peg(0.019), 2, 2.0).y;
    assert!((y - 0.03).abs() < 1e-3, "in the hole on the floor: {y}");
    // 21 mm: it stays on the block's top.
    let y = settle(&peg(0.021), 2, 2.0).y;
    assert!((y - 0.07).abs() < 1e-3, "on the block: {y}");
}

#[test]
fn a_decomposed_mug_dropped_tilted_settles_upright_on_its_base() {
    let dir = support::scratch("rapier", "rapier-mug");
    let shipped = support::repo_dir().join("config/scenes/meshes/mug.obj");
    std::fs::copy(shipped, dir.join("mug.obj")).unwrap();
    let tilt = DQuat::from_rotation_z(0.3);
    let (w, x, y, z) = (tilt.w, tilt.x, tilt.y, tilt.z);
    let spec = scene(
        &dir,
        &format!(
            "  - {{ name: mug, mesh: mug.obj, position: [0, 0.03, 0], orientation: [{w}, {x}, {y}, {z}], density: 800 }}\n"
        ),
    );
    // Its mass is the closed volume's (hapticctl mesh inspect: 1.157665755e-4 m³).
    assert!((spec.bodies[1].mass / (800.0 * 1.157665755e-4) - 1.0).abs() < 1e-8);
    let mut world = RapierWorld::new(&spec, 0);
    for _ in 0..400 {
        assert!(world.advance(1.0 / spec.rate));
    }
    let mug = world.body(1);
    let axis = mug.orientation * (tilt * DVec3::Y);
    assert!(axis.angle_between(DVec3::Y) < 2f64.to_radians(), "{axis}");
    let surface = spec.surfaces[1].as_ref().unwrap();
    let low = surface
        .iter()
        .flatten()
        .map(|c| (mug.orientation * *c + mug.position).y)
        .fold(f64::INFINITY, f64::min);
    assert!(low.abs() < 1e-3, "lowest point at {low} m");
}
