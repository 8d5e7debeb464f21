//! hapticd-render: draws hapticd's world (the scene, the pointers, the strings) with Vulkan
//! and serves the pictures on D-Bus as `org.hapticd.Renderer1`.
//!
//! A process of its own, not a thread of hapticd: a Vulkan driver may compile code at run
//! time (which hapticd's `MemoryDenyWriteExecute=yes` forbids), loads hundreds of
//! megabytes that hapticd's `mlockall` would lock, and takes its process down when it
//! crashes. hapticd hands it the world through shared memory and never waits for it.
//!
//! - [`world_source`]: hapticd's world and the scene's solids, as meshes;
//! - [`drawing`]: the thread that owns the Vulkan device and draws;
//! - [`options`]: the options of requests, checked;
//! - [`limits`]: what the renderer will take on (streams, pixels a second, memory);
//! - [`statistics`]: what it has open and has done, for the bus;
//! - [`bus`]: the D-Bus interface; [`error`]: its errors.

mod bus;
mod drawing;
mod error;
mod limits;
mod options;
mod statistics;
mod world_source;

use std::process::ExitCode;
use std::sync::Arc;

use clap::Parser;
use hapticd_ipc::names::{RENDERER_BUS_NAME, RENDERER_PATH};
use hapticd_service::Workers;
use hapticd_service::cli::RenderCli;

use crate::statistics::Statistics;

fn main() -> ExitCode {
    let cli = RenderCli::parse();
    hapticd_service::logging::init("hapticd-render", hapticd_service::logging::Level::INFO);
    // Off the CPU hapticd's first haptic thread takes, before the driver starts its own
    // threads (they inherit the affinity).
    if let Err(e) = hapticd_service::cpus::keep_off_the_haptic_cpu() {
        tracing::warn!("cannot keep off the haptic CPU: {e}");
    }
    let statistics = Arc::new(Statistics::default());
    let limits = cli.limits;
    let started = drawing::start(cli.bus.clone(), cli.device, limits, statistics.clone());
    let (jobs, availability) = match started {
        Ok(started) => started,
        Err(e) => {
            tracing::error!("cannot start the drawing thread: {e}");
            return ExitCode::FAILURE;
        }
    };
    match &availability {
        drawing::Availability::Available(device) => tracing::info!("drawing on {device}"),
        drawing::Availability::Unavailable(why) => tracing::warn!(
            "no pictures on this machine: {why}; hapticd runs without them, and \
             org.hapticd.Renderer1 says so"
        ),
    }
    let workers = match Workers::start() {
        Ok(w) => Arc::new(w),
        Err(e) => {
            tracing::error!("cannot start the worker threads: {e}");
            return ExitCode::FAILURE;
        }
    };
    let interface =
        bus::RendererInterface::new(jobs.clone(), workers, availability, limits, statistics);
    let connection = zbus::block_on(async {
        cli.bus
            .builder()
            .serve_at(RENDERER_PATH, interface)
            .name(RENDERER_BUS_NAME)
            .allow_name_replacements(false)
            .replace_existing_names(false)
            .build()
            .await
    });
    let connection = match connection {
        Ok(c) => c,
        Err(e) => {
            tracing::error!("cannot serve {} on {:?}: {e}", RENDERER_BUS_NAME, cli.bus);
            return ExitCode::FAILURE;
        }
    };
    let _ = jobs.send(drawing::Job::Connected(connection.clone()));
    let _ = hapticd_service::sd_notify::notify("READY=1");
    // zbus's own thread serves the bus; SIGTERM ends the process (nothing to save).
    loop {
        std::thread::park();
    }
}
