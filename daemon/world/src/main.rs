//! `hapticd-world`: a rapier world stepped on this machine for the devices of hapticd on
//! several (thesis Fig. 6.13's hierarchy over a network). Each hapticd renders it locally
//! through a remote scene (`engine: remote`), its bridge carrying the messages of
//! `hapticd_core::scene::remote` under the keys of `hapticd_zenoh::world_keys`. Like the
//! bridge, it listens on the loopback only unless configured otherwise.

mod status;

use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Parser;
use hapticd_core::scene::remote::{MAX_WORLD_BYTES, decode_host};
use hapticd_core::wire::Encoder;
use hapticd_physics::scene::{RapierScene, SceneFile};
use hapticd_service::cli::WorldCli;
use hapticd_service::log_lines::{self, LogLines};
use hapticd_service::logging::{self, Level};
use hapticd_zenoh::config::NetworkConfig;
use hapticd_zenoh::{session, world_keys};
use zenoh::Wait;
use zenoh::qos::CongestionControl;

use hapticd_core::scene::shared_world::SharedWorld;
use hapticd_rapier::world::RapierWorld;

/// The network configuration with the command line's overrides.
fn configuration(cli: &WorldCli) -> Result<NetworkConfig, String> {
    let mut config = NetworkConfig::load(cli.config.as_deref()).map_err(|e| e.to_string())?;
    if !cli.listen.is_empty() {
        config.listen = cli.listen.clone();
    }
    if !cli.connect.is_empty() {
        config.connect = cli.connect.clone();
    }
    config
        .check()
        .map_err(|e| format!("the command line: {e}"))?;
    Ok(config)
}

/// The world's name: `--name`, or the scene file's.
fn world_name(cli: &WorldCli) -> Result<String, String> {
    let name = match &cli.name {
        Some(name) => name.clone(),
        None => cli
            .scene
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
    };
    if !world_keys::is_name(&name) {
        return Err(format!(
            "{name:?} is no world's name (letters, digits, - and _): give one with --name"
        ));
    }
    Ok(name)
}

/// The scene file of the command line, which must be a rapier one.
fn rapier_scene(cli: &WorldCli) -> Result<Box<RapierScene>, String> {
    match SceneFile::load(&cli.scene, cli.pointers).map_err(|e| e.to_string())? {
        SceneFile::Rapier(spec) => Ok(spec),
        SceneFile::Penalty(_) => Err(format!(
            "{}: a shared world is a rapier one (engine: rapier)",
            cli.scene.display()
        )),
    }
}

fn run(cli: &WorldCli) -> Result<(), String> {
    let config = configuration(cli)?;
    let until = session::deadline(cli.duration).map_err(|e| e.to_string())?;
    if !(1..=64).contains(&cli.pointers) {
        return Err(format!("--pointers {}: from 1 to 64", cli.pointers));
    }
    let name = world_name(cli)?;
    let spec = rapier_scene(cli)?;
    let mut world = SharedWorld::new(
        RapierWorld::new(&spec, cli.pointers),
        spec.rate,
        cli.pointers,
    );
    let mut peak_energy: f64 = 0.0;
    let session = session::open(&config).map_err(|e| e.to_string())?;
    session::say_when_unmet(&session, &config);
    let zenoh = |e: zenoh::Error| format!("zenoh: {e}");
    let incoming = session
        .declare_subscriber(world_keys::from_hosts(&name))
        .wait()
        .map_err(zenoh)?;
    let status = session
        .declare_queryable(world_keys::status(&name))
        .wait()
        .map_err(zenoh)?;
    tracing::info!(
        "world {name} from {}: {} steps a second, room for {} grips, on {:?}",
        cli.scene.display(),
        spec.rate,
        cli.pointers,
        config.listen
    );
    let _ = hapticd_service::sd_notify::notify("READY=1");
    let period = Duration::from_secs_f64(world.period());
    let mut out = Encoder::with_capacity(MAX_WORLD_BYTES);
    // What cannot be taken in is said once an interval, the rest counted: any peer could
    // otherwise fill the journal (with a new host name a message, or the same one).
    let mut refused = LogLines::new(log_lines::INTERVAL);
    let started = Instant::now();
    let mut next = Instant::now();
    while until.is_none_or(|t| Instant::now() < t) {
        let now = Instant::now();
        while let Ok(Some(sample)) = incoming.try_recv() {
            let key = sample.key_expr().as_str();
            let Some(host) = world_keys::host_of(&name, key) else {
                continue;
            };
            let taken = match decode_host(&sample.payload().to_bytes()) {
                Some(update) => world.take(host, update, now).map_err(|e| e.to_string()),
                None => Err("a message that is no host message".to_string()),
            };
            if let Ok(Some(admitted)) = &taken {
                tracing::info!(
                    "host {host}: {} grip(s), pointers {}..{}",
                    admitted.count,
                    admitted.first,
                    admitted.first + admitted.count
                );
            }
            if let Err(why) = taken
                && refused.event(now.duration_since(started).as_secs_f64())
            {
                tracing::warn!("host {host}: {why}");
            }
        }
        if let Some(more) = refused.summary(now.duration_since(started).as_secs_f64()) {
            tracing::warn!(
                "{more} more messages from hosts could not be taken in the last {:.0} s",
                log_lines::INTERVAL
            );
        }
        world.forget_silent(now, |host| tracing::info!("host {host}: silent, forgotten"));
        if !world.step() {
            return Err(format!("world {name}: no longer finite, stopped"));
        }
        peak_energy = peak_energy.max(status::kinetic_energy(world.world()));
        world.updates(&mut out, |host, bytes| {
            let sent = session
                .put(world_keys::to_host(&name, host), bytes.to_vec())
                .congestion_control(CongestionControl::Block)
                .wait();
            if let Err(e) = sent {
                tracing::warn!("host {host}: {e}");
            }
        });
        while let Ok(Some(query)) = status.try_recv() {
            let answer = status::status(&world, &name, &spec.names, peak_energy).to_string();
            if let Err(e) = query.reply(query.key_expr().clone(), answer).wait() {
                tracing::warn!("answering a status query: {e}");
            }
        }
        next += period;
        match next.checked_duration_since(Instant::now()) {
            Some(rest) => std::thread::sleep(rest),
            // Behind (a step longer than its period): start again from now, not in a burst.
            None => next = Instant::now(),
        }
    }
    session.close().wait().map_err(|e| e.to_string())
}

fn main() -> ExitCode {
    let cli = WorldCli::parse();
    logging::init("hapticd-world", Level::INFO);
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            tracing::error!("{e}");
            ExitCode::FAILURE
        }
    }
}
