//! hapticd: a real-time daemon for string-driven haptic interfaces of the SPIDAR family.
//!
//! - [`mechanism`]: what a device is made of (YAML descriptors, plugins, validation);
//! - [`solver`]: the computations every mechanism shares (pose, tension, force closure);
//! - [`plugin`]: loading plugins safely through the C ABI of `hapticd-plugin-api`;
//! - [`plot`]: PNG line charts for experiments and `hapticctl`.

pub mod bus;
pub mod config;
pub mod control;
pub mod device;
pub mod experiments;
pub mod haptics;
pub mod logging;
pub mod mechanism;
pub mod parameters;
pub mod plot;
pub mod plugin;
pub mod runtime;
pub mod scene;
pub mod sd_notify;
pub mod sim;
pub mod solver;
pub mod state;
