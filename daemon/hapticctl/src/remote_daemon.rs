//! A hapticd on another machine, reached through its network bridge (hapticd-zenoh) instead
//! of the bus: each device's status from its status query, and its ticks from its telemetry
//! key, written in the CSV of every recording ([`telemetry_csv`]; one row in every so many
//! ticks, the bridge's rate).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use hapticd_core::telemetry::Sample;
use hapticd_ipc::telemetry_csv;
use serde_json::Value;
use zenoh::Wait;

use crate::daemon_view::words;

/// Why a remote hapticd could not be asked.
#[derive(Debug)]
pub enum RemoteError {
    /// The Zenoh configuration file is refused (the caller's mistake).
    Config {
        /// The file.
        path: PathBuf,
        /// Zenoh's reason.
        error: zenoh::Error,
    },
    /// The endpoint is no setting Zenoh takes (the caller's mistake).
    Endpoint {
        /// The endpoint.
        endpoint: String,
        /// Zenoh's reason.
        error: zenoh::Error,
    },
    /// No session to the endpoint.
    Unreachable {
        /// The endpoint.
        endpoint: String,
        /// Zenoh's reason.
        error: zenoh::Error,
    },
    /// A query or subscription failed.
    Zenoh {
        /// The endpoint.
        endpoint: String,
        /// Zenoh's reason.
        error: zenoh::Error,
    },
    /// No bridge answered the status query.
    NoAnswer(String),
    /// No device of that index or identity.
    NoDevice {
        /// The endpoint.
        endpoint: String,
        /// What was asked for.
        asked: String,
    },
    /// The bridge names no telemetry key.
    NoTelemetry(String),
    /// The bridge publishes ticks in another layout than this hapticctl reads.
    Layout {
        /// The endpoint.
        endpoint: String,
        /// The key it publishes on.
        key: String,
        /// The layout read here.
        layout: String,
    },
    /// The CSV file cannot be written.
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// No tick arrived in the first 10 s.
    NoTick(String),
}

impl std::fmt::Display for RemoteError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RemoteError::Config { path, error } => {
                write!(f, "--remote-config {}: {error}", path.display())
            }
            RemoteError::Endpoint { endpoint, error } => write!(f, "--remote {endpoint}: {error}"),
            RemoteError::Unreachable { endpoint, error } => {
                write!(f, "cannot reach {endpoint}: {error}")
            }
            RemoteError::Zenoh { endpoint, error } => write!(f, "{endpoint}: {error}"),
            RemoteError::NoAnswer(endpoint) => write!(
                f,
                "no hapticd answers at {endpoint} (is hapticd-zenoh running there, and reachable?)"
            ),
            RemoteError::NoDevice { endpoint, asked } => {
                write!(f, "no device {asked} at {endpoint}")
            }
            RemoteError::NoTelemetry(endpoint) => {
                write!(f, "{endpoint}: the bridge names no telemetry")
            }
            RemoteError::Layout {
                endpoint,
                key,
                layout,
            } => write!(
                f,
                "{endpoint} publishes ticks as {key}; this hapticctl reads layout {layout}"
            ),
            RemoteError::Write { path, error } => {
                write!(f, "cannot write {}: {error}", path.display())
            }
            RemoteError::NoTick(endpoint) => write!(f, "{endpoint}: no tick arrived in 10 s"),
        }
    }
}

impl std::error::Error for RemoteError {}

impl RemoteError {
    /// Whether the caller's arguments are at fault (a usage error).
    pub fn is_usage(&self) -> bool {
        matches!(
            self,
            RemoteError::Config { .. } | RemoteError::Endpoint { .. }
        )
    }
}

/// Where a remote hapticd is: its bridge's Zenoh endpoint, and the Zenoh configuration file
/// (JSON5: TLS certificates, authentication) to reach it with.
pub struct Remote {
    /// The bridge's endpoint (`tcp/HOST:7447`, `tls/HOST:7447`).
    pub endpoint: String,
    /// A Zenoh configuration file read first.
    pub config: Option<PathBuf>,
}

/// A recording taken: its rows, the ticks lost on the way, and one tick in how many.
pub struct Recorded {
    /// Rows written.
    pub rows: u64,
    /// Published ticks that never arrived.
    pub missed: u64,
    /// The bridge publishes one tick in this many.
    pub every: u64,
}

impl Remote {
    /// A Zenoh client session to the bridge (nothing looked for by multicast).
    fn session(&self) -> Result<zenoh::Session, RemoteError> {
        let endpoint = &self.endpoint;
        let mut config = match &self.config {
            Some(path) => zenoh::Config::from_file(path).map_err(|error| RemoteError::Config {
                path: path.clone(),
                error,
            })?,
            None => zenoh::Config::default(),
        };
        for (key, value) in [
            ("mode", "\"client\"".to_string()),
            (
                "connect/endpoints",
                serde_json::json!([endpoint]).to_string(),
            ),
            ("scouting/multicast/enabled", "false".to_string()),
        ] {
            config
                .insert_json5(key, &value)
                .map_err(|error| RemoteError::Endpoint {
                    endpoint: endpoint.clone(),
                    error,
                })?;
        }
        zenoh::open(config)
            .wait()
            .map_err(|error| RemoteError::Unreachable {
                endpoint: endpoint.clone(),
                error,
            })
    }

    /// Each device's status as the bridge answers it, in identity order.
    pub fn statuses(&self) -> Result<Vec<Value>, RemoteError> {
        statuses(&self.session()?, &self.endpoint)
    }

    /// The device `asked` (an index or an identity) recorded for `seconds` from its first
    /// tick into `file`.
    pub fn record(&self, asked: &str, seconds: f64, file: &Path) -> Result<Recorded, RemoteError> {
        let endpoint = &self.endpoint;
        let session = self.session()?;
        let found = statuses(&session, endpoint)?;
        let device = match asked.parse::<usize>() {
            Ok(k) => found.get(k),
            Err(_) => found.iter().find(|s| s["identity"] == asked),
        }
        .ok_or_else(|| RemoteError::NoDevice {
            endpoint: endpoint.clone(),
            asked: asked.to_string(),
        })?;
        let key = device["telemetry"]
            .as_str()
            .ok_or_else(|| RemoteError::NoTelemetry(endpoint.clone()))?;
        let layout = format!("/v{}", hapticd_core::telemetry::VERSION);
        if !key.ends_with(&layout) {
            return Err(RemoteError::Layout {
                endpoint: endpoint.clone(),
                key: key.to_string(),
                layout,
            });
        }
        let effectors: Vec<String> = device["effectors"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|e| e.as_str().map(String::from))
            .collect();
        let every = device["publishing_every"].as_u64().unwrap_or(1).max(1);
        let subscriber =
            session
                .declare_subscriber(key)
                .wait()
                .map_err(|error| RemoteError::Zenoh {
                    endpoint: endpoint.clone(),
                    error,
                })?;
        let cannot = |error: std::io::Error| RemoteError::Write {
            path: file.to_path_buf(),
            error,
        };
        let mut out = std::io::BufWriter::new(std::fs::File::create(file).map_err(cannot)?);
        let mut recorded = Recorded {
            rows: 0,
            missed: 0,
            every,
        };
        let (mut strings, mut last, mut until) = (None, None::<u64>, None);
        let started = Instant::now();
        loop {
            let deadline = until.unwrap_or(started + Duration::from_secs(10));
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            let Ok(Some(sample)) = subscriber.recv_timeout(left) else {
                continue;
            };
            let Some(tick) = Sample::decode(&sample.payload().to_bytes()) else {
                continue;
            };
            // The duration counts from the first tick received.
            until.get_or_insert_with(|| Instant::now() + Duration::from_secs_f64(seconds));
            let n = *strings.get_or_insert_with(|| {
                let n = tick.strings as usize;
                let _ = writeln!(out, "{}", telemetry_csv::header(&effectors, n));
                n
            });
            if let Some(previous) = last {
                recorded.missed += (tick.tick.saturating_sub(previous) / every).saturating_sub(1);
            }
            last = Some(tick.tick);
            writeln!(out, "{}", telemetry_csv::row(&tick, effectors.len(), n)).map_err(cannot)?;
            recorded.rows += 1;
        }
        out.flush().map_err(cannot)?;
        if recorded.rows == 0 {
            return Err(RemoteError::NoTick(endpoint.clone()));
        }
        Ok(recorded)
    }
}

/// Each device's status as the bridge at `endpoint` answers it, in identity order.
fn statuses(session: &zenoh::Session, endpoint: &str) -> Result<Vec<Value>, RemoteError> {
    let replies = session
        .get("hapticd/*/status")
        .timeout(Duration::from_secs(5))
        .wait()
        .map_err(|error| RemoteError::Zenoh {
            endpoint: endpoint.to_string(),
            error,
        })?;
    let mut found: Vec<Value> = Vec::new();
    while let Ok(reply) = replies.recv() {
        if let Ok(sample) = reply.result()
            && let Ok(text) = sample.payload().try_to_string()
            && let Ok(status) = serde_json::from_str(&text)
        {
            found.push(status);
        }
    }
    if found.is_empty() {
        return Err(RemoteError::NoAnswer(endpoint.to_string()));
    }
    found.sort_by_key(|s| s["identity"].to_string());
    Ok(found)
}

/// The devices of `statuses` in lines, as `hapticctl --remote ENDPOINT status` says them.
pub fn status_text(endpoint: &str, statuses: &[Value]) -> String {
    let mut text = format!("hapticd at {endpoint}, through its network bridge:\n");
    for s in statuses {
        text += &format!(
            "{}: {}, {} Hz, tick {}, effectors {}, published one tick in {}, commands {}\n",
            words(&s["identity"]),
            words(&s["state"]),
            words(&s["rate"]),
            words(&s["tick"]),
            words(&s["effectors"]),
            words(&s["publishing_every"]),
            if s["commands"] == Value::Bool(true) {
                "taken"
            } else {
                "refused"
            },
        );
    }
    text
}
