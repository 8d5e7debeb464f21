//! Solid shapes the proxy cannot enter: half-spaces (floors, walls, the planes a physics
//! thread publishes), spheres, oriented boxes, and the triangles of a mesh's surface.

use glam::{DQuat, DVec3};

use super::signed_mesh::closest_point;

/// A solid convex shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// Everything below the plane through `point` with outward `normal` (unit).
    HalfSpace {
        /// A point of the boundary plane.
        point: DVec3,
        /// Outward unit normal.
        normal: DVec3,
    },
    /// A ball.
    Sphere {
        /// Centre.
        centre: DVec3,
        /// Radius.
        radius: f64,
    },
    /// An infinitely long round bar.
    Cylinder {
        /// A point on the axis.
        point: DVec3,
        /// Unit direction of the axis.
        axis: DVec3,
        /// Radius.
        radius: f64,
    },
    /// An oriented box.
    Cuboid {
        /// Centre.
        centre: DVec3,
        /// Half the edge lengths, along the box's own axes.
        half: DVec3,
        /// Orientation of the box's axes.
        rotation: DQuat,
    },
    /// One face of a solid's surface: entered from the side its normal points to, through
    /// the triangle itself (edges included, so that a seam between two faces holds). A face
    /// of an open surface (a scan, a sheet) bounds no solid: it is `two_sided`, entered
    /// from whichever side a segment comes from, and nothing is inside it.
    Triangle {
        /// The corners, counter-clockwise seen from outside.
        corners: [DVec3; 3],
        /// Outward unit normal.
        normal: DVec3,
        /// Whether the back is a surface too.
        two_sided: bool,
    },
}

/// How far inside a point may be and still count as on the surface, metres: covers the
/// rounding of surface points computed in floating point.
pub const SURFACE: f64 = 1e-9;

/// Where a segment enters a shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Entry {
    /// Fraction of the segment travelled, in [0, 1].
    pub t: f64,
    /// The surface point.
    pub point: DVec3,
    /// Outward unit normal there.
    pub normal: DVec3,
}

/// What a proxy walks among: the solids a segment may enter.
pub trait Obstacles {
    /// [rt] Call `visit` with where the segment from `a` to `b` enters each solid it enters,
    /// in any order; no allocation.
    fn entries(&self, a: DVec3, b: DVec3, visit: &mut dyn FnMut(Entry));
}

/// Shapes scanned one by one: what a few primitives need.
impl Obstacles for [Shape] {
    fn entries(&self, a: DVec3, b: DVec3, visit: &mut dyn FnMut(Entry)) {
        for e in self.iter().filter_map(|s| s.entry(a, b)) {
            visit(e);
        }
    }
}

impl Shape {
    /// The face `a`, `b`, `c` of a solid (counter-clockwise seen from outside), or None for
    /// one with no area or a corner that is not finite.
    pub fn triangle(a: DVec3, b: DVec3, c: DVec3) -> Option<Shape> {
        Self::face(a, b, c, false)
    }

    /// The face `a`, `b`, `c` of an open surface, felt from both sides (its winding only
    /// names a normal), or None as for [`Shape::triangle`].
    pub fn sheet(a: DVec3, b: DVec3, c: DVec3) -> Option<Shape> {
        Self::face(a, b, c, true)
    }

    fn face(a: DVec3, b: DVec3, c: DVec3, two_sided: bool) -> Option<Shape> {
        let normal = (b - a).cross(c - a).try_normalize()?;
        (a.is_finite() && b.is_finite() && c.is_finite()).then_some(Shape::Triangle {
            corners: [a, b, c],
            normal,
            two_sided,
        })
    }

    /// [rt] For a triangle: the normal at `p` (seen along the face) blended from the corners'
    /// `normals` by `p`'s barycentric weights, on the side of `face` (the normal pushed
    /// along there); None for other shapes.
    pub fn blend(&self, p: DVec3, normals: &[DVec3; 3], face: DVec3) -> Option<DVec3> {
        let Shape::Triangle {
            corners: [a, b, c],
            normal,
            ..
        } = *self
        else {
            return None;
        };
        let area = |x: DVec3, y: DVec3| (y - x).cross(p - x).dot(normal).max(0.0);
        let weights = [area(b, c), area(c, a), area(a, b)];
        let total: f64 = weights.iter().sum();
        if total <= 0.0 {
            return None;
        }
        let blended = (0..3).map(|k| normals[k] * weights[k]).sum::<DVec3>() / total;
        let blended = blended.try_normalize()?;
        Some(if blended.dot(face) < 0.0 {
            -blended
        } else {
            blended
        })
    }

    /// Whether `p` is strictly inside (deeper than `tolerance`).
    pub fn contains(&self, p: DVec3, tolerance: f64) -> bool {
        self.signed_distance(p) < -tolerance
    }

    /// Signed distance from the surface: negative inside.
    pub fn signed_distance(&self, p: DVec3) -> f64 {
        match *self {
            Shape::HalfSpace { point, normal } => (p - point).dot(normal),
            Shape::Sphere { centre, radius } => (p - centre).length() - radius,
            Shape::Cylinder {
                point,
                axis,
                radius,
            } => (p - point).reject_from_normalized(axis).length() - radius,
            Shape::Cuboid {
                centre,
                half,
                rotation,
            } => {
                let local = rotation.inverse() * (p - centre);
                let q = local.abs() - half;
                q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
            }
            // Behind the face, within its edges, is inside (a sheet has no inside); anywhere
            // else the distance to it.
            Shape::Triangle {
                corners,
                normal,
                two_sided,
            } => {
                let height = (p - corners[0]).dot(normal);
                if within_edges(&corners, normal, p) {
                    if two_sided { height.abs() } else { height }
                } else {
                    // Outside its edges, the nearest point of the triangle is on them.
                    (p - closest_point(&corners, p)).length()
                }
            }
        }
    }

    /// Where the segment from `a` to `b` first enters the shape, if it does. A segment that
    /// starts on the surface (within [`SURFACE`]) and heads inward enters at t = 0; one that
    /// starts deeper inside, or heads outward, does not enter.
    pub fn entry(&self, a: DVec3, b: DVec3) -> Option<Entry> {
        let d = b - a;
        match *self {
            Shape::HalfSpace { point, normal } => half_space_entry(a, b, d, point, normal),
            Shape::Sphere { centre, radius } => {
                round_entry(a - centre, d, radius).map(|(t, radial)| Entry {
                    t,
                    point: a + d * t,
                    normal: radial / radius,
                })
            }
            Shape::Cylinder {
                point,
                axis,
                radius,
            } => {
                // The sphere problem again, in the plane across the axis.
                let (m, d2) = (
                    (a - point).reject_from_normalized(axis),
                    d.reject_from_normalized(axis),
                );
                round_entry(m, d2, radius).map(|(t, radial)| Entry {
                    t,
                    point: a + d * t,
                    normal: radial / radius,
                })
            }
            Shape::Cuboid {
                centre,
                half,
                rotation,
            } => self.cuboid_entry(a, d, (centre, half, rotation)),
            // The face's plane, entered within its edges; a sheet's from the side the
            // segment starts on (on the plane, within rounding: the side it leaves).
            Shape::Triangle {
                corners,
                normal,
                two_sided,
            } => {
                let height = (a - corners[0]).dot(normal);
                let from_behind = height < -SURFACE || (height <= SURFACE && d.dot(normal) > 0.0);
                let facing = if two_sided && from_behind {
                    -normal
                } else {
                    normal
                };
                Shape::HalfSpace {
                    point: corners[0],
                    normal: facing,
                }
                .entry(a, b)
                .filter(|e| within_edges(&corners, normal, e.point))
            }
        }
    }

    /// [rt] Where the segment from `a` along `d` first enters the box `centre`, `half`, `rotation`.
    #[inline]
    fn cuboid_entry(
        &self,
        a: DVec3,
        d: DVec3,
        (centre, half, rotation): (DVec3, DVec3, DQuat),
    ) -> Option<Entry> {
        let inverse = rotation.inverse();
        let (la, ld) = (inverse * (a - centre), inverse * d);
        // Slab method: the entry is the latest of the per-axis entry times.
        let (mut enter, mut exit, mut axis) = (f64::NEG_INFINITY, f64::INFINITY, 0);
        for k in 0..3 {
            if ld[k].abs() < 1e-300 {
                if la[k].abs() > half[k] {
                    return None;
                }
                continue;
            }
            let (t0, t1) = ((-half[k] - la[k]) / ld[k], (half[k] - la[k]) / ld[k]);
            let (near, far) = (t0.min(t1), t0.max(t1));
            if near > enter {
                (enter, axis) = (near, k);
            }
            exit = exit.min(far);
        }
        if enter > exit || enter > 1.0 {
            return None;
        }
        if enter < 0.0 {
            if self.signed_distance(a) < -SURFACE {
                return None;
            }
            // Starting on the surface: entering through the face it lies on that
            // the motion heads into most (none, when it slides along its face).
            let mut face = None;
            let mut most = 0.0;
            for k in 0..3 {
                if (la[k].abs() - half[k]).abs() <= SURFACE {
                    let mut local = DVec3::ZERO;
                    local[k] = la[k].signum();
                    let normal = rotation * local;
                    if -d.dot(normal) > most {
                        (face, most) = (Some(normal), -d.dot(normal));
                    }
                }
            }
            return face.and_then(|normal| at_start(a, d, normal));
        }
        let mut local_normal = DVec3::ZERO;
        local_normal[axis] = -ld[axis].signum();
        let normal = rotation * local_normal;
        Some(Entry {
            t: enter,
            point: a + d * enter,
            normal,
        })
    }
}

/// [rt] Whether a segment along `d` heads into a surface of outward `normal`.
#[inline]
fn inward(d: DVec3, normal: DVec3) -> bool {
    d.dot(normal) < -1e-12 * d.length()
}

/// [rt] The entry at the start `a` through a surface of outward `normal`, if `d` heads into it.
#[inline]
fn at_start(a: DVec3, d: DVec3, normal: DVec3) -> Option<Entry> {
    inward(d, normal).then_some(Entry {
        t: 0.0,
        point: a,
        normal,
    })
}

/// [rt] Where the segment `a` to `b` (along `d`) enters the half-space under `point`, `normal`.
#[inline]
fn half_space_entry(a: DVec3, b: DVec3, d: DVec3, point: DVec3, normal: DVec3) -> Option<Entry> {
    let (da, db) = ((a - point).dot(normal), (b - point).dot(normal));
    if da < 0.0 {
        return if da >= -SURFACE {
            at_start(a, d, normal)
        } else {
            None
        };
    }
    if db >= 0.0 || !inward(d, normal) {
        return None;
    }
    let t = da / (da - db);
    Some(Entry {
        t,
        point: a + d * t,
        normal,
    })
}

/// Whether `p`, seen along `normal`, lies on the triangle `corners`, its edges included
/// (to [`SURFACE`]: a point on the seam of two faces is on both).
fn within_edges(corners: &[DVec3; 3], normal: DVec3, p: DVec3) -> bool {
    (0..3).all(|i| {
        let (from, to) = (corners[i], corners[(i + 1) % 3]);
        let edge = to - from;
        edge.cross(p - from).dot(normal) >= -SURFACE * edge.length()
    })
}

/// Entry of a segment into a round surface (a sphere, or a cylinder seen across its axis):
/// `m` is the start relative to the centre and `d` the motion, both in the round problem's
/// space. Returns the fraction travelled and the radial vector at the entry (t = 0 when
/// starting on the surface, within rounding, and heading in).
fn round_entry(m: DVec3, d: DVec3, radius: f64) -> Option<(f64, DVec3)> {
    let (qa, qb, qc) = (d.dot(d), m.dot(d), m.dot(m) - radius * radius);
    if qc <= 0.0 {
        let on_surface = m.length() >= radius - SURFACE;
        let inward = qb < -1e-12 * d.length() * m.length();
        return (on_surface && inward).then(|| (0.0, m.normalize_or_zero() * radius));
    }
    let disc = qb * qb - qa * qc;
    if qa == 0.0 || disc < 0.0 {
        return None;
    }
    let t = (-qb - disc.sqrt()) / qa;
    (0.0..=1.0).contains(&t).then(|| (t, m + d * t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sheet_is_entered_from_either_side_and_has_no_inside() {
        let (a, b, c) = (
            DVec3::new(-1.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 0.0, -1.0),
        );
        let sheet = Shape::sheet(a, b, c).unwrap();
        let face = Shape::triangle(a, b, c).unwrap();
        let (above, below) = (DVec3::new(0.0, 0.01, 0.0), DVec3::new(0.0, -0.01, 0.0));
        for shape in [sheet, face] {
            let e = shape.entry(above, below).unwrap();
            assert!((e.t - 0.5).abs() < 1e-12 && e.normal == DVec3::Y);
        }
        let e = sheet.entry(below, above).unwrap();
        assert!((e.t - 0.5).abs() < 1e-12 && e.normal == DVec3::NEG_Y);
        assert!(
            face.entry(below, above).is_none(),
            "a solid's face from inside"
        );
        // Resting on it within rounding, on the wrong side of the plane: pressing either
        // way enters, at once, from the side the motion leaves.
        for (rest, into, normal) in [(-1e-12, -0.01, DVec3::Y), (1e-12, 0.01, DVec3::NEG_Y)] {
            let e = sheet
                .entry(DVec3::new(0.0, rest, 0.0), DVec3::new(0.0, into, 0.0))
                .unwrap();
            assert!(e.t == 0.0 && e.normal == normal, "{rest}: {e:?}");
        }
        assert!((sheet.signed_distance(below) - 0.01).abs() < 1e-15);
        assert!(!sheet.contains(below, 0.0) && face.contains(below, 0.0));
    }

    #[test]
    fn segments_enter_each_shape_at_its_surface() {
        let floor = Shape::HalfSpace {
            point: DVec3::new(0.0, -0.03, 0.0),
            normal: DVec3::Y,
        };
        let e = floor
            .entry(DVec3::ZERO, DVec3::new(0.0, -0.05, 0.0))
            .unwrap();
        assert!((e.t - 0.6).abs() < 1e-12 && e.normal == DVec3::Y);
        assert!(
            floor
                .entry(DVec3::new(0.0, -0.05, 0.0), DVec3::ZERO)
                .is_none()
        );
        // On the surface: entering when heading in, not when heading along or out.
        let on = DVec3::new(0.0, -0.03 - 1e-12, 0.0);
        assert_eq!(floor.entry(on, DVec3::new(0.0, -0.04, 0.0)).unwrap().t, 0.0);
        assert!(floor.entry(on, DVec3::new(0.01, -0.03, 0.0)).is_none());

        let ball = Shape::Sphere {
            centre: DVec3::ZERO,
            radius: 0.02,
        };
        let e = ball.entry(DVec3::new(0.05, 0.0, 0.0), DVec3::ZERO).unwrap();
        assert!((e.point.x - 0.02).abs() < 1e-12 && (e.normal - DVec3::X).length() < 1e-12);
        // From the entry point (rounded a hair inside), heading inward still enters.
        assert_eq!(
            ball.entry(e.point * (1.0 - 1e-15), DVec3::ZERO).unwrap().t,
            0.0
        );
        assert!(ball.entry(e.point, DVec3::new(0.02, 0.01, 0.0)).is_none());

        let bar = Shape::Cylinder {
            point: DVec3::ZERO,
            axis: DVec3::Y,
            radius: 0.2,
        };
        let e = bar
            .entry(DVec3::new(0.0, 0.3, 0.3), DVec3::new(0.0, -0.1, 0.0))
            .unwrap();
        assert!((e.point.z - 0.2).abs() < 1e-12 && (e.normal - DVec3::Z).length() < 1e-12);
        assert!((bar.signed_distance(DVec3::new(0.3, 5.0, 0.0)) - 0.1).abs() < 1e-12);

        let tilted = Shape::Cuboid {
            centre: DVec3::ZERO,
            half: DVec3::splat(0.01),
            rotation: DQuat::from_rotation_z(std::f64::consts::FRAC_PI_4),
        };
        let e = tilted
            .entry(DVec3::new(0.0, 0.05, 0.0), DVec3::ZERO)
            .unwrap();
        // Straight down onto the top edge of a box turned 45°: the edge is √2·0.01 up.
        assert!((e.point.y - 0.01 * 2f64.sqrt()).abs() < 1e-12);
        assert!(
            (tilted.signed_distance(DVec3::new(0.0, 0.02, 0.0)) - (0.02 - 0.01 * 2f64.sqrt()))
                .abs()
                < 1e-12
        );
        assert!(tilted.contains(DVec3::ZERO, 0.0));
        // On a box's top, sliding along it enters nothing; heading down enters the top.
        let block = Shape::Cuboid {
            centre: DVec3::ZERO,
            half: DVec3::new(0.04, 0.05, 0.03),
            rotation: DQuat::IDENTITY,
        };
        let top = DVec3::new(-0.01, 0.05, 0.01);
        assert!(
            block
                .entry(top, top + DVec3::new(0.001, 0.0, 0.001))
                .is_none()
        );
        let down = block
            .entry(top, top + DVec3::new(0.001, -0.001, 0.0))
            .unwrap();
        assert_eq!((down.t, down.normal), (0.0, DVec3::Y));
        // The same face as two triangles: the seam between them holds, from either side.
        let corners = [
            DVec3::new(-0.04, 0.05, -0.03),
            DVec3::new(-0.04, 0.05, 0.03),
            DVec3::new(0.04, 0.05, 0.03),
            DVec3::new(0.04, 0.05, -0.03),
        ];
        let halves = [
            Shape::triangle(corners[0], corners[1], corners[2]).unwrap(),
            Shape::triangle(corners[0], corners[2], corners[3]).unwrap(),
        ];
        let on_seam = DVec3::new(0.0, 0.06, 0.0);
        for half in halves {
            let e = half
                .entry(on_seam, on_seam - DVec3::new(0.0, 0.02, 0.0))
                .unwrap();
            assert!((e.t - 0.5).abs() < 1e-12 && e.normal == DVec3::Y, "{e:?}");
        }
        assert!(Shape::triangle(corners[0], corners[0], corners[1]).is_none());
    }
}
