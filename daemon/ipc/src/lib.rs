//! hapticd's wire contract: what a program needs to talk to the daemon and its renderer,
//! and nothing of the daemon itself.
//!
//! - [`names`]: the bus names, object paths, interfaces and error names;
//! - [`bus`]: which bus (system, session, an address) and who a caller is;
//! - [`client`]: a blocking client for programs built on hapticd: devices, parameters,
//!   calibration, every tick, scenes;
//! - [`proxies`]: typed clients of `org.hapticd.Hapticd1.Manager`, `…Device` and
//!   `org.hapticd.Renderer1`;
//! - [`world_share`]: the shared world a device's `OpenWorld` hands out (its layout is
//!   `hapticd_core::world_state`), and the reader that maps it;
//! - [`geometry_share`]: the scene's solids a device's `OpenGeometry` hands out (its layout
//!   is `hapticd_core::world_geometry`), and their reader;
//! - [`telemetry_share`]: every tick of a device, in the ring its `OpenTelemetry` hands out
//!   (its layout is `hapticd_core::telemetry`), and a reader that follows it;
//! - [`telemetry_csv`]: ticks as CSV, the columns every recording writes;
//! - [`touch_events`]: touches begun, ended and slipping, found in those ticks;
//! - [`wrench_share`]: the wrench commanded from outside, which `OpenWrenchInput` hands out
//!   to be written;
//! - [`world_link_share`]: the link through which a device's remote scene and the network
//!   bridge exchange a world stepped on another machine (`OpenWorldLink`);
//! - [`frame_ring`]: the ring of frames the renderer's `OpenFrameStream` hands out;
//! - [`shared_memory`]: the sealed memfds both are made of.
//!
//! hapticd, hapticd-render and hapticctl use it; so may any other program.
//!
//! ```no_run
//! use hapticd_ipc::bus::Bus;
//! use hapticd_ipc::proxies::DeviceProxy;
//! use hapticd_ipc::world_share::MappedWorld;
//!
//! // The first device's world, as the renderer reads it.
//! let world = zbus::block_on(async {
//!     let connection = Bus::System.connection().await?;
//!     let device = DeviceProxy::builder(&connection)
//!         .path(hapticd_ipc::device_path(0))
//!         .build()
//!         .await?;
//!     device.open_world().await
//! })?;
//! let world = MappedWorld::open(&world.into()).map_err(std::io::Error::other)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod bus;
pub mod client;
pub mod frame_ring;
pub mod geometry_share;
pub mod names;
pub mod proxies;
pub mod shared_memory;
pub mod telemetry_csv;
pub mod telemetry_share;
pub mod touch_events;
pub mod world_link_share;
pub mod world_share;
pub mod wrench_share;

pub use names::{
    API_VERSION, BUS_NAME, DEVICE_INTERFACE, MANAGER_INTERFACE, MANAGER_PATH, SCENE_INTERFACE,
    SCENE_PATH, device_path,
};
