//! Haptic rendering (thesis Ch. 4): turning the grip's motion among virtual objects into the
//! force the user feels, safely.
//!
//! - [`effects`]: springs, dampers, friction, vibrations and fields that come from no solid;
//! - [`god_object`]: a held part's 6-DOF god-object, kept out of what it touches by a
//!   constrained solve over the contacts of exact meshes ([`signed_mesh`]), their pushes
//!   solved exactly as a [`least_distance`] problem;
//! - [`grasp`]: fingers holding an object, with the shape shell and the resultant shared
//!   among them (4.2–4.7);
//! - [`obstacle`]: solid shapes the proxy cannot enter; [`scenery`]: a static scene's
//!   shapes as the proxy walks among them, a mesh's triangles in a [`bvh`];
//! - [`proxy`]: the god-object with Coulomb friction;
//! - [`passivity`]: the time-domain passivity observer and controller on each port;
//! - [`safety`]: force limits, the NaN guard and the ramp to zero on any fault;
//! - [`surface`]: surface materials, felt by whatever touches them: a texture while
//!   sliding, a transient on impact;
//! - [`texture`]: the textures: gratings, random roughness, height maps;
//! - [`touch`]: what a pointer touches, for contact events;
//! - [`wrench_command`]: a wrench commanded from outside (teleoperation), bounded, ramped,
//!   and dropped when it goes stale.

pub mod bvh;
pub mod effects;
#[cfg(test)]
pub(crate) mod fixtures;
pub mod god_object;
pub mod grasp;
pub mod least_distance;
pub mod obstacle;
pub mod passivity;
pub mod proxy;
pub mod safety;
pub mod scenery;
pub mod shading;
pub mod signed_mesh;
pub mod surface;
pub mod texture;
pub mod touch;
pub mod wrench_command;
