//! Joints between a scene's bodies (thesis 7.2: rigid bodies combined with joints): a file's
//! `joints:` as both engines read them. Each joins two bodies (or a body and the world) at
//! an anchor given in the world at load, about or along an axis, with optional limits (a
//! hard stop that gives back `restitution` of the speed it stops), a spring and damper along
//! the joint, and a motor.
//!
//! ```yaml
//! name: door
//! engine: rapier               # or penalty (with its dt and material)
//! rate: 60
//! material: { static_friction: 0.4, friction: 0.3 }
//! bodies:
//!   - { name: door, box: [0.08, 0.1, 0.005], position: [0.04, 0, 0] }
//!   - { name: drawer, box: [0.06, 0.03, 0.06], position: [0, -0.06, 0.05] }
//! joints:
//!   - name: hinge              # optional: joint N by default
//!     kind: revolute           # fixed, revolute (a hinge), prismatic (a slider) or spherical
//!     bodies: [world, door]    # the first may be the world
//!     anchor: [0, 0, 0]        # m, in the world at load
//!     axis: [0, 1, 0]          # about it (revolute) or along it (prismatic)
//!     limits: [0, 1.5]         # rad or m from where it starts (optional)
//!     restitution: 0.2         # of the speed a limit stops, given back (default 0)
//!     stiffness: 0.005         # N·m/rad or N/m back to where it starts (default 0)
//!     damping: 0.001           # N·m·s/rad or N·s/m (default 0)
//!     motor: { position: 0.5, max_force: 0.05 }   # rad or m (or velocity: rad/s or m/s),
//!                              #   with the most torque (N·m) or force (N) it may use
//!   - { kind: prismatic, bodies: [world, drawer], anchor: [0, -0.06, 0.05], axis: [0, 0, 1],
//!       limits: [0, 0.04], damping: 0.5 }
//! ```
//!
//! A joint's coordinate is 0 where the file places its bodies: a hinge's angle turns the
//! second body about the axis (right-handed), a slider's distance moves it along the axis.

use std::collections::HashMap;

use glam::DVec3;
use hapticd_core::diagnostics::Findings;
use hapticd_core::kinematics::WORLD_EXTENT;
use serde::Deserialize;

use crate::joint::{Joint, JointKind, Motor, MotorTarget};

/// The name that stands for the world in a joint's `bodies:`.
pub const WORLD: &str = "world";

/// Stiffest joint spring, N·m/rad or N/m, and most damping, N·m·s/rad or N·s/m.
const STIFFEST: f64 = 1e6;
/// Strongest motor, N·m or N.
const STRONGEST_MOTOR: f64 = 1e4;
/// Fastest motor, rad/s or m/s.
const FASTEST_MOTOR: f64 = 100.0;

/// One of `joints:` as YAML gives it.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawJoint {
    pub(super) name: Option<String>,
    pub(super) kind: JointKind,
    pub(super) bodies: [String; 2],
    pub(super) anchor: [f64; 3],
    pub(super) axis: Option<[f64; 3]>,
    pub(super) limits: Option<[f64; 2]>,
    #[serde(default)]
    pub(super) restitution: f64,
    #[serde(default)]
    pub(super) stiffness: f64,
    #[serde(default)]
    pub(super) damping: f64,
    pub(super) motor: Option<RawMotor>,
}

/// A joint's `motor:`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMotor {
    velocity: Option<f64>,
    position: Option<f64>,
    max_force: f64,
}

/// The `joints:` of a file whose `bodies:` are `bodies` (each one's name, and whether it is
/// fixed), each mistake reported at its place; those with one are left out.
pub(super) fn joints(f: &mut Findings, raw: &[RawJoint], bodies: &[(&str, bool)]) -> Vec<Joint> {
    let mut named: HashMap<&str, Option<usize>> = HashMap::new();
    for (i, (name, _)) in bodies.iter().enumerate() {
        // A name two bodies share names neither.
        named
            .entry(name)
            .and_modify(|e| *e = None)
            .or_insert(Some(i));
    }
    let fixed: Vec<bool> = bodies.iter().map(|b| b.1).collect();
    raw.iter()
        .enumerate()
        .filter_map(|(k, j)| joint(f, &format!("joints[{k}]"), k, j, &named, &fixed))
        .collect()
}

/// Joint `k` (at `at`), or None after reporting what is wrong.
fn joint(
    f: &mut Findings,
    at: &str,
    k: usize,
    j: &RawJoint,
    named: &HashMap<&str, Option<usize>>,
    fixed: &[bool],
) -> Option<Joint> {
    let name = j.name.clone().unwrap_or_else(|| format!("joint {}", k + 1));
    let mut ok = j
        .name
        .as_ref()
        .is_none_or(|n| f.name(format!("{at}.name"), n));
    let bodies = joined(f, at, j, named, fixed);
    ok &= f.coordinates(format!("{at}.anchor"), &j.anchor, WORLD_EXTENT, "m");
    let axis = match (j.axis, j.kind) {
        (Some(axis), _) => {
            let unit = DVec3::from(axis).try_normalize();
            if unit.is_none() {
                f.error(format!("{at}.axis"), "must be a finite direction, not zero");
            }
            unit
        }
        (None, JointKind::Revolute | JointKind::Prismatic) => {
            f.error(
                format!("{at}.axis"),
                "missing: a hinge or a slider needs one",
            );
            None
        }
        (None, _) => Some(DVec3::X),
    };
    ok &= range(f, at, j);
    ok &= f.within(format!("{at}.restitution"), j.restitution, 0.0, 1.0, "");
    ok &= f.within(format!("{at}.stiffness"), j.stiffness, 0.0, STIFFEST, "");
    ok &= f.within(format!("{at}.damping"), j.damping, 0.0, STIFFEST, "");
    let moves = j.kind.has_coordinate();
    if !moves && (j.stiffness > 0.0 || j.damping > 0.0) {
        f.error(
            format!("{at}.kind"),
            "a spring or damper acts on a hinge's angle or a slider's distance: a fixed or \
             spherical joint has none",
        );
        ok = false;
    }
    let motor = match &j.motor {
        Some(m) => Some(motor(f, &format!("{at}.motor"), m, j.kind)?),
        None => None,
    };
    (ok && axis.is_some()).then_some(())?;
    Some(Joint {
        name,
        kind: j.kind,
        bodies: bodies?,
        anchor: DVec3::from(j.anchor),
        axis: axis?,
        limits: j.limits,
        restitution: j.restitution,
        stiffness: j.stiffness,
        damping: j.damping,
        motor,
    })
}

/// The two bodies joint `j` (at `at`) joins, the first None for the world, or None after
/// reporting what is wrong with them.
fn joined(
    f: &mut Findings,
    at: &str,
    j: &RawJoint,
    named: &HashMap<&str, Option<usize>>,
    fixed: &[bool],
) -> Option<(Option<usize>, usize)> {
    let mut body = |side: usize| -> Option<Option<usize>> {
        let given = &j.bodies[side];
        if side == 0 && given == WORLD {
            return Some(None);
        }
        match named.get(given.as_str()) {
            Some(Some(i)) => Some(Some(*i)),
            Some(None) => {
                f.error(
                    format!("{at}.bodies[{side}]"),
                    format!("{given:?} names more than one body: give each a name of its own"),
                );
                None
            }
            None => {
                f.error(
                    format!("{at}.bodies[{side}]"),
                    format!(
                        "no body is named {given:?}{}",
                        if side == 0 { " (nor is it world)" } else { "" }
                    ),
                );
                None
            }
        }
    };
    let (first, second) = (body(0), body(1));
    match (first, second) {
        (Some(a), Some(Some(b))) if a == Some(b) => {
            f.error(format!("{at}.bodies"), "joins a body to itself");
            None
        }
        (Some(a), Some(Some(b))) if a.is_none_or(|a| fixed[a]) && fixed[b] => {
            f.error(
                format!("{at}.bodies"),
                "joins two bodies that never move (fixed, or the world)",
            );
            None
        }
        (Some(a), Some(Some(b))) => Some((a, b)),
        _ => None,
    }
}

/// Whether joint `j`'s `limits:` (at `at`) are a range its kind can have.
fn range(f: &mut Findings, at: &str, j: &RawJoint) -> bool {
    let Some([low, high]) = j.limits else {
        return true;
    };
    let field = format!("{at}.limits");
    let widest = match j.kind {
        JointKind::Revolute | JointKind::Prismatic => reach(j.kind),
        JointKind::Fixed | JointKind::Spherical => {
            f.error(
                field,
                "a hinge's angle or a slider's distance is limited: a fixed or spherical joint \
                 has neither",
            );
            return false;
        }
    };
    if !(low.is_finite() && high.is_finite() && low <= 0.0 && 0.0 <= high && low < high) {
        f.error(
            field,
            "must be [low, high] with low < high, around 0 (where the file places the bodies)",
        );
        return false;
    }
    f.within(field, high - low, 0.0, widest, " wide")
}

/// The farthest a joint of `kind` reaches from where it starts: a turn, or across the world.
fn reach(kind: JointKind) -> f64 {
    match kind {
        JointKind::Revolute => std::f64::consts::TAU,
        _ => 2.0 * WORLD_EXTENT,
    }
}

/// Motor `m` (at `at`) of a joint of `kind`, or None after reporting what is wrong.
fn motor(f: &mut Findings, at: &str, m: &RawMotor, kind: JointKind) -> Option<Motor> {
    if !kind.has_coordinate() {
        f.error(
            at,
            "a motor drives a hinge's angle or a slider's distance: a fixed or spherical \
             joint has none",
        );
        return None;
    }
    let target = match (m.velocity, m.position) {
        (Some(v), None) => f
            .within(
                format!("{at}.velocity"),
                v,
                -FASTEST_MOTOR,
                FASTEST_MOTOR,
                "",
            )
            .then_some(MotorTarget::Velocity(v)),
        (None, Some(p)) => f
            .within(format!("{at}.position"), p, -reach(kind), reach(kind), "")
            .then_some(MotorTarget::Position(p)),
        _ => {
            f.error(at, "needs one of velocity and position");
            None
        }
    };
    let strong = f.within(
        format!("{at}.max_force"),
        m.max_force,
        f64::MIN_POSITIVE,
        STRONGEST_MOTOR,
        "",
    );
    Some(Motor {
        target: target?,
        max_force: strong.then_some(m.max_force)?,
    })
}

#[cfg(test)]
mod tests {
    use super::super::SceneFile;
    use super::*;

    const BODIES: &str = "name: j\nengine: rapier\nrate: 60\nmaterial: { static_friction: 0.5, friction: \
                          0.4 }\nbodies:\n  - { name: frame, box: [0.1, 0.1, 0.1], position: [0, \
                          0, 0], fixed: true }\n  - { name: door, box: [0.1, 0.1, 0.01], \
                          position: [0.2, 0, 0] }\n  - { name: door, box: [0.1, 0.1, 0.01], \
                          position: [0.4, 0, 0] }\n  - { name: lid, box: [0.1, 0.01, 0.1], \
                          position: [0, 0.2, 0] }\n";

    fn joints(entries: &str) -> Result<Vec<Joint>, String> {
        let text = format!("{BODIES}joints:\n{entries}");
        match SceneFile::parse(&text, std::path::Path::new("j.yaml"), 0) {
            Ok(SceneFile::Rapier(scene)) => Ok(scene.joints),
            Ok(SceneFile::Penalty(_)) => unreachable!("a rapier scene"),
            Err(e) => Err(e.to_string()),
        }
    }

    #[test]
    fn a_joint_is_read_with_its_defaults_and_bodies_by_name() {
        let read = joints(
            "  - { kind: revolute, bodies: [world, lid], anchor: [0, 0.2, 0.05], axis: [2, 0, \
             0], limits: [-1, 0.5], motor: { velocity: 1, max_force: 2 } }\n  - { name: glue, \
             kind: fixed, bodies: [frame, lid], anchor: [0, 0.1, 0] }\n",
        )
        .unwrap();
        assert_eq!(read.len(), 2);
        let hinge = &read[0];
        assert_eq!(
            (hinge.name.as_str(), hinge.kind, hinge.bodies),
            ("joint 1", JointKind::Revolute, (None, 3))
        );
        assert_eq!(hinge.axis, DVec3::X);
        assert_eq!(hinge.limits, Some([-1.0, 0.5]));
        assert_eq!(
            hinge.motor,
            Some(Motor {
                target: MotorTarget::Velocity(1.0),
                max_force: 2.0
            })
        );
        assert_eq!(
            (hinge.stiffness, hinge.damping, hinge.restitution),
            (0.0, 0.0, 0.0)
        );
        assert_eq!(
            (read[1].name.as_str(), read[1].bodies),
            ("glue", (Some(0), 3))
        );
    }

    #[test]
    fn a_mistaken_joint_is_refused_at_its_place() {
        for (entry, said) in [
            (
                "{ kind: revolute, bodies: [world, nobody], anchor: [0, 0, 0], axis: [0, 1, 0] }",
                "no body is named \"nobody\"",
            ),
            (
                "{ kind: revolute, bodies: [lid, world], anchor: [0, 0, 0], axis: [0, 1, 0] }",
                "no body is named \"world\"",
            ),
            (
                "{ kind: revolute, bodies: [world, door], anchor: [0, 0, 0], axis: [0, 1, 0] }",
                "names more than one body",
            ),
            (
                "{ kind: revolute, bodies: [lid, lid], anchor: [0, 0, 0], axis: [0, 1, 0] }",
                "joins a body to itself",
            ),
            (
                "{ kind: fixed, bodies: [world, frame], anchor: [0, 0, 0] }",
                "never move",
            ),
            (
                "{ kind: revolute, bodies: [world, lid], anchor: [0, .nan, 0], axis: [0, 1, 0] }",
                "joints[0].anchor",
            ),
            (
                "{ kind: revolute, bodies: [world, lid], anchor: [0, 0, 0], axis: [0, 0, 0] }",
                "not zero",
            ),
            (
                "{ kind: prismatic, bodies: [world, lid], anchor: [0, 0, 0] }",
                "needs one",
            ),
            (
                "{ kind: revolute, bodies: [world, lid], anchor: [0, 0, 0], axis: [0, 1, 0], limits: [0.5, 1] }",
                "around 0",
            ),
            (
                "{ kind: revolute, bodies: [world, lid], anchor: [0, 0, 0], axis: [0, 1, 0], limits: [-4, 4] }",
                "wide",
            ),
            (
                "{ kind: spherical, bodies: [world, lid], anchor: [0, 0, 0], limits: [-1, 1] }",
                "has neither",
            ),
            (
                "{ kind: fixed, bodies: [world, lid], anchor: [0, 0, 0], stiffness: 3 }",
                "spring or damper",
            ),
            (
                "{ kind: revolute, bodies: [world, lid], anchor: [0, 0, 0], axis: [0, 1, 0], damping: -1 }",
                "joints[0].damping",
            ),
            (
                "{ kind: revolute, bodies: [world, lid], anchor: [0, 0, 0], axis: [0, 1, 0], restitution: 2 }",
                "joints[0].restitution",
            ),
            (
                "{ kind: revolute, bodies: [world, lid], anchor: [0, 0, 0], axis: [0, 1, 0], motor: { velocity: 1, position: 1, max_force: 1 } }",
                "one of velocity and position",
            ),
            (
                "{ kind: revolute, bodies: [world, lid], anchor: [0, 0, 0], axis: [0, 1, 0], motor: { velocity: 1, max_force: 0 } }",
                "max_force",
            ),
            (
                "{ kind: revolute, bodies: [world, lid], anchor: [0, 0, 0], axis: [0, 1, 0], motor: { velocity: .inf, max_force: 1 } }",
                "motor.velocity",
            ),
            (
                "{ kind: spherical, bodies: [world, lid], anchor: [0, 0, 0], motor: { velocity: 1, max_force: 1 } }",
                "motor drives",
            ),
            (
                "{ kind: hinge, bodies: [world, lid], anchor: [0, 0, 0] }",
                "kind",
            ),
        ] {
            let why = joints(&format!("  - {entry}\n")).unwrap_err();
            assert!(why.contains(said), "{entry}: {why}");
        }
    }
}
