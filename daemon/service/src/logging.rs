//! Where log messages go: the systemd journal (structured fields, priorities) when hapticd
//! runs as a service, standard error otherwise. The real-time thread never logs: it sends
//! events through a ring to an ordinary thread, which logs them here.

pub use tracing::Level;
use tracing_subscriber::Layer;
use tracing_subscriber::filter::LevelFilter;
use tracing_subscriber::layer::SubscriberExt;

/// Whether systemd connected the standard streams to the journal (`$JOURNAL_STREAM`).
pub fn under_journal() -> bool {
    std::env::var_os("JOURNAL_STREAM").is_some()
}

/// Install the global logger for `program`, passing messages of `level` and more severe
/// (a service logs what it does; a command-line tool only what went wrong). The journal is
/// used when systemd connected standard error to it.
pub fn init(program: &str, level: Level) {
    if under_journal()
        && let Ok(layer) = tracing_journald::layer()
    {
        let layer = layer
            .with_syslog_identifier(program.to_string())
            .with_filter(LevelFilter::from_level(level));
        if tracing::subscriber::set_global_default(tracing_subscriber::registry().with(layer))
            .is_ok()
        {
            return;
        }
    }
    let _ = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_max_level(level)
        .without_time()
        .with_target(false)
        .try_init();
}
