//! A body the pointer holds (`pointer.holds`): left out of the world's bodies and made the
//! pointer's solid, rendered by a 6-DOF god-object kept out of the fixed bodies' exact
//! surfaces (`rendering: god-object`, the default) or tied to the grip by `coupling:`
//! (`rendering: coupling`).
//!
//! Under rapier the held body goes back among the world's bodies, last of the file's rigid
//! ones, as a body the proxy places: the haptic side renders its god-object against every
//! body's exact surface and pushes the bodies near it by local dynamics
//! (`hapticd_core::scene::held_part`).

use glam::{DQuat, DVec3};
use hapticd_core::diagnostics::Findings;
use hapticd_core::haptics::god_object::{GodObject, GodObjectParameters, Obstacle};
use hapticd_core::haptics::signed_mesh::SignedMesh;
use hapticd_core::kinematics::Wrench;
use hapticd_core::scene::held_part::HeldSpec;

use super::Engine;
use super::checks::Primitive;
use super::checks::{Bodies, Surface, rigid_body};
use super::meshes::MeshFiles;
use super::schema::{RawFeedback, RawRendering, RawScene};
use crate::body::Body;
use crate::coupling::Grip;
use crate::polyhedron::Polyhedron;

/// The body the pointer holds, as the file gives it and checked.
pub(super) struct Held {
    /// The body where the file puts it.
    body: Body,
    /// What each of its pieces is.
    primitives: Vec<Primitive>,
    /// Its triangles in its frame when it is a mesh.
    surface: Option<Surface>,
    /// Where the grip holds it: the point the file places (`position:`).
    grip: DVec3,
    /// Where the file gives it, for what is reported.
    at: String,
    /// How it is rendered.
    rendering: RawRendering,
}

/// The body `pointer.holds` names in `raw`, marked held (the world's bodies leave it out),
/// checked as a rigid body of a scene for `engine` with `pointers` pointers; None without
/// one, or after reporting what is wrong.
pub(super) fn take(
    f: &mut Findings,
    raw: &mut RawScene,
    engine: Engine,
    pointers: usize,
    files: &MeshFiles<'_>,
) -> Option<Held> {
    let pointer = raw.pointer.as_ref()?;
    let name = pointer.holds.as_ref()?;
    let mut ok = true;
    let mut refuse = |field: &str, why: String| {
        f.error(field, why);
        ok = false;
    };
    if pointers == 0 {
        refuse(
            "pointer.holds",
            "a held body needs a pointer to hold it, and this scene has none".into(),
        );
    }
    if engine == Engine::Rapier {
        if pointer.rendering == RawRendering::Coupling {
            refuse(
                "pointer.rendering",
                "under rapier a held body is rendered by the god-object".into(),
            );
        }
        if matches!(
            raw.feedback,
            Some(RawFeedback::Impulse | RawFeedback::Position)
        ) {
            refuse(
                "feedback",
                "a held body pushes the bodies near it by local dynamics: give local".into(),
            );
        }
    }
    if pointer.size.is_some() || pointer.hull.is_some() || pointer.sphere.is_some() {
        refuse(
            "pointer.holds",
            "the held body is the pointer's solid: give no box, hull or sphere".into(),
        );
    }
    if raw.grasp.is_some() {
        refuse(
            "pointer.holds",
            "a held body is held by the first pointer, not grasped: give no grasp".into(),
        );
    }
    if pointer.rendering == RawRendering::Coupling && pointer.coupling.is_none() {
        refuse(
            "pointer.rendering",
            "coupling needs pointer.coupling".into(),
        );
    }
    // The god-object's proxy moves by the spring's compliance: a spring of none would
    // leave it nowhere to go (one not a number is refused with the coupling's own checks).
    if let (RawRendering::GodObject, Some(c)) = (pointer.rendering, &pointer.coupling) {
        for (key, value) in [
            ("stiffness", c.stiffness),
            ("rotational_stiffness", c.rotational_stiffness),
        ] {
            if value <= 0.0 {
                refuse(
                    &format!("pointer.coupling.{key}"),
                    "the god-object's spring: more than 0".into(),
                );
            }
        }
    }
    let rendering = pointer.rendering;
    let Some(i) = raw.bodies.iter().position(|b| &b.name == name) else {
        refuse("pointer.holds", format!("no body is named {name:?}"));
        return None;
    };
    let at = format!("bodies[{i}]");
    let b = &mut raw.bodies[i];
    b.held = true;
    if b.fixed {
        refuse(
            &format!("{at}.fixed"),
            "the pointer holds it: it moves".into(),
        );
    }
    if b.soft.is_some() {
        refuse(
            &format!("{at}.soft"),
            "the pointer holds it: it is rigid".into(),
        );
    }
    if !ok {
        return None;
    }
    let grip = DVec3::from(b.position);
    let (body, primitives, surface) = rigid_body(f, &at, b, engine, files)?;
    if surface.is_none() && body.pieces.len() > 1 {
        f.error(
            format!("{at}.pieces"),
            "the pointer holds it: a mesh, a box, a hull or a ball, not pieces",
        );
        return None;
    }
    Some(Held {
        body,
        primitives,
        surface,
        grip,
        at,
        rendering,
    })
}

/// The held body of `raw` as the pointer's body: with its god-object among the fixed
/// `bodies` (`rendering: god-object`), or coupled (`rendering: coupling`).
pub(super) fn pointer_body(
    f: &mut Findings,
    raw: &RawScene,
    held: Held,
    bodies: &Bodies,
) -> Option<HeldPointer> {
    let Held {
        mut body,
        surface,
        grip,
        at,
        rendering,
        ..
    } = held;
    if rendering == RawRendering::Coupling {
        body.fixed = false;
        return Some((body, None));
    }
    // A mesh's own triangles, or the one convex piece's faces, about the point the grip
    // holds (a mesh's body frame is at its centre of volume, which the hand does not hold).
    let centre = body.orientation.inverse() * (body.position - grip);
    let surface = surface.unwrap_or_else(|| faces(&body.pieces[0]));
    let held: Vec<[DVec3; 3]> = surface.iter().map(|t| t.map(|c| c + centre)).collect();
    let surface = closed(f, &at, &held)?;
    let parameters = god_object_parameters(raw);
    let names: Vec<&str> = raw
        .bodies
        .iter()
        .filter(|b| b.rigid())
        .map(|b| b.name.as_str())
        .collect();
    let god = GodObject::new(surface, grip, body.orientation, parameters);
    let part = HeldPart::new(f, god, centre, (bodies, &names))?;
    (body.fixed, body.kinematic) = (true, true);
    Some((body, Some(part)))
}

/// The god-object's spring as `raw`'s `pointer.coupling:` gives it (the defaults without
/// one); its contacts hold with the material's (dynamic) friction, what the hand feels
/// sliding.
fn god_object_parameters(raw: &RawScene) -> GodObjectParameters {
    let mut parameters = GodObjectParameters {
        friction: raw.material.friction,
        ..GodObjectParameters::default()
    };
    if let Some(c) = raw.pointer.as_ref().and_then(|p| p.coupling.as_ref()) {
        parameters.stiffness = c.stiffness;
        parameters.damping = c.damping;
        parameters.rotational_stiffness = c.rotational_stiffness;
        parameters.rotational_damping = c.rotational_damping;
    }
    parameters
}

/// The held body of `raw` as rapier's: the body, its pieces, its mesh if it is one, its name,
/// and how it is held (numbered `body`).
pub(super) fn rapier_body(
    raw: &RawScene,
    held: Held,
    body: usize,
) -> (Body, Vec<Primitive>, Option<Surface>, String, HeldSpec) {
    let name = raw
        .pointer
        .as_ref()
        .and_then(|p| p.holds.clone())
        .unwrap_or_default();
    let grip = held.body.orientation.inverse() * (held.grip - held.body.position);
    let spec = HeldSpec {
        pointer: 0,
        body: body as u32,
        grip,
        parameters: god_object_parameters(raw),
    };
    (held.body, held.primitives, held.surface, name, spec)
}

/// Report at `pointer.holds` each body of `bodies`, and the `held` one, whose surface cannot
/// be touched exactly: the haptic side renders a held body of a rapier world against every
/// body's surface.
pub(super) fn check_surfaces(f: &mut Findings, held: &Held, bodies: &Bodies, names: &[&str]) {
    for piece in surface_pieces(&held.body, held.surface.as_ref()) {
        closed(f, &held.at, &piece);
    }
    let Bodies {
        bodies, surfaces, ..
    } = bodies;
    for (i, body) in bodies.iter().enumerate() {
        let at = format!("pointer.holds: {:?}", names[i]);
        for piece in surface_pieces(body, surfaces[i].as_ref()) {
            closed(f, &at, &piece);
        }
    }
}

/// Each closed piece of a body's surface, in its frame: a mesh's own triangles (`surface`),
/// else each convex piece's faces.
pub(super) fn surface_pieces(body: &Body, surface: Option<&Surface>) -> Vec<Surface> {
    match surface {
        Some(triangles) => vec![triangles.clone()],
        None => body.pieces.iter().map(faces).collect(),
    }
}

/// The triangles of `piece`'s faces, each face a fan from its first corner.
fn faces(piece: &Polyhedron) -> Vec<[DVec3; 3]> {
    let v = &piece.vertices;
    piece
        .faces
        .iter()
        .flat_map(|face| (1..face.len() - 1).map(|k| [v[face[0]], v[face[k]], v[face[k + 1]]]))
        .collect()
}

/// The surface of `triangles` for exact queries; None after reporting at `at` why it cannot
/// be one.
fn closed(f: &mut Findings, at: &str, triangles: &[[DVec3; 3]]) -> Option<SignedMesh> {
    SignedMesh::of_triangles(triangles)
        .map_err(|e| f.error(at, format!("its surface cannot be touched exactly: {e}")))
        .ok()
}

/// The held body as the pointer's body, and its god-object unless it is coupled.
pub(super) type HeldPointer = (Body, Option<HeldPart>);

/// A held body's god-object and the fixed bodies it cannot enter.
#[derive(Debug, Clone)]
pub(super) struct HeldPart {
    /// The god-object; its pose is where the grip holds the held body.
    god: GodObject,
    /// The held body's centre from where the grip holds it, in the body's frame.
    centre: DVec3,
    /// Each fixed body's surface (a mesh's own, or each of its convex pieces), in its frame,
    /// by body.
    obstacles: Vec<(usize, SignedMesh)>,
    /// What the god-object's spring gave at the last tick.
    pub(super) felt: Wrench,
}

impl HeldPart {
    /// The held body's `god`-object among the fixed ones of `bodies` (`names` naming them in
    /// what is reported); None after reporting a surface that cannot be touched exactly.
    fn new(
        f: &mut Findings,
        god: GodObject,
        centre: DVec3,
        (bodies, names): (&Bodies, &[&str]),
    ) -> Option<Self> {
        let Bodies {
            bodies, surfaces, ..
        } = bodies;
        let mut obstacles = Vec::new();
        for (i, body) in bodies.iter().enumerate().filter(|(_, b)| b.fixed) {
            let at = format!("pointer.holds: {:?}", names[i]);
            for piece in surface_pieces(body, surfaces[i].as_ref()) {
                obstacles.push((i, closed(f, &at, &piece)?));
            }
        }
        Some(Self {
            god,
            centre,
            obstacles,
            felt: Wrench::ZERO,
        })
    }

    /// Keep the god-object's query to its share of each tick by the wall clock (see
    /// [`GodObject::keep_to_the_clock`]).
    pub(super) fn keep_to_the_clock(&mut self) {
        self.god.keep_to_the_clock();
    }

    /// [rt] Move the proxy towards `grip` among `bodies` as they are now, `dt` after the last
    /// tick; keeps what the user feels of its spring.
    pub(super) fn follow(&mut self, grip: &Grip, dt: f64, bodies: &[Body]) {
        let obstacles = self.obstacles.iter().map(|(i, mesh)| Obstacle {
            mesh,
            position: bodies[*i].position,
            orientation: bodies[*i].orientation,
        });
        self.felt = self
            .god
            .update((grip.position, grip.orientation), dt, obstacles)
            .felt;
    }

    /// Where the held body is now: its centre and orientation.
    pub(super) fn body_pose(&self) -> (DVec3, DQuat) {
        let (at, turn) = self.god.pose();
        (at + turn * self.centre, turn)
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use glam::{DQuat, DVec3};
    use hapticd_core::kinematics::Wrench;

    use crate::coupling::Grip;
    use crate::scene::PenaltyScene;

    /// A block whose top is at y = 0 with a square hole 10.2 mm wide and 15 mm deep, of
    /// five box pieces, and a peg of `width` held by the pointer; `more` adds bodies.
    fn scene(width: f64, more: &str) -> String {
        format!(
            "name: peg
dt: 0.0001
material: {{ stiffness: 1.0e7, damping: 2.0e4, static_friction: 0.5, friction: 0.4,
            friction_stiffness: 1.0e7, friction_damping: 2.0e4, slip_speed: 0.001 }}
bodies:
  - name: block
    fixed: true
    position: [0, 0, 0]
    pieces:
      - {{ box: [0.0099, 0.015, 0.030], position: [-0.01005, -0.0075, 0] }}
      - {{ box: [0.0099, 0.015, 0.030], position: [0.01005, -0.0075, 0] }}
      - {{ box: [0.0102, 0.015, 0.0099], position: [0, -0.0075, -0.01005] }}
      - {{ box: [0.0102, 0.015, 0.0099], position: [0, -0.0075, 0.01005] }}
      - {{ box: [0.030, 0.010, 0.030], position: [0, -0.020, 0] }}
  - {{ name: peg, box: [{width}, 0.020, {width}], position: [0, 0.02, 0], density: 7800 }}
{more}pointer:
  holds: peg
"
        )
    }

    fn grip(position: DVec3) -> Grip {
        Grip {
            position,
            orientation: DQuat::IDENTITY,
            velocity: DVec3::ZERO,
            spin: DVec3::ZERO,
        }
    }

    /// The held peg of `width` lowered by the hand to 5 mm below the hole's floor: where its
    /// centre ends, and what the hand feels there.
    fn lowered(width: f64) -> (DVec3, Wrench) {
        let text = scene(width, "");
        let mut scene = PenaltyScene::parse(&text, Path::new("peg.yaml"), 1).unwrap();
        let mut felt = [Wrench::default()];
        for tick in 0..1000 {
            let y = 0.02 - 0.03 * (tick as f64 / 700.0).min(1.0);
            assert!(scene.step_pointers(1e-3, &[grip(DVec3::new(0.0, y, 0.0))], &mut felt));
        }
        (scene.world.bodies[scene.first_pointer].position, felt[0])
    }

    #[test]
    fn a_held_peg_goes_into_a_hole_it_fits_and_stops_on_one_it_does_not() {
        // 0.2 mm clearance: to the floor, 15 mm down, its centre 10 mm above it; the hand,
        // 5 mm further, feels the spring's 2 000 N/m of it.
        let (at, felt) = lowered(0.010);
        assert!((at.y + 0.005).abs() < 1e-5, "{at}");
        assert!((felt.force.y - 2000.0 * 0.005).abs() < 0.05, "{felt:?}");
        // 0.2 mm interference: on the rim, the block's top.
        let (at, felt) = lowered(0.0104);
        assert!((at.y - 0.010).abs() < 1e-5, "{at}");
        assert!((felt.force.y - 2000.0 * 0.020).abs() < 0.05, "{felt:?}");
    }

    #[test]
    fn a_held_peg_pushes_a_moving_body_and_the_hand_feels_it() {
        // A floor level with the block's foot, and a light box on it beside the block.
        let more =
            "  - { name: floor, box: [0.2, 0.01, 0.2], position: [0, -0.03, 0], fixed: true }
  - { name: box, box: [0.01, 0.01, 0.01], position: [0.05, -0.02, 0], density: 500 }
";
        let text = scene(0.010, more);
        let mut scene = PenaltyScene::parse(&text, Path::new("peg.yaml"), 1).unwrap();
        let mut felt = [Wrench::default()];
        let (mut pushed, mut most) = (0.0f64, 0.0f64);
        // Over beside the block, down to 3 mm above the floor, then along x into the box.
        let way = |tick: usize| match tick {
            0..200 => DVec3::new(0.025, 0.03, 0.0),
            200..400 => DVec3::new(0.025, 0.03 - 0.042 * (tick - 200) as f64 / 200.0, 0.0),
            _ => DVec3::new(
                0.025 + 0.04 * ((tick - 400) as f64 / 400.0).min(1.0),
                -0.012,
                0.0,
            ),
        };
        for tick in 0..900 {
            assert!(scene.step_pointers(1e-3, &[grip(way(tick))], &mut felt));
            most = most.max(-felt[0].force.x);
            pushed = pushed.max(scene.world.bodies[2].position.x - 0.05);
        }
        assert!(pushed > 0.01, "the box moved {pushed} m");
        assert!(most > 0.0, "the hand felt {most} N against the push");
    }

    #[test]
    fn on_a_device_of_two_the_first_pointer_holds_and_the_second_is_a_fingertip() {
        let text = scene(0.010, "");
        let mut scene = PenaltyScene::parse(&text, Path::new("peg.yaml"), 2).unwrap();
        let mut felt = [Wrench::default(); 2];
        // The peg held still where it starts; the fingertip (10 mm) pressed 2 mm into the
        // block's top beside the hole.
        let grips = [
            grip(DVec3::new(0.0, 0.02, 0.0)),
            grip(DVec3::new(0.012, 0.008, 0.0)),
        ];
        for _ in 0..200 {
            assert!(scene.step_pointers(1e-3, &grips, &mut felt));
        }
        assert!(felt[0].force.length() < 1e-9, "{felt:?}");
        assert!(felt[1].force.y > 1.0, "{felt:?}");
    }

    #[test]
    fn a_pointer_that_holds_what_it_cannot_is_refused_by_name() {
        let refused = |text: &str, pointers: usize, says: &str| {
            let e = PenaltyScene::parse(text, Path::new("peg.yaml"), pointers)
                .err()
                .unwrap_or_else(|| panic!("accepted: {text}"))
                .to_string();
            assert!(e.contains(says), "{e}");
        };
        let good = scene(0.010, "");
        refused(
            &good.replace("holds: peg", "holds: pig"),
            1,
            "no body is named \"pig\"",
        );
        refused(&good.replace("holds: peg", "holds: block"), 1, "it moves");
        refused(&good, 0, "a held body needs a pointer to hold it");
        refused(
            &format!("{good}grasp: {{ grip_stiffness: 1000, inertia_stiffness: 1000 }}\n"),
            2,
            "give no grasp",
        );
        refused(
            &good.replace("holds: peg", "holds: peg\n  sphere: 0.01"),
            1,
            "give no box, hull or sphere",
        );
        refused(
            &good.replace("holds: peg", "holds: peg\n  rendering: coupling"),
            1,
            "coupling needs pointer.coupling",
        );
        refused(
            &good.replace("holds: peg", "holds: peg\n  rendering: glue"),
            1,
            "rendering",
        );
        refused(
            &good.replace(
                "holds: peg",
                "holds: peg\n  coupling: { stiffness: 0, damping: 5 }",
            ),
            1,
            "the god-object's spring: more than 0",
        );
    }

    #[test]
    fn under_rapier_a_held_body_is_the_god_objects_with_local_dynamics_or_refused() {
        use crate::scene::SceneFile;
        // The penalty test's block and peg in rapier's world.
        let penalty = scene(0.010, "");
        let bodies = &penalty[penalty.find("bodies:").unwrap()..];
        let good = format!(
            "name: peg\nengine: rapier\nrate: 100\nmaterial: {{ static_friction: 0.5, friction: 0.4 }}\n{bodies}"
        );
        let Ok(SceneFile::Rapier(world)) = SceneFile::parse(&good, Path::new("peg.yaml"), 1) else {
            panic!("refused: {good}");
        };
        // The peg is the world's last rigid body, held at its middle.
        let held = world.held.expect("a held body");
        assert_eq!(held.body as usize, world.bodies.len() - 1);
        assert_eq!(world.names[held.body as usize], "peg");
        assert!(held.grip.length() < 1e-12, "{held:?}");
        assert_eq!(held.parameters.friction, 0.4);
        let refused = |text: String, says: &str| {
            let e = SceneFile::parse(&text, Path::new("peg.yaml"), 1)
                .err()
                .unwrap_or_else(|| panic!("accepted: {text}"))
                .to_string();
            assert!(e.contains(says), "{e}");
        };
        refused(
            good.replace(
                "holds: peg",
                "holds: peg\n  rendering: coupling\n  coupling: { stiffness: 1000, damping: 5 }",
            ),
            "under rapier a held body is rendered by the god-object",
        );
        refused(
            good.replace("rate: 100", "rate: 100\nfeedback: impulse"),
            "give local",
        );
    }
}
