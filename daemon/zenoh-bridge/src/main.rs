//! `hapticd-zenoh`: hapticd's devices on the network, in a process of its own (the haptic
//! process never touches a socket). It follows each device's telemetry ring and publishes
//! ROS 2 topics in rmw_zenoh's keys and CDR (the table in `topics`), at a rate of the
//! administrator's choosing up to the device's, announces them as rmw_zenoh announces its
//! own, answers `hapticd/<device>/status` queries, and answers commands (`commands`) by
//! carrying them out only where its configuration says so. It listens on the loopback only
//! unless configured otherwise.

mod bridge;
mod commands;
mod ros_publisher;
mod topics;
mod world_relay;

use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Parser;
use hapticd_ipc::client::Hapticd;
use hapticd_service::cli::ZenohCli;
use hapticd_service::logging::{self, Level};
use zenoh::Wait;

use crate::bridge::{BridgeError, Settings};
use hapticd_zenoh::config::NetworkConfig;
use hapticd_zenoh::session;

/// The configuration file with the command line's overrides.
fn configuration(cli: &ZenohCli) -> Result<NetworkConfig, String> {
    let mut config = NetworkConfig::load(cli.config.as_deref()).map_err(|e| e.to_string())?;
    if !cli.listen.is_empty() {
        config.listen = cli.listen.clone();
    }
    if let Some(rate) = cli.rate {
        config.rate = rate;
    }
    if let Some(domain) = cli.domain {
        config.domain = domain;
    }
    config
        .check()
        .map_err(|e| format!("the command line: {e}"))?;
    Ok(config)
}

/// A queryable of command keys, its queries waiting in a channel.
type CommandQueryable =
    zenoh::query::Queryable<zenoh::handlers::FifoChannelHandler<zenoh::query::Query>>;

/// Answer commands until `until` (for ever without one): carried out on `devices` when
/// `allowed`, refused otherwise.
fn serve_commands(
    queryables: &[CommandQueryable],
    hapticd: &Hapticd,
    devices: &[(String, hapticd_ipc::client::Device)],
    allowed: bool,
    until: Option<Instant>,
) {
    while until.is_none_or(|t| Instant::now() < t) {
        let mut idle = true;
        for queryable in queryables {
            let Ok(Some(query)) = queryable.try_recv() else {
                continue;
            };
            idle = false;
            let key = query.key_expr().to_string();
            // A wildcard query that only meets the command keys (`hapticd/*/status` meets
            // `hapticd/scene/**`) is no command: it gets no answer from here.
            if key.contains('*') {
                continue;
            }
            let payload = query
                .payload()
                .map(|p| {
                    p.try_to_string()
                        .map(|s| s.into_owned())
                        .unwrap_or_default()
                })
                .unwrap_or_default();
            let answer = if allowed {
                commands::parse(&key, &payload)
                    .map_err(|e| e.to_string())
                    .and_then(|c| {
                        commands::carry_out(hapticd, devices, &c).map_err(|e| e.to_string())
                    })
            } else {
                Err("refused: this bridge takes no commands from the network \
                     (commands: false in its configuration)"
                    .to_string())
            };
            let sent = match &answer {
                Ok(text) => query.reply(query.key_expr().clone(), text.clone()).wait(),
                Err(why) => query.reply_err(why.clone()).wait(),
            };
            match (&answer, sent) {
                (_, Err(e)) => tracing::warn!("answering {key}: {e}"),
                (Ok(_), Ok(())) => tracing::info!("carried out {key} {payload}"),
                (Err(why), Ok(())) => tracing::info!("refused {key}: {why}"),
            }
        }
        if idle {
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

fn run(cli: &ZenohCli) -> Result<(), String> {
    let config = configuration(cli)?;
    let until = session::deadline(cli.duration).map_err(|e| e.to_string())?;
    let hapticd = Hapticd::connect(&cli.bus).map_err(|e| e.to_string())?;
    let devices = commands::device_words(hapticd.devices().map_err(|e| e.to_string())?)
        .map_err(|e| e.to_string())?;
    let session = session::open(&config).map_err(|e| e.to_string())?;
    session::say_when_unmet(&session, &config);
    tracing::info!(
        "publishing {} device(s), listening on {:?}, connecting to {:?}, ROS domain {}, {} \
         samples/s; commands {}",
        devices.len(),
        config.listen,
        config.connect,
        config.domain,
        config.rate,
        if config.commands { "taken" } else { "refused" }
    );
    let queryables = [
        session.declare_queryable(topics::SET_COMMANDS).wait(),
        session.declare_queryable(topics::EFFECT_COMMANDS).wait(),
        session.declare_queryable(topics::SCENE_COMMANDS).wait(),
    ]
    .into_iter()
    .collect::<Result<Vec<_>, _>>()
    .map_err(|e| format!("zenoh: {e}"))?;
    // Without a scene to ask (the daemon's control of it refused), no joint states.
    let scene = hapticd.scene().ok();
    std::thread::scope(|scope| {
        let scene = scene.as_ref();
        let (session, hapticd, devices, config) = (&session, &hapticd, &devices, &config);
        let (declared, ready) = std::sync::mpsc::channel();
        let threads: Vec<_> = devices
            .iter()
            .enumerate()
            .map(|(k, (_, device))| {
                let declared = declared.clone();
                scope.spawn(move || {
                    let device_rate = device.open_telemetry()?.rate();
                    let settings = Settings {
                        graph: config.graph(),
                        node: k as u32 + 1,
                        every: (device_rate / config.rate).round().max(1.0) as u64,
                        commands: config.commands,
                    };
                    bridge::run(session, (device, scene), settings, until, declared)
                })
            })
            .collect();
        let relays: Vec<_> = match &config.world {
            Some(world) => devices
                .iter()
                .map(|(word, device)| {
                    let host = format!("{}-{word}", session.zid());
                    scope.spawn(move || world_relay::run(session, device, world, &host, until))
                })
                .collect(),
            None => Vec::new(),
        };
        drop(declared);
        // Ready (for systemd and its tests) once every device answers its status, or one
        // failed before it could.
        while ready.recv().is_ok() {}
        let _ = hapticd_service::sd_notify::notify("READY=1");
        serve_commands(&queryables, hapticd, devices, config.commands, until);
        threads
            .into_iter()
            .chain(relays)
            .map(|t| {
                t.join()
                    .unwrap_or_else(|_| Err(BridgeError::Zenoh("a thread panicked".into())))
            })
            .collect::<Result<Vec<()>, BridgeError>>()
    })
    .map_err(|e| e.to_string())?;
    session.close().wait().map_err(|e| e.to_string())
}

fn main() -> ExitCode {
    let cli = ZenohCli::parse();
    logging::init("hapticd-zenoh", Level::INFO);
    // Off the haptic CPU before Zenoh starts its threads (they inherit the affinity): a
    // publisher there would delay the haptic thread's wake-ups.
    if let Err(e) = hapticd_service::cpus::keep_off_the_haptic_cpu() {
        tracing::warn!("cannot keep off the haptic CPU: {e}");
    }
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            tracing::error!("{e}");
            ExitCode::FAILURE
        }
    }
}
