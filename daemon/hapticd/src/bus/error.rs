//! The bus edge of the control plane's errors: each [`control::Error`] becomes the D-Bus
//! error `org.hapticd.Hapticd1.Error.<Name>`, its text the error's message (every finding of
//! a file, one per line). Below this module errors stay typed.

use hapticd_ipc::names::ERROR_PREFIX;
use zbus::message::{Header, Message};
use zbus::names::ErrorName;

use crate::control;
use crate::scenes::OpenError;
use hapticd_core::scene::control::CommandError;

/// A control-plane error as the bus sends it: its name and its text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BusError {
    name: String,
    text: String,
}

/// The last element of the D-Bus error name of `error`.
fn name_of(error: &control::Error) -> &'static str {
    use control::Error::*;
    match error {
        NotFinite(_) => "NotFinite",
        OutOfRange(_) => "OutOfRange",
        Scene(OpenError::NotFound(_)) => "UnknownScene",
        Scene(_) | SceneNotKept(_) => "SceneFailed",
        UnknownMechanism(_) => "UnknownMechanism",
        InvalidConfiguration(_) => "InvalidConfiguration",
        NotSaved(_) => "NotSaved",
        Disconnected(_) => "Disconnected",
        Timeout(_) => "Timeout",
        StillFaulted(_) => "StillFaulted",
        Unavailable(_) => "Unavailable",
        NameExpected(_) => "NameExpected",
        Preparing(_) => "Preparing",
        Command(CommandError::UnknownBody(_)) => "UnknownBody",
        Command(CommandError::UnknownJoint(_)) => "UnknownJoint",
        Command(CommandError::FixedBody(_)) => "FixedBody",
        Command(CommandError::NotFinite(_)) => "NotFinite",
        Command(CommandError::OutOfRange(_)) => "OutOfRange",
        Command(CommandError::Refused(_)) => "CommandRefused",
        Command(CommandError::Timeout(_)) => "Timeout",
        InvalidEffect(_) => "InvalidEffect",
        UnknownEffect(_) => "UnknownEffect",
    }
}

impl From<control::Error> for BusError {
    fn from(error: control::Error) -> Self {
        Self {
            name: format!("{ERROR_PREFIX}.{}", name_of(&error)),
            text: error.to_string(),
        }
    }
}

impl zbus::DBusError for BusError {
    fn create_reply(&self, call: &Header<'_>) -> zbus::Result<Message> {
        Message::error(call, self.name()).build(&(self.text.as_str(),))
    }

    fn name(&self) -> ErrorName<'_> {
        ErrorName::try_from(self.name.as_str()).expect("the prefix and every name are valid")
    }

    fn description(&self) -> Option<&str> {
        Some(&self.text)
    }
}

impl std::fmt::Display for BusError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.name, self.text)
    }
}

impl std::error::Error for BusError {}

#[cfg(test)]
mod tests {
    use super::*;
    use hapticd_core::diagnostics::Diagnostics;
    use std::path::Path;

    #[test]
    fn findings_reach_the_bus_whole_under_their_name() {
        let mut findings = Diagnostics::file(Path::new("a.yaml"), "first");
        findings
            .diagnostics
            .extend(Diagnostics::file(Path::new("b.yaml"), "second").diagnostics);
        let error = BusError::from(control::Error::InvalidConfiguration(findings));
        assert_eq!(
            zbus::DBusError::name(&error).as_str(),
            "org.hapticd.Hapticd1.Error.InvalidConfiguration"
        );
        assert_eq!(
            zbus::DBusError::description(&error),
            Some("a.yaml: error: first\nb.yaml: error: second")
        );
    }

    #[test]
    fn a_missing_scene_is_unknown_and_a_broken_one_failed() {
        let missing = control::Error::Scene(OpenError::NotFound("no scene named x".into()));
        let broken = control::Error::Scene(OpenError::Refused("the plugin said no".into()));
        assert!(BusError::from(missing).name.ends_with(".UnknownScene"));
        assert!(BusError::from(broken).name.ends_with(".SceneFailed"));
    }
}
