//! hapticctl's library: the thesis' experiments, reproduced on the simulated SPIDAR and the
//! physics, offline scene runs, and the PNG charts they draw. The binary parses arguments
//! and prints or plots what these return.

pub mod experiments;
pub mod multirate;
pub mod plot;
pub mod scene_run;
