//! What a scene looks like: its solids as meshes, where they are now, and a camera that
//! frames them. The solids are whatever the scene's plugin (or the daemon, for static scenes)
//! published ([`Geometry`]); nothing here knows a scene file.

use glam::{DQuat, DVec3, Vec3};
use hapticd_core::kinematics::{Dof, Pose, quat_from_wxyz};
use hapticd_core::mechanism::Mechanism;
use hapticd_plugin_api::*;

use crate::camera::Camera;
use crate::mesh::Mesh;
use crate::shading::Shaded;

/// A string as drawn: from its motor's exit to its knot, and how hard it pulls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrawnString {
    /// The string's exit on the frame, metres.
    pub motor: DVec3,
    /// Its knot on the grip, metres.
    pub knot: DVec3,
    /// Its tension, newtons.
    pub tension: f64,
    /// Its least and greatest tension, newtons.
    pub range: [f64; 2],
}

/// A grip as drawn: where it is and the wrench it presents.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrawnGrip {
    /// Its pose.
    pub pose: Pose,
    /// A point grip (3) or a rigid one (6).
    pub dof: Dof,
    /// The force it presents, newtons.
    pub force: DVec3,
    /// The torque it presents, newton-metres (rigid grips).
    pub torque: DVec3,
}

/// Colours of fixed solids and of the floor's stripes.
pub const FIXED: [f32; 4] = [0.55, 0.57, 0.6, 1.0];
/// The floor's stripes, one every [`STRIPE`] metres.
pub const FLOOR: [[f32; 4]; 2] = [[0.72, 0.72, 0.7, 1.0], [0.6, 0.6, 0.58, 1.0]];
/// Width of a floor stripe, metres: a distance scale.
pub const STRIPE: f64 = 0.01;
/// Colours of moving bodies, in turn.
pub const BODIES: [[f32; 4]; 6] = [
    [0.80, 0.25, 0.20, 1.0],
    [0.20, 0.45, 0.80, 1.0],
    [0.90, 0.65, 0.15, 1.0],
    [0.25, 0.65, 0.35, 1.0],
    [0.60, 0.35, 0.70, 1.0],
    [0.15, 0.65, 0.70, 1.0],
];
/// Pointers: where the fingers are.
pub const POINTER: [f32; 4] = [0.95, 0.85, 0.2, 1.0];
/// A grip where a proxy shows where the finger rests: the hand, inside what it presses.
const FAINT_POINTER: [f32; 4] = [0.95, 0.85, 0.2, 0.35];
/// A translucent wall where a plane bounds the workspace.
const WALL: [f32; 4] = [0.55, 0.6, 0.7, 0.35];
/// Largest box (its diagonal, metres) of the pointers that make fingertips, not bodies worth
/// a picture of their own: a 5 mm ball's is 17 mm.
const FINGERTIP: f64 = 0.03;

/// The solids of a picture and the box that holds the ones worth framing.
#[derive(Debug, Clone, Default)]
pub struct Scenery {
    /// The meshes, drawn in order.
    pub meshes: Vec<Mesh>,
    low: Option<(DVec3, DVec3)>,
}

impl Scenery {
    /// Make the camera frame `low..high` too.
    fn frame(&mut self, low: DVec3, high: DVec3) {
        self.low = Some(match self.low {
            None => (low, high),
            Some((l, h)) => (l.min(low), h.max(high)),
        });
    }

    /// A camera that frames what is worth framing, from the front, right and above.
    pub fn camera(&self) -> Camera {
        let (low, high) = self.low.unwrap_or((DVec3::splat(-0.1), DVec3::splat(0.1)));
        let centre = (low + high) / 2.0;
        let radius = ((high - low).length() / 2.0).max(0.03);
        let fov = 40f64.to_radians();
        Camera::orbit(centre, 1.3 * radius / (fov / 2.0).sin(), 0.45, 0.55)
    }

    /// The solids of `geometry`, each where its body's pose in `poses` (by body id) puts
    /// it, the deforming ones with their corners where `corners` says (see
    /// [`WorldFrame::corners`](hapticd_core::world_state::WorldFrame::corners); as at load
    /// when it does not say, or says something not finite); a solid whose body has no pose
    /// is not drawn. The movable bodies are framed, or when there are none the bounded fixed
    /// solids, and the pointers with them.
    pub fn of_geometry(shaded: &Shaded, poses: &[Pose], corners: &[[f32; 3]]) -> Self {
        let geometry = &shaded.geometry;
        let mut s = Self::default();
        let (mut mesh, mut translucent) = (Mesh::default(), Mesh::default());
        let mut fixed: Vec<(DVec3, DVec3)> = Vec::new();
        let mut pointers: Option<(DVec3, DVec3)> = None;
        let mut deformed = Deformed { corners, next: 0 };
        for (k, solid) in geometry.solids.iter().enumerate() {
            let moved = deformed.take(shaded, k, solid);
            let body = match solid.body {
                HAPTICD_NO_BODY => Pose::IDENTITY,
                id => match poses.get(id as usize) {
                    Some(pose) => *pose,
                    None => continue,
                },
            };
            let offset = &solid.offset;
            let frame = Pose {
                position: body.transform_point(DVec3::from(offset.position)),
                orientation: body.orientation * quat_from_wxyz(offset.orientation).normalize(),
            };
            let colour = colour_of(solid, k);
            let target = if colour[3] < 1.0 {
                &mut translucent
            } else {
                &mut mesh
            };
            let Some((low, high)) = draw(target, shaded, solid, &frame, moved, colour) else {
                continue;
            };
            if solid.flags & HAPTICD_SOLID_POINTER != 0 {
                pointers = Some(pointers.map_or((low, high), |(l, h)| (l.min(low), h.max(high))));
            } else if solid.flags & HAPTICD_SOLID_FIXED != 0 {
                fixed.push((low, high));
            } else {
                s.frame(low, high);
            }
        }
        // The pointers are framed with what the scene holds: its movable bodies, or when it
        // has none (a user's model on a floor), its bounded fixed solids, but for the one
        // the others stand on (the largest, its top no higher than their bottoms), unless a
        // pointer is itself a body to look at (a held block). A fingertip alone made a
        // close-up of a ball of a scene of fixed solids.
        let fingertips = pointers.is_none_or(|(l, h)| (h - l).length() < FINGERTIP);
        if s.low.is_none() && fingertips {
            let size = |(l, h): &(DVec3, DVec3)| (*h - *l).length();
            let largest =
                (0..fixed.len()).max_by(|&a, &b| size(&fixed[a]).total_cmp(&size(&fixed[b])));
            if let Some(k) = largest
                && fixed.len() > 1
                && fixed
                    .iter()
                    .enumerate()
                    .all(|(j, (low, _))| j == k || fixed[k].1.y <= low.y + 1e-3)
            {
                fixed.swap_remove(k);
            }
            for (low, high) in fixed {
                s.frame(low, high);
            }
        }
        if let Some((low, high)) = pointers {
            s.frame(low, high);
        }
        s.meshes.push(mesh);
        // Translucent walls last, over what lies behind them.
        s.meshes.push(translucent);
        s
    }

    /// Add `mechanism` with each grip at its pose in `poses` (one per effector): each
    /// motor's string exit, each string from its exit to its knot coloured by its tension in
    /// `tensions` (one per string, newtons; see [`tension_colour`]), each grip, and the force
    /// it presents (`forces`, newtons) as an arrow. The camera frames the frame too.
    pub fn add_mechanism(
        &mut self,
        mechanism: &Mechanism,
        poses: &[Pose],
        tensions: &[f64],
        forces: &[DVec3],
    ) {
        let strings: Vec<DrawnString> = mechanism
            .strings
            .iter()
            .zip(tensions)
            .map(|(string, &tension)| DrawnString {
                motor: string.motor,
                knot: poses[string.effector].transform_point(string.knot),
                tension,
                range: [string.tension_min, string.tension_max],
            })
            .collect();
        let grips: Vec<DrawnGrip> = mechanism
            .effectors
            .iter()
            .zip(poses)
            .zip(forces)
            .map(|((effector, pose), force)| DrawnGrip {
                pose: *pose,
                dof: effector.dof,
                force: *force,
                torque: DVec3::ZERO,
            })
            .collect();
        self.add_device(&strings, &grips, true);
    }

    /// Add a device as it is now: each string from its motor's exit to its knot coloured by
    /// its tension, each motor, each grip (`solid_grips`, or faint where something else
    /// shows where the finger rests), and the force each grip presents as an arrow, its
    /// torque as a second one along the axis it turns about. The camera frames the frame too.
    pub fn add_device(&mut self, strings: &[DrawnString], grips: &[DrawnGrip], solid_grips: bool) {
        let mut mesh = Mesh::default();
        for string in strings {
            let span = string.knot - string.motor;
            let [low, high] = string.range;
            let colour = tension_colour(string.tension, low, high);
            mesh.cylinder(
                string.motor + span / 2.0,
                span,
                STRING_RADIUS,
                span.length(),
                colour,
            );
            mesh.cuboid(string.motor, DVec3::splat(0.004), DQuat::IDENTITY, MOTOR);
            self.frame(string.motor, string.motor);
        }
        let mut faint = Mesh::default();
        for grip in grips {
            let position = grip.pose.position;
            mesh.arrow(position, grip.force * ARROW_PER_NEWTON, 0.006, ARROW);
            if grip.dof == Dof::Six && grip.torque.length() > 0.0 {
                mesh.arrow(
                    position,
                    grip.torque * ARROW_PER_NEWTON_METRE,
                    0.004,
                    TORQUE,
                );
            }
            let (target, colour) = if solid_grips {
                (&mut mesh, POINTER)
            } else {
                (&mut faint, FAINT_POINTER)
            };
            match grip.dof {
                Dof::Three => target.ball(position, 0.005, 12, colour),
                Dof::Six => {
                    target.cuboid(position, DVec3::splat(0.008), grip.pose.orientation, colour)
                }
            }
        }
        self.meshes.insert(0, mesh);
        // Translucent things last, over what lies behind them.
        self.meshes.push(faint);
    }

    /// Add the proxies: where each finger rests on surfaces, solid.
    pub fn add_proxies(&mut self, proxies: &[DVec3]) {
        let mut solid = Mesh::default();
        for proxy in proxies {
            self.frame(*proxy, *proxy);
            solid.ball(*proxy, POINTER_RADIUS, 10, POINTER);
        }
        self.meshes.insert(0, solid);
    }

    /// Add pointers: each proxy (where the finger rests on surfaces) solid, and its grip
    /// (where the hand is, inside a surface it presses) faint; the camera frames them too.
    pub fn add_pointers(&mut self, proxies: &[DVec3], grips: &[DVec3]) {
        self.add_proxies(&proxies[..proxies.len().min(grips.len())]);
        let mut faint = Mesh::default();
        for (_, grip) in proxies.iter().zip(grips) {
            self.frame(*grip, *grip);
            faint.ball(*grip, POINTER_RADIUS, 10, FAINT_POINTER);
        }
        // Translucent things last, over what lies behind them.
        self.meshes.push(faint);
    }
}

/// Radius strings are drawn with, metres (thicker than real ones, to be seen).
const STRING_RADIUS: f64 = 0.0012;
/// Radius pointers are drawn with, metres.
const POINTER_RADIUS: f64 = 0.004;
/// Length of a force arrow per newton, metres.
const ARROW_PER_NEWTON: f64 = 0.005;
/// Force arrows.
const ARROW: [f32; 4] = [0.1, 0.7, 0.3, 1.0];
/// Length of a torque arrow per newton-metre, metres.
const ARROW_PER_NEWTON_METRE: f64 = 0.1;
/// Torque arrows.
const TORQUE: [f32; 4] = [0.7, 0.2, 0.7, 1.0];
/// Motors' string exits.
const MOTOR: [f32; 4] = [0.2, 0.2, 0.22, 1.0];

/// The colour of a string pulling `tension` newtons between `min` and `max`: blue at the
/// least, through violet, red at the most.
pub fn tension_colour(tension: f64, min: f64, max: f64) -> [f32; 4] {
    let t = if max > min {
        ((tension - min) / (max - min)).clamp(0.0, 1.0)
    } else {
        0.0
    } as f32;
    [0.15 + 0.75 * t, 0.3 - 0.15 * t, 0.9 - 0.75 * t, 1.0]
}

/// The colour of solid `k`: its own, or else a translucent wall for a plane, the pointers'
/// yellow for a pointer's solid, grey for a fixed body, or one of [`BODIES`] by its body (by
/// its place when it has none).
fn colour_of(solid: &HapticdSolid, k: usize) -> [f32; 4] {
    if solid.colour != [0.0; 4] {
        return solid.colour;
    }
    if solid.shape == HAPTICD_SHAPE_PLANE {
        return WALL;
    }
    if solid.flags & HAPTICD_SOLID_POINTER != 0 {
        return POINTER;
    }
    if solid.flags & HAPTICD_SOLID_FIXED != 0 && solid.body != HAPTICD_NO_BODY {
        return FIXED;
    }
    let index = match solid.body {
        HAPTICD_NO_BODY => k,
        id => id as usize,
    };
    BODIES[index % BODIES.len()]
}

/// The corners of a world's deforming solids where a frame says they stand, taken solid by
/// solid in the geometry's order.
struct Deformed<'a> {
    corners: &'a [[f32; 3]],
    /// Where the next deforming solid's corners begin.
    next: usize,
}

impl Deformed<'_> {
    /// Deforming solid `solid` (place `k`) as its corners stand: each triangle's corners and
    /// their normals; None for a solid that does not deform, or corners not finite or not
    /// there.
    fn take(
        &mut self,
        shaded: &Shaded,
        k: usize,
        solid: &HapticdSolid,
    ) -> Option<Vec<[[DVec3; 3]; 2]>> {
        if solid.flags & HAPTICD_SOLID_DEFORMING == 0 || solid.shape != HAPTICD_SHAPE_TRIANGLES {
            return None;
        }
        let first = self.next;
        self.next += 3 * solid.triangle_count as usize;
        let corners: Vec<[DVec3; 3]> = self
            .corners
            .get(first..self.next)?
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]].map(|c| Vec3::from(c).as_dvec3()))
            .collect();
        if !corners.iter().flatten().all(|c| c.is_finite()) {
            return None;
        }
        let normals = shaded.deformed_normals(k, &corners)?;
        Some(
            corners
                .into_iter()
                .zip(normals)
                .map(|(c, n)| [c, n])
                .collect(),
        )
    }
}

/// Draw `solid` at `frame` in `colour` into `mesh`, a deforming one as `moved` (its
/// triangles' corners and normals) when given; the box worth framing, None for a solid
/// without bounds (planes and bars drawn across the workspace).
fn draw(
    mesh: &mut Mesh,
    shaded: &Shaded,
    solid: &HapticdSolid,
    frame: &Pose,
    moved: Option<Vec<[[DVec3; 3]; 2]>>,
    colour: [f32; 4],
) -> Option<(DVec3, DVec3)> {
    let centre = frame.position;
    let [a, b, _] = solid.size;
    match solid.shape {
        HAPTICD_SHAPE_BOX => {
            let half = DVec3::from(solid.size);
            mesh.cuboid(centre, half, frame.orientation, colour);
            let corners = (0..8).map(|k| {
                let sign = |bit: i32| if k & (1 << bit) == 0 { -1.0 } else { 1.0 };
                frame.transform_point(half * DVec3::new(sign(0), sign(1), sign(2)))
            });
            Some(bounds(corners))
        }
        HAPTICD_SHAPE_SPHERE => {
            mesh.ball(centre, a, 16, colour);
            Some((centre - a, centre + a))
        }
        HAPTICD_SHAPE_CYLINDER => {
            mesh.cylinder(centre, frame.orientation * DVec3::Y, a, b, colour);
            None
        }
        HAPTICD_SHAPE_PLANE => {
            let normal = frame.orientation * DVec3::Y;
            if normal.y > 0.999 {
                mesh.floor(DVec3::ZERO, centre.y, a, STRIPE, FLOOR);
            } else {
                mesh.panel(centre, normal, a, colour);
            }
            None
        }
        _ => {
            let mut framed: Option<(DVec3, DVec3)> = None;
            let mut put = |corners: [DVec3; 3], normals: [DVec3; 3]| {
                let corners = corners.map(|c| frame.transform_point(c));
                mesh.shaded_triangle(corners, normals.map(|n| frame.orientation * n), colour);
                let (low, high) = bounds(corners.into_iter());
                framed = Some(framed.map_or((low, high), |(l, h)| (l.min(low), h.max(high))));
            };
            match moved {
                Some(moved) => moved.into_iter().for_each(|[c, n]| put(c, n)),
                None => {
                    let first = solid.first_triangle as usize;
                    for (k, t) in shaded.geometry.triangles_of(solid).iter().enumerate() {
                        put(t.corners.map(DVec3::from), shaded.normals(first + k));
                    }
                }
            }
            framed
        }
    }
}

/// The smallest axis-aligned box holding `points`.
fn bounds(points: impl Iterator<Item = DVec3>) -> (DVec3, DVec3) {
    points.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), p| {
        (l.min(p), h.max(p))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square of two triangles in the x–z plane, facing up, that deforms.
    fn sheet() -> Shaded {
        let mut geometry = Geometry::default();
        let [a, b, c, d] = [
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 0.0, 0.0],
        ];
        geometry.add_triangles(
            HapticdSolid {
                flags: HAPTICD_SOLID_DEFORMING,
                ..HapticdSolid::placed([0.0; 3], [1.0, 0.0, 0.0, 0.0])
            },
            [[a, b, c], [a, c, d]].map(|corners| HapticdTriangle { corners }),
        );
        Shaded::new(geometry)
    }

    fn positions(scenery: &Scenery) -> Vec<DVec3> {
        scenery.meshes[0]
            .vertices
            .iter()
            .map(|v| v.position)
            .collect()
    }

    #[test]
    fn a_deforming_solid_is_drawn_where_its_corners_stand_smoothly_shaded() {
        let shaded = sheet();
        // The corner at (1, 0, 0) lifted 0.2: the sheet folds along its diagonal, by 16°.
        let lifted = [
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 1.0],
            [1.0, 0.2, 0.0],
        ];
        let scenery = Scenery::of_geometry(&shaded, &[], &lifted);
        let drawn = positions(&scenery);
        let expected: Vec<DVec3> = lifted.iter().map(|&c| Vec3::from(c).as_dvec3()).collect();
        assert_eq!(drawn, expected);
        // The fold's corners take the mean of both faces' normals, weighted by area; the
        // lifted corner its own face's.
        let faces = [
            DVec3::Y,
            (expected[4] - expected[3])
                .cross(expected[5] - expected[3])
                .normalize(),
        ];
        let normals: Vec<DVec3> = scenery.meshes[0]
            .vertices
            .iter()
            .map(|v| v.normal)
            .collect();
        let area = [
            1.0,
            (expected[4] - expected[3])
                .cross(expected[5] - expected[3])
                .length(),
        ];
        let fold = (faces[0] * area[0] + faces[1] * area[1]).normalize();
        assert!(normals[0].distance(fold) < 1e-6, "{normals:?}");
        assert!(normals[4].distance(fold) < 1e-6, "{normals:?}");
        assert!(normals[5].distance(faces[1]) < 1e-6, "{normals:?}");
        // Unfolded, it is flat and faces up.
        let flat = Scenery::of_geometry(&shaded, &[], &[]);
        assert!(
            flat.meshes[0]
                .vertices
                .iter()
                .all(|v| v.normal.distance(DVec3::Y) < 1e-12)
        );
    }

    #[test]
    fn corners_that_are_not_finite_or_not_the_solids_leave_it_as_it_stood() {
        let shaded = sheet();
        let at_load = positions(&Scenery::of_geometry(&shaded, &[], &[]));
        let mut broken = [[0.5f32; 3]; 6];
        broken[2][1] = f32::NAN;
        for corners in [&broken[..], &[[0.5; 3]; 5][..], &[[0.5; 3]; 3][..]] {
            let drawn = positions(&Scenery::of_geometry(&shaded, &[], corners));
            assert_eq!(drawn, at_load, "{corners:?}");
        }
    }
}
