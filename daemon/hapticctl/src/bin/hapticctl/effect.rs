//! `hapticctl effect …`: a device's haptic effects (springs, dampers, friction, vibrations,
//! constant forces, fields and magnets), started, changed and stopped through the daemon's
//! Device interface; each written as one entry of a scene file's `effects:`.

use clap::{Args, Subcommand};

use crate::Failure;
use crate::client::{Client, DeviceArg};
use crate::mechanism::Output;

#[derive(Subcommand)]
pub enum Command {
    /// The effects the device renders: id and definition.
    List {
        #[command(flatten)]
        device: DeviceArg,
        #[command(flatten)]
        output: Output,
    },
    /// Start an effect, such as '{kind: sine, direction: [0, 1, 0], frequency: 40,
    /// amplitude: 1}' or '{kind: spring, anchor: [0, 0, 0], stiffness: 200}'; prints its id.
    Add(Definition),
    /// Cross-fade effect ID into another definition.
    Change {
        /// The effect's id (`effect list`).
        id: u32,
        #[command(flatten)]
        definition: Definition,
    },
    /// Fade effect ID out.
    Remove {
        /// The effect's id (`effect list`).
        id: u32,
        #[command(flatten)]
        device: DeviceArg,
    },
    /// Fade every effect out.
    Clear(DeviceArg),
}

/// An effect's definition and its device.
#[derive(Args)]
pub struct Definition {
    /// The effect in YAML (kind, effector, and the kind's keys: see the scenes chapter).
    yaml: String,
    #[command(flatten)]
    device: DeviceArg,
}

/// Carry out `command` on the daemon of `client`.
pub fn run(command: Command, client: &Client) -> Result<(), Failure> {
    let device = |arg: &DeviceArg| client.library_device(&client.device(arg.name())?);
    let refused = |e| Failure::from(client.refused(e));
    match command {
        Command::List {
            device: arg,
            output,
        } => {
            let effects = device(&arg)?.effects().map_err(refused)?;
            if output.json {
                let listed: Vec<_> = effects
                    .iter()
                    .map(|(id, yaml)| serde_json::json!({ "id": id, "effect": yaml }))
                    .collect();
                println!("{}", serde_json::Value::from(listed));
            } else {
                for (id, yaml) in effects {
                    println!("{id:>4}  {}", yaml.trim().replace('\n', " "));
                }
            }
            Ok(())
        }
        Command::Add(definition) => {
            let id = device(&definition.device)?
                .add_effect(&definition.yaml)
                .map_err(refused)?;
            println!("{id}");
            Ok(())
        }
        Command::Change { id, definition } => device(&definition.device)?
            .change_effect(id, &definition.yaml)
            .map_err(refused),
        Command::Remove { id, device: arg } => device(&arg)?.remove_effect(id).map_err(refused),
        Command::Clear(arg) => device(&arg)?.clear_effects().map_err(refused),
    }
}
