//! What a physics scene looks like, as its plugin hands it out for pictures
//! ([`hapticd_plugin_api::geometry`]): one body id per body of the world, in the order its
//! poses are written, each piece a solid placed in its body's frame; and its joints, drawn
//! faintly on the body they move.

use glam::{DQuat, DVec3};
use hapticd_core::kinematics::{Pose, quat_to_wxyz};
use hapticd_plugin_api::{
    Geometry, HAPTICD_SHAPE_BOX, HAPTICD_SHAPE_CYLINDER, HAPTICD_SHAPE_SPHERE,
    HAPTICD_SOLID_DEFORMING, HAPTICD_SOLID_FIXED, HAPTICD_SOLID_POINTER, HapticdBodyPose,
    HapticdSolid, HapticdTriangle,
};

use super::{PenaltyScene, Primitive, RapierScene};
use crate::body::Body;
use crate::joint::{Joint, JointKind};
use crate::polyhedron::Polyhedron;
use crate::soft::SoftPart;

/// A joint's colour: a dark slate, half see-through, so that it shows against the light
/// background without hiding what it joins.
const JOINT_COLOUR: [f32; 4] = [0.15, 0.2, 0.3, 0.5];

impl PenaltyScene {
    /// The world's solids: every piece of every body as its faces (a mesh as its own
    /// triangles), the pointers' bodies marked as such, and each soft body's surface as a
    /// deforming solid. Body ids: the file's rigid bodies, its soft ones, the pointers.
    pub fn geometry(&self) -> Geometry {
        let mut geometry = Geometry::default();
        let (rigid, pointers) = self.world.bodies.split_at(self.first_pointer);
        for (i, body) in rigid.iter().enumerate() {
            let id = geometry.add_body();
            if let Some(Some(surface)) = self.surfaces.get(i) {
                geometry.add_triangles(solid_of(id, body, 0), triangles(surface));
                continue;
            }
            for piece in &body.pieces {
                geometry.add_triangles(solid_of(id, body, 0), faces(piece));
            }
        }
        for _ in &self.soft {
            geometry.add_body();
        }
        for body in pointers {
            let id = geometry.add_body();
            for piece in &body.pieces {
                geometry.add_triangles(solid_of(id, body, HAPTICD_SOLID_POINTER), faces(piece));
            }
        }
        add_soft_surfaces(&mut geometry, &self.soft);
        let joints: Vec<&Joint> = self.world.joints.iter().map(|l| &l.joint).collect();
        add_joints(&mut geometry, &self.world.bodies, &joints);
        geometry
    }

    /// [rt] Where the corners of the soft bodies' surfaces ([`geometry`](Self::geometry)'s
    /// deforming solids) stand now, the first ones into `out`; how many there are.
    pub fn corners(&self, out: &mut [[f32; 3]]) -> usize {
        soft_corners(&self.soft, out)
    }

    /// Where the corners of the soft bodies' surfaces stand now, all of them.
    pub fn all_corners(&self) -> Vec<[f32; 3]> {
        let mut corners = vec![[0.0; 3]; self.corners(&mut [])];
        self.corners(&mut corners);
        corners
    }

    /// Where each body of [`geometry`](Self::geometry) is now, by id.
    pub fn poses(&self) -> Vec<Pose> {
        (0..self.body_count()).map(|id| self.pose_of(id)).collect()
    }

    /// Bodies by id: the file's rigid ones, its soft ones, the pointers.
    pub fn body_count(&self) -> usize {
        self.world.bodies.len() + self.soft.len()
    }

    /// [rt] Where body `id` is now (a soft one's centre of mass, turned as its rest shape
    /// best fits it); the identity past the last.
    pub fn pose_of(&self, id: usize) -> Pose {
        let soft = self.soft.len();
        let world = match id.checked_sub(self.first_pointer) {
            Some(k) if k < soft => {
                let body = &self.soft[k].body;
                return Pose {
                    position: body.centre(),
                    orientation: body.turn(),
                };
            }
            Some(_) => id - soft,
            None => id,
        };
        self.world
            .bodies
            .get(world)
            .map_or(Pose::IDENTITY, |b| Pose {
                position: b.position,
                orientation: b.orientation,
            })
    }
}

impl RapierScene {
    /// The world's solids: boxes and balls as such, hulls as their faces, meshes as their
    /// triangles (the pointers'
    /// solids are not drawn: their proxies show where the fingers rest).
    pub fn geometry(&self) -> Geometry {
        let mut geometry = Geometry::default();
        for ((body, primitives), surface) in
            self.bodies.iter().zip(&self.primitives).zip(&self.surfaces)
        {
            let id = geometry.add_body();
            if let Some(surface) = surface {
                geometry.add_triangles(solid_of(id, body, 0), triangles(surface));
                continue;
            }
            for (piece, primitive) in body.pieces.iter().zip(primitives) {
                let at = |shape, size, orientation| HapticdSolid {
                    shape,
                    size,
                    offset: HapticdBodyPose {
                        position: piece.vertex_centre().to_array(),
                        orientation,
                    },
                    ..solid_of(id, body, 0)
                };
                match *primitive {
                    Primitive::Cuboid { half, rotation } => geometry.add_solid(at(
                        HAPTICD_SHAPE_BOX,
                        half.to_array(),
                        quat_to_wxyz(rotation),
                    )),
                    Primitive::Ball { radius } => geometry.add_solid(at(
                        HAPTICD_SHAPE_SPHERE,
                        [radius, 0.0, 0.0],
                        [1.0, 0.0, 0.0, 0.0],
                    )),
                    Primitive::Hull => geometry.add_triangles(solid_of(id, body, 0), faces(piece)),
                }
            }
        }
        for _ in &self.soft {
            geometry.add_body();
        }
        add_soft_surfaces(&mut geometry, &self.soft);
        let joints: Vec<&Joint> = self.joints.iter().collect();
        add_joints(&mut geometry, &self.bodies, &joints);
        geometry
    }
}

/// Each soft body of `parts` as a deforming solid: its surface where it stands at load in
/// the world's frame, moved by [`soft_corners`] (not by its body's pose).
fn add_soft_surfaces(geometry: &mut Geometry, parts: &[SoftPart]) {
    for part in parts {
        let corners: Vec<DVec3> = part.corners().collect();
        geometry.add_triangles(
            HapticdSolid {
                flags: HAPTICD_SOLID_DEFORMING,
                ..HapticdSolid::placed([0.0; 3], [1.0, 0.0, 0.0, 0.0])
            },
            corners.chunks_exact(3).map(|t| HapticdTriangle {
                corners: [t[0], t[1], t[2]].map(|c| c.to_array()),
            }),
        );
    }
}

/// [the stepping thread] Where the corners of `parts`' surfaces (the deforming solids of
/// [`add_soft_surfaces`]) stand now, the first ones into `out`; how many there are.
pub fn soft_corners(parts: &[SoftPart], out: &mut [[f32; 3]]) -> usize {
    let mut count = 0;
    for c in parts.iter().flat_map(SoftPart::corners) {
        if let Some(slot) = out.get_mut(count) {
            *slot = c.as_vec3().to_array();
        }
        count += 1;
    }
    count
}

/// Draw `joints` faintly on the body each moves (its second), as `bodies` stand at load: a
/// hinge as a thin bar along its axis through its anchor, a slider as a longer one, a ball
/// joint as a small ball; a weld is not drawn.
fn add_joints(geometry: &mut Geometry, bodies: &[Body], joints: &[&Joint]) {
    for j in joints {
        let Some(body) = bodies.get(j.bodies.1) else {
            continue;
        };
        let (shape, size) = match j.kind {
            JointKind::Revolute => (HAPTICD_SHAPE_CYLINDER, [0.002, 0.03, 0.0]),
            JointKind::Prismatic => (HAPTICD_SHAPE_CYLINDER, [0.0015, 0.06, 0.0]),
            JointKind::Spherical => (HAPTICD_SHAPE_SPHERE, [0.004, 0.0, 0.0]),
            JointKind::Fixed => continue,
        };
        let back = body.orientation.inverse();
        // A cylinder stands along its frame's y.
        let turn = back * DQuat::from_rotation_arc(DVec3::Y, j.axis.normalize_or(DVec3::Y));
        geometry.add_solid(HapticdSolid {
            shape,
            size,
            colour: JOINT_COLOUR,
            ..HapticdSolid {
                body: j.bodies.1 as u32,
                ..HapticdSolid::placed(
                    (back * (j.anchor - body.position)).to_array(),
                    quat_to_wxyz(turn.normalize()),
                )
            }
        });
    }
}

/// A solid of body `id` at the body's own frame, flagged as `body` is and with `flags`.
fn solid_of(id: u32, body: &Body, flags: u32) -> HapticdSolid {
    let fixed = if body.fixed { HAPTICD_SOLID_FIXED } else { 0 };
    HapticdSolid {
        body: id,
        flags: fixed | flags,
        ..HapticdSolid::placed([0.0; 3], [1.0, 0.0, 0.0, 0.0])
    }
}

/// A mesh's `surface` as the ABI's triangles.
fn triangles(surface: &[[DVec3; 3]]) -> Vec<HapticdTriangle> {
    surface
        .iter()
        .map(|t| HapticdTriangle {
            corners: t.map(|c| c.to_array()),
        })
        .collect()
}

/// The faces of `piece` as triangles (fans, counter-clockwise from outside).
fn faces(piece: &Polyhedron) -> Vec<HapticdTriangle> {
    let corner = |k: usize| -> [f64; 3] { piece.vertices[k].to_array() };
    piece
        .faces
        .iter()
        .flat_map(|face| {
            (1..face.len().saturating_sub(1)).map(move |k| HapticdTriangle {
                corners: [corner(face[0]), corner(face[k]), corner(face[k + 1])],
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneFile;
    use std::path::Path;

    fn scene(name: &str, pointers: usize) -> SceneFile {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../config/scenes")
            .join(format!("{name}.yaml"));
        SceneFile::load(&path, pointers).unwrap()
    }

    /// The area of a solid's triangles.
    fn area(geometry: &Geometry, solid: &HapticdSolid) -> f64 {
        geometry
            .triangles_of(solid)
            .iter()
            .map(|t| {
                let [a, b, c] = t.corners.map(DVec3::from);
                (b - a).cross(c - a).length() / 2.0
            })
            .sum()
    }

    #[test]
    fn a_penalty_world_gives_each_body_its_faces_and_marks_the_pointers() {
        let SceneFile::Penalty(scene) = scene("grasp", 2) else {
            panic!("grasp is a penalty scene");
        };
        let geometry = scene.geometry();
        assert_eq!(geometry.check(), Ok(()));
        assert_eq!(geometry.body_count as usize, scene.world.bodies.len());
        let table = &geometry.solids[0];
        assert_eq!(table.flags, HAPTICD_SOLID_FIXED);
        // The table's box 0.3 × 0.04 × 0.3: its faces cover the box's surface.
        let surface = 2.0 * (0.3 * 0.04 + 0.3 * 0.3 + 0.04 * 0.3);
        assert!((area(&geometry, table) - surface).abs() < 1e-12);
        let pointers: Vec<u32> = geometry
            .solids
            .iter()
            .filter(|s| s.flags & HAPTICD_SOLID_POINTER != 0)
            .map(|s| s.body)
            .collect();
        let first = scene.first_pointer as u32;
        assert_eq!(pointers, [first, first + 1]);
    }

    #[test]
    fn a_rapier_world_keeps_boxes_and_balls_whole() {
        let SceneFile::Rapier(scene) = scene("balls", 1) else {
            panic!("balls is a rapier scene");
        };
        let geometry = scene.geometry();
        assert_eq!(geometry.check(), Ok(()));
        assert_eq!(geometry.body_count, 17);
        let (walls, balls) = geometry.solids.split_at(5);
        assert!(
            walls
                .iter()
                .all(|s| s.shape == HAPTICD_SHAPE_BOX && s.flags == HAPTICD_SOLID_FIXED)
        );
        assert_eq!(walls[0].size, [0.12, 0.01, 0.12], "half the floor's edges");
        assert!(
            balls
                .iter()
                .all(|s| s.shape == HAPTICD_SHAPE_SPHERE && s.size[0] == 0.012 && s.flags == 0)
        );
        let ids: Vec<u32> = geometry.solids.iter().map(|s| s.body).collect();
        assert_eq!(ids, (0..17).collect::<Vec<_>>());
    }

    /// Each joint with a coordinate or a ball is drawn faintly on the body it moves, where
    /// the file puts it, in both engines: the shipped joints' door hinge a bar along y
    /// through its anchor; welds are not drawn.
    #[test]
    fn joints_are_drawn_faintly_where_they_join() {
        for (name, engine) in [("hinges", "penalty"), ("joints", "rapier")] {
            let (geometry, bodies, joints): (Geometry, Vec<Body>, Vec<Joint>) = match scene(name, 1)
            {
                SceneFile::Penalty(s) => (
                    s.geometry(),
                    s.world.bodies.clone(),
                    s.world.joints.iter().map(|l| l.joint.clone()).collect(),
                ),
                SceneFile::Rapier(s) => (s.geometry(), s.bodies.clone(), s.joints.clone()),
            };
            assert_eq!(geometry.check(), Ok(()), "{engine}");
            let faint: Vec<&HapticdSolid> = geometry
                .solids
                .iter()
                .filter(|s| s.colour[3] < 1.0 && s.colour[3] > 0.0)
                .collect();
            let drawn = joints.iter().filter(|j| j.kind != JointKind::Fixed).count();
            assert_eq!(faint.len(), drawn, "{engine}");
            let hinge = &joints[0];
            let bar = faint[0];
            assert_eq!(
                (bar.shape, bar.body),
                (HAPTICD_SHAPE_CYLINDER, hinge.bodies.1 as u32)
            );
            let door = &bodies[hinge.bodies.1];
            let at = door.position + door.orientation * DVec3::from(bar.offset.position);
            assert!(at.distance(hinge.anchor) < 1e-12, "{engine}: {at}");
            let [w, x, y, z] = bar.offset.orientation;
            let along = door.orientation * DQuat::from_xyzw(x, y, z, w) * DVec3::Y;
            assert!(along.distance(hinge.axis) < 1e-12, "{engine}: {along}");
        }
    }
}
