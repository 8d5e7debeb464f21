//! The real-time runtime: the haptic loop of each device, the thread that runs it on time,
//! and the lock-free channels between it and the rest of the daemon.

pub mod haptic_loop;
pub mod realtime;
pub mod spsc;
pub mod stats;
pub mod triple_buffer;
