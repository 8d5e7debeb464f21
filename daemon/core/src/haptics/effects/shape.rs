//! Shapes an effect acts about, as signed distance fields: negative inside, zero on the
//! surface, the distance outside (exact for the sphere, box, capsule, cylinder and plane;
//! the rounded box is a box grown by its radius; the cone is a bound).

use glam::{DVec2, DVec3};

/// A solid shape in the device's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A ball.
    Sphere {
        /// Its centre.
        centre: DVec3,
        /// Its radius, m.
        radius: f64,
    },
    /// An axis-aligned box, its edges rounded.
    Box {
        /// Its centre.
        centre: DVec3,
        /// Half its edges, m.
        half: DVec3,
        /// The rounding of its edges and corners, m (0: sharp).
        radius: f64,
    },
    /// The points within a radius of a segment.
    Capsule {
        /// One end of the segment.
        a: DVec3,
        /// The other end.
        b: DVec3,
        /// The radius, m.
        radius: f64,
    },
    /// A cylinder about a segment, flat at both ends.
    Cylinder {
        /// The centre of one end.
        a: DVec3,
        /// The centre of the other.
        b: DVec3,
        /// The radius, m.
        radius: f64,
    },
    /// The half-space behind a plane.
    Plane {
        /// A point of the plane.
        point: DVec3,
        /// Its outward unit normal.
        normal: DVec3,
    },
    /// A cone, solid, from its tip along its axis.
    Cone {
        /// Its tip.
        apex: DVec3,
        /// The unit direction it opens along.
        axis: DVec3,
        /// Its half-angle, radians.
        angle: f64,
        /// Its length along the axis, m.
        height: f64,
    },
}

/// Step for the gradient by central differences, metres: far below any shape's size, far
/// above the rounding of distances of a metre.
const STEP: f64 = 1e-6;

impl Shape {
    /// The signed distance of `p` to the surface, metres.
    pub fn distance(&self, p: DVec3) -> f64 {
        match *self {
            Shape::Sphere { centre, radius } => (p - centre).length() - radius,
            Shape::Box {
                centre,
                half,
                radius,
            } => {
                let q = (p - centre).abs() - (half - DVec3::splat(radius)).max(DVec3::ZERO);
                q.max(DVec3::ZERO).length() + q.max_element().min(0.0) - radius
            }
            Shape::Capsule { a, b, radius } => {
                let (ab, ap) = (b - a, p - a);
                let t = (ap.dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
                (ap - ab * t).length() - radius
            }
            Shape::Cylinder { a, b, radius } => {
                let axis = b - a;
                let length = axis.length();
                let along = (p - (a + b) * 0.5).dot(axis / length.max(f64::MIN_POSITIVE));
                let across =
                    ((p - a) - axis * ((p - a).dot(axis) / axis.length_squared())).length();
                let d = DVec2::new(across - radius, along.abs() - 0.5 * length);
                d.max(DVec2::ZERO).length() + d.max_element().min(0.0)
            }
            Shape::Plane { point, normal } => (p - point).dot(normal),
            Shape::Cone {
                apex,
                axis,
                angle,
                height,
            } => {
                let v = p - apex;
                let along = v.dot(axis);
                let across = (v - axis * along).length();
                let (sin, cos) = angle.sin_cos();
                // Distance to the slanted side (signed), and to the cap and the tip's plane.
                let side = across * cos - along * sin;
                side.max(along - height).max(-along)
            }
        }
    }

    /// The outward unit normal of the surface nearest `p` (the distance's gradient); zero
    /// where it has none.
    pub fn normal(&self, p: DVec3) -> DVec3 {
        let d = |offset: DVec3| self.distance(p + offset);
        let gradient = DVec3::new(
            d(DVec3::X * STEP) - d(-DVec3::X * STEP),
            d(DVec3::Y * STEP) - d(-DVec3::Y * STEP),
            d(DVec3::Z * STEP) - d(-DVec3::Z * STEP),
        );
        gradient.normalize_or_zero()
    }

    /// Whether every number that defines it is finite and every size positive.
    pub fn is_valid(&self) -> bool {
        match *self {
            Shape::Sphere { centre, radius } => centre.is_finite() && radius > 0.0,
            Shape::Box {
                centre,
                half,
                radius,
            } => {
                centre.is_finite()
                    && half.is_finite()
                    && half.min_element() > 0.0
                    && (0.0..=half.min_element()).contains(&radius)
            }
            Shape::Capsule { a, b, radius } | Shape::Cylinder { a, b, radius } => {
                a.is_finite() && b.is_finite() && a != b && radius > 0.0 && radius.is_finite()
            }
            Shape::Plane { point, normal } => {
                point.is_finite() && (normal.length() - 1.0).abs() < 1e-9
            }
            Shape::Cone {
                apex,
                axis,
                angle,
                height,
            } => {
                apex.is_finite()
                    && (axis.length() - 1.0).abs() < 1e-9
                    && angle > 0.0
                    && angle < std::f64::consts::FRAC_PI_2
                    && height > 0.0
                    && height.is_finite()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_are_exact_where_they_can_be_said_by_hand() {
        let sphere = Shape::Sphere {
            centre: DVec3::new(1.0, 0.0, 0.0),
            radius: 0.5,
        };
        assert!((sphere.distance(DVec3::new(3.0, 0.0, 0.0)) - 1.5).abs() < 1e-15);
        assert!((sphere.distance(DVec3::new(1.0, 0.25, 0.0)) + 0.25).abs() < 1e-15);
        let cube = Shape::Box {
            centre: DVec3::ZERO,
            half: DVec3::splat(1.0),
            radius: 0.0,
        };
        assert!((cube.distance(DVec3::new(2.0, 0.5, 0.0)) - 1.0).abs() < 1e-15);
        assert!((cube.distance(DVec3::new(2.0, 2.0, 1.0)) - 2f64.sqrt()).abs() < 1e-15);
        assert!((cube.distance(DVec3::new(0.5, 0.0, 0.0)) + 0.5).abs() < 1e-15);
        let rounded = Shape::Box {
            centre: DVec3::ZERO,
            half: DVec3::splat(1.0),
            radius: 0.25,
        };
        // A corner rounded: from (2, 2, 2) to the sphere of 0.25 about (0.75, 0.75, 0.75).
        let expected = (DVec3::splat(2.0) - DVec3::splat(0.75)).length() - 0.25;
        assert!((rounded.distance(DVec3::splat(2.0)) - expected).abs() < 1e-15);
        let capsule = Shape::Capsule {
            a: DVec3::ZERO,
            b: DVec3::Y,
            radius: 0.1,
        };
        assert!((capsule.distance(DVec3::new(0.3, 0.5, 0.0)) - 0.2).abs() < 1e-15);
        assert!((capsule.distance(DVec3::new(0.0, 1.5, 0.0)) - 0.4).abs() < 1e-15);
        let cylinder = Shape::Cylinder {
            a: DVec3::ZERO,
            b: DVec3::Z,
            radius: 0.2,
        };
        assert!((cylinder.distance(DVec3::new(0.0, 0.5, 0.5)) - 0.3).abs() < 1e-15);
        assert!((cylinder.distance(DVec3::new(0.1, 0.0, 1.25)) - 0.25).abs() < 1e-15);
        assert!((cylinder.distance(DVec3::new(0.0, 0.0, 0.5)) + 0.2).abs() < 1e-15);
        let floor = Shape::Plane {
            point: DVec3::new(0.0, -0.1, 0.0),
            normal: DVec3::Y,
        };
        assert!((floor.distance(DVec3::new(3.0, 0.4, -2.0)) - 0.5).abs() < 1e-15);
    }

    #[test]
    fn normals_point_out_of_every_shape() {
        let shapes = [
            Shape::Sphere {
                centre: DVec3::ZERO,
                radius: 0.1,
            },
            Shape::Box {
                centre: DVec3::ZERO,
                half: DVec3::new(0.1, 0.2, 0.3),
                radius: 0.02,
            },
            Shape::Cylinder {
                a: DVec3::ZERO,
                b: DVec3::X * 0.5,
                radius: 0.1,
            },
            Shape::Cone {
                apex: DVec3::ZERO,
                axis: DVec3::Y,
                angle: 0.5,
                height: 0.3,
            },
        ];
        for shape in shapes {
            assert!(shape.is_valid(), "{shape:?}");
            // Just outside the surface along a ray, the normal leads away from the inside.
            for ray in [DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 1.0).normalize()] {
                let mut p = ray * 1e-3;
                while shape.distance(p) < 0.0 {
                    p += ray * 1e-3;
                }
                let n = shape.normal(p);
                assert!((n.length() - 1.0).abs() < 1e-6, "{shape:?} at {p}");
                assert!(
                    shape.distance(p + n * 1e-3) > shape.distance(p),
                    "{shape:?}"
                );
            }
        }
    }
}
