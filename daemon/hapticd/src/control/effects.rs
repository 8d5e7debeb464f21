//! A device's effects as the control plane holds them: each by the id it was given and the
//! text it was written in, checked against the device (its effectors, its MaxForce, its
//! rate) before the loop is handed it.

use std::path::Path;

use hapticd_core::diagnostics::{self, Diagnostics, Findings};
use hapticd_core::haptic_loop::LoopCommand;
use hapticd_core::haptics::effects::spec::{EffectSpec, Limits};
use hapticd_core::haptics::effects::{Effect, EffectCommand, MAX_EFFECTS};
use hapticd_core::parameters::Name;

use super::Error;
use super::device::{DeviceHandle, lock};

/// Longest text of one effect, bytes.
const MAX_TEXT: usize = 16 << 10;

/// The effects a device renders.
#[derive(Debug, Default)]
pub struct Effects {
    /// The id the next effect gets.
    next: u32,
    /// Each effect held, by id, as written.
    held: Vec<(u32, String)>,
}

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
        let limits = Limits {
            effectors: self.effectors(),
            max_force: self.parameter(Name::MaxForce),
            rate: self.rate(),
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
        let mut effects = lock(&self.effects);
        if effects.held.len() >= MAX_EFFECTS {
            return Err(Error::OutOfRange(format!(
                "the device renders {MAX_EFFECTS} effects already: remove one first"
            )));
        }
        let id = effects.next;
        self.send(LoopCommand::Effect(EffectCommand::Add(id, effect)))?;
        effects.next += 1;
        effects.held.push((id, text.to_string()));
        Ok(id)
    }

    /// Check `text` and cross-fade effect `id` into it.
    pub fn change_effect(&self, id: u32, text: &str) -> Result<(), Error> {
        let effect = self.checked(text)?;
        let mut effects = lock(&self.effects);
        let held = effects
            .held
            .iter_mut()
            .find(|(held, _)| *held == id)
            .ok_or_else(|| unknown(id))?;
        self.send(LoopCommand::Effect(EffectCommand::Change(id, effect)))?;
        held.1 = text.to_string();
        Ok(())
    }

    /// Fade effect `id` out.
    pub fn remove_effect(&self, id: u32) -> Result<(), Error> {
        let mut effects = lock(&self.effects);
        let at = effects
            .held
            .iter()
            .position(|(held, _)| *held == id)
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
        lock(&self.effects).held.clone()
    }
}

fn unknown(id: u32) -> Error {
    Error::UnknownEffect(format!("no effect {id} (Effects lists them)"))
}
