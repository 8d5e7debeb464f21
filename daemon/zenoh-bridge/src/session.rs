//! The Zenoh session of hapticd's network programs (the bridge, the world host), a peer on the
//! configured endpoints on the administrator's own Zenoh configuration when one is named, and
//! how long they run.

use std::time::{Duration, Instant};

use zenoh::Wait;

use crate::config::NetworkConfig;

/// Why the session could not be opened.
#[derive(Debug)]
pub enum SessionError {
    /// The administrator's Zenoh configuration file is refused.
    Config {
        /// The file.
        path: std::path::PathBuf,
        /// Zenoh's reason.
        error: zenoh::Error,
    },
    /// A setting of the network configuration is refused by Zenoh.
    Setting {
        /// Its key.
        key: &'static str,
        /// Zenoh's reason.
        error: zenoh::Error,
    },
    /// Zenoh could not open the session on these endpoints.
    Open {
        /// The endpoints listened on.
        listen: Vec<String>,
        /// Zenoh's reason.
        error: zenoh::Error,
    },
}

impl std::fmt::Display for SessionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SessionError::Config { path, error } => write!(f, "{}: {error}", path.display()),
            SessionError::Setting { key, error } => write!(f, "{key}: {error}"),
            SessionError::Open { listen, error } => {
                write!(f, "cannot open a zenoh session on {listen:?}: {error}")
            }
        }
    }
}

impl std::error::Error for SessionError {}

/// A run's length that is no number of seconds above zero.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BadDuration(pub f64);

impl std::fmt::Display for BadDuration {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("--duration must be a number of seconds > 0")
    }
}

impl std::error::Error for BadDuration {}

/// The Zenoh session: a peer on the configured endpoints, not looking for others by
/// multicast (nothing leaves the machine unless an endpoint says so), built on the
/// administrator's own Zenoh configuration when one is named.
pub fn open(config: &NetworkConfig) -> Result<zenoh::Session, SessionError> {
    let mut zenoh_config = match &config.zenoh {
        Some(path) => zenoh::Config::from_file(path).map_err(|error| SessionError::Config {
            path: path.clone(),
            error,
        })?,
        None => zenoh::Config::default(),
    };
    let mut set = |key: &'static str, value: String| {
        zenoh_config
            .insert_json5(key, &value)
            .map_err(|error| SessionError::Setting { key, error })
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
        .map_err(|error| SessionError::Open {
            listen: config.listen.clone(),
            error,
        })
}

/// How long a session has to meet the routers or peers it connects to before the log says
/// none answers (it goes on trying: one that starts later is met then).
pub const MEETING: Duration = Duration::from_secs(2);

/// Say once in the log, [`MEETING`] after `session` opened, when none of the endpoints
/// `config` connects to answers; nothing waits for it.
pub fn say_when_unmet(session: &zenoh::Session, config: &NetworkConfig) {
    if config.connect.is_empty() {
        return;
    }
    let (session, connect) = (session.clone(), config.connect.clone());
    let spawned = std::thread::Builder::new()
        .name("zenoh-meeting".into())
        .spawn(move || {
            std::thread::sleep(MEETING);
            let info = session.info();
            let met = info.routers_zid().wait().next().is_some()
                || info.peers_zid().wait().next().is_some();
            if !met {
                tracing::warn!(
                    "no Zenoh router or peer answers at {connect:?} (ROS 2 nodes of rmw_zenoh \
                     meet through a router: `ros2 run rmw_zenoh_cpp rmw_zenohd`); publishing \
                     anyway, and meeting one as soon as it answers"
                );
            }
        });
    if let Err(e) = spawned {
        tracing::warn!("cannot watch for the Zenoh router: {e}");
    }
}

/// When a run of `duration` seconds from now ends (None: never); an error for a duration that
/// is no number of seconds above zero.
pub fn deadline(duration: Option<f64>) -> Result<Option<Instant>, BadDuration> {
    match duration {
        Some(s) if s.is_finite() && s > 0.0 => {
            Ok(Some(Instant::now() + Duration::from_secs_f64(s)))
        }
        Some(s) => Err(BadDuration(s)),
        None => Ok(None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_lasts_a_number_of_seconds_above_zero_or_for_ever() {
        assert_eq!(deadline(None), Ok(None));
        assert!(deadline(Some(1.0)).is_ok_and(|d| d.is_some()));
        for bad in [0.0, -1.0, f64::INFINITY] {
            assert_eq!(deadline(Some(bad)), Err(BadDuration(bad)));
        }
        assert!(deadline(Some(f64::NAN)).is_err());
    }

    #[test]
    fn an_administrators_file_that_is_not_there_is_refused_by_name() {
        let config = NetworkConfig {
            zenoh: Some("/nonexistent/zenoh.json5".into()),
            ..NetworkConfig::default()
        };
        let refused = open(&config).err().unwrap();
        assert!(
            matches!(&refused, SessionError::Config { path, .. } if path.ends_with("zenoh.json5")),
            "{refused}"
        );
        assert!(
            refused
                .to_string()
                .starts_with("/nonexistent/zenoh.json5: ")
        );
    }
}
