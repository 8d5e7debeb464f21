//! `hapticctl`: the command-line companion of hapticd.

mod body;
mod client;
mod completion;
mod device;
mod effect;
mod experiment;
mod joint;
mod manual;
mod mechanism;
mod mesh;
mod pictures;
mod remote;
mod render;
mod scene;
mod scene_file;

use std::ffi::OsString;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use hapticd_config::catalog::Catalog;
use hapticd_core::diagnostics::Diagnostics;
use hapticd_ipc::bus::Bus;
use mechanism::Output;

/// Control hapticd and work with SPIDAR mechanisms.
#[derive(Parser)]
#[command(name = "hapticctl", version)]
struct Cli {
    /// Look for mechanism descriptors and plugins in DIR instead of the default search path
    /// (repeatable; default: $HAPTICD_MECHANISM_PATH, else /etc/hapticd/mechanisms,
    /// /usr/lib/hapticd/plugins, /usr/share/hapticd/mechanisms).
    #[arg(long = "mechanism-dir", value_name = "DIR", global = true)]
    mechanism_dirs: Vec<PathBuf>,
    /// The bus the running daemon serves: `system`, `session` or a D-Bus address.
    #[arg(long, value_name = "BUS", global = true, default_value = "system")]
    bus: Bus,
    /// Reach a hapticd on another machine through its network bridge (hapticd-zenoh) at
    /// this Zenoh endpoint (`tcp/HOST:7447`), instead of the bus: for `status` and `record`.
    #[arg(long, value_name = "ENDPOINT", global = true)]
    remote: Option<String>,
    /// With --remote: a Zenoh configuration file (JSON5) to reach the bridge with, such as the
    /// certificates of a `tls/` endpoint.
    #[arg(long, value_name = "FILE", global = true, requires = "remote")]
    remote_config: Option<PathBuf>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Inspect mechanisms and run their pose and tension computations.
    #[command(subcommand)]
    Mechanism(mechanism::Command),
    /// Look at triangle meshes (OBJ, STL, glTF) as hapticd reads them.
    #[command(subcommand)]
    Mesh(mesh::Command),
    /// Find SPIDAR amplifiers on USB and exercise them.
    #[command(subcommand)]
    Device(device::Command),
    /// Run the thesis' closed-loop experiments on the simulated SPIDAR.
    #[command(subcommand)]
    Experiment(experiment::Command),
    /// Step physics scene files (either engine) headless, or list and switch the daemon's scenes.
    #[command(subcommand)]
    Scene(scene::Command),
    /// The running world's bodies: list them, see where one is, or move, push, weigh one.
    #[command(subcommand)]
    Body(body::Command),
    /// The running world's joints: list them, see where one stands, or drive one's motor.
    #[command(subcommand)]
    Joint(joint::Command),
    /// A device's haptic effects: springs, dampers, friction, vibrations, constant forces,
    /// fields about shapes and magnets, started, changed and stopped.
    #[command(subcommand)]
    Effect(effect::Command),
    /// Draw one frame of a scene file to a PNG file with Vulkan (no daemon needed).
    Render(render::RenderArgs),
    /// Write a picture of the running daemon's world to a PNG file (from hapticd-render).
    Snapshot(pictures::SnapshotArgs),
    /// Show the running daemon's world live in a window (from hapticd-render).
    View(pictures::ViewerArgs),
    /// The running daemon and each of its devices: state, mechanism, scene, rate, timing.
    Status(Output),
    /// A parameter or property of a device of the running daemon.
    Get(client::GetArgs),
    /// Change a parameter of a device; the daemon checks, saves and applies it.
    Set(client::SetArgs),
    /// Calibrate a device: every grip must be held at its calibration pose.
    Calibrate(client::DeviceArg),
    /// Drive a device with another installed mechanism from its next start.
    Bind(client::BindArgs),
    /// Re-read hapticd.yaml and rescan the mechanism plugins and descriptors.
    Reload,
    /// Start the haptic loops again (forces ramped to zero first), applying what waits for
    /// the next start (a bound mechanism, a changed Rate: `status` shows them as pending).
    Restart,
    /// Print every change of the daemon's state as it happens (anyone may watch).
    Monitor(client::MonitorArgs),
    /// Record every tick of a device's haptic loop to a CSV file, at the device's rate.
    Record(client::RecordArgs),
    /// Each device's loop, refreshed like pw-top: state, timing, force and grip.
    Top(client::TopArgs),
    /// Print the completion script of a shell for hapticctl (installed by `make install`):
    /// it asks hapticctl at each Tab, which offers the running daemon's scenes, mechanisms
    /// and devices.
    Completions {
        /// bash, zsh, fish, elvish or powershell.
        shell: String,
    },
    /// Write the manual pages (hapticd(8), hapticctl(1) and the file formats' pages) into
    /// DIR (installed by `make install`).
    Manual {
        /// The directory to write into (created if missing).
        dir: PathBuf,
    },
}

/// A refusal of the daemon's: a device that is not there is the caller's mistake.
impl From<hapticctl::daemon_client::DaemonError> for Failure {
    fn from(error: hapticctl::daemon_client::DaemonError) -> Self {
        match error {
            hapticctl::daemon_client::DaemonError::NoDevice { .. } => Failure::usage(error),
            error => Failure::failed(error),
        }
    }
}

/// Why a command failed, with its exit status.
pub struct Failure {
    /// 1: the operation failed; 2: the arguments were wrong.
    pub code: u8,
    /// What to tell the user.
    pub message: String,
}

impl Failure {
    /// Bad arguments (exit status 2, like a usage error).
    pub fn usage(message: impl std::fmt::Display) -> Self {
        Self {
            code: 2,
            message: format!("hapticctl: error: {message}"),
        }
    }

    /// The operation failed (exit status 1).
    pub fn failed(message: impl std::fmt::Display) -> Self {
        Self {
            code: 1,
            message: format!("hapticctl: error: {message}"),
        }
    }

    /// Diagnostics that already say file, position and severity, with exit status `code`.
    pub fn diagnostics(code: u8, error: &Diagnostics) -> Self {
        Self {
            code,
            message: error.to_string(),
        }
    }
}

/// A file that cannot be used fails the operation (exit status 1), each finding shown.
impl From<Diagnostics> for Failure {
    fn from(error: Diagnostics) -> Self {
        Failure::diagnostics(1, &error)
    }
}

/// The command line with a `--json` given among the leading options (`hapticctl --json
/// status`) moved behind the command, where the commands that print take it: like `--bus`,
/// it may be written anywhere.
fn json_anywhere(args: impl Iterator<Item = OsString>) -> Vec<OsString> {
    let mut args: Vec<OsString> = args.collect();
    let mut i = 1;
    let mut json = false;
    while let Some(arg) = args.get(i).and_then(|a| a.to_str()) {
        match arg {
            "--json" => {
                args.remove(i);
                json = true;
            }
            // Global options whose value is the next argument.
            "--bus" | "--mechanism-dir" | "--remote" | "--remote-config" => i += 2,
            _ if arg.starts_with('-') => i += 1,
            _ => break,
        }
    }
    if json {
        args.push("--json".into());
    }
    args
}

fn main() -> ExitCode {
    completion::answer_the_shell();
    let cli = Cli::parse_from(json_anywhere(std::env::args_os()));
    // What plugins say as they load is the daemon log's business, not a command's output.
    hapticd_service::logging::init("hapticctl", hapticd_service::logging::Level::WARN);
    let catalog = if cli.mechanism_dirs.is_empty() {
        Catalog::from_env()
    } else {
        Catalog::new(cli.mechanism_dirs)
    };
    // Only the commands that talk to hapticd connect to the bus.
    let connect = || client::Client::connect(&cli.bus).map_err(Failure::from);
    let remote = cli.remote.map(|endpoint| hapticctl::remote_daemon::Remote {
        endpoint,
        config: cli.remote_config,
    });
    let result = match (&remote, cli.command) {
        (Some(remote), Command::Status(output)) => remote::status(remote, &output),
        (Some(remote), Command::Record(args)) => remote::record(remote, &args),
        (Some(_), _) => Err(Failure::usage(
            "--remote reaches a hapticd's status and its ticks (status, record), nothing else",
        )),
        (None, command) => match command {
            Command::Mechanism(command) => mechanism::run(command, &catalog),
            Command::Experiment(command) => experiment::run(command, &catalog),
            Command::Device(command) => device::run(command),
            Command::Mesh(command) => mesh::run(command),
            Command::Scene(command) => scene::run(command, &cli.bus),
            Command::Body(command) => connect().and_then(|c| body::run(command, &c)),
            Command::Joint(command) => connect().and_then(|c| joint::run(command, &c)),
            Command::Effect(command) => connect().and_then(|c| effect::run(command, &c)),
            Command::Render(args) => render::run(&args, &catalog),
            Command::Snapshot(args) => pictures::snapshot(&args, &cli.bus),
            Command::View(args) => pictures::view(&args, &cli.bus),
            Command::Status(output) => connect().and_then(|c| client::status(&c, &output)),
            Command::Get(args) => connect().and_then(|c| client::get(&c, &args)),
            Command::Set(args) => connect().and_then(|c| client::set(&c, &args)),
            Command::Calibrate(device) => connect().and_then(|c| client::calibrate(&c, &device)),
            Command::Bind(args) => connect().and_then(|c| client::bind(&c, &args)),
            Command::Reload => connect().and_then(|c| client::reload(&c)),
            Command::Restart => connect().and_then(|c| client::restart(&c)),
            Command::Monitor(args) => connect().and_then(|c| client::monitor(&c, &args)),
            Command::Record(args) => connect().and_then(|c| client::record(&c, &args)),
            Command::Top(args) => connect().and_then(|c| client::top(&c, &args)),
            Command::Completions { shell } => completion::script(&shell)
                .map_err(Failure::usage)
                .map(|script| {
                    use std::io::Write;
                    // Written whole, then sent: a reader that stops early is no failure.
                    let _ = std::io::stdout().write_all(&script);
                }),
            Command::Manual { dir } => manual::write(&dir),
        },
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            eprintln!("{}", failure.message);
            ExitCode::from(failure.code)
        }
    }
}
