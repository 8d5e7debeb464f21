//! Where log messages go: the systemd journal (structured fields, priorities) when hapticd
//! runs as a service, standard error otherwise. The real-time thread never logs: it sends
//! events through a ring to an ordinary thread, which logs them here.

use tracing_subscriber::layer::SubscriberExt;

/// Install the global logger for `program`. The journal is used when systemd connected
/// standard error to it (`$JOURNAL_STREAM`), or when `journal` is true.
pub fn init(program: &str, journal: bool) {
    let to_journal = journal || std::env::var_os("JOURNAL_STREAM").is_some();
    if to_journal && let Ok(layer) = tracing_journald::layer() {
        let layer = layer.with_syslog_identifier(program.to_string());
        if tracing::subscriber::set_global_default(tracing_subscriber::registry().with(layer))
            .is_ok()
        {
            return;
        }
    }
    let _ = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .without_time()
        .with_target(false)
        .try_init();
}
