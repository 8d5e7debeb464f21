//! hapticctl's library: the thesis' experiments, reproduced on the simulated SPIDAR and the
//! physics, studies of mechanisms, offline scene runs, and the PNG charts they draw; the
//! running daemon's properties in words ([`daemon_view`]) and the terminal's keys
//! ([`terminal`]) for the commands that talk to it. The
//! experiments and the mechanism studies return a [`report::Report`]: the binary parses
//! arguments, writes its figure and prints it.

pub mod daemon_view;
pub mod experiments;
pub mod mechanism_report;
pub mod multirate;
pub mod plot;
pub mod report;
pub mod scene_run;
pub mod terminal;
