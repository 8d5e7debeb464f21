//! Physics scene files: bodies of boxes, spheres, convex hulls or meshes, one material, gravity, the
//! shape of each pointer, and the engine that steps them (`engine:`):
//!
//! - `penalty` (the default): the contact-volume penalty method inside every haptic tick
//!   (thesis Ch. 5), in steps of `dt`, with the material's stiffness, damping and friction
//!   springs;
//! - `rapier`: rapier3d's constraint solver at `rate:` steps per second in hapticd's physics
//!   thread (thesis Ch. 6); the hand feels the surfaces near each pointer as planes moved
//!   between physics steps. The bodies near a pointer move with the hand in the haptic
//!   thread and the physics takes back what the hand did to them (`feedback: local`, thesis
//!   6.5.4, the default: of the three it alone pushes light bodies as far as physics at the
//!   haptic rate and throws none, `hapticctl experiment push-mass`); each body gets back the
//!   impulse of the force felt (`feedback: impulse`), or is pushed by a solid placed where
//!   the hand was when the physics sampled it (`feedback: position`, the conventional
//!   method).
//!
//! Bodies, gravity, `static_friction` and `friction` mean the same under both; a key only
//! one engine reads is an error, at its place, under the other. A penalty scene:
//!
//! ```yaml
//! name: blocks
//! gravity: [0, -9.81, 0]
//! dt: 0.00025                  # longest physics step; a haptic tick is split into steps
//! material:
//!   stiffness: 2.0e7           # N/m³: normal force per unit depth per unit area
//!   damping: 2.0e4             # N·s/m³
//!   static_friction: 0.5       # μ0
//!   friction: 0.4              # μ
//!   friction_stiffness: 2.0e7  # N/m³
//!   friction_damping: 2.0e4    # N·s/m³
//!   slip_speed: 0.001          # m/s
//!   model: volume              # or point: the deepest point only, for comparison
//!   point_stiffness: 1000      # N/m and N·s/m of the point model (default: the numbers of
//!   point_damping: 50          #   stiffness and damping, which the point model reads per point)
//!   scaling: { spring: 0.05, damper: 0.4 }   # optional: instead of the numbers above, each
//!                              #   contact a spring 2·spring·m/dt² and damper damper·m/dt for
//!                              #   its pair's reduced mass m (stable for any masses)
//!   texture: { kind: roughness, amplitude: 0.2, shortest: 0.0005, longest: 0.01 }   # optional:
//!   transient: { gain: 10, frequency: 250, decay: 0.01 }   # every surface's, felt by the hand
//!                              #   (a body's own `texture:` and `transient:` stand for it)
//! bodies:
//!   - name: floor
//!     box: [0.3, 0.02, 0.3]    # edge lengths, metres
//!     position: [0, -0.04, 0]
//!     fixed: true
//!   - name: block
//!     box: [0.03, 0.03, 0.03]
//!     position: [0.03, -0.015, 0]
//!     orientation: [1, 0, 0, 0]
//!     density: 500             # kg/m³
//!     inertial:                # optional, instead of density: its mass (kg), centre of mass
//!       mass: 0.2              #   (m, in its frame; default its origin) and inertia about
//!       centre: [0, 0, 0]      #   it ([ixx, iyy, izz, ixy, ixz, iyz], kg·m²), a solid's
//!       inertia: [3.0e-5, 3.0e-5, 3.0e-5, 0, 0, 0]
//!     velocity: [0, 0, 0]      # m/s, optional
//!     spin: [0, 0, 0]          # rad/s, optional
//!   - name: wedge
//!     hull: [[0, 0, 0], [0.02, 0, 0], [0, 0.02, 0], [0, 0, 0.02]]   # instead of box: the convex
//!     position: [-0.05, 0, 0]  #   hull of these points, relative to position
//!   - name: marble
//!     sphere: 0.008            # radius; the penalty engine uses a 42-vertex hull of the
//!     position: [0, 0.05, 0]   #   ball's volume (within 4 % of its surface)
//!   - name: arch               # a body that is not convex: convex pieces, each a box or a
//!     pieces:                  #   hull, placed relative to the body's position
//!       - { box: [0.01, 0.03, 0.03], position: [-0.02, 0, 0] }
//!       - { box: [0.01, 0.03, 0.03], position: [0.02, 0, 0] }
//!       - { box: [0.05, 0.01, 0.03], position: [0, 0.02, 0] }
//!     position: [0.1, 0.015, 0]
//!   - name: mug                # a body of a mesh file: OBJ, STL, glTF or GLB
//!     mesh: meshes/mug.obj     #   relative to the scene file, in its directory or below
//!     scale: 1                 #   the file's units to metres (optional)
//!     position: [-0.1, 0, 0]   #   where the file's origin goes, turned by orientation:
//!     density: 800             #   as the file has it
//!     shading: smooth          #   optional: felt round across its faces (haptic shading)
//! pointer:                     # optional: without one each pointer is a ball of 1 cm radius
//!   box: [0.01, 0.01, 0.01]    # each pointer: this solid (or a hull), centred at the grip
//!   coupling:                  # optional (thesis 4.1.2): the solid is a body of the world,
//!     stiffness: 400           #   tied to the grip by a spring (N/m) and damper (N·s/m),
//!     damping: 5               #   and the user feels their stretch; without it the solid
//!     rotational_stiffness: 0.5  # sits at the grip and the user feels its contacts
//!     rotational_damping: 0.01   # (N·m/rad, N·m·s/rad; both optional, default 0)
//!   density: 1000              # kg/m³ of a coupled pointer (its weight is felt too)
//! ```
//!
//! One pointer may hold a body of the scene instead (penalty engine), which is then its solid:
//!
//! ```yaml
//! name: peg
//! dt: 0.0001
//! material: { stiffness: 1.0e7, damping: 2.0e4, static_friction: 0.5, friction: 0.4,
//!             friction_stiffness: 1.0e7, friction_damping: 2.0e4, slip_speed: 0.001 }
//! bodies:
//!   - name: block              # its top at y = 0, a square hole 10.2 mm wide, 15 mm deep
//!     fixed: true
//!     position: [0, 0, 0]
//!     pieces:
//!       - { box: [0.0099, 0.015, 0.030], position: [-0.01005, -0.0075, 0] }
//!       - { box: [0.0099, 0.015, 0.030], position: [0.01005, -0.0075, 0] }
//!       - { box: [0.0102, 0.015, 0.0099], position: [0, -0.0075, -0.01005] }
//!       - { box: [0.0102, 0.015, 0.0099], position: [0, -0.0075, 0.01005] }
//!       - { box: [0.030, 0.010, 0.030], position: [0, -0.020, 0] }
//!   - { name: peg, box: [0.01, 0.02, 0.01], position: [0, 0.02, 0], density: 7800 }
//! pointer:
//!   holds: peg                 # a body of bodies: (a mesh, a box, a hull or a ball)
//!   rendering: god-object      # the default: a 6-DOF god-object kept out of the fixed
//!                              #   bodies' exact surfaces, the hand feeling the spring to it;
//!                              #   or coupling: coupled by coupling: (then required)
//! ```
//!
//! A mesh must close a volume (every edge shared by two faces): its mass, centre and
//! inertia are those of that volume. Both engines touch a movable mesh through convex pieces
//! (V-HACD at 64 voxels along its longest side), cut once and kept by the mesh's content in
//! hapticd's cache directory (`/var/cache/hapticd`; `hapticctl mesh decompose` cuts one ahead
//! and says how many pieces, how far their volume strays from the mesh's, and how long it
//! took). A fixed mesh keeps its own triangles under rapier, so a hole in it is a hole; the
//! penalty engine, which integrates over intersections of convex solids, cuts fixed meshes
//! too. A world of the penalty engine holds at most 256 pieces, pointers and meshes' pieces
//! included. A mesh file is read from the scene file's directory or below alone, with at most
//! 500 000 vertices and triangles in 64 MiB; a scene sent by descriptor names none.
//!
//! Scenes for two or more pointers may let them hold bodies (thesis 4.2–4.7): a body that is
//! one `box:` is held while two pointers press it from opposite sides, and let go when they
//! open (see `config/scenes/grasp.yaml`):
//!
//! ```yaml
//! name: grasp
//! gravity: [0, -2.0, 0]
//! dt: 0.0005
//! material: { stiffness: 2.0e7, damping: 2.0e4, static_friction: 1.0, friction: 1.0,
//!             friction_stiffness: 2.0e7, friction_damping: 2.0e4, slip_speed: 0.02 }
//! bodies:
//!   - { name: table, box: [0.3, 0.04, 0.3], position: [0, -0.17, 0], fixed: true }
//!   - { name: box, box: [0.06, 0.1, 0.06], position: [0, -0.1, 0], density: 2777.8 }
//! pointer:
//!   box: [0.01, 0.01, 0.01]
//! grasp:
//!   method: distributed        # the shape shell and the resultant shared among the fingers;
//!                              #   or conventional: one spring per finger (for comparison)
//!   grip_stiffness: 800        # N/m from each pointer to the surface it holds
//!   inertia_stiffness: 800     # N/m from the shell to the body (moments scale with size²)
//!   inertia_damping: 10        # N·s/m; optional, default 0.35·√(kr·m) for each body
//! ```
//!
//! In such a scene the pointers touch box bodies through the grasp springs (grasped or not),
//! and held bodies stick to them up to the material's `static_friction`.
//!
//! A rapier scene (see `config/scenes/balls.yaml`):
//!
//! ```yaml
//! name: tray
//! engine: rapier
//! rate: 20                     # physics steps per second (10–1000)
//! feedback: local              # or impulse, or position
//! gravity: [0, -9.81, 0]
//! material:
//!   static_friction: 0.3       # rapier's contacts stick and slide at μ; the proxy the
//!   friction: 0.3              #   hand feels sticks at μ0
//! bodies:
//!   - { name: floor, box: [0.3, 0.02, 0.3], position: [0, -0.04, 0], fixed: true }
//!   - { name: ball, sphere: 0.015, position: [0, -0.015, 0], density: 7800 }
//! pointer:
//!   sphere: 0.005              # the solid that pushes under feedback: position
//! ```

//!
//! The format by concern: [`schema`] (the keys), [`checks`] (what they must be, section by
//! section), [`penalty`] and [`rapier`] (each engine's scene, built from a checked file),
//! [`stepping`] (a penalty scene stepped in the haptic thread).

mod checks;
mod contacts;
mod control;
mod geometry;
mod held;
mod joints;
mod meshes;
mod penalty;
mod rapier;
mod schema;
mod soft;
mod stepping;
mod urdf;

use std::path::Path;

use hapticd_core::diagnostics::{self, Diagnostics, Findings};
use hapticd_mesh::cache::Cache;
use hapticd_plugin_api::Geometry;

use crate::soft::SOFT_TICK;

pub use checks::{
    DENSITY_RANGE, GRASP_STIFFNESS, INERTIA_DAMPING_FACTOR, MAX_DT, MAX_GRASP_DAMPING, MAX_GRAVITY,
    MAX_HULL_POINTS, MAX_PIECES, MAX_POINTERS, MAX_SPEED, MAX_STEPS_PER_CALL, MIN_DT, Primitive,
    RATE_RANGE,
};
pub use geometry::soft_corners;
pub use joints::WORLD;
pub use meshes::SCALE_RANGE;
pub use penalty::PenaltyScene;
pub use rapier::{Feedback, RapierScene};
use schema::{RawPointer, RawScene};

/// Which simulator steps a scene file's world (`engine:`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Engine {
    /// The contact-volume penalty method inside every haptic tick (thesis Ch. 5).
    Penalty,
    /// rapier3d's constraint solver at `rate:` in a physics thread (thesis Ch. 6).
    Rapier,
}

/// A physics scene file, read for the engine it names.
pub enum SceneFile {
    /// `engine: penalty` (the default).
    Penalty(Box<PenaltyScene>),
    /// `engine: rapier`.
    Rapier(Box<RapierScene>),
}

impl SceneFile {
    /// Load the scene file at `path` for `pointers` pointers.
    pub fn load(path: &Path, pointers: usize) -> Result<Self, Diagnostics> {
        Self::parse(&diagnostics::read_text(path)?, path, pointers)
    }

    /// Parse scene `text` for `pointers` pointers; `path` names it in diagnostics, which
    /// come all at once, each at its line and column, and its directory holds the meshes it
    /// names, whose convex pieces come from this process's cache
    /// ([`Cache::from_environment`]).
    pub fn parse(text: &str, path: &Path, pointers: usize) -> Result<Self, Diagnostics> {
        Self::parse_cached(text, path, pointers, &Cache::from_environment())
    }

    /// [`SceneFile::parse`] with the meshes' pieces from `cache`.
    pub fn parse_cached(
        text: &str,
        path: &Path,
        pointers: usize,
        cache: &Cache,
    ) -> Result<Self, Diagnostics> {
        Self::parse_with(
            text,
            path,
            pointers,
            meshes::MeshFiles::of_scene(path, Some(cache)),
        )
    }

    /// Check the scene file at `path` for `pointers` pointers as [`SceneFile::load`] would,
    /// its meshes read and measured but not cut into pieces (which can take minutes): the
    /// scene that comes back touches its meshes through nothing, and only says the file is
    /// sound.
    pub fn check(path: &Path, pointers: usize) -> Result<Self, Diagnostics> {
        let text = diagnostics::read_text(path)?;
        Self::parse_with(
            &text,
            path,
            pointers,
            meshes::MeshFiles::of_scene(path, None),
        )
    }

    fn parse_with(
        text: &str,
        path: &Path,
        pointers: usize,
        files: meshes::MeshFiles<'_>,
    ) -> Result<Self, Diagnostics> {
        let parsed = diagnostics::parse_yaml::<RawScene>(text, path)?;
        let (mut raw, map) = (parsed.value, parsed.map);
        // A scene that names no pointer solid gets a fingertip, so that every scene runs on
        // every device.
        if pointers > 0 {
            raw.pointer.get_or_insert_with(RawPointer::fingertip);
        }
        let locate = |field: &str| map.find(field);
        let mut f = Findings::after_schema(path, &locate, parsed.schema);
        urdf::expand(&mut f, &mut raw, path);
        let (engine, penalty) = checks::scene_keys(&mut f, &raw);
        let held = held::take(&mut f, &mut raw, engine, pointers, &files);
        let Some(bodies) = checks::bodies(&mut f, &raw, engine, pointers, &files) else {
            return Err(f.into_error());
        };
        // A soft body is stepped each device tick under the penalty engine, each physics
        // step under rapier.
        let tick = match penalty {
            Some(_) => SOFT_TICK,
            None => 1.0 / rapier::physics_rate(&raw),
        };
        let soft = soft::soft_bodies(&mut f, &raw, (engine, tick), &bodies.bodies, &files);
        let named: Vec<(&str, bool)> = raw
            .bodies
            .iter()
            .filter(|b| b.rigid())
            .map(|b| (b.name.as_str(), b.fixed))
            .collect();
        let joints = joints::joints(&mut f, &raw.joints, &named);
        let pointer = checks::pointer(&mut f, &raw, pointers);
        // A coupled pointer moves on its own: a soft body pushes it, as any body that moves.
        if let (Some(_), Some((shape, _)), Some(coupled)) = (
            &penalty,
            &pointer,
            raw.pointer.as_ref().filter(|p| p.coupling.is_some()),
        ) {
            let body = crate::body::Body::new(shape, coupled.density, false);
            let gravity = glam::DVec3::from(raw.gravity);
            for s in &soft {
                let name = ("the coupled pointer", &body);
                soft::rests_on(
                    &mut f,
                    "pointer.density",
                    name,
                    &s.lattice(gravity),
                    gravity.length(),
                );
            }
        }
        // The penalty engine makes the held body the pointer's; rapier keeps it a body.
        let (held, rapier_held) = match penalty {
            Some(_) => (
                held.and_then(|held| held::pointer_body(&mut f, &raw, held, &bodies)),
                None,
            ),
            None => {
                if let Some(held) = &held {
                    let names: Vec<&str> = named.iter().map(|(name, _)| *name).collect();
                    held::check_surfaces(&mut f, held, &bodies, &names);
                }
                (None, held)
            }
        };
        checks::grasp(&mut f, &raw, pointers);
        if let Some(penalty) = &penalty
            && !f.has_errors()
        {
            checks::stability(&mut f, &raw.material, penalty.dt, &bodies.bodies);
            checks::joint_springs(&mut f, &joints, penalty.dt, &bodies.bodies);
        }
        let warnings = f.finish()?;
        Ok(match penalty {
            None => SceneFile::Rapier(Box::new(RapierScene::build(
                raw,
                (bodies, joints, soft),
                (pointer, rapier_held),
                warnings,
            ))),
            Some(penalty) => SceneFile::Penalty(Box::new(PenaltyScene::build(
                raw,
                penalty,
                (bodies, joints, soft),
                (pointer, held),
                pointers,
                warnings,
            ))),
        })
    }

    /// The world's solids, for pictures.
    pub fn geometry(&self) -> Geometry {
        match self {
            SceneFile::Penalty(scene) => scene.geometry(),
            SceneFile::Rapier(scene) => scene.geometry(),
        }
    }

    /// The engine that runs the scene.
    pub fn engine(&self) -> Engine {
        match self {
            SceneFile::Penalty(_) => Engine::Penalty,
            SceneFile::Rapier(_) => Engine::Rapier,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped(name: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../config/scenes")
            .join(name)
    }

    fn parse(text: &str, pointers: usize) -> Result<PenaltyScene, Diagnostics> {
        PenaltyScene::parse(text, Path::new("s.yaml"), pointers)
    }

    #[test]
    fn grasp_settings_are_checked_each_at_its_place() {
        let text = std::fs::read_to_string(shipped("grasp.yaml")).unwrap();
        let scene = parse(&text, 2).unwrap();
        assert!(scene.grasping.is_some());
        // One pointer holds nothing: no grasping, and no error either.
        assert!(parse(&text, 1).unwrap().grasping.is_none());
        for (from, to, expected) in [
            (
                "grip_stiffness: 800",
                "grip_stiffness: .nan",
                "grasp.grip_stiffness",
            ),
            (
                "inertia_stiffness: 800",
                "inertia_stiffness: 1.0e9",
                "grasp.inertia_stiffness",
            ),
            (
                "method: distributed",
                "method: telepathic",
                "`telepathic` is not one of",
            ),
            (
                "grip_stiffness: 800",
                "grip_stiffnes: 800",
                "grasp.grip_stiffnes: unknown key",
            ),
            (
                "box: [0.01, 0.01, 0.01]      # each finger",
                "box: [0.01, 0.01, 0.01]\n  coupling: { stiffness: 400, damping: 5 }\n  #",
                "not coupled ones",
            ),
        ] {
            assert!(text.contains(from), "{from}");
            let e = parse(&text.replace(from, to), 2).err().unwrap().to_string();
            assert!(e.contains(expected), "{to}: {e}");
        }
    }

    #[test]
    fn the_shipped_scenes_parse() {
        let scene = PenaltyScene::load(&shipped("blocks.yaml"), 2).unwrap();
        assert_eq!(scene.world.bodies.len(), scene.first_pointer + 2);
        assert!(scene.world.bodies[scene.first_pointer].fixed);
        for (name, bodies) in [("cube-drop.yaml", 2), ("stack.yaml", 14), ("top.yaml", 2)] {
            let scene = PenaltyScene::load(&shipped(name), 0).unwrap();
            assert_eq!(scene.world.bodies.len(), bodies, "{name}");
            // Without a pointer of its own, each pointer is a fingertip: a ball of 1 cm.
            let touched = PenaltyScene::load(&shipped(name), 1).unwrap();
            assert_eq!(touched.world.bodies.len(), bodies + 1, "{name}");
            let tip = &touched.world.bodies[bodies];
            let ball = 4.0 / 3.0 * std::f64::consts::PI * 0.01f64.powi(3) * 1000.0;
            assert!(
                (tip.mass - ball).abs() < 0.05 * ball,
                "{name}: {}",
                tip.mass
            );
        }
    }

    #[test]
    fn bad_scenes_are_refused() {
        let good = std::fs::read_to_string(shipped("blocks.yaml")).unwrap();
        assert!(parse(&good.replacen("dt: ", "dt: -", 1), 1).is_err());
        assert!(parse(&format!("{good}\nspeed: 3\n"), 1).is_err());
        assert!(parse(&good.replacen("density: 500", "density: 0", 1), 1).is_err());
        let scaled = "material:\n  scaling: { spring: 0.05, damper: 0.4 }\n";
        assert!(parse(&good.replacen("material:\n", scaled, 1), 1).is_ok());
        let unstable = "material:\n  scaling: { spring: 0, damper: 0.4 }\n";
        assert!(parse(&good.replacen("material:\n", unstable, 1), 1).is_err());
    }

    #[test]
    fn one_format_serves_both_engines_and_engine_specific_keys_are_located() {
        let push = std::fs::read_to_string(shipped("push.yaml")).unwrap();
        let SceneFile::Rapier(world) = SceneFile::parse(&push, Path::new("push.yaml"), 1).unwrap()
        else {
            panic!("push.yaml is a rapier scene");
        };
        assert_eq!((world.rate, world.feedback), (20.0, Feedback::Local));
        assert_eq!(world.names, ["floor", "block"]);
        assert!((world.bodies[1].mass - 8.0).abs() < 1e-9);
        assert!(matches!(world.pointer, Some((_, Primitive::Ball { radius })) if radius == 0.005));
        // The penalty engine reads the same bodies (and runs nothing else).
        let as_penalty = push.replace("engine: rapier", "engine: penalty");
        let e = SceneFile::parse(&as_penalty, Path::new("s.yaml"), 1)
            .err()
            .unwrap()
            .to_string();
        for expected in [
            "s.yaml:6:7: error: rate: only for engine: rapier",
            "material.stiffness: missing",
        ] {
            assert!(e.contains(expected), "{e}");
        }
        let blocks = std::fs::read_to_string(shipped("blocks.yaml")).unwrap();
        let as_rapier = blocks.replace("name: blocks", "name: blocks\nengine: rapier\nrate: 50");
        let e = parse(&as_rapier, 1).err().unwrap().to_string();
        assert!(
            e.contains("s.yaml:8:5: error: dt: only for engine: penalty"),
            "{e}"
        );
        assert!(
            e.contains("s.yaml:10:14: error: material.stiffness: only for engine: penalty"),
            "{e}"
        );
        for (from, to, expected) in [
            (
                "rate: 20 ",
                "rate: 5000 ",
                "rate: must be a number from 10 to 1000 Hz",
            ),
            (
                "feedback: local",
                "feedback: telepathy",
                "`telepathy` is not one of",
            ),
            ("engine: rapier", "engine: bullet", "`bullet` is not one of"),
            (
                "sphere: 0.005",
                "sphere: .nan",
                "pointer.sphere: must be a number",
            ),
            (
                "box: [0.1, 0.1, 0.1]",
                "box: [0.1, 0.1, 0.1]\n    sphere: 0.1",
                "exactly one of",
            ),
        ] {
            assert!(push.contains(from), "{from}");
            let e = SceneFile::parse(&push.replace(from, to), Path::new("s.yaml"), 1)
                .err()
                .unwrap()
                .to_string();
            assert!(e.contains(expected), "{to}: {e}");
        }
        // A rapier file is no penalty scene.
        let e = PenaltyScene::parse(&push, Path::new("s.yaml"), 1)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("s.yaml:5:9: error: engine: a rapier scene"),
            "{e}"
        );
    }

    #[test]
    fn a_sphere_under_the_penalty_engine_has_the_balls_mass_and_rests_at_its_radius() {
        let text = "name: ball
dt: 0.0005
gravity: [0, -9.81, 0]
material: { stiffness: 1.0e7, damping: 3.0e4, static_friction: 0.5, friction: 0.4,
            friction_stiffness: 1.0e7, friction_damping: 2.0e4, slip_speed: 0.001 }
bodies:
  - { name: floor, box: [0.4, 0.1, 0.4], position: [0, -0.05, 0], fixed: true }
  - { name: ball, sphere: 0.02, position: [0, 0.02, 0], density: 1000 }
";
        let mut scene = parse(text, 0).unwrap();
        let ball = &scene.world.bodies[1];
        let exact = 1000.0 * 4.0 / 3.0 * std::f64::consts::PI * 0.02f64.powi(3);
        assert!((ball.mass / exact - 1.0).abs() < 1e-12, "{} kg", ball.mass);
        // Within 1 % of a solid ball's 2/5·m·r² about every axis.
        let moment = 0.4 * exact * 0.02f64.powi(2);
        for k in 0..3 {
            assert!((ball.inertia.col(k)[k] / moment - 1.0).abs() < 0.01);
        }
        for _ in 0..4000 {
            assert!(scene.step_pointers(5e-4, &[], &mut []));
        }
        // At rest on the floor within the hull's 4 % and the spring's millimetre fraction.
        let y = scene.world.bodies[1].position.y;
        assert!((y - 0.02).abs() < 0.04 * 0.02, "{y}");
    }

    #[test]
    fn every_mistake_is_reported_at_its_line() {
        let text = "\
name: three-mistakes
gravity: [0, .nan, 0]
dt: 0.001
material: { stiffness: 1.0e7, damping: -5, static_friction: 0.5, friction: 0.4,
            friction_stiffness: 1.0e7, friction_damping: 2.0e4, slip_speed: 0.001 }
bodies:
  - { name: floor, box: [1, 0.1, 1], position: [0, -0.05, 0], fixed: true }
  - name: block
    box: [0.03, 0, 0.03]
    position: [0, 0.1, 0]
";
        let e = parse(text, 0).err().expect("three mistakes").to_string();
        let lines: Vec<_> = e.lines().collect();
        assert_eq!(
            lines,
            [
                "s.yaml:2:10: error: gravity: must be a finite number",
                "s.yaml:4:40: error: material.damping: must be a finite number ≥ 0",
                "s.yaml:9:17: error: bodies[1].box[1]: must be a number from 0.0001 to 1000 m, not 0",
            ]
        );
    }

    #[test]
    fn schema_mistakes_come_with_the_checks_of_values() {
        let text = "\
name: five-mistakes
colour: red
dt: 0.001
material: { stiffness: 1.0e7, damping: 5, static_friction: 0.5, friction: 0.4,
            friction_stiffness: 1.0e7, friction_damping: 2.0e4, slip_speed: .nan }
bodies:
  - { name: floor, box: [1, 0.1], position: [0, -0.05, 0], fixed: maybe }
  - name: ball
    sphere: -0.02
    position: [0, 0.1, 0]
";
        let e = parse(text, 0).err().expect("five mistakes").to_string();
        let lines: Vec<_> = e.lines().collect();
        assert_eq!(lines.len(), 5, "{e}");
        assert!(
            lines[0].starts_with("s.yaml:2:1: error: colour: unknown key"),
            "{e}"
        );
        assert!(
            lines[1].starts_with("s.yaml:7:25: error: bodies[0].box: expected a list of 3 items"),
            "{e}"
        );
        assert!(
            lines[2].starts_with("s.yaml:7:67: error: bodies[0].fixed: expected true or false"),
            "{e}"
        );
        assert!(
            lines[3].starts_with("s.yaml:5:77: error: material.slip_speed: must be"),
            "{e}"
        );
        assert!(
            lines[4].starts_with("s.yaml:9:13: error: bodies[1].sphere: must be"),
            "{e}"
        );
    }
}
