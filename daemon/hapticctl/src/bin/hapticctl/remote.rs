//! `hapticctl --remote ENDPOINT`: a hapticd on another machine, reached through its network
//! bridge (hapticd-zenoh) instead of the bus: `status` from each device's status query,
//! `record` from the device's telemetry key, in the same CSV as a local `record` (one row in
//! every so many ticks: the bridge's rate).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use hapticd_core::telemetry::Sample;
use serde_json::Value;
use zenoh::Wait;

use crate::Failure;
use crate::client::RecordArgs;
use crate::mechanism::Output;
use hapticd_ipc::telemetry_csv;

/// Where a remote hapticd is: its bridge's Zenoh endpoint, and the Zenoh configuration file
/// (JSON5: TLS certificates, authentication) to reach it with.
pub struct Remote {
    /// The bridge's endpoint (`tcp/HOST:7447`, `tls/HOST:7447`).
    pub endpoint: String,
    /// A Zenoh configuration file read first.
    pub config: Option<PathBuf>,
}

impl Remote {
    /// A Zenoh client session to the bridge (nothing looked for by multicast).
    fn session(&self) -> Result<zenoh::Session, Failure> {
        let endpoint = &self.endpoint;
        let mut config = match &self.config {
            Some(path) => zenoh::Config::from_file(path)
                .map_err(|e| Failure::usage(format!("--remote-config {}: {e}", path.display())))?,
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
                .map_err(|e| Failure::usage(format!("--remote {endpoint}: {e}")))?;
        }
        zenoh::open(config)
            .wait()
            .map_err(|e| Failure::failed(format!("cannot reach {endpoint}: {e}")))
    }
}

/// Each device's status as the bridge at `endpoint` answers it, in key order.
fn statuses(session: &zenoh::Session, endpoint: &str) -> Result<Vec<Value>, Failure> {
    let replies = session
        .get("hapticd/*/status")
        .timeout(Duration::from_secs(5))
        .wait()
        .map_err(|e| Failure::failed(format!("{endpoint}: {e}")))?;
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
        return Err(Failure::failed(format!(
            "no hapticd answers at {endpoint} (is hapticd-zenoh running there, and reachable?)"
        )));
    }
    found.sort_by_key(|s| s["identity"].to_string());
    Ok(found)
}

/// `hapticctl --remote ENDPOINT status`.
pub fn status(remote: &Remote, output: &Output) -> Result<(), Failure> {
    let endpoint = &remote.endpoint;
    let session = remote.session()?;
    let found = statuses(&session, endpoint)?;
    if output.json {
        println!("{}", Value::Array(found));
        return Ok(());
    }
    println!("hapticd at {endpoint}, through its network bridge:");
    for s in &found {
        let words = |v: &Value| match v {
            Value::String(s) => s.clone(),
            Value::Number(n) => n.as_f64().map_or(n.to_string(), |x| x.to_string()),
            other => other.to_string(),
        };
        println!(
            "{}: {}, {} Hz, tick {}, effectors {}, published one tick in {}, commands {}",
            words(&s["identity"]),
            words(&s["state"]),
            words(&s["rate"]),
            words(&s["tick"]),
            s["effectors"]
                .as_array()
                .map(|e| e.iter().map(words).collect::<Vec<_>>().join(" "))
                .unwrap_or_default(),
            words(&s["publishing_every"]),
            if s["commands"] == Value::Bool(true) {
                "taken"
            } else {
                "refused"
            },
        );
    }
    Ok(())
}

/// `hapticctl --remote ENDPOINT record`: the device's ticks as the bridge publishes them.
pub fn record(remote: &Remote, args: &RecordArgs) -> Result<(), Failure> {
    use std::io::Write;
    args.check()?;
    let endpoint = &remote.endpoint;
    let session = remote.session()?;
    let found = statuses(&session, endpoint)?;
    let wanted = args.device_name();
    let device = match wanted.parse::<usize>() {
        Ok(k) => found.get(k),
        Err(_) => found.iter().find(|s| s["identity"] == wanted),
    }
    .ok_or_else(|| Failure::failed(format!("no device {wanted} at {endpoint}")))?;
    let key = device["telemetry"]
        .as_str()
        .ok_or_else(|| Failure::failed(format!("{endpoint}: the bridge names no telemetry")))?;
    let layout = format!("/v{}", hapticd_core::telemetry::VERSION);
    if !key.ends_with(&layout) {
        return Err(Failure::failed(format!(
            "{endpoint} publishes ticks as {key}; this hapticctl reads layout {layout}"
        )));
    }
    let effectors: Vec<String> = device["effectors"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|e| e.as_str().map(String::from))
        .collect();
    let every = device["publishing_every"].as_u64().unwrap_or(1).max(1);
    let subscriber = session
        .declare_subscriber(key)
        .wait()
        .map_err(|e| Failure::failed(format!("{endpoint}: {e}")))?;
    let cannot =
        |e: std::io::Error| Failure::failed(format!("cannot write {}: {e}", args.file.display()));
    let mut out = std::io::BufWriter::new(std::fs::File::create(&args.file).map_err(cannot)?);
    let (mut rows, mut missed, mut strings, mut last) = (0u64, 0u64, None, None::<u64>);
    let mut until = None;
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
        until.get_or_insert_with(|| Instant::now() + Duration::from_secs_f64(args.duration()));
        let n = *strings.get_or_insert_with(|| {
            let n = tick.strings as usize;
            let _ = writeln!(out, "{}", telemetry_csv::header(&effectors, n));
            n
        });
        if let Some(previous) = last {
            missed += (tick.tick.saturating_sub(previous) / every).saturating_sub(1);
        }
        last = Some(tick.tick);
        writeln!(out, "{}", telemetry_csv::row(&tick, effectors.len(), n)).map_err(cannot)?;
        rows += 1;
    }
    out.flush().map_err(cannot)?;
    if rows == 0 {
        return Err(Failure::failed(format!(
            "{endpoint}: no tick arrived in 10 s"
        )));
    }
    let missed = match missed {
        0 => String::new(),
        n => format!(" ({n} published ticks lost on the way)"),
    };
    eprintln!(
        "{rows} ticks, one in every {every}, in {}{missed}",
        args.file.display()
    );
    Ok(())
}
