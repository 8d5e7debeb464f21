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

/// One closed piece of a body's surface, as a world describes it.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfacePiece {
    /// Its body's number.
    pub body: u32,
    /// Whether its body does not move.
    pub fixed: bool,
    /// Where its body is: its centre of mass, the frame of the triangles.
    pub pose: Pose,
    /// Its triangles, counter-clockwise seen from outside.
    pub triangles: Vec<[DVec3; 3]>,
}

/// The surfaces a held body meets: each a solid's closed surface in its body's frame (whose
/// origin is the body's centre of mass).
#[derive(Debug, Clone, Default)]
pub struct HeldWorld {
    /// The fixed bodies' surfaces, each where its body stands.
    pub fixed: Vec<(SignedMesh, Pose)>,
    /// The surfaces of the bodies that move, each with its body's number.
    pub moving: Vec<(u32, SignedMesh)>,
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
    pub fn new(
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

    /// The god-object, for its contacts.
    pub fn god_object(&self) -> &GodObject {
        &self.god
    }

    /// [rt] Move the proxy towards `grip` among the fixed bodies and the `locals` as they are
    /// shown now, `dt` after the last tick: what the god-object gives, and what its contacts
    /// load each of `locals` with.
    pub fn follow(
        &mut self,
        grip: Pose,
        dt: f64,
        locals: &[Option<LocalBody>; HAPTICD_MAX_LOCAL_BODIES],
    ) -> (GodObjectOutput, [Load; HAPTICD_MAX_LOCAL_BODIES]) {
        let was = self.motion().position;
        let fixed = self.world.fixed.iter().map(|(mesh, pose)| Obstacle {
            mesh,
            position: pose.position,
            orientation: pose.orientation,
        });
        let shown = moving_shown(&self.world.moving, locals).map(|(_, mesh, m)| Obstacle {
            mesh,
            position: m.position,
            orientation: m.orientation,
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
            let Some((i, _, m)) = moving_shown(&self.world.moving, locals).nth(k) else {
                continue;
            };
            let on_body = -(c.normal * c.force + c.friction);
            let (force, torque) = &mut loads[i];
            *force += on_body;
            *torque += (c.point - m.position).cross(on_body);
        }
        (out, loads)
    }
}

/// Each surface of `moving` whose body is among `locals`, with that body's slot and where
/// it is shown now.
fn moving_shown<'a>(
    moving: &'a [(u32, SignedMesh)],
    locals: &'a [Option<LocalBody>; HAPTICD_MAX_LOCAL_BODIES],
) -> impl Iterator<Item = (usize, &'a SignedMesh, Motion)> + 'a {
    locals
        .iter()
        .enumerate()
        .filter_map(|(i, b)| Some((i, b.as_ref()?)))
        .flat_map(move |(i, b)| {
            let shown = b.shown();
            moving
                .iter()
                .filter(move |(body, _)| *body == b.body)
                .map(move |(_, mesh)| (i, mesh, shown))
        })
}

/// The point on the line of action of `force` with `torque` about `centre` nearest the
/// centre: where that force alone gives the torque (all of it across the force).
pub fn line_of_action(centre: DVec3, (force, torque): Load) -> DVec3 {
    centre + force.cross(torque) / force.length_squared()
}
