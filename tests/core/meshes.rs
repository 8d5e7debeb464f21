//! A static scene that names a mesh file: the shipped bracket (a plate with a hole), read by
//! hapticd-mesh, placed by the scene, touched by the proxy: its plate holds the finger, its
//! hole lets it through to the floor below; a mesh the scene may not read is an error at its
//! place.

use std::path::{Path, PathBuf};

use glam::DVec3;
use hapticd_core::haptics::obstacle::{Obstacles, Shape};
use hapticd_core::haptics::proxy::{Proxy, ProxyParameters};
use hapticd_core::haptics::scenery::Scenery;
use hapticd_core::scene::static_scene::StaticSceneSpec;
use hapticd_mesh::scene_files;

use crate::support::ball_mesh::ball_faces;
use crate::support::{dir_with_mesh, scratch_root};

const SCENE: &str = "\
name: bracket
shapes:
  - floor: { height: -0.05 }
  - mesh: { file: bracket.obj, centre: [0, -0.02, 0] }
";

/// A scene directory with the bracket's mesh beside its scene file.
fn scene_dir(name: &str) -> PathBuf {
    dir_with_mesh(
        &format!("meshes-{name}"),
        "config/scenes/meshes/bracket.obj",
        "bracket.obj",
    )
}

fn parse(dir: &Path, text: &str) -> Result<StaticSceneSpec, String> {
    StaticSceneSpec::parse_with_files(text, &dir.join("scene.yaml"), scene_files())
        .map_err(|e| e.to_string())
}

/// Where the proxy rests after the grip comes straight down at (`x`, `z`) to `depth` below
/// the plate's top, a millimetre a tick.
fn pressed(spec: &StaticSceneSpec, x: f64, z: f64, depth: f64) -> (DVec3, DVec3) {
    let top = -0.02 + 0.006;
    let scenery = Scenery::new(&spec.shapes);
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
            &scenery,
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
    assert!(e.contains("reads no mesh or image files"), "{e}");
}

/// The proxy's walk over `path` (grip positions, a tick each) among `obstacles`: the forces.
fn walk<O: Obstacles + ?Sized>(
    obstacles: &O,
    path: &[DVec3],
    parameters: &ProxyParameters,
) -> Vec<DVec3> {
    let mut proxy = Proxy::new(path[0]);
    path.windows(2)
        .map(|w| {
            proxy
                .update(w[1], (w[1] - w[0]) / 1e-3, obstacles, parameters, 1e-3)
                .force
        })
        .collect()
}

#[test]
fn a_large_meshs_triangles_found_through_the_hierarchy_are_those_a_scan_finds() {
    // A ball of 19 800 triangles; the finger comes down on its top, presses 5 mm in, and
    // slides round its side with friction.
    let centre = DVec3::new(0.0, -0.05, 0.0);
    let faces = ball_faces(centre, 0.05, 100, 100);
    let mut path: Vec<DVec3> = (0..=30)
        .map(|k| DVec3::new(0.001, 0.01 - 0.0005 * k as f64, 0.0))
        .collect();
    path.extend((0..400).map(|k| {
        let angle = 0.02 + k as f64 * 0.003;
        centre + 0.045 * DVec3::new(angle.sin(), angle.cos(), 0.3 * angle.sin())
    }));
    let with_friction = ProxyParameters::default();
    let through_tree = walk(&Scenery::new(&faces), &path, &with_friction);
    let scanned = walk(&faces[..], &path, &with_friction);
    let pressed = through_tree.iter().filter(|f| f.length() > 1.0).count();
    assert!(
        pressed > 350,
        "the finger pressed the ball: {pressed} ticks"
    );
    for (k, (a, b)) in through_tree.iter().zip(&scanned).enumerate() {
        assert!(a.distance(*b) < 1e-9, "tick {k}: {a} vs {b}");
    }
    // Without friction or damping the faceted ball pushes out by the grip's depth under the
    // round ball's surface times the stiffness, within its facets' depth (0.025 mm).
    let frictionless = ProxyParameters {
        static_friction: 0.0,
        dynamic_friction: 0.0,
        damping: 0.0,
        ..with_friction
    };
    let faceted = walk(&Scenery::new(&faces), &path, &frictionless);
    for (k, (f, grip)) in faceted.iter().zip(&path[1..]).enumerate() {
        let depth = (0.05 - grip.distance(centre)).max(0.0);
        let exact = frictionless.stiffness * depth;
        let error = (f.length() - exact).abs();
        assert!(
            error < 0.03e-3 * frictionless.stiffness,
            "tick {k}: {} N vs {exact} N",
            f.length()
        );
    }
}

/// A file written z up (`up: z`) is turned a quarter about x so that its z is hapticd's y:
/// the bracket, a plate 6 mm thick along its file's y, stands 50 mm tall once its z is up,
/// 6 mm thick along z.
#[test]
fn a_mesh_written_z_up_is_turned_so_that_its_z_is_up() {
    let dir = scene_dir("up");
    let extent = |up: &str| {
        let text = format!("name: up\nshapes:\n  - mesh: {{ file: bracket.obj{up} }}\n");
        let spec = parse(&dir, &text).unwrap();
        let (mut low, mut high) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for shape in &spec.shapes {
            if let Shape::Triangle { corners, .. } = shape {
                for p in corners {
                    (low, high) = (low.min(*p), high.max(*p));
                }
            }
        }
        high - low
    };
    let as_is = extent("");
    assert!(
        (as_is - DVec3::new(0.05, 0.006, 0.05)).length() < 1e-9,
        "{as_is}"
    );
    assert_eq!(extent(", up: y"), as_is);
    let turned = extent(", up: z");
    assert!(
        (turned - DVec3::new(0.05, 0.05, 0.006)).length() < 1e-9,
        "{turned}"
    );
    assert!(
        parse(
            &dir,
            "name: up\nshapes:\n  - mesh: { file: bracket.obj, up: x }\n"
        )
        .is_err()
    );
}

/// Where the ray from `from` along unit `direction` first meets one of `faces`, either side
/// (Möller and Trumbore's test).
fn first_hit(faces: &[Shape], from: DVec3, direction: DVec3) -> f64 {
    let mut nearest = f64::INFINITY;
    for face in faces {
        let Shape::Triangle {
            corners: [a, b, c], ..
        } = *face
        else {
            continue;
        };
        let (e1, e2) = (b - a, c - a);
        let p = direction.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-15 {
            continue;
        }
        let s = from - a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = direction.dot(q) / det;
        let t = e2.dot(q) / det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 {
            nearest = nearest.min(t);
        }
    }
    nearest
}

#[test]
fn an_open_scan_is_felt_from_inside_as_from_outside_and_a_closed_one_only_outside() {
    // assimp's sphere with a hole (open, its hole facing −z), 3 cm in radius, centred at
    // the origin; the finger starts at its centre and pushes up through its wall, then
    // comes down onto its top from above. Both ways the wall holds it, 5 mm deep.
    let dir = dir_with_mesh(
        "meshes-open",
        "tests/corpus/sphereWithHole.stl",
        "sphere.stl",
    );
    let text = "name: open\nshapes:\n  - mesh: { file: sphere.stl, centre: [-0.03, -0.03, -0.03], scale: 0.02 }\n";
    let spec = parse(&dir, text).unwrap();
    let scenery = Scenery::new(&spec.shapes);
    let parameters = ProxyParameters {
        stiffness: 1000.0,
        damping: 0.0,
        static_friction: 0.0,
        dynamic_friction: 0.0,
    };
    let inner = first_hit(&spec.shapes, DVec3::ZERO, DVec3::Y);
    let top = 0.1 - first_hit(&spec.shapes, DVec3::new(0.0, 0.1, 0.0), DVec3::NEG_Y);
    assert!(
        (inner - 0.03).abs() < 1e-3 && (top - inner).abs() < 1e-9,
        "{inner} {top}"
    );
    let line = |from: f64, to: f64| -> Vec<DVec3> {
        let steps = ((to - from).abs() / 1e-3).ceil() as usize;
        (0..=steps)
            .map(|k| DVec3::new(0.0, from + (to - from) * k as f64 / steps as f64, 0.0))
            .collect()
    };
    let up = walk(&scenery, &line(0.0, inner + 0.005), &parameters);
    let held = up.last().unwrap();
    assert!(
        (*held - DVec3::new(0.0, -5.0, 0.0)).length() < 1e-6,
        "from inside: {held}"
    );
    let down = walk(&scenery, &line(0.06, top - 0.005), &parameters);
    let held = down.last().unwrap();
    assert!(
        (*held - DVec3::new(0.0, 5.0, 0.0)).length() < 1e-6,
        "from outside: {held}"
    );
    // The bracket is closed: it bounds a solid, and a finger inside it feels nothing until
    // it leaves.
    let dir = scene_dir("closed");
    let spec = parse(&dir, SCENE).unwrap();
    let inside = walk(
        &Scenery::new(&spec.shapes),
        &[
            DVec3::new(0.015, -0.017, 0.0),
            DVec3::new(0.015, -0.012, 0.0),
        ],
        &parameters,
    );
    assert_eq!(inside, [DVec3::ZERO], "a finger leaving the closed plate");
}
