//! The Zenoh session of hapticd's network programs (the bridge, the world host): a peer on
//! the configured endpoints, on the administrator's own Zenoh configuration when one is named.

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
