//! The penalty engine against exact results and independent methods: contact volumes,
//! closest points, intersections and mass properties, mesh bodies, a step's allocations and
//! bodies at rest, sliding and on inclines.

mod common;
mod contact;
mod gjk;
mod intersection;
mod meshes;
mod no_allocation;
mod world;
