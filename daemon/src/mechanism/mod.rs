//! The mechanism part of the thesis' split (Ch. 3.6): what a string-driven device is made of.
//!
//! A [`Mechanism`] comes from a YAML descriptor ([`descriptor`]) or from a plugin
//! ([`crate::plugin`]); both produce the same flat [`MechanismSpec`] of the plugin ABI, and
//! [`Mechanism::from_spec`] validates it once, so a YAML file and a plugin are held to the
//! same rules. The base part (pose, tension) lives in [`crate::solver`].

pub mod analysis;
pub mod catalog;
pub mod descriptor;

use std::fmt;
use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3};
use hapticd_plugin_api::MechanismSpec;

use crate::solver::geometry::{EffectorKinematics, StringGeometry};

/// Most strings one end effector may have; fixes the size of every real-time buffer.
pub const MAX_STRINGS_PER_EFFECTOR: usize = 16;

/// Degrees of freedom of an end effector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dof {
    /// A point grip (finger cap): position only.
    Three,
    /// A rigid grip: position and orientation.
    Six,
}

impl Dof {
    /// Number of pose (and wrench) components.
    pub const fn count(self) -> usize {
        match self {
            Dof::Three => 3,
            Dof::Six => 6,
        }
    }
}

/// Position and orientation of an end effector, frame-centred metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Grip centre.
    pub position: DVec3,
    /// Grip orientation (identity for point grips).
    pub orientation: DQuat,
}

impl Default for Pose {
    fn default() -> Self {
        Pose::IDENTITY
    }
}

impl Pose {
    /// The frame centre with identity orientation.
    pub const IDENTITY: Pose = Pose {
        position: DVec3::ZERO,
        orientation: DQuat::IDENTITY,
    };

    /// A knot given in the grip frame, in world coordinates.
    pub fn transform_point(&self, knot: DVec3) -> DVec3 {
        self.position + self.orientation * knot
    }
}

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

/// Settings of the tension problem (thesis eq. 3.16).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TensionSettings {
    /// λ: weight of |τ|²; λ > 0 makes tensions unique and continuous in position.
    pub lambda: f64,
    /// Weight of the torque rows of the wrench error, 1/m² (1 = every component weighted 1).
    pub torque_weight: f64,
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

/// How serious a finding is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    /// The mechanism cannot be used.
    Error,
    /// The mechanism works, with a limitation worth knowing.
    Warning,
}

/// A validation finding, located in its file.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    /// Error or warning.
    pub severity: Severity,
    /// File the finding is in.
    pub file: PathBuf,
    /// 1-based line and column, when the source has them (YAML does, plugins do not).
    pub position: Option<(u64, u64)>,
    /// Field path such as `strings[3].tension_min`; empty for the whole file.
    pub field: String,
    /// What is wrong, in words.
    pub message: String,
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some((line, column)) = self.position {
            write!(f, ":{line}:{column}")?;
        }
        let kind = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        write!(f, ": {kind}: ")?;
        if !self.field.is_empty() {
            write!(f, "{}: ", self.field)?;
        }
        f.write_str(&self.message)
    }
}

/// Why a mechanism could not be loaded: every error found, not just the first.
#[derive(Debug, Clone, PartialEq)]
pub struct MechanismError {
    /// The findings, errors first.
    pub diagnostics: Vec<Diagnostic>,
}

impl fmt::Display for MechanismError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.diagnostics.iter().enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            write!(f, "{d}")?;
        }
        Ok(())
    }
}

impl std::error::Error for MechanismError {}

impl MechanismError {
    /// A single error about a whole file.
    pub fn file(file: &Path, message: impl Into<String>) -> Self {
        Self {
            diagnostics: vec![Diagnostic {
                severity: Severity::Error,
                file: file.to_path_buf(),
                position: None,
                field: String::new(),
                message: message.into(),
            }],
        }
    }
}

/// Collects findings while validating; `locate` maps a field path to a line and column.
struct Findings<'a> {
    file: &'a Path,
    locate: &'a dyn Fn(&str) -> Option<(u64, u64)>,
    list: Vec<Diagnostic>,
}

impl Findings<'_> {
    fn push(&mut self, severity: Severity, field: String, message: String) {
        let position = (self.locate)(&field);
        self.list.push(Diagnostic {
            severity,
            file: self.file.to_path_buf(),
            position,
            field,
            message,
        });
    }

    fn error(&mut self, field: String, message: impl Into<String>) {
        self.push(Severity::Error, field, message.into());
    }

    fn warning(&mut self, field: String, message: impl Into<String>) {
        self.push(Severity::Warning, field, message.into());
    }

    fn finite(&mut self, field: String, values: &[f64]) -> bool {
        let ok = values.iter().all(|v| v.is_finite());
        if !ok {
            self.error(field, "must be a finite number");
        }
        ok
    }
}

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
        locate: &dyn Fn(&str) -> Option<(u64, u64)>,
    ) -> Result<Mechanism, MechanismError> {
        let mut f = Findings {
            file: source,
            locate,
            list: Vec::new(),
        };
        if name.is_empty() || name.chars().any(|c| c.is_whitespace() || c == '/') {
            f.error(
                "name".into(),
                format!(
                    "{name:?} is not a usable name: it must be non-empty, without spaces or '/'"
                ),
            );
        }
        if !(spec.lambda.is_finite() && spec.lambda >= 0.0) {
            f.error("tension.lambda".into(), "must be a finite number ≥ 0");
        }
        if !(spec.torque_weight.is_finite() && spec.torque_weight > 0.0) {
            f.error(
                "tension.torque_weight".into(),
                "must be a finite number > 0",
            );
        }
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
        if !f.list.iter().any(|d| d.severity == Severity::Error) {
            validate_solvable(&mut f, &mechanism);
        }
        let (errors, warnings): (Vec<_>, Vec<_>) = f
            .list
            .into_iter()
            .partition(|d| d.severity == Severity::Error);
        if !errors.is_empty() {
            return Err(MechanismError {
                diagnostics: errors.into_iter().chain(warnings).collect(),
            });
        }
        mechanism.warnings = warnings;
        Ok(mechanism)
    }

    /// Index of the effector called `name`.
    pub fn effector_index(&self, name: &str) -> Option<usize> {
        self.effectors.iter().position(|e| e.name == name)
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
            "end_effectors".into(),
            "a mechanism needs at least one end effector",
        );
    }
    let mut effectors: Vec<Effector> = Vec::with_capacity(spec.effectors.len());
    for (i, raw) in spec.effectors.iter().enumerate() {
        let field = format!("end_effectors[{i}]");
        let name = match raw.name_str() {
            Some(n) if !n.is_empty() => n.to_string(),
            _ => {
                f.error(format!("{field}.name"), "must be a non-empty UTF-8 name");
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
        let [w, x, y, z] = raw.calibration_orientation;
        let mut orientation = DQuat::from_xyzw(x, y, z, w);
        if f.finite(format!("{calib}.position"), &raw.calibration_position)
            && f.finite(format!("{calib}.orientation"), &raw.calibration_orientation)
        {
            if (orientation.length() - 1.0).abs() > 1e-6 {
                f.error(
                    format!("{calib}.orientation"),
                    format!(
                        "must be a unit quaternion (w, x, y, z); its norm is {}",
                        orientation.length()
                    ),
                );
            }
            orientation = orientation.normalize();
        }
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
        let motor_ok = f.finite(format!("{field}.motor"), &raw.motor);
        let knot_ok = f.finite(format!("{field}.knot"), &raw.knot);
        if knot_ok && owner.dof == Dof::Three && raw.knot != [0.0; 3] {
            f.error(
                format!("{field}.knot"),
                "a point grip (dof 3) has no knot offset: use [0, 0, 0]",
            );
        }
        for (key, value) in [
            ("metres_per_pulse", raw.metres_per_pulse),
            ("volts_per_newton", raw.volts_per_newton),
        ] {
            if !value.is_finite() || value == 0.0 {
                f.error(
                    format!("{field}.{key}"),
                    "must be a finite, non-zero number",
                );
            }
        }
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
        }
        let spec = StringSpec {
            effector,
            motor: DVec3::from(raw.motor),
            knot: DVec3::from(raw.knot),
            metres_per_pulse: raw.metres_per_pulse,
            volts_per_newton: raw.volts_per_newton,
            tension_min: lo,
            tension_max: hi,
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
        }
    }
}
