//! Rigid-body geometry for the penalty method with contact-volume integration (thesis Ch. 5):
//! convex polyhedra, their exact intersection, and the mass properties of a polyhedron.
//!
//! - [`polyhedron`]: convex polyhedra as faces (vertex loops) with their planes;
//! - [`clip`]: the exact intersection of two convex polyhedra by clipping one with the
//!   other's face planes, reusing its buffers so that steady-state contacts allocate nothing;
//! - [`mass`]: volume, centroid and inertia from the faces (divergence theorem).

pub mod clip;
pub mod mass;
pub mod polyhedron;
