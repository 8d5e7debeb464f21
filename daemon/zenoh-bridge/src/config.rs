//! The bridge's configuration (`/etc/hapticd/network.yaml`): where to listen and connect, the
//! ROS domain and distribution, the publishing rate, whether commands are taken, the shared world its devices'
//! remote scenes reach, and the administrator's own Zenoh configuration. Unknown keys and values out of range are refused with the file's name.

use std::path::{Path, PathBuf};

use hapticd_ros2::keys::{Distro, Graph};
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
    /// The ROS 2 distribution of the nodes the topics are for (Humble's rmw_zenoh names no
    /// type hashes).
    pub ros_distro: Distro,
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
            // As rmw_zenoh's nodes: the local router (rmw_zenohd's port) for discovery, and a
            // port of its own on the loopback for peers to reach it directly.
            listen: vec!["tcp/127.0.0.1:0".into()],
            connect: vec!["tcp/localhost:7447".into()],
            domain: 0,
            ros_distro: Distro::default(),
            rate: 100.0,
            commands: false,
            zenoh: None,
            world: None,
        }
    }
}

/// What a network configuration holds that cannot be meant.
#[derive(Debug, Clone, PartialEq)]
pub enum ConfigError {
    /// `rate` is no number of samples a second in (0, [`MAX_RATE`]].
    Rate(f64),
    /// An endpoint of `listen` or `connect` is empty.
    EmptyEndpoint,
    /// `world` is no world's name.
    World(String),
}

impl std::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ConfigError::Rate(rate) => write!(
                f,
                "rate: {rate} is not a number of samples a second in (0, {MAX_RATE}]"
            ),
            ConfigError::EmptyEndpoint => f.write_str("listen, connect: an endpoint is empty"),
            ConfigError::World(world) => write!(
                f,
                "world: {world:?} is no world's name (letters, digits, - and _)"
            ),
        }
    }
}

impl std::error::Error for ConfigError {}

/// Why a network configuration file is refused, and which file.
#[derive(Debug)]
pub struct LoadError {
    /// The file.
    pub path: std::path::PathBuf,
    /// Why.
    pub kind: LoadErrorKind,
}

/// Why a network configuration file is refused.
#[derive(Debug)]
pub enum LoadErrorKind {
    /// It could not be read.
    Io(std::io::Error),
    /// It is no configuration of this format (the parser's error, boxed: it is large).
    Format(Box<serde_saphyr::Error>),
    /// It holds what cannot be meant.
    Config(ConfigError),
}

impl std::fmt::Display for LoadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: ", self.path.display())?;
        match &self.kind {
            LoadErrorKind::Io(e) => write!(f, "{e}"),
            LoadErrorKind::Format(e) => write!(f, "{e}"),
            LoadErrorKind::Config(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for LoadError {}

impl NetworkConfig {
    /// The ROS graph the topics are in.
    pub fn graph(&self) -> Graph {
        Graph {
            domain: self.domain,
            distro: self.ros_distro,
        }
    }

    /// The configuration in `path`; the defaults if `path` is the default one and absent.
    pub fn load(path: Option<&Path>) -> Result<Self, LoadError> {
        let (path, required) = match path {
            Some(p) => (p, true),
            None => (Path::new(DEFAULT_PATH), false),
        };
        let refused = |kind| LoadError {
            path: path.to_path_buf(),
            kind,
        };
        let text = match std::fs::read_to_string(path) {
            Ok(text) => text,
            Err(e) if !required && e.kind() == std::io::ErrorKind::NotFound => {
                return Ok(Self::default());
            }
            Err(e) => return Err(refused(LoadErrorKind::Io(e))),
        };
        let config: Self = if text.trim().is_empty() {
            Self::default()
        } else {
            serde_saphyr::from_str(&text)
                .map_err(|e| refused(LoadErrorKind::Format(Box::new(e))))?
        };
        config
            .check()
            .map_err(|e| refused(LoadErrorKind::Config(e)))?;
        Ok(config)
    }

    /// Refuse what cannot be meant.
    pub fn check(&self) -> Result<(), ConfigError> {
        if !(self.rate.is_finite() && self.rate > 0.0 && self.rate <= MAX_RATE) {
            return Err(ConfigError::Rate(self.rate));
        }
        if self
            .listen
            .iter()
            .chain(&self.connect)
            .any(|e| e.is_empty())
        {
            return Err(ConfigError::EmptyEndpoint);
        }
        if let Some(world) = &self.world
            && !crate::world_keys::is_name(world)
        {
            return Err(ConfigError::World(world.clone()));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `text` loaded from a file of its own, `name`.yaml.
    fn parsed(name: usize, text: &str) -> Result<NetworkConfig, LoadError> {
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
            NetworkConfig::load(Some(Path::new(shipped))).unwrap(),
            NetworkConfig::default()
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
            "ros_distro: iron\n",
            "ros_distro: Humble\n",
        ]
        .iter()
        .enumerate()
        {
            let e = parsed(bad.0, bad.1).unwrap_err();
            assert!(e.to_string().contains(".yaml"), "{}: {e}", bad.1);
        }
        // Said by kind: what cannot be meant, and what is no configuration at all.
        assert!(matches!(
            parsed(200, "rate: 0\n").unwrap_err().kind,
            LoadErrorKind::Config(ConfigError::Rate(r)) if r == 0.0
        ));
        assert!(matches!(
            parsed(201, "world: 'a/b'\n").unwrap_err().kind,
            LoadErrorKind::Config(ConfigError::World(w)) if w == "a/b"
        ));
        assert!(matches!(
            parsed(202, "comands: true\n").unwrap_err().kind,
            LoadErrorKind::Format(_)
        ));
        assert!(NetworkConfig::load(Some(Path::new("/nonexistent/network.yaml"))).is_err());
        let set = parsed(100, "rate: 1000\ncommands: true\n").unwrap();
        assert_eq!((set.rate, set.commands), (1000.0, true));
    }

    #[test]
    fn each_distribution_is_taken_by_its_name() {
        for (k, (name, distro)) in Distro::ALL.into_iter().enumerate() {
            let set = parsed(300 + k, &format!("ros_distro: {name}\n")).unwrap();
            assert_eq!(set.graph().distro, distro, "{name}");
        }
        assert_eq!(NetworkConfig::default().ros_distro, Distro::Jazzy);
    }
}
