//! Mechanism descriptors in YAML: any string mechanism without a line of code.
//!
//! ```yaml
//! name: my-spidar
//! description: A SPIDAR-G on my desk   # optional
//! end_effectors:
//!   - name: grip
//!     dof: 6                 # 3: point grip; 6: rigid grip
//! strings:
//!   - effector: grip
//!     motor: [0.0849, 0.076, 0.0]     # exit point on the frame, metres
//!     knot: [0.0159, 0.0, -0.0159]    # attachment on the grip, grip frame (omit for dof 3)
//!     metres_per_pulse: 1.66555e-5
//!     volts_per_newton: 0.3653
//!     tension_min: 0.3                # N
//!     tension_max: 20.0               # N
//! calibration:                        # pose of each effector while calibrating (optional)
//!   grip: { position: [0, 0, 0], orientation: [1, 0, 0, 0] }   # quaternion w, x, y, z
//! tension:
//!   lambda: 0.001                     # λ of eq. 3.16
//!   torque_weight: 1.0                # weight of torque rows (optional)
//! ```
//!
//! Unknown and duplicate keys are errors; every error names file, line and column.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use hapticd_plugin_api::{HapticdEffector, HapticdString, MechanismSpec};
use serde::Deserialize;
use serde_saphyr::Spanned;

use super::{Diagnostic, Mechanism, MechanismError, Severity};

/// λ when the descriptor gives none: small enough to keep forces accurate, large enough to
/// keep tensions continuous across the edge of the complete region.
pub const DEFAULT_LAMBDA: f64 = 0.01;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDescriptor {
    name: Spanned<String>,
    #[serde(default)]
    description: String,
    end_effectors: Spanned<Vec<RawEffector>>,
    strings: Spanned<Vec<RawString>>,
    #[serde(default)]
    calibration: BTreeMap<String, Spanned<RawPose>>,
    #[serde(default)]
    tension: Option<RawTension>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEffector {
    name: Spanned<String>,
    dof: Spanned<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawString {
    effector: Spanned<String>,
    motor: Spanned<[f64; 3]>,
    #[serde(default)]
    knot: Option<Spanned<[f64; 3]>>,
    metres_per_pulse: Spanned<f64>,
    volts_per_newton: Spanned<f64>,
    tension_min: Spanned<f64>,
    tension_max: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPose {
    #[serde(default)]
    position: Option<Spanned<[f64; 3]>>,
    #[serde(default)]
    orientation: Option<Spanned<[f64; 4]>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTension {
    #[serde(default)]
    lambda: Option<Spanned<f64>>,
    #[serde(default)]
    torque_weight: Option<Spanned<f64>>,
}

/// Field paths and where they are in the file.
#[derive(Default)]
struct Locations(HashMap<String, (u64, u64)>);

impl Locations {
    fn add<T>(&mut self, field: impl Into<String>, spanned: &Spanned<T>) {
        let at = &spanned.referenced;
        self.0.insert(field.into(), (at.line(), at.column()));
    }

    /// The location of `field`, or of its nearest located ancestor.
    fn find(&self, field: &str) -> Option<(u64, u64)> {
        let mut path = field;
        loop {
            if let Some(&at) = self.0.get(path) {
                return Some(at);
            }
            path = &path[..path.rfind(['.', '['])?];
        }
    }
}

/// Load and validate the descriptor at `path`.
pub fn load(path: &Path) -> Result<Mechanism, MechanismError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| MechanismError::file(path, format!("cannot read: {e}")))?;
    parse(&text, path)
}

/// Parse and validate descriptor `text`; `path` names it in diagnostics.
pub fn parse(text: &str, path: &Path) -> Result<Mechanism, MechanismError> {
    let raw: RawDescriptor = serde_saphyr::from_str(text).map_err(|e| yaml_error(path, &e))?;
    let mut at = Locations::default();
    at.add("name", &raw.name);
    at.add("end_effectors", &raw.end_effectors);
    at.add("strings", &raw.strings);

    let mut errors = Vec::new();
    let mut error = |at: &Locations, field: String, message: String| {
        errors.push(Diagnostic {
            severity: Severity::Error,
            file: path.to_path_buf(),
            position: at.find(&field),
            field,
            message,
        });
    };

    let mut effectors = Vec::with_capacity(raw.end_effectors.value.len());
    for (i, e) in raw.end_effectors.value.iter().enumerate() {
        at.add(format!("end_effectors[{i}]"), &e.name);
        at.add(format!("end_effectors[{i}].name"), &e.name);
        at.add(format!("end_effectors[{i}].dof"), &e.dof);
        let name = &e.name.value;
        if name.len() >= hapticd_plugin_api::HAPTICD_NAME_CAPACITY || name.contains('\0') {
            error(
                &at,
                format!("end_effectors[{i}].name"),
                format!(
                    "effector names are at most {} bytes, without NUL",
                    hapticd_plugin_api::HAPTICD_NAME_CAPACITY - 1
                ),
            );
            effectors.push(HapticdEffector::new("", e.dof.value));
            continue;
        }
        effectors.push(HapticdEffector::new(name, e.dof.value));
    }
    let index_of = |name: &str| {
        raw.end_effectors
            .value
            .iter()
            .position(|e| e.name.value == name)
    };

    for (name, pose) in &raw.calibration {
        let field = format!("calibration.{name}");
        at.add(field.clone(), pose);
        let Some(index) = index_of(name) else {
            error(&at, field, format!("no end effector named {name:?}"));
            continue;
        };
        if let Some(p) = &pose.value.position {
            at.add(format!("{field}.position"), p);
            effectors[index].calibration_position = p.value;
        }
        if let Some(o) = &pose.value.orientation {
            at.add(format!("{field}.orientation"), o);
            effectors[index].calibration_orientation = o.value;
        }
    }

    let mut strings = Vec::with_capacity(raw.strings.value.len());
    for (i, s) in raw.strings.value.iter().enumerate() {
        let field = format!("strings[{i}]");
        at.add(field.clone(), &s.effector);
        at.add(format!("{field}.effector"), &s.effector);
        at.add(format!("{field}.motor"), &s.motor);
        if let Some(k) = &s.knot {
            at.add(format!("{field}.knot"), k);
        }
        at.add(format!("{field}.metres_per_pulse"), &s.metres_per_pulse);
        at.add(format!("{field}.volts_per_newton"), &s.volts_per_newton);
        at.add(format!("{field}.tension_min"), &s.tension_min);
        at.add(format!("{field}.tension_max"), &s.tension_max);
        let Some(effector) = index_of(&s.effector.value) else {
            let known: Vec<_> = raw
                .end_effectors
                .value
                .iter()
                .map(|e| &e.name.value)
                .collect();
            error(
                &at,
                format!("{field}.effector"),
                format!(
                    "no end effector named {:?} (known: {known:?})",
                    s.effector.value
                ),
            );
            continue;
        };
        strings.push(HapticdString {
            effector: effector as u32,
            motor: s.motor.value,
            knot: s.knot.as_ref().map_or([0.0; 3], |k| k.value),
            metres_per_pulse: s.metres_per_pulse.value,
            volts_per_newton: s.volts_per_newton.value,
            tension_min: s.tension_min.value,
            tension_max: s.tension_max.value,
        });
    }

    let tension = raw.tension.as_ref();
    let lambda = tension.and_then(|t| t.lambda.as_ref());
    let torque_weight = tension.and_then(|t| t.torque_weight.as_ref());
    if let Some(l) = lambda {
        at.add("tension.lambda", l);
    }
    if let Some(w) = torque_weight {
        at.add("tension.torque_weight", w);
    }
    let spec = MechanismSpec {
        lambda: lambda.map_or(DEFAULT_LAMBDA, |l| l.value),
        torque_weight: torque_weight.map_or(1.0, |w| w.value),
        effectors,
        strings,
    };

    if !errors.is_empty() {
        return Err(MechanismError {
            diagnostics: errors,
        });
    }
    Mechanism::from_spec(&raw.name.value, &raw.description, path, &spec, &|field| {
        at.find(field)
    })
}

/// A YAML or schema error as a located diagnostic.
fn yaml_error(path: &Path, error: &serde_saphyr::Error) -> MechanismError {
    let (position, message) = crate::config::yaml_error(error);
    MechanismError {
        diagnostics: vec![Diagnostic {
            severity: Severity::Error,
            file: path.to_path_buf(),
            position,
            field: String::new(),
            message,
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "\
name: tiny
end_effectors:
  - name: finger
    dof: 3
strings:
  - effector: finger
    motor: [-0.2, 0.2, 0.2]
    metres_per_pulse: 2.0e-5
    volts_per_newton: 0.3653
    tension_min: 0.5
    tension_max: 10
  - effector: finger
    motor: [0.2, 0.2, -0.2]
    metres_per_pulse: 2.0e-5
    volts_per_newton: 0.3653
    tension_min: 0.5
    tension_max: 10
  - effector: finger
    motor: [-0.2, -0.2, -0.2]
    metres_per_pulse: 2.0e-5
    volts_per_newton: 0.3653
    tension_min: 0.5
    tension_max: 10
  - effector: finger
    motor: [0.2, -0.2, 0.2]
    metres_per_pulse: 2.0e-5
    volts_per_newton: 0.3653
    tension_min: 0.5
    tension_max: 10
tension:
  lambda: 0.02
";

    /// The single error of parsing `text`, rendered.
    fn error_of(text: &str) -> String {
        let e = parse(text, Path::new("m.yaml")).expect_err("descriptor should be refused");
        assert_eq!(e.diagnostics[0].severity, Severity::Error);
        e.diagnostics[0].to_string()
    }

    #[test]
    fn a_good_descriptor_loads_with_its_values() {
        let m = parse(GOOD, Path::new("m.yaml")).unwrap();
        assert_eq!(m.name, "tiny");
        assert_eq!(m.effectors[0].strings, vec![0, 1, 2, 3]);
        assert_eq!(m.strings[2].motor, glam::DVec3::new(-0.2, -0.2, -0.2));
        assert_eq!(m.tension.lambda, 0.02);
        assert!(m.warnings.is_empty());
    }

    #[test]
    fn unknown_keys_are_refused_with_their_position() {
        let text = GOOD.replace("    dof: 3\n", "    dof: 3\n    colour: red\n");
        let e = error_of(&text);
        assert!(
            e.starts_with("m.yaml:5:5: error: unknown field `colour`"),
            "{e}"
        );
    }

    #[test]
    fn duplicate_keys_are_refused() {
        let text = GOOD.replace("  lambda: 0.02\n", "  lambda: 0.02\n  lambda: 0.03\n");
        let e = error_of(&text);
        assert!(
            e.starts_with("m.yaml:32:3: error: duplicate mapping key: lambda"),
            "{e}"
        );
    }

    #[test]
    fn vectors_of_the_wrong_length_are_refused() {
        let text = GOOD.replacen("[-0.2, 0.2, 0.2]", "[-0.2, 0.2]", 1);
        let e = error_of(&text);
        assert!(
            e.starts_with("m.yaml:7:5: error: invalid length 2, expected an array of length 3"),
            "{e}"
        );
    }

    #[test]
    fn non_finite_numbers_are_refused() {
        let text = GOOD.replacen("metres_per_pulse: 2.0e-5", "metres_per_pulse: .nan", 1);
        let e = error_of(&text);
        assert!(
            e.starts_with("m.yaml:8:23: error: strings[0].metres_per_pulse: must be a finite"),
            "{e}"
        );
        let text = GOOD.replacen("[-0.2, 0.2, 0.2]", "[-0.2, .inf, 0.2]", 1);
        let e = error_of(&text);
        assert!(
            e.starts_with("m.yaml:7:12: error: strings[0].motor: must be a finite number"),
            "{e}"
        );
    }

    #[test]
    fn a_minimum_above_the_maximum_is_refused() {
        let text = GOOD.replacen("tension_min: 0.5", "tension_min: 12", 1);
        let e = error_of(&text);
        assert!(
            e.starts_with("m.yaml:10:18: error: strings[0].tension_min: tension_min 12 N exceeds tension_max 10 N"),
            "{e}"
        );
    }

    #[test]
    fn unknown_effector_names_are_refused() {
        let text = GOOD.replacen("  - effector: finger", "  - effector: thumb", 1);
        let e = error_of(&text);
        assert!(
            e.starts_with(
                "m.yaml:6:15: error: strings[0].effector: no end effector named \"thumb\""
            ),
            "{e}"
        );
        let text = format!("{GOOD}calibration:\n  thumb: {{ position: [0, 0, 0] }}\n");
        let e = error_of(&text);
        assert!(
            e.starts_with("m.yaml:33:10: error: calibration.thumb: no end effector named"),
            "{e}"
        );
    }

    #[test]
    fn an_effector_with_fewer_strings_than_dof_is_refused() {
        let text = GOOD.replace("dof: 3", "dof: 6");
        let e = error_of(&text);
        assert!(
            e.contains("end_effectors[0]: effector \"finger\" has 4 strings but 6 degrees of freedom: its pose cannot be solved"),
            "{e}"
        );
        assert!(e.starts_with("m.yaml:3:11:"), "{e}");
    }

    #[test]
    fn an_effector_without_spare_strings_loads_with_a_warning() {
        let cut = GOOD.rfind("  - effector").unwrap();
        let end = GOOD.find("tension:\n").unwrap();
        let text = format!("{}{}", &GOOD[..cut], &GOOD[end..]);
        let m = parse(&text, Path::new("m.yaml")).unwrap();
        assert_eq!(m.warnings.len(), 1);
        let w = m.warnings[0].to_string();
        assert!(
            w.starts_with("m.yaml:3:11: warning:")
                && w.contains("can never present force in every direction"),
            "{w}"
        );
    }

    #[test]
    fn a_point_grip_with_a_knot_offset_is_refused() {
        let text = GOOD.replacen(
            "    metres_per_pulse",
            "    knot: [0.01, 0, 0]\n    metres_per_pulse",
            1,
        );
        let e = error_of(&text);
        assert!(
            e.starts_with(
                "m.yaml:8:11: error: strings[0].knot: a point grip (dof 3) has no knot offset"
            ),
            "{e}"
        );
    }

    #[test]
    fn calibration_orientations_must_be_unit_quaternions() {
        let text = format!("{GOOD}calibration:\n  finger: {{ orientation: [1, 1, 0, 0] }}\n");
        let e = error_of(&text);
        assert!(
            e.contains("calibration.finger.orientation: must be a unit quaternion"),
            "{e}"
        );
    }

    #[test]
    fn degenerate_geometry_is_refused() {
        // All four motors on one line through the grip: the pose is unobservable.
        let mut text = GOOD.to_string();
        for (old, new) in [
            ("[-0.2, 0.2, 0.2]", "[0.1, 0, 0]"),
            ("[0.2, 0.2, -0.2]", "[0.2, 0, 0]"),
            ("[-0.2, -0.2, -0.2]", "[-0.1, 0, 0]"),
            ("[0.2, -0.2, 0.2]", "[-0.2, 0, 0]"),
        ] {
            text = text.replace(old, new);
        }
        let e = error_of(&text);
        assert!(e.contains("do not determine its pose"), "{e}");
    }

    #[test]
    fn malformed_yaml_is_located() {
        let e = error_of("name: x\nend_effectors: [\n");
        assert!(e.starts_with("m.yaml:2:16: error: unclosed bracket"), "{e}");
    }

    #[test]
    fn every_error_is_reported_not_only_the_first() {
        let text = GOOD
            .replacen("tension_min: 0.5", "tension_min: -1", 1)
            .replacen("volts_per_newton: 0.3653", "volts_per_newton: 0", 1);
        let e = parse(&text, Path::new("m.yaml")).unwrap_err();
        assert_eq!(e.diagnostics.len(), 2, "{e}");
    }
}
