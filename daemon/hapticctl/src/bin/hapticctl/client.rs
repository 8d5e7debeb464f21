//! `hapticctl status|get|set|calibrate|reload|bind` and `scene list|switch`: the running
//! daemon, over D-Bus, as `busctl` would reach it but in words.

use std::os::unix::fs::OpenOptionsExt;

use clap::Args;
pub use hapticctl::daemon_client::Client;
use hapticctl::daemon_client::bus_name;
use hapticctl::daemon_view::{self, clock_time, to_json, words};
use hapticctl::terminal::KeyReader;
use hapticd_core::parameters::Name;
use hapticd_ipc::bus::has_owner;
use hapticd_ipc::names::RENDERER_BUS_NAME;
use hapticd_ipc::{
    BUS_NAME, DEVICE_INTERFACE as DEVICE, MANAGER_INTERFACE as MANAGER, MANAGER_PATH,
};
use serde_json::json;

use crate::mechanism::{Output, print};
use crate::{Failure, completion};

/// The parameters a client may set, with their ranges (as the daemon enforces them).
const PARAMETERS: &str = "Stiffness (N/m, 0–100000), Damping (N·s/m, 0–500), StaticFriction \
     (0–2), DynamicFriction (0–StaticFriction), Lambda (0–10), MaxForce (N, 0–50), MaxTorque \
     (N·m, 0–5), Rate (Hz, 100–10000, at the next start)";

/// A device: its index in `Devices`, or its identity (`sim`, `usb:1-2`).
#[derive(Args)]
pub struct DeviceArg {
    /// Device index or identity (default: the first).
    #[arg(long, default_value = "0", add = completion::devices())]
    device: String,
}

impl DeviceArg {
    /// The device as given: an index or an identity.
    pub fn name(&self) -> &str {
        &self.device
    }
}

#[derive(Args)]
pub struct GetArgs {
    /// Parameter or property name.
    #[arg(long_help = format!("Parameter or property name: {PARAMETERS}; or any property of the device (State, Pose, Force, Statistics, …)."), add = completion::parameters())]
    name: String,
    #[command(flatten)]
    device: DeviceArg,
    #[command(flatten)]
    output: Output,
}

#[derive(Args)]
pub struct SetArgs {
    /// Parameter name.
    #[arg(long_help = format!("Parameter name: {PARAMETERS}."), add = completion::parameters())]
    name: String,
    /// New value (a number; taken as text so that a wrong name is said first).
    #[arg(allow_hyphen_values = true)]
    value: String,
    #[command(flatten)]
    device: DeviceArg,
}

#[derive(Args)]
pub struct BindArgs {
    /// Installed mechanism to drive the device with from its next start.
    #[arg(add = completion::mechanisms())]
    mechanism: String,
    #[command(flatten)]
    device: DeviceArg,
}

/// `hapticctl status`: the daemon and each device in a few lines.
pub fn status(client: &Client, output: &Output) -> Result<(), Failure> {
    let manager = client.manager()?;
    let devices = client.devices(&manager)?;
    // The renderer is asked without being started, as the daemon is.
    let renderer = zbus::block_on(has_owner(client.connection(), RENDERER_BUS_NAME))
        .map_err(|e| client.failed(e))?;
    let (text, value) = daemon_view::status(manager, devices, renderer);
    print(output, value, text);
    Ok(())
}

/// `hapticctl get NAME`: one property of a device.
pub fn get(client: &Client, args: &GetArgs) -> Result<(), Failure> {
    let path = client.device(&args.device.device)?;
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
/// A name that is no parameter is refused here, with the parameters (and, for a property of
/// the device, that it is read-only).
pub fn set(client: &Client, args: &SetArgs) -> Result<(), Failure> {
    let path = client.device(&args.device.device)?;
    if !Name::ALL.iter().any(|n| n.as_str() == args.name) {
        let properties = client.properties(&path, DEVICE)?;
        let what = if properties.contains_key(&args.name) {
            format!("{} is read-only", args.name)
        } else {
            format!("no parameter {:?}", args.name)
        };
        return Err(Failure::usage(format!(
            "{what}: the parameters are {PARAMETERS}"
        )));
    }
    let value: f64 = args.value.trim().parse().map_err(|_| {
        Failure::usage(format!(
            "{} takes a number, not {:?}",
            args.name, args.value
        ))
    })?;
    client
        .library_device(&path)?
        .set(&args.name, value)
        .map_err(|e| client.refused(e).into())
}

/// `hapticctl calibrate`: take the counter offsets with every grip at its calibration pose.
pub fn calibrate(client: &Client, device: &DeviceArg) -> Result<(), Failure> {
    let path = client.device(&device.device)?;
    client
        .library_device(&path)?
        .calibrate()
        .map_err(|e| client.refused(e).into())
}

/// `hapticctl bind MECHANISM`: drive the device with another mechanism from its next start.
pub fn bind(client: &Client, args: &BindArgs) -> Result<(), Failure> {
    let path = client.device(&args.device.device)?;
    client
        .library_device(&path)?
        .bind_mechanism(&args.mechanism)
        .map_err(|e| client.refused(e).into())
}

/// `hapticctl reload`: re-read the configuration and rescan the plugins.
pub fn reload(client: &Client) -> Result<(), Failure> {
    client
        .hapticd()?
        .reload_plugins()
        .map_err(|e| client.refused(e).into())
}

/// How long `restart` waits for hapticd to be back.
const RESTART_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(20);

/// `hapticctl restart`: ask hapticd to start its loops again, and wait until it is back on
/// the bus under a new connection with every device's loop running again.
pub fn restart(client: &Client) -> Result<(), Failure> {
    // The connection that owns the name: a new one once hapticd runs again.
    let owner = |client: &Client| {
        let reply = zbus::block_on(client.connection().call_method(
            Some("org.freedesktop.DBus"),
            "/org/freedesktop/DBus",
            Some("org.freedesktop.DBus"),
            "GetNameOwner",
            &(BUS_NAME,),
        ));
        reply
            .ok()
            .and_then(|m| m.body().deserialize::<String>().ok())
    };
    let before = owner(client);
    client.call(MANAGER_PATH, MANAGER, "Restart", &())?;
    let started = std::time::Instant::now();
    while started.elapsed() < RESTART_TIMEOUT {
        std::thread::sleep(std::time::Duration::from_millis(100));
        if owner(client).is_some_and(|now| Some(&now) != before.as_ref()) {
            // The new hapticd owns its name a moment before its objects are on the bus.
            let Ok(manager) = client.manager() else {
                continue;
            };
            for d in client.devices(&manager)? {
                println!(
                    "{}: {} at {} Hz",
                    words(&d["Identity"]),
                    words(&d["Mechanism"]),
                    words(&d["LoopRate"])
                );
            }
            return Ok(());
        }
    }
    Err(Failure::failed(format!(
        "hapticd did not come back within {} s (see `journalctl -u hapticd`)",
        RESTART_TIMEOUT.as_secs()
    )))
}

/// `hapticctl scene list`: the scenes the daemon can switch to, the active one marked.
pub fn scenes(client: &Client, output: &Output) -> Result<(), Failure> {
    let manager = client.manager()?;
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
    if hapticd_config::scene_name::is_name(scene) {
        return switch_when_prepared(client, scene);
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
        .filter(|s| hapticd_config::scene_name::is_name(s))
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

/// Switch to the scene called `scene`, asking again while the daemon says its meshes are
/// being cut into convex pieces (it says so rather than hold the call for minutes).
fn switch_when_prepared(client: &Client, scene: &str) -> Result<(), Failure> {
    let mut said = false;
    let mut waiting = |message: &str| {
        if !std::mem::replace(&mut said, true) {
            eprintln!("{scene}: {message}; waiting");
        }
    };
    client
        .hapticd()?
        .switch_scene(scene, std::time::Duration::from_secs(600), &mut waiting)
        .map_err(|e| client.refused(e).into())
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
        println!("watching hapticd on the {} bus", bus_name(client.bus()));
        let mut seen = 0;
        // A change announced twice (by the request that made it, then by the periodic
        // announcement) is one change.
        let mut last: std::collections::HashMap<(String, String), String> = Default::default();
        while args.count.is_none_or(|n| seen < n) {
            let Some((path, changed)) = client.next_change(&mut stream).await? else {
                continue;
            };
            let mut events: Vec<_> = changed
                .iter()
                .filter(|(name, _)| !TELEMETRY.contains(&name.as_str()))
                .map(|(name, value)| (name.clone(), words(&to_json(value))))
                .collect();
            events.sort();
            for (name, value) in events {
                if last
                    .insert((path.clone(), name.clone()), value.clone())
                    .as_ref()
                    == Some(&value)
                {
                    continue;
                }
                println!("{} {path}: {name} = {value}", clock_time());
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
    /// Record for this many seconds of the device's ticks.
    #[arg(long)]
    duration: f64,
    /// The CSV file to write.
    pub file: std::path::PathBuf,
    #[command(flatten)]
    device: DeviceArg,
}

impl RecordArgs {
    /// Refuse a duration that is no number of seconds from 0 to a day.
    pub fn check(&self) -> Result<(), Failure> {
        if !(self.duration.is_finite() && self.duration > 0.0 && self.duration <= 86_400.0) {
            return Err(Failure::usage(
                "--duration must be a number of seconds from 0 to a day",
            ));
        }
        Ok(())
    }

    /// Seconds to record.
    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// The device asked for: an index or an identity.
    pub fn device_name(&self) -> &str {
        &self.device.device
    }
}

/// `hapticctl record`: every tick of the device's haptic loop for `--duration` seconds, read
/// from its telemetry ring (`OpenTelemetry`) at the device's rate, a row per tick (see
/// `hapticd_ipc::telemetry_csv`). Ticks the ring overwrote before they were read are counted
/// and said.
pub fn record(client: &Client, args: &RecordArgs) -> Result<(), Failure> {
    args.check()?;
    // A reader of every tick keeps off the haptic thread's CPU, as the renderer does: on a
    // kernel without full preemption its system calls there would delay the loop's wakes.
    if let Err(e) = hapticd_service::cpus::keep_off_the_haptic_cpu() {
        eprintln!("hapticctl: could not keep off the haptic CPU: {e}");
    }
    let path = client.device(&args.device.device)?;
    let recorded = client.record(&path, args.duration, &args.file)?;
    let missed = match recorded.missed {
        0 => String::new(),
        n => format!(" ({n} ticks overwritten before they were read)"),
    };
    eprintln!(
        "{} ticks at {} Hz in {}{missed}",
        recorded.rows,
        recorded.rate,
        args.file.display()
    );
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

/// `hapticctl top`: the devices refreshed in place, like pw-top; `q` quits. Into a pipe or
/// a file the refreshes follow one another.
pub fn top(client: &Client, args: &TopArgs) -> Result<(), Failure> {
    use std::io::{IsTerminal, Write};
    if !(0.05..=60.0).contains(&args.interval) {
        return Err(Failure::usage("--interval must be from 0.05 to 60 seconds"));
    }
    let terminal = std::io::stdout().is_terminal();
    let keys = (terminal && std::io::stdin().is_terminal())
        .then(KeyReader::new)
        .flatten();
    let interval = std::time::Duration::from_secs_f64(args.interval);
    let mut frame = 0;
    while args.count.is_none_or(|n| frame < n) {
        if frame > 0 {
            match &keys {
                Some(keys) => {
                    if matches!(keys.key(interval), Some(b'q' | b'Q')) {
                        break;
                    }
                }
                None => std::thread::sleep(interval),
            }
        }
        // On a terminal each refresh replaces the last; in a file they follow one another.
        let clear = match (terminal, frame) {
            (true, _) => "\x1b[H\x1b[2J",
            (false, 0) => "",
            (false, _) => "\n",
        };
        let manager = client.manager()?;
        let screen = daemon_view::top_screen(&manager, &client.devices(&manager)?);
        print!("{clear}{screen}");
        let _ = std::io::stdout().flush();
        frame += 1;
    }
    Ok(())
}
