//! A device's effects as the control plane holds them: each by the id it was given and the
//! text it was written in, checked against the device (its effectors, its MaxForce, its
//! rate) before the loop is handed it. Those of the scene's file come and go with the scene;
//! those added over the bus stay until removed.

use std::path::Path;

use hapticd_core::diagnostics::{self, Diagnostics, Findings};
use hapticd_core::haptic_loop::LoopCommand;
use hapticd_core::haptics::effects::spec::{EffectSpec, Limits, listed_in};
use hapticd_core::haptics::effects::{Effect, EffectCommand, MAX_EFFECTS};
use hapticd_core::parameters::Name;

use super::Error;
use super::device::{DeviceHandle, Effects, Held, lock};

/// Longest text of one effect, bytes.
const MAX_TEXT: usize = 16 << 10;

/// The effects of a scene's file for one device, checked: each and its text.
pub type SceneEffects = Vec<(Effect, String)>;

impl DeviceHandle {
    /// The effect `text` describes, checked against this device; every mistake located in
    /// it.
    fn checked(&self, text: &str) -> Result<Effect, Error> {
        let named = Path::new("effect");
        if text.len() > MAX_TEXT || text.contains('\0') {
            return Err(Error::InvalidEffect(Diagnostics::file(
                named,
                format!("must be at most {MAX_TEXT} bytes of YAML without NUL"),
            )));
        }
        let parsed =
            diagnostics::parse_yaml::<EffectSpec>(text, named).map_err(Error::InvalidEffect)?;
        let map = parsed.map;
        let locate = |field: &str| map.find(field);
        let mut f = Findings::after_schema(named, &locate, parsed.schema);
        let bodies: Vec<String> = self.bodies().into_iter().map(|b| b.name).collect();
        let limits = Limits {
            effectors: self.effectors(),
            max_force: self.parameter(Name::MaxForce),
            rate: self.rate(),
            bodies: &bodies,
        };
        let effect = parsed.value.check("", &limits, &mut f);
        f.finish().map_err(Error::InvalidEffect)?;
        effect.ok_or_else(|| {
            Error::InvalidEffect(Diagnostics::file(
                named,
                "is no effect this device can render",
            ))
        })
    }

    /// Check and start the effect `text` describes; its id.
    pub fn add_effect(&self, text: &str) -> Result<u32, Error> {
        let effect = self.checked(text)?;
        self.start(&mut lock(&self.effects), effect, text.to_string(), false)
    }

    /// Start `effect` (written `text`) among `effects`; its id.
    fn start(
        &self,
        effects: &mut Effects,
        effect: Effect,
        text: String,
        of_scene: bool,
    ) -> Result<u32, Error> {
        if effects.held.len() >= MAX_EFFECTS {
            return Err(Error::OutOfRange(format!(
                "the device renders {MAX_EFFECTS} effects already: remove one first"
            )));
        }
        let id = effects.next;
        self.send(LoopCommand::Effect(EffectCommand::Add(id, effect)))?;
        effects.next += 1;
        effects.held.push(Held { id, text, of_scene });
        Ok(id)
    }

    /// The effects of scene file `file` (none without one), checked against this device
    /// with their places in the file.
    pub fn scene_effects(&self, file: Option<&Path>) -> Result<SceneEffects, Error> {
        let Some(file) = file else {
            return Ok(Vec::new());
        };
        // The file's own bodies are read with its effects.
        let limits = Limits {
            effectors: self.effectors(),
            max_force: self.parameter(Name::MaxForce),
            rate: self.rate(),
            bodies: &[],
        };
        let listed = listed_in(file, &limits).map_err(Error::InvalidEffect)?;
        Ok(listed
            .into_iter()
            .map(|(effect, spec)| {
                // JSON is YAML too: the text reads back as the effect.
                let text = serde_json::to_string(&spec).unwrap_or_default();
                (effect, text)
            })
            .collect())
    }

    /// Fade out the last scene's effects and start `effects`, the new scene's.
    pub fn replace_scene_effects(&self, effects: SceneEffects) -> Result<(), Error> {
        let mut held = lock(&self.effects);
        let old: Vec<u32> = held
            .held
            .iter()
            .filter(|h| h.of_scene)
            .map(|h| h.id)
            .collect();
        for id in old {
            self.send(LoopCommand::Effect(EffectCommand::Remove(id)))?;
            held.held.retain(|h| h.id != id);
        }
        for (effect, text) in effects {
            self.start(&mut held, effect, text, true)?;
        }
        Ok(())
    }

    /// Check `text` and cross-fade effect `id` into it.
    pub fn change_effect(&self, id: u32, text: &str) -> Result<(), Error> {
        let effect = self.checked(text)?;
        let mut effects = lock(&self.effects);
        let held = effects
            .held
            .iter_mut()
            .find(|held| held.id == id)
            .ok_or_else(|| unknown(id))?;
        self.send(LoopCommand::Effect(EffectCommand::Change(id, effect)))?;
        held.text = text.to_string();
        Ok(())
    }

    /// Fade effect `id` out.
    pub fn remove_effect(&self, id: u32) -> Result<(), Error> {
        let mut effects = lock(&self.effects);
        let at = effects
            .held
            .iter()
            .position(|held| held.id == id)
            .ok_or_else(|| unknown(id))?;
        self.send(LoopCommand::Effect(EffectCommand::Remove(id)))?;
        effects.held.remove(at);
        Ok(())
    }

    /// Fade every effect out.
    pub fn clear_effects(&self) -> Result<(), Error> {
        let mut effects = lock(&self.effects);
        self.send(LoopCommand::Effect(EffectCommand::Clear))?;
        effects.held.clear();
        Ok(())
    }

    /// The effects rendered, by id, as written.
    pub fn effects(&self) -> Vec<(u32, String)> {
        let effects = lock(&self.effects);
        effects
            .held
            .iter()
            .map(|h| (h.id, h.text.clone()))
            .collect()
    }
}

fn unknown(id: u32) -> Error {
    Error::UnknownEffect(format!("no effect {id} (Effects lists them)"))
}
