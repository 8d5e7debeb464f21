//! `hapticd.yaml`: the daemon's configuration. Unknown keys and bad values are errors with
//! file, line and column; every key has a default, so an empty file is a valid one.
//!
//! ```yaml
//! realtime:
//!   priority: 80            # SCHED_FIFO priority of the haptic threads (clamped to RLIMIT_RTPRIO)
//!   rate: 1000              # ticks per second (up to 4000 on USB, 10000 on the simulator)
//! # the directories default to the installation's: these for PREFIX=/usr, and under
//! # PREFIX (configuration in PREFIX/etc) for another
//! mechanism_dirs: [/etc/hapticd/mechanisms, /usr/lib/hapticd/plugins, /usr/share/hapticd/mechanisms]
//! scene_dirs: [/etc/hapticd/scenes, /usr/share/hapticd/scenes]
//! scene_plugin_dirs: [/usr/lib/hapticd/scenes]   # where physics scenes find their engine
//! scene: static             # default scene: a name in scene_dirs, or a path
//! hardware:                 # a USB amplifier (0CEC:0205 or 0CEC:0203), when one is plugged in
//!   mechanism: spidar-g     # the mechanism wired to it
//! simulator:                # the simulated device, used when no hardware is present
//!   mechanism: spidar-g
//!   hand: /usr/share/hapticd/hands/press-floor.yaml   # optional script of the simulated hand
//! devices:                  # optional: exactly these devices, each on a haptic thread of its own
//!   - usb: all              # every amplifier plugged in, and those plugged in later
//!   - sim: spidar-g         # a simulated SPIDAR of this mechanism
//!     hand: /usr/share/hapticd/hands/press-floor.yaml
//!     name: left            # its name on the bus and the network (default sim-spidar-g-1)
//! safety:
//!   max_force: 10           # N per effector
//!   max_torque: 0.3         # N·m per effector
//!   max_force_rate: 5000    # N/s: how fast an effect's force may change as it starts, stops or changes
//! ```

use std::path::{Path, PathBuf};

use hapticd_core::diagnostics::{self, Diagnostics, Findings, YamlMap};
use hapticd_core::parameters::Name;
use serde::Deserialize;

use crate::layout::Layout;

/// The whole configuration.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// Real-time thread settings.
    pub realtime: RealtimeConfig,
    /// Where mechanisms are looked up (default: the catalog's search path).
    pub mechanism_dirs: Option<Vec<PathBuf>>,
    /// Where scenes are looked up.
    pub scene_dirs: Vec<PathBuf>,
    /// Where scene plugins are looked up; physics scene files run on the plugin of their
    /// engine (`libhapticd_scene_penalty.so`, `libhapticd_scene_rapier.so`).
    pub scene_plugin_dirs: Vec<PathBuf>,
    /// The scene rendered at start.
    pub scene: String,
    /// Connected amplifiers.
    pub hardware: HardwareConfig,
    /// The simulated device.
    pub simulator: SimulatorConfig,
    /// Force limits.
    pub safety: SafetyConfig,
    /// The devices to drive; empty: every amplifier plugged in, else the simulator.
    pub devices: Vec<DeviceConfig>,
}

/// One entry of `devices:`: a simulated SPIDAR, or the amplifiers plugged in.
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DeviceConfig {
    /// `sim: MECH`: a simulated SPIDAR of this mechanism.
    pub sim: Option<String>,
    /// `usb: all`: every amplifier plugged in now or later.
    pub usb: Option<String>,
    /// The simulated hand's script.
    pub hand: Option<PathBuf>,
    /// The simulated device's name (default `sim-<mechanism>-<n>`).
    pub name: Option<String>,
}

/// `realtime:`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RealtimeConfig {
    /// SCHED_FIFO priority.
    pub priority: i32,
    /// Ticks per second.
    pub rate: f64,
}

/// `hardware:`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HardwareConfig {
    /// Mechanism of the SPIDAR wired to the amplifier.
    pub mechanism: String,
}

impl Default for HardwareConfig {
    fn default() -> Self {
        Self {
            mechanism: "spidar-g".into(),
        }
    }
}

/// `simulator:`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimulatorConfig {
    /// Mechanism of the simulated device.
    pub mechanism: String,
    /// Script of the simulated hand.
    pub hand: Option<PathBuf>,
}

/// `safety:`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SafetyConfig {
    /// Largest force per effector, newtons.
    pub max_force: f64,
    /// Largest torque per effector, newton-metres.
    pub max_torque: f64,
    /// How fast an effect's force may change as it starts, stops or changes, N/s.
    pub max_force_rate: f64,
}

impl Default for Config {
    fn default() -> Self {
        let layout = Layout::of_this_program();
        Self {
            realtime: RealtimeConfig::default(),
            mechanism_dirs: None,
            scene_dirs: layout.scene_dirs(),
            scene_plugin_dirs: layout.scene_plugin_dirs(),
            scene: "static".into(),
            hardware: HardwareConfig::default(),
            simulator: SimulatorConfig::default(),
            safety: SafetyConfig::default(),
            devices: Vec::new(),
        }
    }
}

impl Default for RealtimeConfig {
    fn default() -> Self {
        Self {
            priority: 80,
            rate: 1000.0,
        }
    }
}

impl Default for SimulatorConfig {
    fn default() -> Self {
        Self {
            mechanism: "spidar-g".into(),
            hand: None,
        }
    }
}

impl Default for SafetyConfig {
    fn default() -> Self {
        Self {
            max_force: 10.0,
            max_torque: 0.3,
            max_force_rate: hapticd_core::haptic_loop::MAX_FORCE_RATE,
        }
    }
}

impl Config {
    /// Load and check `path`.
    pub fn load(path: &Path) -> Result<Config, Diagnostics> {
        Config::parse(&diagnostics::read_text(path)?, path)
    }

    /// Parse and check configuration `text`; `path` names it in diagnostics.
    pub fn parse(text: &str, path: &Path) -> Result<Config, Diagnostics> {
        let parsed = if text.trim().is_empty() {
            diagnostics::Parsed {
                value: Config::default(),
                map: YamlMap::default(),
                schema: Vec::new(),
            }
        } else {
            diagnostics::parse_yaml(text, path)?
        };
        let (config, map) = (parsed.value, parsed.map);
        let locate = |field: &str| map.find(field);
        let mut f = Findings::after_schema(path, &locate, parsed.schema);
        config.check_into(&mut f);
        f.finish()?;
        Ok(config)
    }

    /// Check values a parser cannot (ranges, finiteness) after command-line overrides;
    /// `source` names where they came from.
    pub fn check(&self, source: &Path) -> Result<(), Diagnostics> {
        let mut f = Findings::new(source, &|_| None);
        self.check_into(&mut f);
        f.finish().map(drop)
    }

    fn check_into(&self, f: &mut Findings) {
        let rt = &self.realtime;
        if !(1..=99).contains(&rt.priority) {
            f.error(
                "realtime.priority",
                format!("must be 1–99, not {}", rt.priority),
            );
        }
        // The ranges the bus allows for the same values, so a start and a change agree.
        for (key, name, value) in [
            ("realtime.rate", Name::Rate, rt.rate),
            ("safety.max_force", Name::MaxForce, self.safety.max_force),
            ("safety.max_torque", Name::MaxTorque, self.safety.max_torque),
        ] {
            if let Err(e) = name.check(value) {
                f.error(key, e.to_string());
            }
        }
        let rate = self.safety.max_force_rate;
        // From a tenth of MaxForce's range a second to MaxForce in a tick at 10 kHz.
        f.within("safety.max_force_rate", rate, 5.0, 500_000.0, " N/s");
        self.check_devices(f);
    }

    fn check_devices(&self, f: &mut Findings) {
        let mut names = Vec::new();
        for (i, device) in self.devices.iter().enumerate() {
            let key = |field: &str| format!("devices[{i}].{field}");
            match (&device.sim, &device.usb) {
                (Some(_), Some(_)) | (None, None) => f.error(
                    format!("devices[{i}]"),
                    "give either `sim: MECHANISM` or `usb: all`",
                ),
                (None, Some(usb)) => {
                    if usb != "all" {
                        f.error(key("usb"), format!("must be `all`, not {usb:?}"));
                    }
                    if device.hand.is_some() || device.name.is_some() {
                        f.error(
                            format!("devices[{i}]"),
                            "`hand` and `name` are for simulated devices (`sim:`)",
                        );
                    }
                }
                (Some(_), None) => {}
            }
            if let Some(name) = &device.name {
                if let Err(e) = check_device_name(name) {
                    f.error(key("name"), e);
                } else if names.contains(&name) {
                    f.error(key("name"), format!("{name:?} names another device too"));
                }
                names.push(name);
            }
        }
    }
}

/// Longest name a device may be given.
pub const MAX_DEVICE_NAME: usize = 64;

/// Whether `name` can name a device: it becomes part of file names, D-Bus values and ROS 2
/// names, so letters, digits, `-` and `_`, starting with a letter.
pub fn check_device_name(name: &str) -> Result<(), String> {
    let fits = name.len() <= MAX_DEVICE_NAME
        && name.starts_with(|c: char| c.is_ascii_alphabetic())
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if fits {
        Ok(())
    } else {
        Err(format!(
            "{name:?} is no device name: up to {MAX_DEVICE_NAME} letters, digits, - and _, \
             starting with a letter"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_configuration_parses() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/hapticd.yaml");
        let config = Config::load(&path).unwrap();
        assert_eq!(config.realtime.rate, 1000.0);
        assert_eq!(Config::parse("", &path).unwrap(), Config::default());
    }

    #[test]
    fn bad_configurations_are_refused_with_their_place() {
        let parse = |text: &str| {
            Config::parse(text, Path::new("h.yaml"))
                .unwrap_err()
                .to_string()
        };
        let e = parse("realtime:\n  rate: 1000\n  prio: 3\n");
        assert!(
            e.starts_with("h.yaml:3:3: error: realtime.prio: unknown key"),
            "{e}"
        );
        let e = parse("realtime:\n  priority: 0\n  rate: 50000\nsafety:\n  max_force: .nan\n");
        let lines: Vec<_> = e.lines().collect();
        assert_eq!(
            lines,
            [
                "h.yaml:2:13: error: realtime.priority: must be 1–99, not 0",
                "h.yaml:3:9: error: realtime.rate: Rate must be in [100, 10000], not 50000",
                "h.yaml:5:14: error: safety.max_force: MaxForce must be a finite number, not NaN",
            ]
        );
    }

    #[test]
    fn devices_are_listed_and_bad_entries_refused_with_their_place() {
        let config = Config::parse(
            "devices:\n  - usb: all\n  - sim: spidar-g\n    name: left\n    hand: /h.yaml\n",
            Path::new("h.yaml"),
        )
        .unwrap();
        assert_eq!(config.devices.len(), 2);
        assert_eq!(config.devices[1].name.as_deref(), Some("left"));
        let e = Config::parse(
            "devices:\n  - usb: some\n    name: x\n  - sim: spidar-g\n    name: 2nd\n  - {}\n  \
             - sim: spidar\n    name: a\n  - sim: spidar\n    name: a\n",
            Path::new("h.yaml"),
        )
        .unwrap_err()
        .to_string();
        let lines: Vec<_> = e.lines().collect();
        assert_eq!(
            lines,
            [
                "h.yaml:2:10: error: devices[0].usb: must be `all`, not \"some\"",
                "h.yaml:2:5: error: devices[0]: `hand` and `name` are for simulated devices (`sim:`)",
                "h.yaml:5:11: error: devices[1].name: \"2nd\" is no device name: up to 64 letters, \
                 digits, - and _, starting with a letter",
                "h.yaml:6:5: error: devices[2]: give either `sim: MECHANISM` or `usb: all`",
                "h.yaml:10:11: error: devices[4].name: \"a\" names another device too",
            ]
        );
    }
}
