//! A scene's drawable world as one value: what a plugin hands out through
//! [`HAPTICD_EXT_SCENE_GEOMETRY`], what the host checks and copies into the shared world, and
//! what a renderer draws.
//!
//! ```
//! use hapticd_plugin_api::geometry::Geometry;
//! use hapticd_plugin_api::*;
//!
//! let mut world = Geometry::default();
//! let floor = world.add_body();
//! world.add_solid(HapticdSolid {
//!     body: floor,
//!     shape: HAPTICD_SHAPE_BOX,
//!     flags: HAPTICD_SOLID_FIXED,
//!     size: [0.15, 0.02, 0.15],
//!     ..HapticdSolid::placed([0.0, -0.05, 0.0], [1.0, 0.0, 0.0, 0.0])
//! });
//! assert_eq!(world.check(), Ok(()));
//! ```

use crate::abi::*;
use crate::ext::scene_geometry::*;

/// Bodies, solids and triangles of one scene's world.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Geometry {
    /// Bodies: ids `0 .. body_count`, posed by the scene's `poses`.
    pub body_count: u32,
    /// The solids.
    pub solids: Vec<HapticdSolid>,
    /// The triangles of [`HAPTICD_SHAPE_TRIANGLES`] solids.
    pub triangles: Vec<HapticdTriangle>,
}

/// Why a plugin's geometry cannot be drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct GeometryError {
    /// The solid at fault.
    pub solid: usize,
    /// What is wrong with it.
    pub reason: SolidFault,
}

/// What is wrong with a solid.
#[derive(Debug, Clone, PartialEq)]
pub enum SolidFault {
    /// It moves with a body the world does not have.
    NoSuchBody {
        /// Its body.
        body: u32,
        /// The world's bodies.
        bodies: u32,
    },
    /// Its shape is none of `HAPTICD_SHAPE_*`.
    UnknownShape(u32),
    /// A size its shape reads (the first `read`) is not above zero.
    Size {
        /// Its sizes.
        size: [f64; 3],
        /// How many its shape reads.
        read: usize,
    },
    /// Its frame is no finite position and unit orientation.
    Frame(HapticdBodyPose),
    /// Its colour is not within 0 to 1.
    Colour([f32; 4]),
    /// Its triangles `first .. end` do not lie within the `triangles` of the list.
    Triangles {
        /// Its first triangle.
        first: u32,
        /// One past its last.
        end: usize,
        /// The triangles in the list.
        triangles: usize,
    },
    /// A corner of one of its triangles is not finite.
    NotFinite,
}

impl std::fmt::Display for SolidFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SolidFault::NoSuchBody { body, bodies } => {
                write!(f, "body {body} of a world of {bodies} bodies")
            }
            SolidFault::UnknownShape(shape) => write!(f, "unknown shape {shape}"),
            SolidFault::Size { size, read } => {
                write!(f, "size {:?} is not above zero", &size[..*read])
            }
            SolidFault::Frame(HapticdBodyPose {
                position,
                orientation,
            }) => write!(
                f,
                "frame {position:?} {orientation:?} is not a finite position and unit orientation"
            ),
            SolidFault::Colour(colour) => write!(f, "colour {colour:?} is not within 0 to 1"),
            SolidFault::Triangles {
                first,
                end,
                triangles,
            } => write!(f, "triangles {first} .. {end} of {triangles}"),
            SolidFault::NotFinite => f.write_str("a triangle's corner is not finite"),
        }
    }
}

impl std::fmt::Display for GeometryError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "solid {}: {}", self.solid, self.reason)
    }
}

impl std::error::Error for GeometryError {}

impl HapticdSolid {
    /// A solid with its frame at `position`, turned by `orientation` (w, x, y, z), of no
    /// body and no shape yet: the rest of a struct literal fills them in.
    pub fn placed(position: [f64; 3], orientation: [f64; 4]) -> Self {
        Self {
            body: HAPTICD_NO_BODY,
            offset: HapticdBodyPose {
                position,
                orientation,
            },
            ..Self::default()
        }
    }
}

impl Geometry {
    /// A new body; its id.
    pub fn add_body(&mut self) -> u32 {
        self.body_count += 1;
        self.body_count - 1
    }

    /// Add `solid`.
    pub fn add_solid(&mut self, solid: HapticdSolid) {
        self.solids.push(solid);
    }

    /// Add a [`HAPTICD_SHAPE_TRIANGLES`] solid made of `triangles` (in its frame), otherwise
    /// as `solid` says.
    pub fn add_triangles(
        &mut self,
        solid: HapticdSolid,
        triangles: impl IntoIterator<Item = HapticdTriangle>,
    ) {
        let first = self.triangles.len();
        self.triangles.extend(triangles);
        self.solids.push(HapticdSolid {
            shape: HAPTICD_SHAPE_TRIANGLES,
            first_triangle: first as u32,
            triangle_count: (self.triangles.len() - first) as u32,
            ..solid
        });
    }

    /// The triangles of `solid` (none unless it is made of triangles).
    pub fn triangles_of(&self, solid: &HapticdSolid) -> &[HapticdTriangle] {
        if solid.shape != HAPTICD_SHAPE_TRIANGLES {
            return &[];
        }
        let first = solid.first_triangle as usize;
        self.triangles
            .get(first..first.saturating_add(solid.triangle_count as usize))
            .unwrap_or(&[])
    }

    /// The counts the extension reports.
    pub fn counts(&self) -> HapticdGeometryCounts {
        HapticdGeometryCounts {
            bodies: self.body_count,
            solids: self.solids.len() as u32,
            triangles: self.triangles.len() as u32,
        }
    }

    /// Whether every solid can be drawn: a known shape and body, finite numbers, sizes
    /// above zero where its shape reads them, a unit orientation, a colour within 0 to 1
    /// and triangles within the list.
    pub fn check(&self) -> Result<(), GeometryError> {
        for (k, solid) in self.solids.iter().enumerate() {
            check_solid(solid, self.body_count, self.triangles.len())
                .map_err(|reason| GeometryError { solid: k, reason })?;
            let finite = self
                .triangles_of(solid)
                .iter()
                .all(|t| t.corners.iter().flatten().all(|c| c.is_finite()));
            if !finite {
                return Err(GeometryError {
                    solid: k,
                    reason: SolidFault::NotFinite,
                });
            }
        }
        Ok(())
    }
}

/// The one solid's part of [`Geometry::check`].
fn check_solid(solid: &HapticdSolid, bodies: u32, triangles: usize) -> Result<(), SolidFault> {
    if solid.body != HAPTICD_NO_BODY && solid.body >= bodies {
        return Err(SolidFault::NoSuchBody {
            body: solid.body,
            bodies,
        });
    }
    let read = match solid.shape {
        HAPTICD_SHAPE_BOX => 3,
        HAPTICD_SHAPE_SPHERE | HAPTICD_SHAPE_PLANE => 1,
        HAPTICD_SHAPE_CYLINDER => 2,
        HAPTICD_SHAPE_TRIANGLES => 0,
        other => return Err(SolidFault::UnknownShape(other)),
    };
    if !solid.size[..read].iter().all(|s| s.is_finite() && *s > 0.0) {
        return Err(SolidFault::Size {
            size: solid.size,
            read,
        });
    }
    let HapticdBodyPose {
        position,
        orientation,
    } = solid.offset;
    let norm = orientation.iter().map(|q| q * q).sum::<f64>().sqrt();
    let unit = (norm - 1.0).abs() < 1e-6;
    if !position.iter().all(|p| p.is_finite()) || !unit {
        return Err(SolidFault::Frame(solid.offset));
    }
    if !solid.colour.iter().all(|c| (0.0..=1.0).contains(c)) {
        return Err(SolidFault::Colour(solid.colour));
    }
    let end = solid.first_triangle as usize + solid.triangle_count as usize;
    if solid.shape == HAPTICD_SHAPE_TRIANGLES && (solid.triangle_count == 0 || end > triangles) {
        return Err(SolidFault::Triangles {
            first: solid.first_triangle,
            end,
            triangles,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ball(body: u32) -> HapticdSolid {
        HapticdSolid {
            body,
            shape: HAPTICD_SHAPE_SPHERE,
            size: [0.01, 0.0, 0.0],
            ..HapticdSolid::placed([0.0; 3], [1.0, 0.0, 0.0, 0.0])
        }
    }

    #[test]
    fn a_world_of_known_solids_passes() {
        let mut world = Geometry::default();
        let body = world.add_body();
        world.add_solid(ball(body));
        let corners = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        world.add_triangles(ball(HAPTICD_NO_BODY), [HapticdTriangle { corners }]);
        assert_eq!(world.check(), Ok(()));
        assert_eq!(world.triangles_of(&world.solids[1]).len(), 1);
        assert_eq!(world.triangles_of(&world.solids[0]).len(), 0);
        let counts = world.counts();
        assert_eq!((counts.bodies, counts.solids, counts.triangles), (1, 2, 1));
    }

    #[test]
    fn each_broken_solid_is_named_with_its_fault() {
        let broken: [(HapticdSolid, &str); 6] = [
            (ball(1), "body 1"),
            (
                HapticdSolid {
                    shape: 9,
                    ..ball(0)
                },
                "unknown shape",
            ),
            (
                HapticdSolid {
                    size: [f64::NAN; 3],
                    ..ball(0)
                },
                "size",
            ),
            (
                HapticdSolid {
                    size: [-1.0; 3],
                    ..ball(0)
                },
                "size",
            ),
            (
                HapticdSolid {
                    offset: HapticdBodyPose {
                        position: [0.0; 3],
                        orientation: [2.0, 0.0, 0.0, 0.0],
                    },
                    ..ball(0)
                },
                "unit orientation",
            ),
            (
                HapticdSolid {
                    colour: [1.5, 0.0, 0.0, 1.0],
                    ..ball(0)
                },
                "colour",
            ),
        ];
        for (solid, fault) in broken {
            let world = Geometry {
                body_count: 1,
                solids: vec![ball(0), solid],
                triangles: Vec::new(),
            };
            let error = world.check().unwrap_err();
            assert_eq!(error.solid, 1);
            assert!(
                error.reason.to_string().contains(fault),
                "{error} lacks {fault:?}"
            );
        }
        let outside = Geometry {
            body_count: 0,
            solids: vec![HapticdSolid {
                shape: HAPTICD_SHAPE_TRIANGLES,
                first_triangle: 0,
                triangle_count: 2,
                ..ball(HAPTICD_NO_BODY)
            }],
            triangles: vec![HapticdTriangle::default()],
        };
        assert_eq!(
            outside.check().unwrap_err().reason,
            SolidFault::Triangles {
                first: 0,
                end: 2,
                triangles: 1
            }
        );
        let nan = Geometry {
            body_count: 0,
            solids: outside
                .solids
                .iter()
                .map(|s| HapticdSolid {
                    triangle_count: 1,
                    ..*s
                })
                .collect(),
            triangles: vec![HapticdTriangle {
                corners: [[f64::NAN; 3]; 3],
            }],
        };
        assert_eq!(nan.check().unwrap_err().reason, SolidFault::NotFinite);
    }
}
