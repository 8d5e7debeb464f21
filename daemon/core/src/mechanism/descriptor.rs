//! Mechanism descriptors in YAML: any string mechanism without a line of code. A complete
//! one, a finger cap held by four strings from alternate corners of a 0.3 m cube:
//!
//! ```yaml
//! name: my-spidar
//! description: A SPIDAR on my desk    # optional
//! end_effectors:
//!   - name: finger
//!     dof: 3                          # 3: point grip; 6: rigid grip
//! strings:
//!   - effector: finger
//!     motor: [-0.15, 0.15, 0.15]      # exit point on the frame, metres
//!     metres_per_pulse: 2.513e-5      # string paid out per encoder count
//!     volts_per_newton: 0.3653        # amplifier input per newton of tension
//!     tension_min: 0.3                # N: keeps the string taut
//!     tension_max: 6.0                # N: never exceeded
//!   - { effector: finger, motor: [0.15, 0.15, -0.15], metres_per_pulse: 2.513e-5,
//!       volts_per_newton: 0.3653, tension_min: 0.3, tension_max: 6.0 }
//!   - { effector: finger, motor: [-0.15, -0.15, -0.15], metres_per_pulse: 2.513e-5,
//!       volts_per_newton: 0.3653, tension_min: 0.3, tension_max: 6.0 }
//!   - { effector: finger, motor: [0.15, -0.15, 0.15], metres_per_pulse: 2.513e-5,
//!       volts_per_newton: 0.3653, tension_min: 0.3, tension_max: 6.0 }
//! calibration:                        # pose of each effector while calibrating (optional)
//!   finger: { position: [0, 0, 0] }   # rigid grips add orientation: [w, x, y, z]
//! tension:
//!   lambda: 0.01                      # λ of eq. 3.16 (optional)
//!   torque_weight: 1.0                # weight of torque rows (optional)
//! ```
//!
//! A rigid grip (`dof: 6`) needs at least six strings to be located and seven to be pulled
//! in every direction; each of its strings also gives `knot:`, where it is tied on the
//! grip, in the grip's frame (metres).
//!
//! Unknown and duplicate keys are errors; every error names file, line and column.

use std::collections::BTreeMap;
use std::path::Path;

use hapticd_plugin_api::{HAPTICD_NAME_CAPACITY, HapticdEffector, HapticdString, MechanismSpec};
use serde::Deserialize;

use super::Mechanism;
use crate::diagnostics::{self, Diagnostics, Findings};

/// λ when the descriptor gives none: small enough to keep forces accurate, large enough to
/// keep tensions continuous across the edge of the complete region.
pub const DEFAULT_LAMBDA: f64 = 0.01;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDescriptor {
    name: String,
    #[serde(default)]
    description: String,
    end_effectors: Vec<RawEffector>,
    strings: Vec<RawString>,
    #[serde(default)]
    calibration: BTreeMap<String, RawPose>,
    #[serde(default)]
    tension: Option<RawTension>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEffector {
    name: String,
    dof: u32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawString {
    effector: String,
    motor: [f64; 3],
    #[serde(default)]
    knot: Option<[f64; 3]>,
    metres_per_pulse: f64,
    volts_per_newton: f64,
    tension_min: f64,
    tension_max: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPose {
    #[serde(default)]
    position: Option<[f64; 3]>,
    #[serde(default)]
    orientation: Option<[f64; 4]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTension {
    #[serde(default)]
    lambda: Option<f64>,
    #[serde(default)]
    torque_weight: Option<f64>,
}

/// Load and validate the descriptor at `path`.
pub fn load(path: &Path) -> Result<Mechanism, Diagnostics> {
    parse(&diagnostics::read_text(path)?, path)
}

/// Parse and validate descriptor `text`; `path` names it in diagnostics.
pub fn parse(text: &str, path: &Path) -> Result<Mechanism, Diagnostics> {
    let parsed = diagnostics::parse_yaml::<RawDescriptor>(text, path)?;
    let (raw, map) = (parsed.value, parsed.map);
    let locate = |field: &str| map.find(field);
    let mut f = Findings::after_schema(path, &locate, parsed.schema);

    let mut effectors = Vec::with_capacity(raw.end_effectors.len());
    for (i, e) in raw.end_effectors.iter().enumerate() {
        if e.name.len() >= HAPTICD_NAME_CAPACITY || e.name.contains('\0') {
            f.error(
                format!("end_effectors[{i}].name"),
                format!(
                    "effector names are at most {} bytes, without NUL",
                    HAPTICD_NAME_CAPACITY - 1
                ),
            );
            effectors.push(HapticdEffector::new("", e.dof));
            continue;
        }
        effectors.push(HapticdEffector::new(&e.name, e.dof));
    }
    let index_of = |name: &str| raw.end_effectors.iter().position(|e| e.name == name);

    for (name, pose) in &raw.calibration {
        let Some(index) = index_of(name) else {
            f.error(
                format!("calibration.{name}"),
                format!("no end effector named {name:?}"),
            );
            continue;
        };
        if let Some(p) = pose.position {
            effectors[index].calibration_position = p;
        }
        if let Some(o) = pose.orientation {
            effectors[index].calibration_orientation = o;
        }
    }

    let mut strings = Vec::with_capacity(raw.strings.len());
    // A string left out renumbers the rest: the mechanism's checks would name them wrong.
    let mut left_out = false;
    for (i, s) in raw.strings.iter().enumerate() {
        let Some(effector) = index_of(&s.effector) else {
            left_out = true;
            let known: Vec<_> = raw.end_effectors.iter().map(|e| &e.name).collect();
            f.error(
                format!("strings[{i}].effector"),
                format!("no end effector named {:?} (known: {known:?})", s.effector),
            );
            continue;
        };
        strings.push(HapticdString {
            effector: effector as u32,
            motor: s.motor,
            knot: s.knot.unwrap_or([0.0; 3]),
            metres_per_pulse: s.metres_per_pulse,
            volts_per_newton: s.volts_per_newton,
            tension_min: s.tension_min,
            tension_max: s.tension_max,
        });
    }

    let tension = raw.tension.as_ref();
    let spec = MechanismSpec {
        lambda: tension.and_then(|t| t.lambda).unwrap_or(DEFAULT_LAMBDA),
        torque_weight: tension.and_then(|t| t.torque_weight).unwrap_or(1.0),
        effectors,
        strings,
    };
    if left_out {
        return Err(f.into_error());
    }
    Mechanism::checked(f, &raw.name, &raw.description, path, &spec)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnostics::Severity;

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
            e.starts_with("m.yaml:5:5: error: end_effectors[0].colour: unknown key"),
            "{e}"
        );
    }

    #[test]
    fn duplicate_keys_are_refused() {
        let text = GOOD.replace("  lambda: 0.02\n", "  lambda: 0.02\n  lambda: 0.03\n");
        let e = error_of(&text);
        assert!(
            e.starts_with("m.yaml:32:3: error: `lambda` is given twice"),
            "{e}"
        );
    }

    #[test]
    fn vectors_of_the_wrong_length_are_refused() {
        let text = GOOD.replacen("[-0.2, 0.2, 0.2]", "[-0.2, 0.2]", 1);
        let e = error_of(&text);
        assert_eq!(
            e,
            "m.yaml:7:12: error: strings[0].motor: expected a list of 3 items, found 2"
        );
    }

    #[test]
    fn schema_and_value_mistakes_are_all_reported_at_once() {
        let text = GOOD
            .replacen("[-0.2, 0.2, 0.2]", "[-0.2, 0.2]", 1)
            .replace("    dof: 3\n", "    dof: 3\n    colour: red\n")
            .replace("  lambda: 0.02\n", "  lambda: -1\n");
        let e = parse(&text, Path::new("m.yaml")).unwrap_err().to_string();
        let lines: Vec<_> = e.lines().collect();
        assert_eq!(lines.len(), 3, "{e}");
        assert!(
            lines[0].contains("end_effectors[0].colour: unknown key"),
            "{e}"
        );
        assert!(
            lines[1].contains("strings[0].motor: expected a list of 3"),
            "{e}"
        );
        assert!(lines[2].contains("tension.lambda:"), "{e}");
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
            e.starts_with("m.yaml:7:12: error: strings[0].motor: must be finite"),
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
        assert!(e.starts_with("m.yaml:3:5:"), "{e}");
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
            w.starts_with("m.yaml:3:5: warning:")
                && w.contains("can never present force in every direction"),
            "{w}"
        );
    }

    #[test]
    fn a_grip_starting_outside_its_strings_span_loads_with_a_warning() {
        // The four motors span a tetrahedron around the centre; a grip calibrated far outside
        // it can be pulled towards the frame but not away from it.
        let text = GOOD.replace(
            "tension:\n",
            "calibration:\n  finger: { position: [0.5, 0.5, 0.5] }\ntension:\n",
        );
        let m = parse(&text, Path::new("m.yaml")).unwrap();
        let shown: Vec<String> = m.warnings.iter().map(ToString::to_string).collect();
        assert_eq!(shown.len(), 1, "{shown:?}");
        assert!(
            shown[0].starts_with("m.yaml:3:5: warning:")
                && shown[0].contains("not force-closed at its calibration pose"),
            "{shown:?}"
        );
        // At the centre it is force-closed: no warning.
        assert!(
            parse(GOOD, Path::new("m.yaml"))
                .unwrap()
                .warnings
                .is_empty()
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
