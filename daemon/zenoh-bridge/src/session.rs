//! The Zenoh session of hapticd's network programs (the bridge, the world host), a peer on the
//! configured endpoints on the administrator's own Zenoh configuration when one is named, and
//! how long they run.

use std::time::{Duration, Instant};

use zenoh::Wait;

use crate::config::NetworkConfig;

/// The Zenoh session: a peer on the configured endpoints, not looking for others by
/// multicast (nothing leaves the machine unless an endpoint says so), built on the
/// administrator's own Zenoh configuration when one is named.
pub fn open(config: &NetworkConfig) -> Result<zenoh::Session, String> {
    let mut zenoh_config = match &config.zenoh {
        Some(path) => {
            zenoh::Config::from_file(path).map_err(|e| format!("{}: {e}", path.display()))?
        }
        None => zenoh::Config::default(),
    };
    let mut set = |key: &str, value: String| {
        zenoh_config
            .insert_json5(key, &value)
            .map_err(|e| format!("{key}: {e}"))
    };
    set("mode", "\"peer\"".into())?;
    set(
        "listen/endpoints",
        serde_json::json!(config.listen).to_string(),
    )?;
    set(
        "connect/endpoints",
        serde_json::json!(config.connect).to_string(),
    )?;
    set("scouting/multicast/enabled", "false".into())?;
    zenoh::open(zenoh_config)
        .wait()
        .map_err(|e| format!("cannot open a zenoh session on {:?}: {e}", config.listen))
}

/// When a run of `duration` seconds from now ends (None: never); an error for a duration that
/// is no number of seconds above zero.
pub fn deadline(duration: Option<f64>) -> Result<Option<Instant>, String> {
    match duration {
        Some(s) if s.is_finite() && s > 0.0 => {
            Ok(Some(Instant::now() + Duration::from_secs_f64(s)))
        }
        Some(_) => Err("--duration must be a number of seconds > 0".into()),
        None => Ok(None),
    }
}
