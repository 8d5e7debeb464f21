//! The pieces of a multi-rate world's bodies, as the world describes them, and those that
//! are exactly a ball or a box, by object: a finger on a body moved here (local dynamics)
//! touches that shape where the body is this tick, instead of the plane the last physics
//! step found, carried along with the body's centre. A finger sliding over a ball between
//! two steps of a 10 Hz world follows its round surface, not one flat facet a period wide.

use glam::{DQuat, DVec3};

use crate::haptics::obstacle::Shape;
use crate::kinematics::Pose;

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
    /// When the piece is exactly a ball or a box (its triangles drawing it), the object it
    /// is (the `object` of its planes) and that solid.
    pub exact: Option<(u32, Solid)>,
}

/// A piece that is exactly a ball or a box, in its body's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Solid {
    /// A ball.
    Ball {
        /// Its centre, metres.
        centre: DVec3,
        /// Its radius, metres.
        radius: f64,
    },
    /// A box.
    Box {
        /// Its centre, metres.
        centre: DVec3,
        /// How its axes are turned.
        rotation: DQuat,
        /// Half its edges, metres.
        half: DVec3,
    },
}

impl Solid {
    /// The solid where a body at `pose` has it.
    pub fn placed(&self, pose: &Pose) -> Shape {
        match *self {
            Solid::Ball { centre, radius } => Shape::Sphere {
                centre: pose.transform_point(centre),
                radius,
            },
            Solid::Box {
                centre,
                rotation,
                half,
            } => Shape::Cuboid {
                centre: pose.transform_point(centre),
                half,
                rotation: (pose.orientation * rotation).normalize(),
            },
        }
    }

    /// Whether every number of it is finite and its sizes above zero.
    pub fn is_sound(&self) -> bool {
        match *self {
            Solid::Ball { centre, radius } => {
                centre.is_finite() && radius > 0.0 && radius.is_finite()
            }
            Solid::Box {
                centre,
                rotation,
                half,
            } => {
                centre.is_finite()
                    && rotation.is_finite()
                    && (rotation.length() - 1.0).abs() < 1e-6
                    && half.is_finite()
                    && half.min_element() > 0.0
            }
        }
    }
}

/// The point of `shape`'s surface nearest `p` and the outward normal there, for a ball or a
/// box placed by [`Solid::placed`] (None for any other shape). From outside a box's edge or
/// corner the normal points from it to `p`; from inside, the nearest face's.
pub fn nearest_on(shape: &Shape, p: DVec3) -> Option<(DVec3, DVec3)> {
    match *shape {
        Shape::Sphere { centre, radius } => {
            let normal = (p - centre).normalize_or(DVec3::Y);
            Some((centre + normal * radius, normal))
        }
        Shape::Cuboid {
            centre,
            half,
            rotation,
        } => {
            let local = rotation.inverse() * (p - centre);
            let clamped = local.clamp(-half, half);
            let (point, normal) = if clamped != local {
                (clamped, (local - clamped).normalize())
            } else {
                // Inside: out through the nearest face.
                let room = half - local.abs();
                let axis = if room.x <= room.y && room.x <= room.z {
                    0
                } else if room.y <= room.z {
                    1
                } else {
                    2
                };
                let mut n = DVec3::ZERO;
                n[axis] = if local[axis] < 0.0 { -1.0 } else { 1.0 };
                let mut at = local;
                at[axis] = half[axis] * n[axis];
                (at, n)
            };
            Some((centre + rotation * point, rotation * normal))
        }
        _ => None,
    }
}

/// The exact pieces of a world's bodies, by the object each is (the `object` of its planes).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExactShapes {
    /// Sorted by object.
    by_object: Vec<(u32, Solid)>,
}

impl ExactShapes {
    /// The pieces `(object, solid)` (built here, off the haptic thread); an unsound solid or
    /// one object given twice is left out.
    pub fn new(mut pieces: Vec<(u32, Solid)>) -> Self {
        pieces.retain(|(_, s)| s.is_sound());
        pieces.sort_by_key(|(object, _)| *object);
        let mut twice = Vec::new();
        for w in pieces.windows(2) {
            if w[0].0 == w[1].0 {
                twice.push(w[0].0);
            }
        }
        pieces.retain(|(object, _)| !twice.contains(object));
        Self { by_object: pieces }
    }

    /// The exact pieces among `pieces`.
    pub fn of_pieces(pieces: &[SurfacePiece]) -> Self {
        Self::new(pieces.iter().filter_map(|p| p.exact).collect())
    }

    /// [rt] The solid of `object`, if it is one.
    pub fn of(&self, object: u32) -> Option<&Solid> {
        let k = self
            .by_object
            .binary_search_by_key(&object, |(o, _)| *o)
            .ok()?;
        Some(&self.by_object[k].1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_nearest_point_of_a_ball_or_box_is_on_its_surface_with_its_outward_normal() {
        let turn = DQuat::from_rotation_y(0.3);
        let pose = Pose {
            position: DVec3::new(1.0, 2.0, 3.0),
            orientation: turn,
        };
        let ball = Solid::Ball {
            centre: DVec3::X * 0.1,
            radius: 0.05,
        }
        .placed(&pose);
        let boxed = Solid::Box {
            centre: DVec3::ZERO,
            rotation: DQuat::from_rotation_z(0.2),
            half: DVec3::new(0.1, 0.2, 0.3),
        }
        .placed(&pose);
        let mut seed = 7u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for shape in [ball, boxed] {
            for _ in 0..500 {
                let p = pose.position + DVec3::new(next(), next(), next()) * 0.8;
                let (at, normal) = nearest_on(&shape, p).unwrap();
                // On the surface, the normal unit, and `p` along it from there (outside) or
                // no farther than the surface's nearest point (inside).
                assert!(shape.signed_distance(at).abs() < 1e-12, "{at}");
                assert!((normal.length() - 1.0).abs() < 1e-12);
                let d = shape.signed_distance(p);
                assert!((d - (p - at).dot(normal)).abs() < 1e-12, "{p}: {d}");
                if d > 0.0 {
                    assert!(((p - at).length() - d).abs() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn a_solid_no_world_has_is_left_out() {
        let ball = |radius| Solid::Ball {
            centre: DVec3::ZERO,
            radius,
        };
        let shapes = ExactShapes::new(vec![
            (5, ball(0.1)),
            (2, ball(f64::NAN)),
            (3, ball(0.2)),
            (3, ball(0.3)),
            (9, ball(-1.0)),
        ]);
        assert_eq!(shapes.of(5), Some(&ball(0.1)));
        assert_eq!(
            (shapes.of(2), shapes.of(3), shapes.of(9)),
            (None, None, None)
        );
    }
}
