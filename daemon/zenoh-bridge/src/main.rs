//! `hapticd-zenoh`: hapticd's devices on the network, in a process of its own (the haptic
//! process never touches a socket). It follows each device's telemetry ring and publishes
//! its effectors' poses and displayed wrenches as ROS 2 topics in rmw_zenoh's keys and CDR
//! (`/hapticd/<device>/<effector>/pose`, `…/wrench`), at a rate of the administrator's
//! choosing up to the device's, and answers `hapticd/<device>/status` queries. It listens on
//! the loopback only unless told otherwise, and takes no commands.

mod bridge;
mod topics;

use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Parser;
use hapticd_ipc::bus::Bus;
use hapticd_ipc::client::Hapticd;
use zenoh::Wait;

/// hapticd's devices as ROS 2 topics over Zenoh.
#[derive(Parser)]
#[command(version)]
struct Cli {
    /// The bus hapticd serves: `system`, `session` or a D-Bus address.
    #[arg(long, default_value = "system")]
    bus: Bus,
    /// Where to listen for Zenoh peers and clients (Zenoh's endpoint form).
    #[arg(long, default_value = "tcp/127.0.0.1:7447")]
    listen: String,
    /// Samples a second per topic; one in every so many ticks of the device is published
    /// (at most the device's rate).
    #[arg(long, default_value_t = 100.0)]
    rate: f64,
    /// The ROS 2 domain (`ROS_DOMAIN_ID`).
    #[arg(long, default_value_t = 0)]
    domain: u32,
    /// Stop after this many seconds (for tests).
    #[arg(long)]
    duration: Option<f64>,
}

/// The Zenoh session: a peer on `listen`, not looking for others by multicast (nothing
/// leaves the machine unless the endpoint says so).
fn session(listen: &str) -> Result<zenoh::Session, String> {
    let mut config = zenoh::Config::default();
    let set = |config: &mut zenoh::Config, key: &str, value: String| {
        config
            .insert_json5(key, &value)
            .map_err(|e| format!("{key}: {e}"))
    };
    set(&mut config, "mode", "\"peer\"".into())?;
    set(
        &mut config,
        "listen/endpoints",
        serde_json::json!([listen]).to_string(),
    )?;
    set(&mut config, "scouting/multicast/enabled", "false".into())?;
    zenoh::open(config)
        .wait()
        .map_err(|e| format!("cannot open a zenoh session on {listen}: {e}"))
}

fn run(cli: &Cli) -> Result<(), String> {
    if !(cli.rate.is_finite() && cli.rate > 0.0) {
        return Err("--rate must be a number of samples a second > 0".into());
    }
    let until = match cli.duration {
        Some(s) if s.is_finite() && s > 0.0 => Some(Instant::now() + Duration::from_secs_f64(s)),
        Some(_) => return Err("--duration must be a number of seconds > 0".into()),
        None => None,
    };
    let hapticd = Hapticd::connect(&cli.bus).map_err(|e| e.to_string())?;
    let devices = hapticd.devices().map_err(|e| e.to_string())?;
    let session = session(&cli.listen)?;
    std::thread::scope(|scope| {
        let bridges: Vec<_> = devices
            .iter()
            .map(|device| {
                let session = &session;
                scope.spawn(move || {
                    let device_rate = device.open_telemetry().map_err(|e| e.to_string())?.rate();
                    let every = (device_rate / cli.rate).round().max(1.0) as u64;
                    bridge::run(session, device, cli.domain, every, until)
                        .map_err(|e| e.to_string())
                })
            })
            .collect();
        bridges
            .into_iter()
            .map(|b| b.join().unwrap_or_else(|_| Err("a bridge panicked".into())))
            .collect::<Result<Vec<()>, String>>()
    })?;
    session.close().wait().map_err(|e| e.to_string())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hapticd-zenoh: {e}");
            ExitCode::FAILURE
        }
    }
}
