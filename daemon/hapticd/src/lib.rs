//! hapticd, the daemon: what turns the core's haptic loop into a system service.
//!
//! Layers, each using only those above it (and `hapticd-core`, `hapticd-device`, the wire
//! contract `hapticd-ipc`, the service helpers `hapticd-service`, and the installation as
//! every program sees it, `hapticd-config`: its layout, configuration file, mechanisms and
//! plugin loader):
//!
//! 1. [`state`]: what the daemon keeps in `/var/lib`.
//! 2. [`plugin_scene`] and [`scenes`]: scenes from plugins and finding scenes by name;
//!    [`scene_list`]: the scenes listed, without reading their meshes;
//!    [`remote_scene`]: a world stepped on another machine, reached through the bridge;
//!    [`shared_scene`]: one world for several devices of this daemon;
//!    [`received`]: scene files callers send by descriptor; [`preparation`]: the convex
//!    pieces of a scene's meshes, cut before it switches in.
//! 3. [`realtime`]: the `SCHED_FIFO` thread that runs a device's haptic loop on time, on a
//!    CPU of its own; [`physics_budget`]: when a multi-rate scene's physics thread may be
//!    real-time too, and how long it rests between steps.
//! 4. [`control`]: the daemon's devices, their parameters and calibration, as the bus and
//!    the supervisor see them; [`bus`]: the D-Bus interfaces on top of it.

pub mod bus;
pub mod control;
pub mod physics_budget;
pub mod plugin_scene;
pub mod preparation;
pub mod realtime;
pub mod received;
pub mod remote_scene;
pub mod scene_list;
pub mod scenes;
pub mod shared_scene;
pub mod state;
