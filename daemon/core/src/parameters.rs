//! The parameters a user may change while a device runs: what each one means, its unit and
//! range, and how a change is checked before it reaches the real-time thread.
//!
//! A device has default values (from the scene, the mechanism and `hapticd.yaml`) and the
//! user's [`Overrides`]; only the overrides are persisted, so a changed scene file still takes
//! effect for every value the user never touched.

use serde::{Deserialize, Serialize};

use crate::haptics::proxy::ProxyParameters;

/// Highest tick rate: the simulator's bound (USB devices are bound near 4 kHz by 125 µs
/// microframes).
pub const MAX_RATE: f64 = 10_000.0;

/// The values the haptic loop renders with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parameters {
    /// Proxy coupling and friction of scenes rendered through the proxy.
    pub proxy: ProxyParameters,
    /// Regularisation λ of the tension computation.
    pub lambda: f64,
    /// Largest force per effector, newtons.
    pub max_force: f64,
    /// Largest torque per effector, newton-metres.
    pub max_torque: f64,
}

/// One parameter the user may set.
///
/// ```
/// use hapticd_core::parameters::{Name, ParameterError};
///
/// assert!(Name::Stiffness.check(2000.0).is_ok());
/// assert!(matches!(Name::Stiffness.check(f64::NAN), Err(ParameterError::NotFinite(_))));
/// assert!(matches!(Name::MaxForce.check(500.0), Err(ParameterError::OutOfRange(_))));
/// assert_eq!(Name::MaxForce.as_str(), "MaxForce");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Name {
    /// Proxy spring, N/m.
    Stiffness,
    /// Proxy damper, N·s/m.
    Damping,
    /// Static friction coefficient μ0.
    StaticFriction,
    /// Dynamic friction coefficient μ.
    DynamicFriction,
    /// Tension regularisation λ.
    Lambda,
    /// Force limit, N.
    MaxForce,
    /// Torque limit, N·m.
    MaxTorque,
    /// Tick rate, Hz (applies when the device's loop next starts).
    Rate,
}

impl Name {
    /// Every parameter.
    pub const ALL: [Name; 8] = [
        Name::Stiffness,
        Name::Damping,
        Name::StaticFriction,
        Name::DynamicFriction,
        Name::Lambda,
        Name::MaxForce,
        Name::MaxTorque,
        Name::Rate,
    ];

    /// The D-Bus property name.
    pub fn as_str(self) -> &'static str {
        match self {
            Name::Stiffness => "Stiffness",
            Name::Damping => "Damping",
            Name::StaticFriction => "StaticFriction",
            Name::DynamicFriction => "DynamicFriction",
            Name::Lambda => "Lambda",
            Name::MaxForce => "MaxForce",
            Name::MaxTorque => "MaxTorque",
            Name::Rate => "Rate",
        }
    }

    /// Allowed values; a zero lower bound of a limit or spring is exclusive.
    pub fn range(self) -> (f64, f64) {
        match self {
            Name::Stiffness => (0.0, 100_000.0),
            Name::Damping => (0.0, 500.0),
            Name::StaticFriction | Name::DynamicFriction => (0.0, 2.0),
            Name::Lambda => (0.0, 10.0),
            Name::MaxForce => (0.0, 50.0),
            Name::MaxTorque => (0.0, 5.0),
            Name::Rate => (100.0, MAX_RATE),
        }
    }

    /// Whether the lower bound itself is allowed (a zero spring or limit is not).
    fn includes_low(self) -> bool {
        matches!(
            self,
            Name::Damping
                | Name::StaticFriction
                | Name::DynamicFriction
                | Name::Lambda
                | Name::Rate
        )
    }

    /// Whether `value` is finite and in this parameter's range, wherever it comes from: the
    /// bus, the configuration or a scene file.
    pub fn check(self, value: f64) -> Result<(), ParameterError> {
        let (low, high) = self.range();
        let what = self.as_str();
        if !value.is_finite() {
            return Err(ParameterError::NotFinite(format!(
                "{what} must be a finite number, not {value}"
            )));
        }
        let low_ok = if self.includes_low() {
            value >= low
        } else {
            value > low
        };
        if !low_ok || value > high {
            let open = if self.includes_low() { '[' } else { '(' };
            return Err(ParameterError::OutOfRange(format!(
                "{what} must be in {open}{low}, {high}], not {value}"
            )));
        }
        Ok(())
    }
}

/// Why a value was refused.
#[derive(Debug, Clone, PartialEq)]
pub enum ParameterError {
    /// NaN or infinite.
    NotFinite(String),
    /// Outside the parameter's range, or inconsistent with another parameter.
    OutOfRange(String),
}

impl std::fmt::Display for ParameterError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParameterError::NotFinite(m) | ParameterError::OutOfRange(m) => f.write_str(m),
        }
    }
}

/// The values the user changed; the rest come from the defaults.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Overrides {
    #[serde(skip_serializing_if = "Option::is_none")]
    stiffness: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    damping: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    static_friction: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    dynamic_friction: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    lambda: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    max_force: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    max_torque: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rate: Option<f64>,
}

impl Overrides {
    fn slot(&mut self, name: Name) -> &mut Option<f64> {
        match name {
            Name::Stiffness => &mut self.stiffness,
            Name::Damping => &mut self.damping,
            Name::StaticFriction => &mut self.static_friction,
            Name::DynamicFriction => &mut self.dynamic_friction,
            Name::Lambda => &mut self.lambda,
            Name::MaxForce => &mut self.max_force,
            Name::MaxTorque => &mut self.max_torque,
            Name::Rate => &mut self.rate,
        }
    }

    /// The user's value of `name`, if set.
    pub fn get(&self, name: Name) -> Option<f64> {
        let mut copy = *self;
        *copy.slot(name)
    }

    /// The rate the user asked for, if any.
    pub fn rate(&self) -> Option<f64> {
        self.rate
    }

    /// These overrides with `name` set to `value`, once `value` is checked on its own and
    /// against the other parameters as they would result over `defaults`.
    pub fn with(
        &self,
        name: Name,
        value: f64,
        defaults: &Parameters,
    ) -> Result<Overrides, ParameterError> {
        name.check(value)?;
        let mut next = *self;
        *next.slot(name) = Some(value);
        check_consistency(&next.resolve(defaults))?;
        Ok(next)
    }

    /// The values in force: each override, or its default.
    pub fn resolve(&self, defaults: &Parameters) -> Parameters {
        let d = defaults;
        Parameters {
            proxy: ProxyParameters {
                stiffness: self.stiffness.unwrap_or(d.proxy.stiffness),
                damping: self.damping.unwrap_or(d.proxy.damping),
                static_friction: self.static_friction.unwrap_or(d.proxy.static_friction),
                dynamic_friction: self.dynamic_friction.unwrap_or(d.proxy.dynamic_friction),
            },
            lambda: self.lambda.unwrap_or(d.lambda),
            max_force: self.max_force.unwrap_or(d.max_force),
            max_torque: self.max_torque.unwrap_or(d.max_torque),
        }
    }

    /// Whether every stored value is finite and in its range on its own.
    pub fn check_ranges(&self) -> Result<(), ParameterError> {
        Name::ALL
            .iter()
            .filter_map(|&name| Some((name, self.get(name)?)))
            .try_for_each(|(name, value)| name.check(value))
    }

    /// Whether every stored value is in range and the values in force over `defaults` agree
    /// with each other (a state file may have been edited by hand, or the scene changed).
    pub fn check(&self, defaults: &Parameters) -> Result<(), ParameterError> {
        self.check_ranges()?;
        check_consistency(&self.resolve(defaults))
    }
}

/// Whether `value` is finite and in the range of `name`.
/// Whether the values in force agree with each other: μ may not exceed μ0.
fn check_consistency(p: &Parameters) -> Result<(), ParameterError> {
    if p.proxy.dynamic_friction > p.proxy.static_friction {
        return Err(ParameterError::OutOfRange(format!(
            "DynamicFriction ({}) must not exceed StaticFriction ({})",
            p.proxy.dynamic_friction, p.proxy.static_friction
        )));
    }
    Ok(())
}

/// The value of `name` in `parameters` (the rate is not a rendering parameter).
pub fn value(parameters: &Parameters, name: Name) -> Option<f64> {
    let p = parameters;
    Some(match name {
        Name::Stiffness => p.proxy.stiffness,
        Name::Damping => p.proxy.damping,
        Name::StaticFriction => p.proxy.static_friction,
        Name::DynamicFriction => p.proxy.dynamic_friction,
        Name::Lambda => p.lambda,
        Name::MaxForce => p.max_force,
        Name::MaxTorque => p.max_torque,
        Name::Rate => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn defaults() -> Parameters {
        Parameters {
            proxy: ProxyParameters::default(),
            lambda: 0.0,
            max_force: 10.0,
            max_torque: 0.3,
        }
    }

    #[test]
    fn values_are_checked_for_finiteness_range_and_consistency() {
        let d = defaults();
        let none = Overrides::default();
        let set = none.with(Name::Stiffness, 3000.0, &d).unwrap();
        assert_eq!(set.resolve(&d).proxy.stiffness, 3000.0);
        assert_eq!(set.resolve(&d).proxy.damping, d.proxy.damping);
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(matches!(
                none.with(Name::Damping, bad, &d),
                Err(ParameterError::NotFinite(_))
            ));
        }
        assert!(none.with(Name::Stiffness, 0.0, &d).is_err());
        assert!(none.with(Name::Damping, 0.0, &d).is_ok());
        assert!(none.with(Name::MaxForce, 50.5, &d).is_err());
        assert!(none.with(Name::Rate, 99.0, &d).is_err());
        let e = none.with(Name::DynamicFriction, 0.5, &d).unwrap_err();
        assert!(
            e.to_string().contains("must not exceed StaticFriction"),
            "{e}"
        );
    }

    #[test]
    fn only_what_was_changed_is_stored() {
        let d = defaults();
        let set = Overrides::default().with(Name::Lambda, 0.2, &d).unwrap();
        let text = serde_json::to_string(&set).unwrap();
        assert_eq!(text, r#"{"lambda":0.2}"#);
        let back: Overrides = serde_json::from_str(&text).unwrap();
        assert_eq!(back, set);
        let edited: Overrides = serde_json::from_str(r#"{"max_force":1e9}"#).unwrap();
        assert!(edited.check(&d).is_err());
        // Lower friction, set μ first then μ0: consistent as a whole, whatever the order.
        let lower = Overrides::default()
            .with(Name::DynamicFriction, 0.05, &d)
            .and_then(|o| o.with(Name::StaticFriction, 0.1, &d))
            .unwrap();
        assert!(lower.check(&d).is_ok());
        let crossed: Overrides =
            serde_json::from_str(r#"{"static_friction":0.1,"dynamic_friction":0.15}"#).unwrap();
        assert!(crossed.check(&d).is_err());
    }
}
