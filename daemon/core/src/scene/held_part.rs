//! A body a pointer holds in a multi-rate world (thesis 7.2 with 6.5.4): rendered in the
//! haptic thread by a 6-DOF god-object ([`GodObject`]) against the exact surfaces of the
//! fixed bodies and of the bodies the physics hands over to move here (local dynamics).
//!
//! What the part touches of a moved body pushes it: each tick, the contacts' forces on that
//! body (their push and friction, reversed) become one force along their resultant's line
//! of action, which the body's local dynamics takes as the hand's push, so the body moves
//! under the part at the haptic rate and the next tick meets it where it went. What the hand
//! did to it goes back to the physics as for a fingertip's push. A body the physics does not
//! hand over is not met: a world hands over the bodies near the held one.

use glam::DVec3;
use hapticd_plugin_api::HAPTICD_MAX_LOCAL_BODIES;

use super::exact_shapes::SurfacePiece;
use super::local_dynamics::{LocalBody, Motion};
use crate::haptics::god_object::{GodObject, GodObjectOutput, GodObjectParameters, Obstacle};
use crate::haptics::signed_mesh::SignedMesh;
use crate::kinematics::Pose;

/// A force and a torque about a body's centre, what the part's contacts give it in a tick.
pub type Load = (DVec3, DVec3);

/// A body a pointer holds, as a world describes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldSpec {
    /// The pointer that holds it.
    pub pointer: usize,
    /// Its number among the world's bodies.
    pub body: u32,
    /// The point the grip holds, in the body's frame (about its centre of mass), metres.
    pub grip: DVec3,
    /// Its god-object's spring and friction.
    pub parameters: GodObjectParameters,
}

/// The surfaces a held body meets: each a solid's closed surface in its body's frame (whose
/// origin is the body's centre of mass).
#[derive(Debug, Clone, Default)]
struct HeldWorld {
    /// The fixed bodies' surfaces, each where its body stands.
    fixed: Vec<(SignedMesh, Pose)>,
    /// The surfaces of the bodies that move, each with its body's number.
    moving: Vec<(u32, SignedMesh)>,
}

/// A held body and its god-object.
#[derive(Debug, Clone)]
pub struct HeldPart {
    pointer: usize,
    body: u32,
    god: GodObject,
    /// The held body's centre of mass from the point the grip holds, in the body's frame.
    centre: DVec3,
    world: HeldWorld,
    /// How fast the held body's centre moved over the last tick, m/s.
    velocity: DVec3,
}

impl HeldPart {
    /// Body `body`, held by pointer `pointer`: its surface `part` about the point the grip
    /// holds, which starts at `at` (the body's orientation there), its centre of mass at
    /// `centre` from that point in its frame, rendered with `parameters` among `world`
    /// (which must leave the held body out).
    fn new(
        (pointer, body): (usize, u32),
        part: SignedMesh,
        (at, centre): (Pose, DVec3),
        parameters: GodObjectParameters,
        world: HeldWorld,
    ) -> Self {
        Self {
            pointer,
            body,
            god: GodObject::new(part, at.position, at.orientation, parameters),
            centre,
            world,
            velocity: DVec3::ZERO,
        }
    }

    /// The held body of `spec` among `pieces` (the surfaces of every body of the world, the
    /// held one's included): the reason when one cannot be touched exactly, naming its body.
    /// Built here, off the haptic thread.
    pub fn build(spec: &HeldSpec, pieces: &[SurfacePiece]) -> Result<Self, String> {
        let surface = |piece: &SurfacePiece, shift: DVec3| {
            let triangles: Vec<[DVec3; 3]> = piece
                .triangles
                .iter()
                .map(|t| t.map(|c| c + shift))
                .collect();
            SignedMesh::of_triangles(&triangles).map_err(|e| {
                format!(
                    "body {}'s surface cannot be touched exactly: {e}",
                    piece.body
                )
            })
        };
        let mut held = pieces.iter().filter(|p| p.body == spec.body);
        let (Some(own), None) = (held.next(), held.next()) else {
            return Err(format!(
                "the held body {} needs one closed surface to be held by",
                spec.body
            ));
        };
        let part = surface(own, -spec.grip)?;
        let mut world = HeldWorld::default();
        for piece in pieces.iter().filter(|p| p.body != spec.body) {
            let mesh = surface(piece, DVec3::ZERO)?;
            match piece.fixed {
                true => world.fixed.push((mesh, piece.pose)),
                false => world.moving.push((piece.body, mesh)),
            }
        }
        let at = Pose {
            position: own.pose.transform_point(spec.grip),
            orientation: own.pose.orientation,
        };
        Ok(Self::new(
            (spec.pointer, spec.body),
            part,
            (at, -spec.grip),
            spec.parameters,
            world,
        ))
    }

    /// Keep the god-object's query to its share of each tick by the wall clock, as on the
    /// haptic thread (see [`GodObject::keep_to_the_clock`]).
    pub fn keep_to_the_clock(&mut self) {
        self.god.keep_to_the_clock();
    }

    /// The pointer that holds it.
    pub fn pointer(&self) -> usize {
        self.pointer
    }

    /// The held body's number in the scene.
    pub fn body(&self) -> u32 {
        self.body
    }

    /// Where the proxy is: the point the grip holds, and the body's orientation.
    pub fn proxy(&self) -> Pose {
        let (position, orientation) = self.god.pose();
        Pose {
            position,
            orientation,
        }
    }

    /// Where the held body is and how it moves: its centre of mass.
    pub fn motion(&self) -> Motion {
        let proxy = self.proxy();
        Motion {
            position: proxy.transform_point(self.centre),
            orientation: proxy.orientation,
            velocity: self.velocity,
            spin: DVec3::ZERO,
        }
    }

    /// [rt] Move the proxy towards `grip` among the fixed bodies and the `locals` as they are
    /// shown now, `dt` after the last tick: what the god-object gives, and what its contacts
    /// load each of `locals` with (the torque about the centre its local dynamics has).
    pub fn follow(
        &mut self,
        grip: Pose,
        dt: f64,
        locals: &[Option<LocalBody>; HAPTICD_MAX_LOCAL_BODIES],
    ) -> (GodObjectOutput, [Load; HAPTICD_MAX_LOCAL_BODIES]) {
        let was = self.motion().position;
        // Each body where it is shown (what the part meets), and the centre its local
        // dynamics turns it about (what its push is taken about), once a tick.
        let placed = locals.map(|b| b.map(|b| (b.body, b.shown().pose(), b.motion().position)));
        let fixed = self.world.fixed.iter().map(|(mesh, pose)| Obstacle {
            mesh,
            position: pose.position,
            orientation: pose.orientation,
        });
        let shown = moving_shown(&self.world.moving, &placed).map(|(_, mesh, at)| Obstacle {
            mesh,
            position: at.position,
            orientation: at.orientation,
        });
        let out = self
            .god
            .update((grip.position, grip.orientation), dt, fixed.chain(shown));
        if dt > 0.0 {
            self.velocity = (self.motion().position - was) / dt;
        }
        let mut loads = [(DVec3::ZERO, DVec3::ZERO); HAPTICD_MAX_LOCAL_BODIES];
        let first = self.world.fixed.len();
        for c in self.god.contacts() {
            let Some(k) = c.obstacle.checked_sub(first) else {
                continue;
            };
            let Some((i, _, _)) = moving_shown(&self.world.moving, &placed).nth(k) else {
                continue;
            };
            let Some((_, _, centre)) = placed[i] else {
                continue;
            };
            let on_body = -(c.normal * c.force + c.friction);
            let (force, torque) = &mut loads[i];
            *force += on_body;
            *torque += (c.point - centre).cross(on_body);
        }
        (out, loads)
    }
}

/// A local body's number, where it is shown and the centre its local dynamics turns it
/// about, by slot.
type Placed = [Option<(u32, Pose, DVec3)>; HAPTICD_MAX_LOCAL_BODIES];

/// Each surface of `moving` whose body is among the `placed` local bodies, with that body's
/// slot and where it is shown now.
fn moving_shown<'a>(
    moving: &'a [(u32, SignedMesh)],
    placed: &'a Placed,
) -> impl Iterator<Item = (usize, &'a SignedMesh, Pose)> + 'a {
    placed
        .iter()
        .enumerate()
        .filter_map(|(i, b)| Some((i, (*b)?)))
        .flat_map(move |(i, (body, shown, _))| {
            moving
                .iter()
                .filter(move |(of, _)| *of == body)
                .map(move |(_, mesh)| (i, mesh, shown))
        })
}

/// The point on the line of action of `force` with `torque` about `centre` nearest the
/// centre: where that force alone gives the torque (all of it across the force).
pub fn line_of_action(centre: DVec3, (force, torque): Load) -> DVec3 {
    centre + force.cross(torque) / force.length_squared()
}

#[cfg(test)]
mod tests {
    use glam::DQuat;
    use hapticd_plugin_api::HapticdLocalBody;

    use super::*;
    use crate::haptics::fixtures::box_faces;
    use crate::kinematics::{quat_to_wxyz, rotation_vector};
    use crate::scene::local_dynamics::Change;

    /// A 2 cm cube of `body` standing at `position`.
    fn cube(body: u32, fixed: bool, position: DVec3) -> SurfacePiece {
        SurfacePiece {
            body,
            fixed,
            pose: Pose {
                position,
                orientation: DQuat::IDENTITY,
            },
            triangles: box_faces(DVec3::ZERO, DVec3::splat(0.01)),
            exact: None,
        }
    }

    fn spec() -> HeldSpec {
        HeldSpec {
            pointer: 0,
            body: 0,
            grip: DVec3::new(0.0, 0.005, 0.0),
            parameters: GodObjectParameters::default(),
        }
    }

    #[test]
    fn a_held_body_without_one_closed_surface_is_refused_naming_the_body() {
        let mut open = cube(1, true, DVec3::X);
        open.triangles.pop();
        let e = HeldPart::build(&spec(), &[cube(0, false, DVec3::ZERO), open]).unwrap_err();
        assert!(e.contains("body 1's surface") && e.contains("open"), "{e}");
        let two = [cube(0, false, DVec3::ZERO), cube(0, false, DVec3::Y)];
        let e = HeldPart::build(&spec(), &two).unwrap_err();
        assert!(e.contains("one closed surface"), "{e}");
        // It starts where its body stands, held at its grip.
        let part = HeldPart::build(&spec(), &[cube(0, false, DVec3::ZERO)]).unwrap();
        assert_eq!(part.proxy().position, DVec3::new(0.0, 0.005, 0.0));
        assert_eq!(part.motion().position, DVec3::ZERO);
    }

    #[test]
    fn a_moved_body_is_loaded_with_the_springs_pull_along_its_line() {
        // The held cube at the origin, a free cube of body 1 beside it along x (a gap of
        // 1 mm), moved here; the grip 3 mm into it and 2 mm aside, so that the contacts
        // push off the body's centre.
        let (held, other) = (
            cube(0, false, DVec3::ZERO),
            cube(1, false, DVec3::X * 0.021),
        );
        let mut part = HeldPart::build(&spec(), &[held, other.clone()]).unwrap();
        let published = HapticdLocalBody {
            body: 1,
            position: other.pose.position.to_array(),
            orientation: quat_to_wxyz(DQuat::IDENTITY),
            inverse_mass: 10.0,
            inverse_inertia: [1e3, 0.0, 0.0, 0.0, 1e3, 0.0, 0.0, 0.0, 1e3],
            ..HapticdLocalBody::default()
        };
        let mut locals = [None; HAPTICD_MAX_LOCAL_BODIES];
        locals[3] = LocalBody::new((&published, None), &Change::default(), 0.01, None);
        let grip = Pose {
            position: DVec3::new(0.003, 0.007, 0.002),
            orientation: DQuat::IDENTITY,
        };
        let centre = other.pose.position;
        let mut most = 0.0f64;
        for tick in 0..200 {
            let (out, loads) = part.follow(grip, 1e-3, &locals);
            assert!(out.penetration < 1e-6, "{}", out.penetration);
            // Only the moved body's slot is loaded.
            for (i, load) in loads.iter().enumerate() {
                if i != 3 {
                    assert_eq!(*load, (DVec3::ZERO, DVec3::ZERO));
                }
            }
            if tick < 100 {
                continue;
            }
            // At rest the contacts balance the springs: the body takes their pull on the
            // part, with its moment about the body's centre.
            let (force, torque) = loads[3];
            let (p, proxy) = (GodObjectParameters::default(), part.proxy());
            let spring = p.stiffness * (grip.position - proxy.position);
            let turn = p.rotational_stiffness
                * rotation_vector(grip.orientation * proxy.orientation.inverse());
            let moment = (proxy.position - centre).cross(spring) + turn;
            let error = ((force - spring).length() / spring.length())
                .max((torque - moment).length() / moment.length());
            most = most.max(error);
            // The push's line gives that moment, but for a twist about the force itself.
            let point = line_of_action(centre, loads[3]);
            let across = torque - force * torque.dot(force) / force.length_squared();
            assert!((point - centre).cross(force).distance(across) < 1e-9 * torque.length());
        }
        // The pushes are solved exactly (measured: within 5e-15 of the springs' wrench).
        assert!(most < 1e-12, "{most}");
    }
}
