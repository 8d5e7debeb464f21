//! The mechanism part of the thesis' split (Ch. 3.6): what a string-driven device is made of.
//!
//! A [`Mechanism`] comes from a YAML descriptor ([`descriptor`]) or from a plugin
//! ([`crate::plugin`]); both produce the same flat [`MechanismSpec`] of the plugin ABI, and
//! [`Mechanism::from_spec`] validates it once, so a YAML file and a plugin are held to the
//! same rules. The base part (pose, tension) lives in [`crate::solver`].

pub mod analysis;
pub mod descriptor;

use std::path::{Path, PathBuf};

use glam::DVec3;
use hapticd_plugin_api::{HapticdString, MechanismSpec};

use crate::diagnostics::{Diagnostic, Diagnostics, Findings, Number, Position};
use crate::kinematics::{Dof, MAX_STRINGS_PER_EFFECTOR, Pose};
use crate::solver::closure::is_force_closed;
use crate::solver::geometry::{EffectorKinematics, StringGeometry};
use crate::solver::tension::{TensionSettings, TensionSolver};
use crate::transport::{AMPLIFIER_MAX_VOLTS, DAC_DIGITS_PER_VOLT, dac_limit};

/// One string.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StringSpec {
    /// Index of the effector it pulls on.
    pub effector: usize,
    /// Exit point on the frame.
    pub motor: DVec3,
    /// Attachment point in the grip frame.
    pub knot: DVec3,
    /// Length per encoder count, metres (negative: encoder counts backwards).
    pub metres_per_pulse: f64,
    /// Amplifier volts per newton (negative: motor wound backwards).
    pub volts_per_newton: f64,
    /// Lowest tension, newtons.
    pub tension_min: f64,
    /// Highest tension, newtons.
    pub tension_max: f64,
}

/// One end effector.
#[derive(Debug, Clone, PartialEq)]
pub struct Effector {
    /// Unique name within the mechanism.
    pub name: String,
    /// Point grip or rigid grip.
    pub dof: Dof,
    /// Pose held while calibrating.
    pub calibration: Pose,
    /// Indices into [`Mechanism::strings`], in descriptor order.
    pub strings: Vec<usize>,
}

/// A validated mechanism.
#[derive(Debug, Clone, PartialEq)]
pub struct Mechanism {
    /// Name users refer to it by.
    pub name: String,
    /// One line saying what it is.
    pub description: String,
    /// Where it was loaded from.
    pub source: PathBuf,
    /// End effectors.
    pub effectors: Vec<Effector>,
    /// All strings.
    pub strings: Vec<StringSpec>,
    /// Tension problem settings.
    pub tension: TensionSettings,
    /// Findings that do not prevent use (e.g. an effector that can never be force-closed).
    pub warnings: Vec<Diagnostic>,
}

/// Farthest a motor, knot or calibration pose may lie from the frame centre, metres: far
/// beyond any desk-top frame, near enough that lengths keep their precision.
pub const MAX_EXTENT: f64 = 10.0;

impl Mechanism {
    /// Validate a flat specification (from YAML or a plugin) into a mechanism.
    ///
    /// `locate` maps field paths such as `strings[2].knot` to the line and column they came
    /// from, so every finding points at its place in the file.
    pub fn from_spec(
        name: &str,
        description: &str,
        source: &Path,
        spec: &MechanismSpec,
        locate: &dyn Fn(&str) -> Option<Position>,
    ) -> Result<Mechanism, Diagnostics> {
        Self::checked(
            Findings::new(source, locate),
            name,
            description,
            source,
            spec,
        )
    }

    /// [`Mechanism::from_spec`] adding to the findings `f` of what was read before.
    pub(crate) fn checked(
        mut f: Findings,
        name: &str,
        description: &str,
        source: &Path,
        spec: &MechanismSpec,
    ) -> Result<Mechanism, Diagnostics> {
        f.name("name", name);
        f.text("description", description);
        f.non_negative("tension.lambda", spec.lambda);
        f.positive("tension.torque_weight", spec.torque_weight);
        let effectors = validate_effectors(&mut f, spec);
        let strings = validate_strings(&mut f, spec, &effectors);
        let mut mechanism = Mechanism {
            name: name.to_string(),
            description: description.to_string(),
            source: source.to_path_buf(),
            effectors,
            strings,
            tension: TensionSettings {
                lambda: spec.lambda,
                torque_weight: spec.torque_weight,
            },
            warnings: Vec::new(),
        };
        for (i, s) in mechanism.strings.iter().enumerate() {
            mechanism.effectors[s.effector].strings.push(i);
        }
        if !f.has_errors() {
            validate_solvable(&mut f, &mechanism);
        }
        mechanism.warnings = f.finish()?;
        Ok(mechanism)
    }

    /// Index of the effector called `name`.
    pub fn effector_index(&self, name: &str) -> Option<usize> {
        self.effectors.iter().position(|e| e.name == name)
    }

    /// The tension solver of effector `index`, with its strings' limits and the
    /// mechanism's settings.
    pub fn tension_solver(&self, index: usize) -> TensionSolver {
        let limits = self.effectors[index].strings.iter().map(|&s| {
            let s = &self.strings[s];
            (s.tension_min, s.tension_max)
        });
        TensionSolver::new(limits, self.tension)
    }

    /// Length of every string at its effector's calibration pose, in string order.
    pub fn calibration_lengths(&self) -> Vec<f64> {
        self.strings
            .iter()
            .map(|s| {
                (s.motor
                    - self.effectors[s.effector]
                        .calibration
                        .transform_point(s.knot))
                .length()
            })
            .collect()
    }

    /// Metres per encoder count of every string, in string order.
    pub fn metres_per_pulse(&self) -> Vec<f64> {
        self.strings.iter().map(|s| s.metres_per_pulse).collect()
    }

    /// Counter offsets that make `counts`, read with every grip at its calibration pose,
    /// give the calibration lengths (see [`crate::solver::calibration`]).
    pub fn offsets(&self, counts: &[i64]) -> Vec<f64> {
        let mut out = vec![0.0; self.strings.len()];
        crate::solver::calibration::offsets_into(
            &self.calibration_lengths(),
            &self.metres_per_pulse(),
            counts,
            &mut out,
        );
        out
    }

    /// Real-time view of effector `index`: fixed-size arrays, no heap.
    pub fn kinematics(&self, index: usize) -> EffectorKinematics {
        let effector = &self.effectors[index];
        EffectorKinematics::new(
            effector.dof,
            effector
                .strings
                .iter()
                .map(|&s| (self.strings[s].motor, self.strings[s].knot)),
        )
    }
}

fn validate_effectors(f: &mut Findings, spec: &MechanismSpec) -> Vec<Effector> {
    if spec.effectors.is_empty() {
        f.error(
            "end_effectors",
            "a mechanism needs at least one end effector",
        );
    }
    let mut effectors: Vec<Effector> = Vec::with_capacity(spec.effectors.len());
    for (i, raw) in spec.effectors.iter().enumerate() {
        let field = format!("end_effectors[{i}]");
        let name = match raw.name_str() {
            Some(n) if f.name(format!("{field}.name"), n) => n.to_string(),
            Some(_) => String::new(),
            None => {
                f.error(format!("{field}.name"), "must be a UTF-8 name");
                String::new()
            }
        };
        if !name.is_empty() && effectors.iter().any(|e| e.name == name) {
            f.error(
                format!("{field}.name"),
                format!("effector {name:?} is defined twice"),
            );
        }
        let dof = match raw.dof {
            3 => Dof::Three,
            6 => Dof::Six,
            other => {
                f.error(
                    format!("{field}.dof"),
                    format!("must be 3 (point grip) or 6 (rigid grip), not {other}"),
                );
                Dof::Three
            }
        };
        let calib = format!("calibration.{name}");
        let position = DVec3::from(raw.calibration_position);
        f.coordinates(
            format!("{calib}.position"),
            &raw.calibration_position,
            MAX_EXTENT,
            "m",
        );
        let orientation =
            f.unit_quaternion(format!("{calib}.orientation"), raw.calibration_orientation);
        effectors.push(Effector {
            name,
            dof,
            calibration: Pose {
                position,
                orientation,
            },
            strings: Vec::new(),
        });
    }
    effectors
}

fn validate_strings(
    f: &mut Findings,
    spec: &MechanismSpec,
    effectors: &[Effector],
) -> Vec<StringSpec> {
    let mut strings = Vec::with_capacity(spec.strings.len());
    for (i, raw) in spec.strings.iter().enumerate() {
        let field = format!("strings[{i}]");
        let effector = raw.effector as usize;
        let Some(owner) = effectors.get(effector) else {
            f.error(
                format!("{field}.effector"),
                format!("effector index {effector} does not exist"),
            );
            continue;
        };
        let motor_ok = f.coordinates(format!("{field}.motor"), &raw.motor, MAX_EXTENT, "m");
        let knot_ok = f.coordinates(format!("{field}.knot"), &raw.knot, MAX_EXTENT, "m");
        if knot_ok && owner.dof == Dof::Three && raw.knot != [0.0; 3] {
            f.error(
                format!("{field}.knot"),
                "a point grip (dof 3) has no knot offset: use [0, 0, 0]",
            );
        }
        let constants_ok = validate_constants(f, &field, raw);
        validate_tensions(f, &field, raw, constants_ok);
        let spec = StringSpec {
            effector,
            motor: DVec3::from(raw.motor),
            knot: DVec3::from(raw.knot),
            metres_per_pulse: raw.metres_per_pulse,
            volts_per_newton: raw.volts_per_newton,
            tension_min: raw.tension_min,
            tension_max: raw.tension_max,
        };
        if motor_ok && knot_ok {
            let length = (spec.motor - owner.calibration.transform_point(spec.knot)).length();
            if length < 1e-6 {
                f.error(
                    format!("{field}.motor"),
                    "the string has zero length at the calibration pose",
                );
            }
        }
        strings.push(spec);
    }
    strings
}

/// Check the encoder and motor constants of string `field`; whether both are in range.
fn validate_constants(f: &mut Findings, field: &str, raw: &HapticdString) -> bool {
    // Wider than any SPIDAR's encoders and motors, narrow enough that lengths and
    // commands stay far from overflow.
    let mut constants_ok = true;
    for (key, value, lo, hi) in [
        ("metres_per_pulse", raw.metres_per_pulse, 1e-9, 1e-2),
        ("volts_per_newton", raw.volts_per_newton, 1e-6, 1e3),
    ] {
        if !(lo..=hi).contains(&value.abs()) {
            constants_ok = false;
            f.error(
                format!("{field}.{key}"),
                format!(
                    "must be a finite number of size {} to {} (either sign), not {}",
                    Number(lo),
                    Number(hi),
                    Number(value)
                ),
            );
        }
    }
    constants_ok
}

/// Check string `field`'s tensions, and (if `constants_ok`) that the amplifier can drive them.
fn validate_tensions(f: &mut Findings, field: &str, raw: &HapticdString, constants_ok: bool) {
    let (lo, hi) = (raw.tension_min, raw.tension_max);
    if !(lo.is_finite() && lo >= 0.0) {
        f.error(
            format!("{field}.tension_min"),
            "must be a finite number ≥ 0 N",
        );
    }
    if !(hi.is_finite() && hi > 0.0) {
        f.error(
            format!("{field}.tension_max"),
            "must be a finite number > 0 N",
        );
    } else if lo > hi {
        f.error(
            format!("{field}.tension_min"),
            format!("tension_min {lo} N exceeds tension_max {hi} N"),
        );
    } else if !constants_ok {
        // The motor constant is wrong already: what it would command means nothing.
    } else if dac_limit(hi, raw.volts_per_newton) == 0 {
        f.error(
            format!("{field}.tension_max"),
            format!(
                "{hi} N at {} V/N is less than one step of the amplifier's D/A converter \
                 ({:.3} N): the string could never pull",
                raw.volts_per_newton,
                1.0 / (DAC_DIGITS_PER_VOLT * raw.volts_per_newton.abs())
            ),
        );
    } else if hi * raw.volts_per_newton.abs() > AMPLIFIER_MAX_VOLTS {
        f.error(
            format!("{field}.tension_max"),
            format!(
                "{hi} N at {} V/N asks the amplifier for {:.1} V; its current drive cannot \
                 be commanded above {AMPLIFIER_MAX_VOLTS} V",
                raw.volts_per_newton,
                hi * raw.volts_per_newton.abs()
            ),
        );
    }
}

/// Per-effector checks that need the whole geometry: string counts and solvability.
fn validate_solvable(f: &mut Findings, mechanism: &Mechanism) {
    for (index, effector) in mechanism.effectors.iter().enumerate() {
        let field = format!("end_effectors[{index}]");
        let (n, dof) = (effector.strings.len(), effector.dof.count());
        if n < dof {
            f.error(
                field,
                format!(
                    "effector {:?} has {n} strings but {dof} degrees of freedom: its pose cannot be solved",
                    effector.name
                ),
            );
            continue;
        }
        if n > MAX_STRINGS_PER_EFFECTOR {
            f.error(
                field,
                format!(
                    "effector {:?} has {n} strings; at most {MAX_STRINGS_PER_EFFECTOR} are supported",
                    effector.name
                ),
            );
            continue;
        }
        if n < dof + 1 {
            f.warning(
                field.clone(),
                format!(
                    "effector {:?} has {n} strings for {dof} degrees of freedom: strings only pull, \
                     so it can never present force in every direction (force closure needs {} strings)",
                    effector.name,
                    dof + 1
                ),
            );
        }
        let kinematics = mechanism.kinematics(index);
        let mut geometry = StringGeometry::default();
        geometry.evaluate(&kinematics, &effector.calibration);
        if !geometry.pose_observable() {
            f.error(
                field,
                format!(
                    "the strings of effector {:?} do not determine its pose at the calibration pose \
                     (their directions are degenerate)",
                    effector.name
                ),
            );
        } else if n > dof && !is_force_closed(&geometry) {
            // Enough strings, badly placed: where the user starts, some push cannot be felt.
            f.warning(
                field,
                format!(
                    "effector {:?} is not force-closed at its calibration pose: the strings \
                     cannot present force in every direction there (move the motors so that the \
                     grip's starting place lies inside their span)",
                    effector.name
                ),
            );
        }
    }
}
