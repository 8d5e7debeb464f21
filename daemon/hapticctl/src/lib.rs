//! hapticctl's library: the thesis' experiments, reproduced on the simulated SPIDAR and the
//! physics, and the PNG charts they draw.

pub mod experiments;
pub mod multirate;
pub mod plot;
