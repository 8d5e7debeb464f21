//! The command lines of hapticd, hapticd-render and hapticd-zenoh, here rather than in the
//! binaries so that `hapticctl manual` can write their pages from the same definitions.

use std::path::PathBuf;

use clap::{Args, Parser};

use hapticd_ipc::bus::Bus;

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
    /// Run a simulated SPIDAR with this mechanism (a name or a descriptor/plugin path),
    /// even when hardware is plugged in; repeat it for several, each on a haptic thread of
    /// its own (named sim-MECH-1, sim-MECH-2, …). Replaces the configuration's `devices`.
    #[arg(long, value_name = "MECH")]
    pub sim: Vec<String>,
    /// Scene to render: a name in the scene directories, a scene file, or a scene plugin (.so).
    #[arg(long)]
    pub scene: Option<String>,
    /// Scene file handed to a scene plugin given with --scene.
    #[arg(long, value_name = "FILE")]
    pub scene_file: Option<PathBuf>,
    /// Script of the simulated hand; repeated, the first is the first simulated device's,
    /// and so on (one given: every simulated device's).
    #[arg(long, value_name = "FILE")]
    pub hand: Vec<PathBuf>,
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

/// Draws hapticd's world with Vulkan and serves the pictures on D-Bus.
///
/// hapticd-render draws the active scene of hapticd's first device, its grips, its strings
/// coloured by tension and the forces they present, from the world hapticd writes into
/// shared memory, and serves the pictures as org.hapticd.Renderer1 (Snapshot,
/// OpenFrameStream) for `hapticctl snapshot` and `hapticctl view`. It is a process of its
/// own, started by hapticd-render.service, which hapticd.service wants: a Vulkan driver may
/// compile code at run time, is large and takes its process down when it crashes. Without
/// a Vulkan driver it stays up and says why.
#[derive(Parser)]
#[command(name = "hapticd-render", version)]
pub struct RenderCli {
    /// The bus hapticd is on, where the pictures are served: `system`, `session` or a
    /// D-Bus address.
    #[arg(long, value_name = "BUS", default_value = "system")]
    pub bus: Bus,
    /// hapticd's device to draw (0: the first).
    #[arg(long, default_value_t = 0)]
    pub device: usize,
    /// What it takes on.
    #[command(flatten)]
    pub limits: RenderLimits,
}

/// What hapticd-render will take on, each limit named on the command line as in its errors.
#[derive(Args, Debug, Clone, Copy, PartialEq, Eq)]
#[command(next_help_heading = "Limits")]
pub struct RenderLimits {
    /// Most pixels in one frame, of a Snapshot or a stream (width × height; default
    /// 3840 × 2160, a 4K screen: a frame's images, read-back copy and ring then take
    /// about 200 MB at most).
    #[arg(long, value_name = "PIXELS", default_value_t = 3840 * 2160,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub max_frame_pixels: u64,
    /// Most frame streams one bus connection may hold open (a viewer needs one; a few
    /// windows of one program, or a program reconnecting, fit).
    #[arg(long, value_name = "N", default_value_t = 4,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub max_streams_per_caller: u32,
    /// Most frame streams the connections of one user (Unix uid) may hold open together,
    /// so that opening more connections gets no more.
    #[arg(long, value_name = "N", default_value_t = 8,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub max_streams_per_user: u32,
    /// Most frame streams open at once, everyone's together.
    #[arg(long, value_name = "N", default_value_t = 32,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub max_streams: u32,
    /// Most pixels a second (width × height × rate, summed over its streams) one user may
    /// ask for (default 1920 × 1080 at 60 frames a second: a full-HD screen, about a third
    /// of a core on lavapipe).
    #[arg(long, value_name = "PIXELS", default_value_t = 1920 * 1080 * 60,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub max_pixel_rate_per_user: u64,
    /// Most pixels a second drawn for all streams together; identical streams are drawn
    /// once and counted once (default twice a user's: two full-HD screens, about two thirds
    /// of the core the drawing thread shares).
    #[arg(long, value_name = "PIXELS", default_value_t = 2 * 1920 * 1080 * 60,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub max_pixel_rate: u64,
    /// Most memory the rings of all streams may hold together, MiB (each ring holds three
    /// frames; identical streams share one). With a frame's working set and the driver,
    /// this stays below the unit's `MemoryHigh=`.
    #[arg(long, value_name = "MIB", default_value_t = 256,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub max_stream_memory: u64,
}

/// hapticd's devices on the network, as ROS 2 topics over Zenoh.
///
/// hapticd-zenoh follows each device's every tick (the telemetry ring) and publishes its
/// effectors' poses, velocities and displayed wrenches, its strings' tensions, its state and
/// its touches as ROS 2 topics in rmw_zenoh's key expressions and CDR, so that ROS 2 nodes
/// using rmw_zenoh_cpp see them as their own; it answers status queries, and takes commands
/// (parameters, scene switches, scene control) only where its configuration says so. A
/// process of its own (hapticd never touches a socket), started by hapticd-zenoh.service.
/// It listens on the loopback only unless configured otherwise.
#[derive(Parser)]
#[command(name = "hapticd-zenoh", version)]
pub struct ZenohCli {
    /// Configuration file (default: /etc/hapticd/network.yaml when it exists).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// The bus hapticd serves: `system`, `session` or a D-Bus address.
    #[arg(long, value_name = "BUS", default_value = "system")]
    pub bus: Bus,
    /// Where to listen for Zenoh peers and clients, in Zenoh's endpoint form (repeatable;
    /// overrides the configuration's `listen`).
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Samples a second per topic, at most the device's rate (overrides the configuration).
    #[arg(long)]
    pub rate: Option<f64>,
    /// The ROS 2 domain, as ROS_DOMAIN_ID (overrides the configuration).
    #[arg(long)]
    pub domain: Option<u32>,
    /// Run this many seconds, then exit cleanly.
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
}

/// A world stepped here and touched from other machines.
///
/// hapticd-world runs a rapier scene file's world for the devices of every hapticd whose
/// network bridge names this world (`world:` in its network.yaml) and whose scene is a
/// remote one (`engine: remote`): each step it sends every such device the planes near its
/// grips and the bodies it moves itself (thesis 6.5.4), and takes back the impulses and
/// local changes their hands gave the world. Its state (bodies, hosts, energy) answers the
/// query hapticd/world/NAME/status. It listens on the loopback only unless configured
/// otherwise.
#[derive(Parser)]
#[command(name = "hapticd-world", version)]
pub struct WorldCli {
    /// The scene file of the world (a rapier scene: `engine: rapier`).
    pub scene: PathBuf,
    /// Configuration file for the Zenoh side (network.yaml's listen, connect and zenoh;
    /// default: /etc/hapticd/network.yaml when it exists).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Where to listen for bridges, in Zenoh's endpoint form (repeatable; overrides the
    /// configuration's `listen`).
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Endpoints to reach (repeatable; overrides the configuration's `connect`).
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// The world's name on the network (default: the scene file's name).
    #[arg(long)]
    pub name: Option<String>,
    /// Grips the world has room for, over all hosts.
    #[arg(long, default_value_t = 8)]
    pub pointers: usize,
    /// Run this many seconds, then exit cleanly.
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
}
