//! Which engine runs a scene file: the one thing the daemon reads of a file a plugin runs.
//! A file says so with `engine:`; one without it is a penalty world when it lists `bodies:`
//! (the penalty engine came first and its files never named it), and the daemon's own
//! static solids otherwise.
//!
//! ```
//! use hapticd_core::scene::engine::{engine_of_text, Engine};
//! use std::path::Path;
//!
//! let engine = engine_of_text("engine: rapier\nbodies: []\n", Path::new("push.yaml"));
//! assert_eq!(engine.unwrap(), Engine::Plugin("rapier".into()));
//! ```

use std::path::Path;

use serde::Deserialize;
use serde::de::IgnoredAny;

use crate::diagnostics::{self, Diagnostics};

/// The engine of files that list bodies without naming one.
pub const DEFAULT_ENGINE: &str = "penalty";

/// Who runs a scene file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Engine {
    /// The daemon itself: fixed solids ([`super::static_scene`]).
    Static,
    /// The scene plugin that declares this `engine:` value.
    Plugin(String),
}

/// The two keys read; every other key is the engine's to check.
#[derive(Deserialize)]
struct Head {
    engine: Option<String>,
    bodies: Option<IgnoredAny>,
}

/// The engine of the scene file at `path`.
pub fn engine_of(path: &Path) -> Result<Engine, Diagnostics> {
    engine_of_text(&diagnostics::read_text(path)?, path)
}

/// The engine of scene `text`; `path` names it in diagnostics (a file that is not YAML).
pub fn engine_of_text(text: &str, path: &Path) -> Result<Engine, Diagnostics> {
    let (head, _) = diagnostics::parse_yaml::<Head>(text, path)?.strict()?;
    Ok(match (head.engine, head.bodies) {
        (Some(engine), _) => Engine::Plugin(engine),
        (None, Some(_)) => Engine::Plugin(DEFAULT_ENGINE.into()),
        (None, None) => Engine::Static,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn engine(text: &str) -> Result<Engine, Diagnostics> {
        engine_of_text(text, Path::new("scene.yaml"))
    }

    #[test]
    fn a_file_names_its_engine_or_is_known_by_its_bodies() {
        let plugin = |name: &str| Ok(Engine::Plugin(name.into()));
        assert_eq!(engine("engine: rapier\nrate: 10\n"), plugin("rapier"));
        assert_eq!(
            engine("name: blocks\nbodies:\n  - { box: [1, 1, 1] }\n"),
            plugin("penalty")
        );
        assert_eq!(engine("name: room\nshapes: []\n"), Ok(Engine::Static));
    }

    #[test]
    fn a_file_that_is_not_yaml_is_refused_at_its_place() {
        let error = engine("name: [unclosed\n").unwrap_err().to_string();
        assert!(error.starts_with("scene.yaml:"), "{error}");
        assert!(engine("engine: [1, 2]\n").is_err(), "an engine is a name");
    }
}
