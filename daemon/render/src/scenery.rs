//! What a scene looks like: its solids as meshes, where they are now, and a camera that
//! frames them.

use glam::{DQuat, DVec3};
use hapticd_core::haptics::obstacle::Shape;
use hapticd_core::kinematics::{Dof, Pose};
use hapticd_core::mechanism::Mechanism;
use hapticd_core::scene::static_scene::StaticSceneSpec;
use hapticd_physics::body::Body;
use hapticd_physics::polyhedron::Polyhedron;
use hapticd_physics::scene::{Primitive, RapierScene};

use crate::camera::Camera;
use crate::mesh::Mesh;

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
/// A translucent wall where a static scene's plane bounds the workspace.
const WALL: [f32; 4] = [0.55, 0.6, 0.7, 0.35];
/// How far a static scene's floor, walls and bars are drawn, metres.
const REACH: f64 = 0.3;

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
        Camera::orbit(centre, 1.15 * radius / (fov / 2.0).sin(), 0.45, 0.75)
    }

    /// A static scene's solids.
    pub fn of_static(spec: &StaticSceneSpec) -> Self {
        let mut s = Self::default();
        let mut mesh = Mesh::default();
        for (k, shape) in spec.shapes.iter().enumerate() {
            let colour = BODIES[k % BODIES.len()];
            match *shape {
                Shape::HalfSpace { point, normal } if normal.y > 0.999 => {
                    mesh.floor(DVec3::ZERO, point.y, 2.0 * REACH, STRIPE, FLOOR);
                }
                Shape::HalfSpace { point, normal } => {
                    mesh.panel(point, normal, REACH, WALL);
                }
                Shape::Sphere { centre, radius } => {
                    mesh.ball(centre, radius, 16, colour);
                    s.frame(centre - radius, centre + radius);
                }
                Shape::Cylinder {
                    point,
                    axis,
                    radius,
                } => mesh.cylinder(point, axis, radius, 2.0 * REACH, colour),
                Shape::Cuboid {
                    centre,
                    half,
                    rotation,
                } => {
                    mesh.cuboid(centre, half, rotation, colour);
                    s.frame(centre - half.length(), centre + half.length());
                }
            }
        }
        // Translucent walls last, over what lies behind them.
        let (walls, solid): (Vec<_>, Vec<_>) =
            mesh.vertices.chunks(3).partition(|t| t[0].colour[3] < 1.0);
        s.meshes.push(Mesh {
            vertices: solid.concat(),
        });
        s.meshes.push(Mesh {
            vertices: walls.concat(),
        });
        s
    }

    /// The bodies of a penalty world as they are now; bodies from `first_pointer` on are
    /// pointers, drawn but not framed.
    pub fn of_penalty(bodies: &[Body], first_pointer: usize) -> Self {
        let mut s = Self::default();
        let mut mesh = Mesh::default();
        for (i, body) in bodies.iter().enumerate() {
            let colour = if i >= first_pointer {
                POINTER
            } else {
                colour_of(i, body.fixed)
            };
            for piece in body.world_pieces() {
                polyhedron(&mut mesh, piece, colour);
                if !body.fixed && i < first_pointer {
                    let (low, high) = bounds(piece.vertices.iter().copied());
                    s.frame(low, high);
                }
            }
        }
        s.frame_fixed_if_empty(bodies.iter().flat_map(|b| b.world_pieces()));
        s.meshes.push(mesh);
        s
    }

    /// The bodies of a rapier world where `state` puts them (`spec` gives their shapes):
    /// the world's bodies now, or the poses between physics steps graphics show (6.5.2).
    pub fn of_rapier(spec: &RapierScene, state: impl Fn(usize) -> Pose) -> Self {
        let mut s = Self::default();
        let mut mesh = Mesh::default();
        for (i, (body, primitives)) in spec.bodies.iter().zip(&spec.primitives).enumerate() {
            let state = state(i);
            let place = |p: DVec3| state.position + state.orientation * p;
            let colour = colour_of(i, body.fixed);
            for (piece, primitive) in body.pieces.iter().zip(primitives) {
                let centre = piece.vertex_centre();
                match *primitive {
                    Primitive::Cuboid { half, rotation } => {
                        mesh.cuboid(place(centre), half, state.orientation * rotation, colour);
                    }
                    Primitive::Ball { radius } => mesh.ball(place(centre), radius, 16, colour),
                    Primitive::Hull => {
                        let placed = piece.transformed(state.orientation, state.position);
                        polyhedron(&mut mesh, &placed, colour);
                    }
                }
                if !body.fixed {
                    let (low, high) = bounds(piece.vertices.iter().map(|v| place(*v)));
                    s.frame(low, high);
                }
            }
        }
        let fixed: Vec<Polyhedron> = spec
            .bodies
            .iter()
            .flat_map(|b| {
                b.pieces
                    .iter()
                    .map(|p| p.transformed(DQuat::IDENTITY, b.position))
            })
            .collect();
        s.frame_fixed_if_empty(fixed.iter());
        s.meshes.push(mesh);
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

    /// Frame every solid when nothing moves.
    fn frame_fixed_if_empty<'a>(&mut self, pieces: impl Iterator<Item = &'a Polyhedron>) {
        if self.low.is_none() {
            for piece in pieces {
                let (low, high) = bounds(piece.vertices.iter().copied());
                self.frame(low, high);
            }
        }
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

/// The colour of body `i`.
fn colour_of(i: usize, fixed: bool) -> [f32; 4] {
    if fixed {
        FIXED
    } else {
        BODIES[i % BODIES.len()]
    }
}

/// The faces of `p` (counter-clockwise from outside) into `mesh`.
fn polyhedron(mesh: &mut Mesh, p: &Polyhedron, colour: [f32; 4]) {
    for face in &p.faces {
        let corners: Vec<DVec3> = face.iter().map(|&k| p.vertices[k]).collect();
        mesh.polygon(&corners, colour);
    }
}

/// The smallest axis-aligned box holding `points`.
fn bounds(points: impl Iterator<Item = DVec3>) -> (DVec3, DVec3) {
    points.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), p| {
        (l.min(p), h.max(p))
    })
}
