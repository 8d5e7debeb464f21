//! hapticctl's library: the thesis' experiments, reproduced on the simulated SPIDAR and the
//! physics, studies of mechanisms, offline scene runs, and the PNG charts they draw; for the
//! commands that talk to the running daemon, its connection ([`daemon_client`]) or its
//! network bridge's ([`remote_daemon`]), its properties in words ([`daemon_view`]) and the
//! terminal's keys ([`terminal`]). The
//! experiments and the mechanism studies return a [`report::Report`]: the binary parses
//! arguments, writes its figure and prints it.
//!
//! The other commands' logic lives here too, their binary only declaring and gluing: scene
//! runs reported ([`scene_report`]) and scene files drawn ([`scenery`]), meshes
//! ([`mesh_report`]), the running world's bodies ([`body_report`]), USB amplifiers
//! ([`device_report`]), the renderer's pictures ([`pictures`]) and live window ([`viewer`]),
//! and the manual pages ([`manual`]).

pub mod body_report;
pub mod daemon_client;
pub mod daemon_view;
pub mod device_report;
pub mod experiments;
pub mod manual;
pub mod mechanism_report;
pub mod mesh_report;
pub mod multirate;
pub mod parts;
pub mod pictures;
pub mod plot;
pub mod remote_daemon;
pub mod report;
pub mod scene_report;
pub mod scene_run;
pub mod scenery;
pub mod terminal;
pub mod viewer;
