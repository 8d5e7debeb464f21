//! Rigid-body geometry for the penalty method with contact-volume integration (thesis Ch. 5):
//! convex polyhedra, their exact intersection, and the mass properties of a polyhedron.
//!
//! - [`polyhedron`]: convex polyhedra as faces (vertex loops) with their planes;
//! - [`hull`]: polyhedra bounded by planes, and convex hulls of points;
//! - [`clip`]: the exact intersection of two convex polyhedra by clipping one with the
//!   other's face planes, reusing its work buffers between calls;
//! - [`mass`]: volume and centroid from the faces (divergence theorem);
//! - [`contact`]: the normal spring and damper integrated over the intersection (eq. 5.8–5.13);
//! - [`friction`]: static friction springs and dynamic friction with their state machine;
//! - [`body`]: rigid bodies and their integration;
//! - [`coupling`]: pointers tied to the grip by a 6-DOF spring and damper (thesis 4.1.2);
//! - [`joint`]: joints between bodies and their coordinates (thesis 7.2);
//! - [`world`]: bodies in contact, stepped by the penalty method;
//! - [`grasping`]: bodies held between pointers (thesis 4.2–4.7);
//! - [`soft`]: soft bodies stepped in a penalty world, touched by its pointers;
//! - [`scene`]: scene files (YAML) describing a world and its pointers.

pub mod body;
pub mod clip;
pub mod contact;
pub mod coupling;
pub mod friction;
pub mod gjk;
pub mod grasping;
pub mod hull;
pub mod joint;
pub mod mass;
pub mod polyhedron;
pub mod scene;
pub mod soft;
pub mod soft_factoring;
pub mod world;
