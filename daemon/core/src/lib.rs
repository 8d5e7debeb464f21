//! hapticd's core: everything the haptic thread runs, and nothing that touches a device,
//! a file descriptor or a bus.
//!
//! Layers, each using only those above it:
//!
//! 1. [`kinematics`], [`diagnostics`], [`sync`], [`stats`]: vocabulary and primitives
//!    (poses and size limits, located findings, wait-free channels, timing statistics).
//! 2. [`solver`]: the base part of the thesis' split (Ch. 3.4–3.5), on slices and settings:
//!    pose, box QP, tension, force closure, calibration.
//! 3. [`mechanism`]: what a device is made of, validated from a descriptor or a plugin.
//! 4. [`haptics`]: rendering (Ch. 4): proxy, obstacles, passivity, safety limits.
//! 5. [`scene`]: the [`scene::Scene`] trait the loop renders and the static scene.
//! 6. [`transport`], [`parameters`], [`haptic_loop`]: the loop itself, talking to devices
//!    through the [`transport::Transport`] trait that `hapticd-device` implements;
//!    [`fault_hold`]: how long a failed scene must render well before it is trusted again.
//! 7. [`world_state`]: the loop's world as pictures show it, shared with the renderer;
//!    [`telemetry`]: every tick, in a ring other programs read; [`shared_header`]: what
//!    both blocks start with; [`wire`]: bytes for other processes and machines.

pub mod diagnostics;
pub mod fault_hold;
pub mod haptic_loop;
pub mod haptics;
pub mod kinematics;
pub mod mechanism;
pub mod parameters;
pub mod scene;
pub mod shared_header;
pub mod solver;
pub mod stats;
pub mod sync;
pub mod telemetry;
pub mod transport;
pub mod wire;
pub mod world_geometry;
pub mod world_state;
