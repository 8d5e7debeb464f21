//! The core's computations with the shipped mechanisms and scenes: the pose solver, the tension
//! QP, the haptic loop, the real-time thread's allocations, and the thesis' experiments.

#[path = "../support/mod.rs"]
mod support;

mod experiments;
mod haptic_loop;
mod no_allocation;
mod pose;
mod tension;
