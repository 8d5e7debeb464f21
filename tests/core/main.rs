//! The core's computations with the shipped mechanisms and scenes: the pose solver, the tension
//! QP, the haptic loop, the real-time thread's allocations, the mesh readers, mesh bodies in
//! rapier, the proxy on meshes, the thesis' experiments, and the ROS 2 messages against an
//! independent encoder.

#[path = "../support/mod.rs"]
mod support;

mod assembly;
mod exact_shapes;
mod experiments;
mod haptic_loop;
mod held_in_rapier;
mod mesh_readers;
mod meshes;
mod motors;
mod no_allocation;
mod pose;
mod rapier_meshes;
mod robots;
mod ros2_cdr;
mod soft;
mod tension;
