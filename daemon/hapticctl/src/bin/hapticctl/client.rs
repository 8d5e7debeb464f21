//! `hapticctl status|get|set|calibrate|reload|bind` and `scene list|switch`: the running
//! daemon, over D-Bus, as `busctl` would reach it but in words.

use std::collections::BTreeMap;
use std::os::unix::fs::OpenOptionsExt;

use clap::Args;
use hapticd_ipc::bus::Bus;
use hapticd_ipc::names::error_name;
use hapticd_ipc::{
    BUS_NAME, DEVICE_INTERFACE as DEVICE, MANAGER_INTERFACE as MANAGER, MANAGER_PATH,
};
use serde_json::{Value, json};
use zbus::{Connection, OwnedVariant, Variant};

use crate::Failure;
use crate::mechanism::{Output, print};

const PROPERTIES: &str = "org.freedesktop.DBus.Properties";

/// The parameters a client may set, with their ranges (as the daemon enforces them).
const PARAMETERS: &str = "Stiffness (N/m, 0–100000), Damping (N·s/m, 0–500), StaticFriction \
     (0–2), DynamicFriction (0–StaticFriction), Lambda (0–10), MaxForce (N, 0–50), MaxTorque \
     (N·m, 0–5), Rate (Hz, 100–10000, at the next start)";

/// A device: its index in `Devices`, or its identity (`sim`, `usb:1-2`).
#[derive(Args)]
pub struct DeviceArg {
    /// Device index or identity (default: the first).
    #[arg(long, default_value = "0")]
    device: String,
}

#[derive(Args)]
pub struct GetArgs {
    /// Parameter or property name.
    #[arg(long_help = format!("Parameter or property name: {PARAMETERS}; or any property of the device (State, Pose, Force, Statistics, …)."))]
    name: String,
    #[command(flatten)]
    device: DeviceArg,
    #[command(flatten)]
    output: Output,
}

#[derive(Args)]
pub struct SetArgs {
    /// Parameter name.
    #[arg(long_help = format!("Parameter name: {PARAMETERS}."))]
    name: String,
    /// New value.
    #[arg(allow_negative_numbers = true)]
    value: f64,
    #[command(flatten)]
    device: DeviceArg,
}

#[derive(Args)]
pub struct BindArgs {
    /// Installed mechanism to drive the device with from its next start.
    mechanism: String,
    #[command(flatten)]
    device: DeviceArg,
}

/// Properties changed, with their new values.
type Changes = std::collections::HashMap<String, OwnedVariant>;

/// A connection to the daemon on one bus.
pub struct Client {
    connection: Connection,
    bus: Bus,
}

/// What a failed request means to the person who made it.
fn failure(bus: &Bus, e: zbus::Error) -> Failure {
    match e {
        zbus::Error::FDO(fdo) => match *fdo {
            zbus::fdo::Error::ServiceUnknown(_) | zbus::fdo::Error::NameHasNoOwner(_) => {
                Failure::failed(format!(
                    "hapticd is not running on the {} bus",
                    bus_name(bus)
                ))
            }
            zbus::fdo::Error::AccessDenied(m) => Failure::failed(format!(
                "not allowed ({m}): root and members of the hapticd group may change things"
            )),
            other => Failure::failed(other.to_string()),
        },
        zbus::Error::MethodError(name, message, _) => Failure::failed(format!(
            "{}: {}",
            error_name(name.as_str()).unwrap_or(name.as_str()),
            message.unwrap_or_default()
        )),
        other => Failure::failed(format!("the {} bus: {other}", bus_name(bus))),
    }
}

fn bus_name(bus: &Bus) -> String {
    match bus {
        Bus::System => "system".into(),
        Bus::Session => "session".into(),
        Bus::Address(a) => a.clone(),
    }
}

/// A D-Bus value as JSON: numbers, strings, paths, arrays and string-keyed dictionaries.
fn to_json(v: &Variant) -> Value {
    match v {
        Variant::Bool(b) => json!(b),
        Variant::U8(n) => json!(n),
        Variant::I16(n) => json!(n),
        Variant::U16(n) => json!(n),
        Variant::I32(n) => json!(n),
        Variant::U32(n) => json!(n),
        Variant::I64(n) => json!(n),
        Variant::U64(n) => json!(n),
        Variant::F64(x) => json!(x),
        Variant::Str(s) => json!(s.as_str()),
        Variant::ObjectPath(p) => json!(p.as_str()),
        Variant::Variant(inner) => to_json(inner),
        Variant::Array(a) => Value::Array(a.inner().iter().map(to_json).collect()),
        Variant::Dict(d) => Value::Object(
            d.iter()
                .map(|(k, v)| {
                    let key = match to_json(k) {
                        Value::String(s) => s,
                        other => other.to_string(),
                    };
                    (key, to_json(v))
                })
                .collect(),
        ),
        _ => Value::Null,
    }
}

/// A JSON value in one line of text, strings without their quotes.
fn words(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        // Counters travel as doubles: a whole number is shown as one.
        Value::Number(n) => match n.as_f64() {
            Some(x) if x.fract() == 0.0 && x.abs() < 1e15 => format!("{}", x as i64),
            _ => n.to_string(),
        },
        Value::Array(a) => a.iter().map(words).collect::<Vec<_>>().join(" "),
        other => other.to_string(),
    }
}

impl Client {
    /// Connect to `bus`.
    pub fn connect(bus: &Bus) -> Result<Client, Failure> {
        let connection = zbus::block_on(bus.connection()).map_err(|e| failure(bus, e))?;
        Ok(Client {
            connection,
            bus: bus.clone(),
        })
    }

    fn call<B>(
        &self,
        path: &str,
        interface: &str,
        method: &str,
        body: &B,
    ) -> Result<zbus::Message, Failure>
    where
        B: serde::Serialize + zbus::Type,
    {
        zbus::block_on(self.connection.call_method(
            Some(BUS_NAME),
            path,
            Some(interface),
            method,
            body,
        ))
        .map_err(|e| failure(&self.bus, e))
    }

    /// Every property of `interface` at `path`, as JSON.
    fn properties(&self, path: &str, interface: &str) -> Result<BTreeMap<String, Value>, Failure> {
        let reply = self.call(path, PROPERTIES, "GetAll", &(interface,))?;
        let all: std::collections::HashMap<String, OwnedVariant> = reply
            .body()
            .deserialize()
            .map_err(|e| failure(&self.bus, e))?;
        Ok(all.iter().map(|(k, v)| (k.clone(), to_json(v))).collect())
    }

    /// Every property of every device the manager lists, in its order.
    fn devices(
        &self,
        manager: &BTreeMap<String, Value>,
    ) -> Result<Vec<BTreeMap<String, Value>>, Failure> {
        manager["Devices"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|path| self.properties(path.as_str().unwrap_or_default(), DEVICE))
            .collect()
    }

    /// The daemon's PropertiesChanged signals, of the object at `path` or of every object.
    async fn changes(&self, path: Option<&str>) -> Result<zbus::MessageStream, Failure> {
        let only = path.map_or(String::new(), |p| format!(",path='{p}'"));
        let rule = format!(
            "type='signal',sender='{BUS_NAME}'{only},interface='{PROPERTIES}',\
             member='PropertiesChanged'"
        );
        zbus::MessageStream::for_match_rule(rule.as_str(), &self.connection, None)
            .await
            .map_err(|e| failure(&self.bus, e))
    }

    /// The next change of `stream`: the object's path and the properties changed with their
    /// values (`None` for a signal that does not have that shape).
    async fn next_change(
        &self,
        stream: &mut zbus::MessageStream,
    ) -> Result<Option<(String, Changes)>, Failure> {
        let Some(message) = next(stream).await else {
            return Err(Failure::failed("the bus closed the connection"));
        };
        let message = message.map_err(|e| failure(&self.bus, e))?;
        let path = message
            .header()
            .path()
            .map(|p| p.to_string())
            .unwrap_or_default();
        let body: zbus::Result<(String, Changes, Vec<String>)> = message.body().deserialize();
        Ok(body.ok().map(|(_, changed, _)| (path, changed)))
    }

    /// The object path of the device `arg` names.
    fn device(&self, arg: &DeviceArg) -> Result<String, Failure> {
        let manager = self.properties(MANAGER_PATH, MANAGER)?;
        let paths: Vec<String> = manager["Devices"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|p| p.as_str().map(str::to_string))
                    .collect()
            })
            .unwrap_or_default();
        if let Ok(index) = arg.device.parse::<usize>() {
            return paths.get(index).cloned().ok_or_else(|| {
                Failure::usage(format!("no device {index}: hapticd drives {}", paths.len()))
            });
        }
        for path in &paths {
            if self.properties(path, DEVICE)?["Identity"] == json!(arg.device) {
                return Ok(path.clone());
            }
        }
        Err(Failure::usage(format!("no device {:?}", arg.device)))
    }
}

/// `hapticctl status`: the daemon and each device in a few lines.
pub fn status(client: &Client, output: &Output) -> Result<(), Failure> {
    let manager = client.properties(MANAGER_PATH, MANAGER)?;
    let mut text = format!(
        "hapticd {}: scene {}, mechanisms {}\n",
        words(&manager["Version"]),
        words(&manager["ActiveScene"]),
        words(&manager["Mechanisms"])
    );
    let mut devices = Vec::new();
    for d in client.devices(&manager)? {
        let stats = &d["Statistics"];
        text += &format!(
            "{}: {}, {} at {} Hz ({}), {} ticks, {} overruns, wake p99 {} µs\n",
            words(&d["Identity"]),
            words(&d["State"]),
            words(&d["Mechanism"]),
            words(&d["LoopRate"]),
            words(&d["Scheduling"]),
            words(&stats["ticks"]),
            words(&stats["overruns"]),
            words(&stats["wait_p99_us"]),
        );
        devices.push(Value::Object(d.into_iter().collect()));
    }
    let value =
        json!({"manager": Value::Object(manager.into_iter().collect()), "devices": devices});
    print(output, value, text);
    Ok(())
}

/// `hapticctl get NAME`: one property of a device.
pub fn get(client: &Client, args: &GetArgs) -> Result<(), Failure> {
    let path = client.device(&args.device)?;
    let all = client.properties(&path, DEVICE)?;
    let value = all.get(&args.name).ok_or_else(|| {
        Failure::usage(format!(
            "no property {:?}: the device has {}",
            args.name,
            all.keys().cloned().collect::<Vec<_>>().join(", ")
        ))
    })?;
    print(&args.output, value.clone(), format!("{}\n", words(value)));
    Ok(())
}

/// `hapticctl set NAME VALUE`: change a parameter; the daemon checks, saves and applies it.
pub fn set(client: &Client, args: &SetArgs) -> Result<(), Failure> {
    let path = client.device(&args.device)?;
    client.call(
        &path,
        PROPERTIES,
        "Set",
        &(DEVICE, args.name.as_str(), Variant::F64(args.value)),
    )?;
    Ok(())
}

/// `hapticctl calibrate`: take the counter offsets with every grip at its calibration pose.
pub fn calibrate(client: &Client, device: &DeviceArg) -> Result<(), Failure> {
    let path = client.device(device)?;
    client.call(&path, DEVICE, "Calibrate", &())?;
    Ok(())
}

/// `hapticctl bind MECHANISM`: drive the device with another mechanism from its next start.
pub fn bind(client: &Client, args: &BindArgs) -> Result<(), Failure> {
    let path = client.device(&args.device)?;
    client.call(&path, DEVICE, "BindMechanism", &(args.mechanism.as_str(),))?;
    Ok(())
}

/// `hapticctl reload`: re-read the configuration and rescan the plugins.
pub fn reload(client: &Client) -> Result<(), Failure> {
    client.call(MANAGER_PATH, MANAGER, "ReloadPlugins", &())?;
    Ok(())
}

/// `hapticctl scene list`: the scenes the daemon can switch to, the active one marked.
pub fn scenes(client: &Client, output: &Output) -> Result<(), Failure> {
    let manager = client.properties(MANAGER_PATH, MANAGER)?;
    let active = words(&manager["ActiveScene"]);
    let names: Vec<String> = manager["Scenes"]
        .as_array()
        .map(|a| a.iter().map(words).collect())
        .unwrap_or_default();
    let mut lines = format!("active: {active}\n");
    for name in &names {
        let mark = if *name == active { "*" } else { " " };
        lines += &format!("{mark} {name}\n");
    }
    print(output, json!({"active": active, "scenes": names}), lines);
    Ok(())
}

/// `hapticctl scene switch NAME|FILE`: swap the scene in, forces ramped down and back up. A
/// name goes as it is; a file is opened here, with the user's rights, and its descriptor is
/// sent (the daemon reads no path a caller names).
pub fn switch(client: &Client, scene: &str) -> Result<(), Failure> {
    if hapticd::scenes::is_name(scene) {
        client.call(MANAGER_PATH, MANAGER, "SwitchScene", &(scene,))?;
        return Ok(());
    }
    let path = std::path::Path::new(scene);
    if path.extension().is_some_and(|e| e == "so") {
        return Err(Failure::usage(format!(
            "{scene}: hapticd loads scene plugins only from its scene plugin directories, by \
             name (libhapticd_scene_NAME.so is switched to as NAME)"
        )));
    }
    let name = path
        .file_stem()
        .and_then(|s| s.to_str())
        .filter(|s| hapticd::scenes::is_name(s))
        .ok_or_else(|| Failure::usage(format!("{scene}: not a scene file name")))?;
    // Non-blocking, so that a FIFO given by mistake cannot hang the client; the daemon
    // refuses anything but a regular file.
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .map_err(|e| Failure::failed(format!("{scene}: {e}")))?;
    let fd = zbus::Fd::from(&file);
    client.call(MANAGER_PATH, MANAGER, "SwitchSceneFile", &(fd, name))?;
    Ok(())
}

#[derive(Args)]
pub struct MonitorArgs {
    /// Stop after this many events.
    #[arg(long)]
    count: Option<usize>,
    /// Stop after this many seconds.
    #[arg(long)]
    duration: Option<f64>,
}

/// Properties that change ten times a second: telemetry, not events.
const TELEMETRY: [&str; 4] = ["Pose", "Force", "Tensions", "Statistics"];

/// The next message of `stream`, waiting for it.
async fn next(stream: &mut zbus::MessageStream) -> Option<zbus::Result<zbus::Message>> {
    use zbus::export::futures_core::Stream;
    std::future::poll_fn(|cx| std::pin::Pin::new(&mut *stream).poll_next(cx)).await
}

/// `hapticctl monitor`: every change of the daemon's state as it happens (a device's state,
/// calibration, binding, parameters, the scene), one line each; readable by anyone.
pub fn monitor(client: &Client, args: &MonitorArgs) -> Result<(), Failure> {
    if let Some(seconds) = args.duration {
        if !(seconds.is_finite() && seconds > 0.0) {
            return Err(Failure::usage("--duration must be a number of seconds > 0"));
        }
        std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_secs_f64(seconds));
            std::process::exit(0);
        });
    }
    zbus::block_on(async {
        let mut stream = client.changes(None).await?;
        println!("watching hapticd on the {} bus", bus_name(&client.bus));
        let mut seen = 0;
        while args.count.is_none_or(|n| seen < n) {
            let Some((path, changed)) = client.next_change(&mut stream).await? else {
                continue;
            };
            let mut events: Vec<_> = changed
                .iter()
                .filter(|(name, _)| !TELEMETRY.contains(&name.as_str()))
                .collect();
            events.sort_by(|a, b| a.0.cmp(b.0));
            for (name, value) in events {
                println!("{path}: {name} = {}", words(&to_json(value)));
                seen += 1;
            }
            use std::io::Write;
            let _ = std::io::stdout().flush();
        }
        Ok(())
    })
}

#[derive(Args)]
pub struct RecordArgs {
    /// Record for this many seconds.
    #[arg(long)]
    duration: f64,
    /// The CSV file to write.
    file: std::path::PathBuf,
    #[command(flatten)]
    device: DeviceArg,
}

/// `hapticctl record`: the device's telemetry as the bus carries it (ten rows a second):
/// seconds since the start, pose (x, y, z, qw, qx, qy, qz per effector), force and torque.
pub fn record(client: &Client, args: &RecordArgs) -> Result<(), Failure> {
    use std::io::Write;
    if !(args.duration.is_finite() && args.duration > 0.0 && args.duration <= 86_400.0) {
        return Err(Failure::usage(
            "--duration must be a number of seconds from 0 to a day",
        ));
    }
    let path = client.device(&args.device)?;
    let cannot =
        |e: std::io::Error| Failure::failed(format!("cannot write {}: {e}", args.file.display()));
    let mut out = std::io::BufWriter::new(std::fs::File::create(&args.file).map_err(cannot)?);
    writeln!(out, "time,pose,force").map_err(cannot)?;
    let started = std::time::Instant::now();
    let rows = zbus::block_on(async {
        let mut stream = client.changes(Some(&path)).await?;
        let mut rows = 0usize;
        while started.elapsed().as_secs_f64() < args.duration {
            let Some((_, changed)) = client.next_change(&mut stream).await? else {
                continue;
            };
            // A telemetry burst carries the pose and the force together.
            let (Some(pose), Some(force)) = (changed.get("Pose"), changed.get("Force")) else {
                continue;
            };
            writeln!(
                out,
                "{:.3},{},{}",
                started.elapsed().as_secs_f64(),
                words(&to_json(pose)),
                words(&to_json(force))
            )
            .map_err(cannot)?;
            rows += 1;
        }
        Ok::<usize, Failure>(rows)
    })?;
    out.flush().map_err(cannot)?;
    eprintln!("{rows} rows in {}", args.file.display());
    Ok(())
}

#[derive(Args)]
pub struct TopArgs {
    /// Stop after this many refreshes.
    #[arg(long)]
    count: Option<usize>,
    /// Seconds between refreshes.
    #[arg(long, default_value_t = 0.5)]
    interval: f64,
}

/// The first three numbers of an array property (a position, a force).
fn vector(v: &Value) -> [f64; 3] {
    let n = |i: usize| v.get(i).and_then(Value::as_f64).unwrap_or(f64::NAN);
    [n(0), n(1), n(2)]
}

/// `hapticctl top`: each device's loop, refreshed (like pw-top): state, ticks, overruns,
/// wake-up latency and compute time, the force felt and where the grip is.
pub fn top(client: &Client, args: &TopArgs) -> Result<(), Failure> {
    use std::io::{IsTerminal, Write};
    if !(0.05..=60.0).contains(&args.interval) {
        return Err(Failure::usage("--interval must be from 0.05 to 60 seconds"));
    }
    let terminal = std::io::stdout().is_terminal();
    let mut frame = 0;
    while args.count.is_none_or(|n| frame < n) {
        if frame > 0 {
            std::thread::sleep(std::time::Duration::from_secs_f64(args.interval));
        }
        let manager = client.properties(MANAGER_PATH, MANAGER)?;
        // On a terminal each refresh replaces the last; in a file they follow one another.
        let mut screen = match (terminal, frame) {
            (true, _) => "\x1b[H\x1b[2J".to_string(),
            (false, 0) => String::new(),
            (false, _) => "\n".to_string(),
        };
        screen += &format!(
            "hapticd {}: scene {}\n{:<12} {:<13} {:>9} {:>8} {:>20} {:>14} {:>8}  {}\n",
            words(&manager["Version"]),
            words(&manager["ActiveScene"]),
            "DEVICE",
            "STATE",
            "TICKS",
            "OVERRUNS",
            "WAIT p50/p99/max µs",
            "BUSY mean/max",
            "FORCE N",
            "GRIP m",
        );
        for d in client.devices(&manager)? {
            let s = &d["Statistics"];
            let [fx, fy, fz] = vector(&d["Force"]);
            let [x, y, z] = vector(&d["Pose"]);
            screen += &format!(
                "{:<12} {:<13} {:>9} {:>8} {:>20} {:>14} {:>8.2}  {x:+.4} {y:+.4} {z:+.4}\n",
                words(&d["Identity"]),
                words(&d["State"]),
                words(&s["ticks"]),
                words(&s["overruns"]),
                format!(
                    "{}/{}/{}",
                    words(&s["wait_p50_us"]),
                    words(&s["wait_p99_us"]),
                    words(&s["wait_max_us"])
                ),
                format!(
                    "{:.1}/{:.1}",
                    s["busy_mean_us"].as_f64().unwrap_or(f64::NAN),
                    s["busy_max_us"].as_f64().unwrap_or(f64::NAN)
                ),
                (fx * fx + fy * fy + fz * fz).sqrt(),
            );
        }
        print!("{screen}");
        let _ = std::io::stdout().flush();
        frame += 1;
    }
    Ok(())
}
