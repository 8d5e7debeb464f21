//! hapticd's command line, here rather than in the binary so that `hapticctl manual` can
//! write the hapticd(8) page from the same definition.

use std::path::PathBuf;

use clap::Parser;

use crate::bus::Bus;

/// Real-time haptics daemon for SPIDAR string-driven haptic interfaces.
///
/// hapticd runs the haptic loop of every SPIDAR amplifier plugged in (or of the simulated
/// SPIDAR when there is none) on a SCHED_FIFO thread of its own, renders the active scene
/// through the strings, and serves org.hapticd.Hapticd1 on the D-Bus system bus. systemd
/// starts it when an amplifier is plugged in (hapticd.service); hapticctl is its client.
#[derive(Parser)]
#[command(name = "hapticd", version)]
pub struct Cli {
    /// Configuration file (default: /etc/hapticd/hapticd.yaml when it exists; for an
    /// installation under another prefix, PREFIX/etc/hapticd/hapticd.yaml).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Run the simulated SPIDAR with this mechanism (a name or a descriptor/plugin path),
    /// even when hardware is plugged in.
    #[arg(long, value_name = "MECH")]
    pub sim: Option<String>,
    /// Scene to render: a name in the scene directories, a scene file, or a scene plugin (.so).
    #[arg(long)]
    pub scene: Option<String>,
    /// Scene file handed to a scene plugin given with --scene.
    #[arg(long, value_name = "FILE")]
    pub scene_file: Option<PathBuf>,
    /// Script of the simulated hand.
    #[arg(long, value_name = "FILE")]
    pub hand: Option<PathBuf>,
    /// Ticks per second (overrides the configuration).
    #[arg(long)]
    pub rate: Option<f64>,
    /// Run this many seconds, then exit cleanly.
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
    /// Write every tick (time, poses, forces, tensions) to this CSV file.
    #[arg(long, value_name = "FILE.csv")]
    pub record: Option<PathBuf>,
    /// Record every bulk transfer with the device to this file (replayable with --replay).
    #[arg(long, value_name = "FILE")]
    pub record_traffic: Option<PathBuf>,
    /// Instead of a device, answer from a traffic recording.
    #[arg(long, value_name = "FILE")]
    pub replay: Option<PathBuf>,
    /// Look for mechanisms in DIR (repeatable; overrides the configuration).
    #[arg(long = "mechanism-dir", value_name = "DIR")]
    pub mechanism_dirs: Vec<PathBuf>,
    /// Serve the D-Bus interface on `system`, `session` or a D-Bus address (default: the
    /// system bus when available).
    #[arg(long, value_name = "BUS")]
    pub bus: Option<Bus>,
    /// Keep calibration and changed parameters in DIR (default: $STATE_DIRECTORY).
    #[arg(long, value_name = "DIR")]
    pub state_dir: Option<PathBuf>,
}
