//! Wait-free channels between the haptic thread and the rest of the process: they never
//! allocate, lock or block on the real-time side.

pub mod spsc;
pub mod triple_buffer;
