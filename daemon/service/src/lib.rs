//! What hapticd's system services (the daemon and its renderer) share as processes, apart
//! from the wire contract of `hapticd-ipc`:
//!
//! - [`clock`]: the one monotonic clock the haptic, physics and plugin threads share;
//! - [`logging`]: log lines to the journal when systemd runs the service, to standard error
//!   otherwise;
//! - [`sd_notify`]: readiness and status for systemd;
//! - [`cpus`]: the CPUs kept for haptic threads, and every other thread kept off them;
//! - [`workers`]: a few threads of their own for a bus service's blocking requests;
//! - [`log_lines`]: how often the log may say what keeps happening;
//! - [`cli`]: both programs' command lines, which `hapticctl manual` writes their pages from.

pub mod cli;
pub mod clock;
pub mod cpus;
pub mod log_lines;
pub mod logging;
pub mod sd_notify;
pub mod workers;

pub use workers::Workers;
