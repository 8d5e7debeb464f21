//! Commands from the network, each a Zenoh query answered with what became of it:
//!
//! - `hapticd/<device>/set/<Parameter>`, payload a number: a parameter of the device;
//! - `hapticd/<device>/effect/add`, payload an effect in YAML (answered with its id),
//!   `…/effect/change/<id>` (payload the new effect), `…/effect/remove/<id>` and
//!   `…/effect/clear`: the device's haptic effects;
//! - `hapticd/scene/switch`, payload a scene's name;
//! - `hapticd/scene/body/<body>/<action>`, payload JSON: `pose` `{"position": [x, y, z],
//!   "orientation": [w, x, y, z]}`, `velocity` `{"velocity": […], "spin": […]}`, `impulse`
//!   `{"impulse": […], "point": […]}` (the point may be left out), `force` `[x, y, z]`,
//!   `mass` and `friction` a number.
//!
//! The bridge carries them out over the bus as its own user, so hapticd checks each as it
//! checks any caller's, and only when its configuration says `commands: true`; otherwise, and
//! for anything malformed, the query is answered with an error saying why.

use hapticd_ipc::client::{BodyState, ClientError, Device, Hapticd};

use crate::topics::name_word;

/// A command, read from its key and payload.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Set parameter `name` of the device whose word is `device` to `value`.
    Set {
        /// The device's word in keys.
        device: String,
        /// The parameter.
        name: String,
        /// Its new value.
        value: f64,
    },
    /// Change the effects of the device whose word is `device`.
    Effect {
        /// The device's word in keys.
        device: String,
        /// What to do.
        action: EffectAction,
    },
    /// Switch every device to the scene named.
    SwitchScene(String),
    /// Act on a body of the world.
    Body {
        /// The body's name or id.
        body: String,
        /// What to do with it.
        action: BodyAction,
    },
}

/// What a command does to a device's effects.
#[derive(Debug, Clone, PartialEq)]
pub enum EffectAction {
    /// Start this one (YAML).
    Add(String),
    /// Cross-fade effect `id` into this one (YAML).
    Change(u32, String),
    /// Fade effect `id` out.
    Remove(u32),
    /// Fade every effect out.
    Clear,
}

/// What a command does to a body.
#[derive(Debug, Clone, PartialEq)]
pub enum BodyAction {
    /// Put it there, so turned (w, x, y, z).
    Pose([f64; 3], [f64; 4]),
    /// Set it moving and turning.
    Velocity([f64; 3], [f64; 3]),
    /// Give it momentum, at a point or its centre of mass.
    Impulse([f64; 3], Option<[f64; 3]>),
    /// Push it with a held force.
    Force([f64; 3]),
    /// Change its mass.
    Mass(f64),
    /// Change its contacts' friction.
    Friction(f64),
}

/// Why a key and payload are no command.
#[derive(Debug, Clone, PartialEq)]
pub enum ParseError {
    /// The key names no command.
    NoCommand(String),
    /// The key names no action on a body.
    NoAction(String),
    /// The payload should be a number.
    NotANumber(String),
    /// The key should end in an effect's id.
    NotAnId(String),
    /// The payload should be JSON; the parser's reason.
    NotJson(String),
    /// A field should be a list of `count` numbers.
    Numbers {
        /// The field.
        field: &'static str,
        /// How many numbers.
        count: usize,
    },
}

impl std::fmt::Display for ParseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParseError::NoCommand(key) => write!(f, "no command at {key}"),
            ParseError::NoAction(action) => write!(f, "no body action {action:?}"),
            ParseError::NotANumber(payload) => {
                write!(f, "the payload must be a number, not {payload:?}")
            }
            ParseError::NotJson(why) => write!(f, "the payload is not JSON: {why}"),
            ParseError::NotAnId(id) => write!(f, "{id:?} is no effect's id"),
            ParseError::Numbers { field, count } => {
                write!(f, "`{field}` must be a list of {count} numbers")
            }
        }
    }
}

impl std::error::Error for ParseError {}

/// A field of a JSON object as `N` numbers.
fn numbers<const N: usize>(
    value: &serde_json::Value,
    field: &'static str,
) -> Result<[f64; N], ParseError> {
    let wrong = ParseError::Numbers { field, count: N };
    let list = value
        .get(field)
        .and_then(|v| v.as_array())
        .ok_or(wrong.clone())?;
    let parsed: Vec<f64> = list.iter().filter_map(|v| v.as_f64()).collect();
    parsed.try_into().map_err(|_| wrong)
}

/// The command at `key` with `payload`.
pub fn parse(key: &str, payload: &str) -> Result<Command, ParseError> {
    let parts: Vec<&str> = key.split('/').collect();
    let number = || {
        payload
            .trim()
            .parse::<f64>()
            .map_err(|_| ParseError::NotANumber(payload.to_string()))
    };
    match parts.as_slice() {
        ["hapticd", "scene", "switch"] => Ok(Command::SwitchScene(payload.trim().to_string())),
        ["hapticd", "scene", "body", body, action] => {
            let json = || {
                serde_json::from_str::<serde_json::Value>(payload)
                    .map_err(|e| ParseError::NotJson(e.to_string()))
            };
            let action = match *action {
                "pose" => {
                    let v = json()?;
                    BodyAction::Pose(numbers(&v, "position")?, numbers(&v, "orientation")?)
                }
                "velocity" => {
                    let v = json()?;
                    BodyAction::Velocity(numbers(&v, "velocity")?, numbers(&v, "spin")?)
                }
                "impulse" => {
                    let v = json()?;
                    let point = match v.get("point") {
                        None => None,
                        Some(_) => Some(numbers(&v, "point")?),
                    };
                    BodyAction::Impulse(numbers(&v, "impulse")?, point)
                }
                "force" => {
                    let v = serde_json::json!({ "force": json()? });
                    BodyAction::Force(numbers(&v, "force")?)
                }
                "mass" => BodyAction::Mass(number()?),
                "friction" => BodyAction::Friction(number()?),
                other => return Err(ParseError::NoAction(other.to_string())),
            };
            Ok(Command::Body {
                body: body.to_string(),
                action,
            })
        }
        ["hapticd", device, "effect", rest @ ..] => {
            let id = |id: &str| {
                id.parse::<u32>()
                    .map_err(|_| ParseError::NotAnId(id.to_string()))
            };
            let action = match rest {
                ["add"] => EffectAction::Add(payload.to_string()),
                ["change", n] => EffectAction::Change(id(n)?, payload.to_string()),
                ["remove", n] => EffectAction::Remove(id(n)?),
                ["clear"] => EffectAction::Clear,
                _ => return Err(ParseError::NoCommand(key.to_string())),
            };
            Ok(Command::Effect {
                device: device.to_string(),
                action,
            })
        }
        ["hapticd", device, "set", name] => Ok(Command::Set {
            device: device.to_string(),
            name: name.to_string(),
            value: number()?,
        }),
        _ => Err(ParseError::NoCommand(key.to_string())),
    }
}

/// A body's state as the answer says it.
fn state_json(state: &BodyState) -> serde_json::Value {
    serde_json::json!({
        "position": state.position,
        "orientation": state.orientation,
        "velocity": state.velocity,
        "spin": state.spin,
        "force": state.force,
        "mass": state.mass,
        "friction": state.friction,
    })
}

/// Carry `command` out on the bus; the answer (JSON) or why not.
pub fn carry_out(
    hapticd: &Hapticd,
    devices: &[(String, Device)],
    command: &Command,
) -> Result<String, ClientError> {
    let answer = match command {
        Command::Set {
            device,
            name,
            value,
        } => {
            device_of(devices, device)?.set(name, *value)?;
            serde_json::json!({ "set": name, "value": value })
        }
        Command::Effect { device, action } => {
            let found = device_of(devices, device)?;
            match action {
                EffectAction::Add(yaml) => serde_json::json!({ "id": found.add_effect(yaml)? }),
                EffectAction::Change(id, yaml) => {
                    found.change_effect(*id, yaml)?;
                    serde_json::json!({ "changed": id })
                }
                EffectAction::Remove(id) => {
                    found.remove_effect(*id)?;
                    serde_json::json!({ "removed": id })
                }
                EffectAction::Clear => {
                    found.clear_effects()?;
                    serde_json::json!({ "cleared": true })
                }
            }
        }
        Command::SwitchScene(scene) => {
            // A scene still being prepared is answered as such, not waited for.
            hapticd.switch_scene(scene, std::time::Duration::ZERO, &mut |_| {})?;
            serde_json::json!({ "scene": scene })
        }
        Command::Body { body, action } => {
            let scene = hapticd.scene()?;
            let state = match *action {
                BodyAction::Pose(p, q) => scene.set_pose(body, p, q)?,
                BodyAction::Velocity(v, w) => scene.set_velocity(body, v, w)?,
                BodyAction::Impulse(j, at) => scene.apply_impulse(body, j, at)?,
                BodyAction::Force(f) => scene.set_force(body, f)?,
                BodyAction::Mass(m) => scene.set_mass(body, m)?,
                BodyAction::Friction(mu) => scene.set_friction(body, mu)?,
            };
            state_json(&state)
        }
    };
    Ok(answer.to_string())
}

/// The device whose word in keys is `word`.
fn device_of<'a>(devices: &'a [(String, Device)], word: &str) -> Result<&'a Device, ClientError> {
    devices
        .iter()
        .find(|(w, _)| w == word)
        .map(|(_, d)| d)
        .ok_or_else(|| ClientError::Refused {
            name: hapticd_ipc::names::UNKNOWN_DEVICE_ERROR.into(),
            message: format!("no device {word}"),
        })
}

/// The word devices are named by in keys, for each device.
pub fn device_words(devices: Vec<Device>) -> Result<Vec<(String, Device)>, ClientError> {
    devices
        .into_iter()
        .map(|d| Ok((name_word(&d.identity()?), d)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_and_payloads_become_commands() {
        assert_eq!(
            parse("hapticd/sim/set/Stiffness", " 2000 "),
            Ok(Command::Set {
                device: "sim".into(),
                name: "Stiffness".into(),
                value: 2000.0
            })
        );
        assert_eq!(
            parse("hapticd/sim/effect/change/3", "{kind: damper, damping: 2}"),
            Ok(Command::Effect {
                device: "sim".into(),
                action: EffectAction::Change(3, "{kind: damper, damping: 2}".into())
            })
        );
        assert_eq!(
            parse("hapticd/sim/effect/clear", ""),
            Ok(Command::Effect {
                device: "sim".into(),
                action: EffectAction::Clear
            })
        );
        assert_eq!(
            parse("hapticd/scene/switch", "blocks"),
            Ok(Command::SwitchScene("blocks".into()))
        );
        assert_eq!(
            parse(
                "hapticd/scene/body/box/impulse",
                r#"{"impulse": [0, 0.1, 0], "point": [1, 2, 3]}"#
            ),
            Ok(Command::Body {
                body: "box".into(),
                action: BodyAction::Impulse([0.0, 0.1, 0.0], Some([1.0, 2.0, 3.0]))
            })
        );
        assert_eq!(
            parse("hapticd/scene/body/2/force", "[1, 0, 0]"),
            Ok(Command::Body {
                body: "2".into(),
                action: BodyAction::Force([1.0, 0.0, 0.0])
            })
        );
    }

    #[test]
    fn malformed_commands_say_why() {
        for (key, payload) in [
            ("hapticd/sim/set/Stiffness", "stiff"),
            ("hapticd/scene/body/box/pose", r#"{"position": [0, 0]}"#),
            ("hapticd/scene/body/box/pose", "not json"),
            (
                "hapticd/scene/body/box/impulse",
                r#"{"impulse": [0, 0, "x"]}"#,
            ),
            ("hapticd/scene/body/box/fly", "1"),
            ("hapticd/sim/effect/remove/x", ""),
            ("hapticd/sim/effect/spin", ""),
            ("hapticd/elsewhere", ""),
        ] {
            assert!(parse(key, payload).is_err(), "{key} {payload}");
        }
    }
}
