//! The bridge's configuration (`/etc/hapticd/network.yaml`): where to listen and connect, the
//! ROS domain, the publishing rate, whether commands are taken, the shared world its devices'
//! remote scenes reach, and the administrator's own Zenoh configuration. Unknown keys and values out of range are refused with the file's name.

use std::path::{Path, PathBuf};

use serde::Deserialize;

/// Where the configuration is looked for when none is named.
pub const DEFAULT_PATH: &str = "/etc/hapticd/network.yaml";

/// Fastest publishing rate asked for, samples a second (a device's own rate is the real
/// bound: no tick is published twice).
pub const MAX_RATE: f64 = 100_000.0;

/// The bridge's configuration.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NetworkConfig {
    /// Zenoh endpoints listened on.
    pub listen: Vec<String>,
    /// Zenoh endpoints connected to.
    pub connect: Vec<String>,
    /// The ROS 2 domain.
    pub domain: u32,
    /// Samples a second per topic.
    pub rate: f64,
    /// Whether commands from the network are carried out.
    pub commands: bool,
    /// The administrator's Zenoh configuration file (JSON5).
    pub zenoh: Option<PathBuf>,
    /// The world (of `hapticd-world --name`) whose updates the bridge carries to its devices'
    /// remote scenes (`engine: remote`), and their grips back; none: no world is carried.
    pub world: Option<String>,
}

impl Default for NetworkConfig {
    fn default() -> Self {
        Self {
            listen: vec!["tcp/127.0.0.1:7447".into()],
            connect: Vec::new(),
            domain: 0,
            rate: 100.0,
            commands: false,
            zenoh: None,
            world: None,
        }
    }
}

impl NetworkConfig {
    /// The configuration in `path`; the defaults if `path` is the default one and absent.
    pub fn load(path: Option<&Path>) -> Result<Self, String> {
        let (path, required) = match path {
            Some(p) => (p, true),
            None => (Path::new(DEFAULT_PATH), false),
        };
        let text = match std::fs::read_to_string(path) {
            Ok(text) => text,
            Err(e) if !required && e.kind() == std::io::ErrorKind::NotFound => {
                return Ok(Self::default());
            }
            Err(e) => return Err(format!("{}: {e}", path.display())),
        };
        let config: Self = if text.trim().is_empty() {
            Self::default()
        } else {
            serde_saphyr::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?
        };
        config
            .check()
            .map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(config)
    }

    /// Refuse what cannot be meant.
    pub fn check(&self) -> Result<(), String> {
        if !(self.rate.is_finite() && self.rate > 0.0 && self.rate <= MAX_RATE) {
            return Err(format!(
                "rate: {} is not a number of samples a second in (0, {MAX_RATE}]",
                self.rate
            ));
        }
        if self
            .listen
            .iter()
            .chain(&self.connect)
            .any(|e| e.is_empty())
        {
            return Err("listen, connect: an endpoint is empty".into());
        }
        if let Some(world) = &self.world
            && !crate::world_keys::is_name(world)
        {
            return Err(format!(
                "world: {world:?} is no world's name (letters, digits, - and _)"
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `text` loaded from a file of its own, `name`.yaml.
    fn parsed(name: usize, text: &str) -> Result<NetworkConfig, String> {
        let dir =
            std::env::temp_dir().join(format!("hapticd-network-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join(format!("{name}.yaml"));
        std::fs::write(&file, text).unwrap();
        let out = NetworkConfig::load(Some(&file));
        std::fs::remove_dir_all(&dir).unwrap();
        out
    }

    #[test]
    fn the_shipped_file_says_the_defaults() {
        let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/network.yaml");
        assert_eq!(
            NetworkConfig::load(Some(Path::new(shipped))),
            Ok(NetworkConfig::default())
        );
    }

    #[test]
    fn bad_files_are_refused_with_their_name() {
        for bad in [
            "rate: .nan\n",
            "rate: 0\n",
            "rate: 1e9\n",
            "listen: ['']\n",
            "commands: yes please\n",
            "comands: true\n",
            "rate: [1, 2]\n",
            "world: 'a/b'\n",
            "world: '*'\n",
        ]
        .iter()
        .enumerate()
        {
            let e = parsed(bad.0, bad.1).unwrap_err();
            assert!(e.contains(".yaml"), "{}: {e}", bad.1);
        }
        assert!(NetworkConfig::load(Some(Path::new("/nonexistent/network.yaml"))).is_err());
        let set = parsed(100, "rate: 1000\ncommands: true\n").unwrap();
        assert_eq!((set.rate, set.commands), (1000.0, true));
    }
}
