//! Meshes, measured side by side in one run: a proxy tick on a ball of 99 600 triangles
//! through the bounding-volume hierarchy, against a scan of every triangle and against
//! parry's own point projection onto the same mesh (its BVH, single precision); cutting the
//! shipped meshes and that ball into convex pieces (their count and volume said beside the
//! table); and a step of the penalty `mug` scene
//! with a finger pressing the mug, against the same scene with a box for the mug.
//!
//! Run: `cargo bench -p hapticd-e2e --bench meshes`.

use std::path::Path;

use divan::Bencher;
use glam::DVec3;
use hapticd_core::haptics::obstacle::Shape;
use hapticd_core::haptics::proxy::{Proxy, ProxyParameters};
use hapticd_core::haptics::scenery::Scenery;
use hapticd_mesh::TriangleMesh;
use hapticd_mesh::cache::Cache;
use hapticd_mesh::decomposition::{RESOLUTION, decompose};
use hapticd_physics::coupling::Grip;
use hapticd_physics::scene::{PenaltyScene, SceneFile};
use rapier3d::parry::query::PointQuery;
use rapier3d::parry::shape::TriMesh;
use rapier3d::prelude::Vector;

#[path = "../support/mod.rs"]
mod support;

use support::ball_mesh::ball_faces;

fn main() {
    divan::main();
}

const CENTRE: DVec3 = DVec3::new(0.0, -0.05, 0.0);
const RADIUS: f64 = 0.05;

/// The large mesh: 250 rings of 200 segments.
fn ball() -> Vec<Shape> {
    ball_faces(CENTRE, RADIUS, 250, 200)
}

/// Where the grip is at tick `k`: pressed 5 mm into the ball, going round it at 0.14 m/s.
fn grip(k: usize) -> DVec3 {
    let angle = 0.3 + (k % 2000) as f64 * 0.003;
    CENTRE + (RADIUS - 0.005) * DVec3::new(angle.sin() * 0.8, angle.cos(), angle.sin() * 0.6)
}

/// A proxy's tick among `obstacles` after 100 ticks of pressing.
fn proxy_ticks<O: hapticd_core::haptics::obstacle::Obstacles + ?Sized>(
    bencher: Bencher,
    obstacles: &O,
) {
    let parameters = ProxyParameters::default();
    let mut proxy = Proxy::new(CENTRE + DVec3::new(0.0, RADIUS + 0.01, 0.0));
    let mut k = 0;
    for _ in 0..100 {
        proxy.update(grip(k), DVec3::ZERO, obstacles, &parameters, 1e-3);
    }
    bencher.bench_local(|| {
        k += 1;
        proxy.update(
            grip(k),
            (grip(k) - grip(k - 1)) / 1e-3,
            obstacles,
            &parameters,
            1e-3,
        )
    });
}

#[divan::bench]
fn proxy_through_the_hierarchy(bencher: Bencher) {
    let scenery = Scenery::new(&ball());
    proxy_ticks(bencher, &scenery);
}

#[divan::bench(sample_count = 20)]
fn proxy_scanning_every_triangle(bencher: Bencher) {
    let faces = ball();
    proxy_ticks(bencher, &faces[..]);
}

/// parry's nearest point on the same triangles, once a tick: what a proxy built on it would
/// start from.
#[divan::bench]
fn parry_point_projection(bencher: Bencher) {
    let faces = ball();
    let vertices: Vec<Vector> = faces
        .iter()
        .flat_map(|f| match f {
            Shape::Triangle { corners, .. } => corners.map(|c| {
                let c = c.as_vec3();
                Vector::new(c.x, c.y, c.z)
            }),
            _ => unreachable!("a ball of triangles"),
        })
        .collect();
    let indices = (0..faces.len() as u32)
        .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
        .collect();
    let mesh = TriMesh::new(vertices, indices).unwrap();
    let mut k = 0;
    bencher.bench_local(|| {
        k += 1;
        let g = grip(k).as_vec3();
        mesh.project_local_point(Vector::new(g.x, g.y, g.z), false)
    });
}

/// A mesh of the shipped ones, or the large ball (written as OBJ first), as hapticd-mesh
/// reads it: its corners welded.
fn mesh(name: &str) -> TriangleMesh {
    let file = if name == "ball" {
        let file = Path::new(env!("CARGO_TARGET_TMPDIR")).join("ball.obj");
        let mut text = String::new();
        for (k, f) in ball().iter().enumerate() {
            if let Shape::Triangle { corners, .. } = f {
                for c in corners {
                    text += &format!("v {} {} {}\n", c.x, c.y, c.z);
                }
                text += &format!("f {} {} {}\n", 3 * k + 1, 3 * k + 2, 3 * k + 3);
            }
        }
        std::fs::write(&file, text).unwrap();
        file
    } else {
        support::repo_dir().join(format!("config/scenes/meshes/{name}.obj"))
    };
    hapticd_mesh::load(&file, 1.0, hapticd_mesh::Limits::DEFAULT, None).unwrap()
}

#[divan::bench(args = ["bracket", "mug", "ball"], sample_count = 3, sample_size = 1)]
fn decomposition(bencher: Bencher, name: &str) {
    let mesh = mesh(name);
    // What the timing is of: said once beside the table.
    let pieces = decompose(&mesh, RESOLUTION).unwrap();
    let volume = hapticd_mesh::properties::mass_properties(&mesh).volume;
    eprintln!(
        "{name}: {} triangles cut into {} pieces, their volume {:+.1} % of the mesh's",
        mesh.triangles.len(),
        pieces.pieces.len(),
        100.0 * (pieces.volume() / volume - 1.0)
    );
    bencher.bench_local(|| decompose(&mesh, RESOLUTION).unwrap().pieces.len());
}

/// The shipped `mug` scene, or with a box of the mug's size in its place.
fn mug_scene(boxed: bool) -> PenaltyScene {
    let path = support::repo_dir().join("config/scenes/mug.yaml");
    let mut text = std::fs::read_to_string(&path).unwrap();
    if boxed {
        let mesh = text
            .lines()
            .find(|l| l.contains("mesh: "))
            .unwrap()
            .to_string();
        let scale = text
            .lines()
            .find(|l| l.contains("scale: "))
            .unwrap()
            .to_string();
        text = text
            .replace(&mesh, "    box: [0.08, 0.09, 0.08]")
            .replace(&format!("{scale}\n"), "")
            .replace("position: [0.075, -0.03, 0]", "position: [0.075, 0.015, 0]");
    }
    let cache = Cache::at(Path::new(env!("CARGO_TARGET_TMPDIR")).join("mesh-cache"));
    match SceneFile::parse_cached(&text, &path, 1, &cache).unwrap() {
        SceneFile::Penalty(scene) => *scene,
        SceneFile::Rapier(_) => unreachable!("a penalty scene"),
    }
}

/// A tick of `scene` with a finger pressing 1 mm into the mug's rim (or the box's top).
fn pressed_step(bencher: Bencher, mut scene: PenaltyScene) {
    let rim = Grip {
        position: DVec3::new(0.075, 0.069, 0.038),
        orientation: glam::DQuat::IDENTITY,
        velocity: DVec3::ZERO,
        spin: DVec3::ZERO,
    };
    let mut felt = [hapticd_core::kinematics::Wrench::default()];
    for _ in 0..300 {
        scene.step_pointers(1e-3, &[rim], &mut felt);
    }
    assert!(felt[0].force.length() > 0.1, "the finger presses");
    bencher.bench_local(|| scene.step_pointers(1e-3, &[rim], &mut felt));
}

#[divan::bench(sample_count = 30)]
fn penalty_tick_pressing_the_mug(bencher: Bencher) {
    pressed_step(bencher, mug_scene(false));
}

#[divan::bench(sample_count = 30)]
fn penalty_tick_pressing_a_box_for_the_mug(bencher: Bencher) {
    pressed_step(bencher, mug_scene(true));
}
