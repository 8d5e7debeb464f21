//! Shell completion that knows the running daemon: parameter names, the scenes it lists,
//! the mechanisms it can bind and the devices it drives, asked for at each Tab. The shell
//! runs hapticctl with `COMPLETE=SHELL` to complete a line; `hapticctl completions SHELL`
//! prints the few lines that make it do so.

use std::ffi::{OsStr, OsString};

use clap_complete::engine::{
    ArgValueCompleter, CompletionCandidate, PathCompleter, ValueCompleter,
};
use hapticd_core::parameters::Name;
use hapticd_ipc::bus::{Bus, has_owner};
use hapticd_ipc::names::BUS_NAME;
use hapticd_ipc::proxies::{DeviceProxy, ManagerProxy};

/// The environment variable the shell sets to ask for completions.
pub const VARIABLE: &str = "COMPLETE";

/// Complete the line in the environment and exit, if the shell asked for that.
pub fn answer_the_shell() {
    clap_complete::CompleteEnv::with_factory(<crate::Cli as clap::CommandFactory>::command)
        .var(VARIABLE)
        // Whichever hapticctl the shell finds, not the one that printed the script
        // (`make install` runs it from the build tree).
        .completer("hapticctl")
        .complete();
}

/// The script that makes `shell` ask hapticctl for completions.
pub fn script(shell: &str) -> Result<Vec<u8>, String> {
    let shells = clap_complete::env::Shells::builtins();
    let Some(completer) = shells.completer(shell) else {
        let names: Vec<_> = shells.0.iter().map(|c| c.name()).collect();
        return Err(format!(
            "no completion for {shell:?}: shells are {}",
            names.join(", ")
        ));
    };
    let mut out = Vec::new();
    completer
        .write_registration(VARIABLE, "hapticctl", "hapticctl", "hapticctl", &mut out)
        .map_err(|e| e.to_string())?;
    Ok(out)
}

/// The parameters' names (no daemon needed).
pub fn parameters() -> ArgValueCompleter {
    ArgValueCompleter::new(|current: &OsStr| {
        matching(current, Name::ALL.iter().map(|n| n.as_str().to_string()))
    })
}

/// The scenes the running daemon lists, then the files of the directory being typed.
pub fn scenes() -> ArgValueCompleter {
    ArgValueCompleter::new(|current: &OsStr| {
        let mut found = matching(current, ask(|m| async move { m.scenes().await }));
        found.extend(PathCompleter::any().complete(current));
        found
    })
}

/// The mechanisms the running daemon can bind.
pub fn mechanisms() -> ArgValueCompleter {
    ArgValueCompleter::new(|current: &OsStr| {
        matching(current, ask(|m| async move { m.mechanisms().await }))
    })
}

/// The devices the running daemon drives: their indices and identities.
pub fn devices() -> ArgValueCompleter {
    ArgValueCompleter::new(|current: &OsStr| matching(current, ask(device_names)))
}

fn matching(current: &OsStr, names: impl IntoIterator<Item = String>) -> Vec<CompletionCandidate> {
    let current = current.to_string_lossy();
    names
        .into_iter()
        .filter(|n| n.starts_with(current.as_ref()))
        .map(CompletionCandidate::new)
        .collect()
}

/// What names each device on the command line: its index and its identity.
async fn device_names(manager: ManagerProxy<'static>) -> zbus::Result<Vec<String>> {
    let mut names = Vec::new();
    for (index, path) in manager.devices().await?.into_iter().enumerate() {
        let device = DeviceProxy::builder(manager.inner().connection())
            .path(path)
            .build()
            .await?;
        names.push(index.to_string());
        names.push(device.identity().await?);
    }
    Ok(names)
}

/// What `query` answers from the daemon's manager on the bus the line being completed
/// names, or nothing: a daemon that is not running has nothing to offer, and completion
/// never starts one.
fn ask<F>(query: impl FnOnce(ManagerProxy<'static>) -> F) -> Vec<String>
where
    F: std::future::Future<Output = zbus::Result<Vec<String>>>,
{
    let bus = bus_on_the_line(std::env::args_os()).unwrap_or(Bus::System);
    zbus::block_on(async {
        let connection = bus.connection().await?;
        if !has_owner(&connection, BUS_NAME).await? {
            return Ok(Vec::new());
        }
        query(ManagerProxy::new(&connection).await?).await
    })
    .unwrap_or_default()
}

/// The `--bus` of the command line being completed (it follows `--` among hapticctl's own
/// arguments).
fn bus_on_the_line(args: impl Iterator<Item = OsString>) -> Option<Bus> {
    let args: Vec<String> = args.map(|a| a.to_string_lossy().into_owned()).collect();
    args.iter().enumerate().find_map(|(i, a)| {
        let value = match a.strip_prefix("--bus=") {
            Some(v) => v,
            None if a == "--bus" => args.get(i + 1)?,
            None => return None,
        };
        value.parse().ok()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bus_is_read_from_the_line_being_completed() {
        let line = |s: &str| {
            s.split(' ')
                .map(OsString::from)
                .collect::<Vec<_>>()
                .into_iter()
        };
        assert!(matches!(
            bus_on_the_line(line("hapticctl -- hapticctl --bus session scene switch ")),
            Some(Bus::Session)
        ));
        assert!(matches!(
            bus_on_the_line(line("hapticctl -- hapticctl get --bus=unix:path=/tmp/b Sti")),
            Some(Bus::Address(a)) if a == "unix:path=/tmp/b"
        ));
        assert!(bus_on_the_line(line("hapticctl -- hapticctl get Sti")).is_none());
    }
}
