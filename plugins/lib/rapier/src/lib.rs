//! The constraint-based half of thesis Ch. 6 on rapier3d: a scene file's world stepped at a
//! low rate, the surfaces near each pointer published as planes (the intermediate
//! representation, 6.3.1) and the impulses the hand gave each body applied back (6.3.5).
//!
//! - [`world`]: a [`RapierScene`](hapticd_physics::scene::RapierScene) as a rapier
//!   world; its physics step with impulse or position feedback;
//! - [`control`]: its bodies moved, pushed or changed from outside between steps;
//! - [`joints`]: the scene's joints as rapier's multibodies and impulse joints, their
//!   coordinates read;
//! - [`articulation`]: how a jointed link answers the hand, for local dynamics;
//! - [`surfaces`]: the nearest point, outward normal and surface velocity of every body
//!   within reach of a pointer, found through rapier's query pipeline;
//! - [`convert`]: between the project's `f64` glam types and rapier's `f32` ones.

pub mod articulation;
pub mod control;
pub mod convert;
pub mod joints;
pub mod surfaces;
pub mod world;
