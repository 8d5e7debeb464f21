//! `hapticd.yaml`: the daemon's configuration. Unknown keys and bad values are errors with
//! file, line and column; every key has a default, so an empty file is a valid one.
//!
//! ```yaml
//! realtime:
//!   priority: 80            # SCHED_FIFO priority of the haptic threads (clamped to RLIMIT_RTPRIO)
//!   rate: 1000              # ticks per second (up to 4000 on USB, 10000 on the simulator)
//! mechanism_dirs: [/etc/hapticd/mechanisms, /usr/lib/hapticd/plugins, /usr/share/hapticd/mechanisms]
//! scene_dirs: [/etc/hapticd/scenes, /usr/share/hapticd/scenes]
//! scene: static             # default scene: a name in scene_dirs, or a path
//! hardware:                 # a USB amplifier (0CEC:0205 or 0CEC:0203), when one is plugged in
//!   mechanism: spidar-g     # the mechanism wired to it
//! simulator:                # the simulated device, used when no hardware is present
//!   mechanism: spidar-g
//!   hand: /usr/share/hapticd/hands/press-floor.yaml   # optional script of the simulated hand
//! safety:
//!   max_force: 10           # N per effector
//!   max_torque: 0.3         # N·m per effector
//! ```

use std::path::{Path, PathBuf};

use serde::Deserialize;

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
    /// The scene rendered at start.
    pub scene: String,
    /// Connected amplifiers.
    pub hardware: HardwareConfig,
    /// The simulated device.
    pub simulator: SimulatorConfig,
    /// Force limits.
    pub safety: SafetyConfig,
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
}

impl Default for Config {
    fn default() -> Self {
        Self {
            realtime: RealtimeConfig::default(),
            mechanism_dirs: None,
            scene_dirs: vec![
                "/etc/hapticd/scenes".into(),
                "/usr/share/hapticd/scenes".into(),
            ],
            scene: "static".into(),
            hardware: HardwareConfig::default(),
            simulator: SimulatorConfig::default(),
            safety: SafetyConfig::default(),
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
        }
    }
}

/// Where a YAML or schema error is (line, column, when known) and what it says, without the
/// parser's own position suffix and its advice about its options, which mean nothing to
/// someone editing a file.
pub fn yaml_error(error: &serde_saphyr::Error) -> (Option<(u64, u64)>, String) {
    let rendered = error.without_snippet().to_string();
    let message = rendered
        .rsplit_once(" at line ")
        .map_or(rendered.as_str(), |(m, _)| m)
        .replace(", set DuplicateKeyPolicy in Options if acceptable", "");
    let position = error
        .location()
        .filter(|l| l.line() > 0)
        .map(|l| (l.line(), l.column()));
    (position, message)
}

/// [`yaml_error`] compiler style, to follow a file name: `:line:column: error: message`.
pub fn located_yaml_error(error: &serde_saphyr::Error) -> String {
    let (position, message) = yaml_error(error);
    let at = position.map_or(String::new(), |(l, c)| format!(":{l}:{c}"));
    format!("{at}: error: {message}")
}

impl Config {
    /// Load and check `path`.
    pub fn load(path: &Path) -> Result<Config, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        Config::parse(&text).map_err(|e| format!("{}{e}", path.display()))
    }

    /// Parse and check configuration text; errors start with `:line:column: ` when located.
    pub fn parse(text: &str) -> Result<Config, String> {
        let config: Config = if text.trim().is_empty() {
            Config::default()
        } else {
            serde_saphyr::from_str(text).map_err(|e| located_yaml_error(&e))?
        };
        config.check().map_err(|e| format!(": error: {e}"))?;
        Ok(config)
    }

    /// Check values a parser cannot (ranges, finiteness); also after command-line overrides.
    pub fn check(&self) -> Result<(), String> {
        let rt = &self.realtime;
        if !(1..=99).contains(&rt.priority) {
            return Err(format!(
                "realtime.priority must be 1–99, not {}",
                rt.priority
            ));
        }
        if !(rt.rate.is_finite() && (100.0..=MAX_RATE).contains(&rt.rate)) {
            return Err(format!(
                "realtime.rate must be 100–{MAX_RATE} Hz, not {}",
                rt.rate
            ));
        }
        let s = &self.safety;
        if !(s.max_force.is_finite()
            && s.max_force > 0.0
            && s.max_torque.is_finite()
            && s.max_torque > 0.0)
        {
            return Err("safety.max_force and safety.max_torque must be finite and > 0".into());
        }
        Ok(())
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
        assert_eq!(Config::parse("").unwrap(), Config::default());
    }

    #[test]
    fn bad_configurations_are_refused_with_their_place() {
        let e = Config::parse("realtime:\n  rate: 1000\n  prio: 3\n").unwrap_err();
        assert!(e.starts_with(":3:3: error: unknown field `prio`"), "{e}");
        let e = Config::parse("realtime:\n  rate: 50000\n").unwrap_err();
        assert!(e.contains("realtime.rate must be 100–10000 Hz"), "{e}");
        assert!(Config::parse("safety:\n  max_force: .nan\n").is_err());
    }
}
