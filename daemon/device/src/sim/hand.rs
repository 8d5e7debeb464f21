//! The simulated hand's script: where the hand wants each grip to be, and what else it does.
//!
//! ```yaml
//! hands:
//!   grip:                                   # an effector of the mechanism
//!     - hold: { at: [0, 0.02, 0], seconds: 0.5 }
//!     - move: { to: [0, -0.04, 0], seconds: 0.5 }
//!     - push: { force: [0, -4, 0], seconds: 1 }
//!     - shake: { amplitude: [0.01, 0, 0], frequency: 5, seconds: 2 }
//!     - trace: { centre: [0, 0, 0], radius: 0.1, normal: [0, 1, 0], period: 4, seconds: 4 }
//!     - turn: { rate: [0, 0, 1.5], seconds: 2 } # a six-DoF grip turned at 1.5 rad/s about z
//!     - unplug: { seconds: 0.3 }            # the device disappears, then returns
//!     - path: { file: session.csv }         # follow a recorded path (hapticd --record, hapticctl record)
//! ```
//!
//! Steps run one after another; after the last one the hand holds still. `move`, `shake`
//! and `trace` start from where the previous step left the target; the wrist keeps the
//! orientation the last `turn` left (a grip of three degrees of freedom ignores turns).
//! During `hold`, `move` and `shake` a finger may `squeeze` what it holds with a grip
//! effort, which the arm never pulls it back against; two fingers so scripted hold an
//! object and shake it:
//! `- shake: { amplitude: [0.025, 0, 0], frequency: 2, seconds: 4, squeeze: [-2, 0, 0] }`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3};
use hapticd_core::diagnostics::{self, Diagnostics, Findings};
use serde::Deserialize;

/// One step of a hand's script.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum Step {
    /// Hold still, at `at` if given (a jump) or where the target is.
    Hold {
        /// Where to hold, metres.
        #[serde(default)]
        at: Option<[f64; 3]>,
        /// For how long.
        seconds: f64,
        /// A finger's grip effort meanwhile, newtons (see [`HandCommand::squeeze`]).
        #[serde(default)]
        squeeze: Option<[f64; 3]>,
    },
    /// Move in a straight line at constant speed.
    Move {
        /// Destination, metres.
        to: [f64; 3],
        /// Duration.
        seconds: f64,
        /// A finger's grip effort meanwhile, newtons.
        #[serde(default)]
        squeeze: Option<[f64; 3]>,
    },
    /// Hold the target and push with an extra force.
    Push {
        /// Force, newtons.
        force: [f64; 3],
        /// Duration.
        seconds: f64,
    },
    /// Oscillate sinusoidally around the target.
    Shake {
        /// Peak displacement per axis, metres.
        amplitude: [f64; 3],
        /// Frequency, hertz.
        frequency: f64,
        /// Duration.
        seconds: f64,
        /// A finger's grip effort meanwhile, newtons.
        #[serde(default)]
        squeeze: Option<[f64; 3]>,
    },
    /// Go round a circle, starting at the point nearest the current target.
    Trace {
        /// Circle centre.
        centre: [f64; 3],
        /// Radius, metres.
        radius: f64,
        /// Normal of the circle's plane.
        normal: [f64; 3],
        /// Seconds per turn.
        period: f64,
        /// Duration.
        seconds: f64,
    },
    /// Hold the target and turn the wrist at a constant angular velocity.
    Turn {
        /// Angular velocity, rad/s: the axis scaled by the speed, in the device's frame.
        rate: [f64; 3],
        /// Duration.
        seconds: f64,
    },
    /// The device disappears for a while (unplugged), then returns.
    Unplug {
        /// Duration.
        seconds: f64,
    },
    /// Follow a recorded path: a CSV file with a `time` column and the effector's
    /// `NAME_x, NAME_y, NAME_z` columns (as `hapticd --record` writes) or plain `x, y, z`.
    Path {
        /// The CSV file; relative paths are taken from the script's directory.
        file: PathBuf,
        /// The samples: seconds from the first row, and positions.
        #[serde(skip)]
        samples: Vec<(f64, DVec3)>,
    },
}

// What a hand can be asked to do, with room to spare: far beyond a person's hand, well
// within what the simulator integrates at its fastest tick.

/// Fastest shake, hertz.
const MAX_SHAKE_FREQUENCY: f64 = 1000.0;
/// Shortest turn of a traced circle, seconds.
const MIN_TRACE_PERIOD: f64 = 0.01;
/// Farthest target from the frame centre, metres (and the largest shake or circle).
const MAX_REACH: f64 = 10.0;
/// Strongest push, newtons.
const MAX_PUSH: f64 = 1000.0;
/// Fastest turn, rad/s (sixteen turns a second).
const MAX_TURN_RATE: f64 = 100.0;
/// Longest step, seconds (eleven days).
const MAX_STEP_SECONDS: f64 = 1e6;

impl Step {
    /// The step's key in a script.
    fn keyword(&self) -> &'static str {
        match self {
            Step::Hold { .. } => "hold",
            Step::Move { .. } => "move",
            Step::Push { .. } => "push",
            Step::Shake { .. } => "shake",
            Step::Trace { .. } => "trace",
            Step::Turn { .. } => "turn",
            Step::Unplug { .. } => "unplug",
            Step::Path { .. } => "path",
        }
    }

    /// Report what the hand cannot do: values that are not finite, a circle without a
    /// plane or period, a shake too fast to simulate, negative durations.
    fn check(&self, f: &mut Findings, at: &str) {
        f.within(
            format!("{at}.seconds"),
            self.seconds(),
            0.0,
            MAX_STEP_SECONDS,
            " s",
        );
        if let Some(squeeze) = self.squeeze() {
            f.coordinates(format!("{at}.squeeze"), &squeeze, MAX_PUSH, "N");
        }
        match self {
            Step::Hold { at: Some(p), .. } => {
                f.coordinates(format!("{at}.at"), p, MAX_REACH, "m");
            }
            Step::Move { to, .. } => {
                f.coordinates(format!("{at}.to"), to, MAX_REACH, "m");
            }
            Step::Push { force, .. } => {
                f.coordinates(format!("{at}.force"), force, MAX_PUSH, "N");
            }
            Step::Turn { rate, .. } => {
                if f.coordinates(format!("{at}.rate"), rate, MAX_TURN_RATE, "rad/s")
                    && DVec3::from(*rate).length() > MAX_TURN_RATE
                {
                    f.error(
                        format!("{at}.rate"),
                        format!("turns faster than {MAX_TURN_RATE} rad/s"),
                    );
                }
            }
            Step::Shake {
                amplitude,
                frequency,
                ..
            } => {
                f.coordinates(format!("{at}.amplitude"), amplitude, MAX_REACH, "m");
                f.within(
                    format!("{at}.frequency"),
                    *frequency,
                    0.0,
                    MAX_SHAKE_FREQUENCY,
                    " Hz",
                );
            }
            Step::Trace {
                centre,
                radius,
                normal,
                period,
                ..
            } => {
                f.coordinates(format!("{at}.centre"), centre, MAX_REACH, "m");
                f.within(format!("{at}.radius"), *radius, 0.0, MAX_REACH, " m");
                // A direction: its length must neither vanish nor overflow when normalised.
                if f.coordinates(format!("{at}.normal"), normal, 1e6, "(a direction)")
                    && DVec3::from(*normal).length() < 1e-9
                {
                    f.error(format!("{at}.normal"), "must not be zero");
                }
                f.within(
                    format!("{at}.period"),
                    *period,
                    MIN_TRACE_PERIOD,
                    MAX_STEP_SECONDS,
                    " s",
                );
            }
            Step::Hold { at: None, .. } | Step::Unplug { .. } | Step::Path { .. } => {}
        }
    }

    /// The grip effort a `hold`, `move` or `shake` squeezes with, if any.
    fn squeeze(&self) -> Option<[f64; 3]> {
        match *self {
            Step::Hold { squeeze, .. }
            | Step::Move { squeeze, .. }
            | Step::Shake { squeeze, .. } => squeeze,
            _ => None,
        }
    }

    fn seconds(&self) -> f64 {
        match *self {
            Step::Hold { seconds, .. }
            | Step::Move { seconds, .. }
            | Step::Push { seconds, .. }
            | Step::Shake { seconds, .. }
            | Step::Trace { seconds, .. }
            | Step::Turn { seconds, .. }
            | Step::Unplug { seconds } => seconds,
            Step::Path { ref samples, .. } => samples.last().map_or(0.0, |s| s.0),
        }
    }
}

/// What is wrong with a recorded path.
#[derive(Debug, Clone, PartialEq)]
pub enum PathError {
    /// The file cannot be read.
    Unreadable(Diagnostics),
    /// The columns of time and position are missing.
    Columns {
        /// The effector whose columns were looked for.
        effector: String,
    },
    /// A cell that is no finite number.
    NotANumber {
        /// Its line in the file, from 1.
        line: usize,
        /// Its column, from 1.
        column: usize,
    },
    /// A position out of any device's reach.
    Beyond {
        /// Its line in the file, from 1.
        line: usize,
    },
    /// Fewer than two rows, or time that does not increase.
    Order,
}

impl std::fmt::Display for PathError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PathError::Unreadable(e) => e.fmt(f),
            PathError::Columns { effector } => {
                write!(
                    f,
                    "needs columns time and pose_x, pose_y, pose_z (or {effector}_pose_x, …, or \
                     x, y, z)"
                )
            }
            PathError::NotANumber { line, column } => {
                write!(f, "row {line}: not a number in column {column}")
            }
            PathError::Beyond { line } => write!(f, "row {line}: a position beyond {MAX_REACH} m"),
            PathError::Order => f.write_str("needs two or more rows in increasing time"),
        }
    }
}

impl std::error::Error for PathError {}

/// Read the path of effector `name` from a CSV recording.
fn read_path(file: &Path, name: &str) -> Result<Vec<(f64, DVec3)>, PathError> {
    let text = diagnostics::read_text(file).map_err(PathError::Unreadable)?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .unwrap_or_default()
        .split(',')
        .map(str::trim)
        .collect();
    let column = |wanted: &[String]| header.iter().position(|h| wanted.iter().any(|w| w == h));
    // A recording's columns (`telemetry_csv`: `pose_x`, or `grip_pose_x` beside other
    // effectors), or a hand-made file's plain `x`.
    let axis = |a: &str| {
        column(&[
            format!("{name}_pose_{a}"),
            format!("pose_{a}"),
            format!("{name}_{a}"),
            a.to_string(),
        ])
    };
    let (Some(t), Some(x), Some(y), Some(z)) =
        (column(&["time".into()]), axis("x"), axis("y"), axis("z"))
    else {
        return Err(PathError::Columns {
            effector: name.to_string(),
        });
    };
    let mut samples = Vec::new();
    for (row, line) in lines.enumerate() {
        let fields: Vec<&str> = line.split(',').collect();
        let value = |c: usize| {
            fields
                .get(c)
                .and_then(|v| v.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or(PathError::NotANumber {
                    line: row + 2,
                    column: c + 1,
                })
        };
        samples.push((value(t)?, DVec3::new(value(x)?, value(y)?, value(z)?)));
    }
    if let Some(far) = samples
        .iter()
        .position(|s| s.1.abs().max_element() > MAX_REACH)
    {
        return Err(PathError::Beyond { line: far + 2 });
    }
    let start = samples.first().map_or(0.0, |s| s.0);
    for s in &mut samples {
        s.0 -= start;
    }
    if samples.len() < 2 || samples.windows(2).any(|w| w[1].0 <= w[0].0) {
        return Err(PathError::Order);
    }
    Ok(samples)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScript {
    hands: BTreeMap<String, Vec<Step>>,
}

/// Scripts for the hands, by effector name.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Script {
    /// Steps of each effector's hand.
    pub hands: BTreeMap<String, Vec<Step>>,
}

impl Script {
    /// Load a script file (recorded paths relative to its directory).
    pub fn load(path: &Path) -> Result<Script, Diagnostics> {
        Script::parse(&diagnostics::read_text(path)?, path)
    }

    /// Parse script `text` as if read from `path`: recorded paths are taken relative to its
    /// directory, and findings name it.
    pub fn parse(text: &str, path: &Path) -> Result<Script, Diagnostics> {
        let parsed = diagnostics::parse_yaml::<RawScript>(text, path)?;
        let (mut raw, map) = (parsed.value, parsed.map);
        let locate = |field: &str| map.find(field);
        let mut f = Findings::after_schema(path, &locate, parsed.schema);
        let base = path.parent().unwrap_or(Path::new("."));
        for (name, steps) in &mut raw.hands {
            for (i, step) in steps.iter_mut().enumerate() {
                let at = format!("hands.{name}[{i}].{}", step.keyword());
                if let Step::Path { file, samples } = step {
                    let path = base.join(&*file);
                    match read_path(&path, name) {
                        Ok(read) => *samples = read,
                        Err(e @ PathError::Unreadable(_)) => {
                            f.error(format!("{at}.file"), e.to_string())
                        }
                        Err(e) => f.error(format!("{at}.file"), format!("{}: {e}", path.display())),
                    }
                }
                step.check(&mut f, &at);
            }
        }
        f.finish()?;
        Ok(Script { hands: raw.hands })
    }
}

/// What a hand does at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandCommand {
    /// Where the hand wants the grip.
    pub target: DVec3,
    /// Velocity of that target.
    pub velocity: DVec3,
    /// Extra force the hand pushes with.
    pub push: DVec3,
    /// A finger's grip effort: the hand pushes with this force, and its arm never pulls the
    /// finger back against it (it may push harder). People hold things so (thesis 4.3): they
    /// keep their grip and move what they hold by pressing harder with the finger behind it.
    pub squeeze: DVec3,
    /// How far the wrist wants the grip turned from its resting orientation.
    pub turn: DQuat,
    /// The angular velocity of that turn, rad/s.
    pub spin: DVec3,
    /// Whether the device is unplugged now.
    pub unplugged: bool,
}

/// One hand's script, evaluated in simulated time.
#[derive(Debug, Clone, PartialEq)]
pub struct HandTrack {
    steps: Vec<Step>,
    /// Target and wrist turn at the start of each step (the end of the previous one).
    starts: Vec<(DVec3, DQuat)>,
}

impl HandTrack {
    /// A track starting at `start`, the wrist at rest.
    pub fn new(start: DVec3, steps: Vec<Step>) -> Self {
        let mut starts = Vec::with_capacity(steps.len() + 1);
        let mut at = (start, DQuat::IDENTITY);
        for step in &steps {
            starts.push(at);
            at = Self::end_of(step, at);
        }
        starts.push(at);
        Self { steps, starts }
    }

    fn end_of(step: &Step, (start, turn): (DVec3, DQuat)) -> (DVec3, DQuat) {
        match *step {
            Step::Hold { at, .. } => (at.map_or(start, DVec3::from), turn),
            Step::Move { to, .. } => (DVec3::from(to), turn),
            Step::Trace { .. } => (Self::trace_at(step, start, step.seconds()).0, turn),
            Step::Turn { rate, seconds } => (start, Self::turned(rate, seconds, turn)),
            Step::Path { ref samples, .. } => (samples.last().map_or(start, |s| s.1), turn),
            _ => (start, turn),
        }
    }

    /// `turn` turned further at `rate` for `t` seconds.
    fn turned(rate: [f64; 3], t: f64, turn: DQuat) -> DQuat {
        (DQuat::from_scaled_axis(DVec3::from(rate) * t) * turn).normalize()
    }

    fn trace_at(step: &Step, start: DVec3, t: f64) -> (DVec3, DVec3) {
        let Step::Trace {
            centre,
            radius,
            normal,
            period,
            ..
        } = *step
        else {
            return (start, DVec3::ZERO);
        };
        let (centre, normal) = (DVec3::from(centre), DVec3::from(normal).normalize());
        let mut u = (start - centre).reject_from(normal);
        if u.length() < 1e-9 {
            u = normal.any_orthonormal_vector();
        }
        let u = u.normalize();
        let v = normal.cross(u);
        let w = std::f64::consts::TAU / period;
        let (s, c) = (w * t).sin_cos();
        (
            centre + radius * (c * u + s * v),
            radius * w * (-s * u + c * v),
        )
    }

    /// The hand's command `t` seconds after the script started.
    pub fn at(&self, t: f64) -> HandCommand {
        let mut begin = 0.0;
        for (step, &start) in self.steps.iter().zip(&self.starts) {
            let end = begin + step.seconds();
            if t < end {
                return Self::during(step, start, t - begin);
            }
            begin = end;
        }
        let (target, turn) = *self.starts.last().expect("starts has steps + 1 entries");
        HandCommand {
            target,
            velocity: DVec3::ZERO,
            push: DVec3::ZERO,
            squeeze: DVec3::ZERO,
            turn,
            spin: DVec3::ZERO,
            unplugged: false,
        }
    }

    fn during(step: &Step, (start, turn): (DVec3, DQuat), t: f64) -> HandCommand {
        let mut c = HandCommand {
            target: start,
            velocity: DVec3::ZERO,
            push: DVec3::ZERO,
            squeeze: DVec3::ZERO,
            turn,
            spin: DVec3::ZERO,
            unplugged: false,
        };
        c.squeeze = step.squeeze().map_or(DVec3::ZERO, DVec3::from);
        match *step {
            Step::Hold { at, .. } => c.target = at.map_or(start, DVec3::from),
            Step::Move { to, seconds, .. } => {
                let velocity = (DVec3::from(to) - start) / seconds.max(f64::EPSILON);
                c.target = start + velocity * t;
                c.velocity = velocity;
            }
            Step::Push { force, .. } => c.push = DVec3::from(force),
            Step::Shake {
                amplitude,
                frequency,
                ..
            } => {
                let w = std::f64::consts::TAU * frequency;
                c.target = start + DVec3::from(amplitude) * (w * t).sin();
                c.velocity = DVec3::from(amplitude) * w * (w * t).cos();
            }
            Step::Trace { .. } => (c.target, c.velocity) = Self::trace_at(step, start, t),
            Step::Turn { rate, .. } => {
                c.turn = Self::turned(rate, t, turn);
                c.spin = DVec3::from(rate);
            }
            Step::Unplug { .. } => c.unplugged = true,
            Step::Path { ref samples, .. } => {
                // The segment holding t, linearly.
                let i = samples
                    .partition_point(|s| s.0 <= t)
                    .clamp(1, samples.len() - 1);
                let ((t0, p0), (t1, p1)) = (samples[i - 1], samples[i]);
                c.velocity = (p1 - p0) / (t1 - t0);
                c.target = p0 + c.velocity * (t - t0);
            }
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hapticd_core::kinematics::rotation_vector;

    #[test]
    fn steps_follow_one_another() {
        let script = Script::parse(
            "hands:\n  grip:\n    - hold: { at: [0, 0.02, 0], seconds: 0.5 }\n    - move: { to: [0, -0.02, 0], seconds: 1 }\n    - push: { force: [0, -4, 0], seconds: 1 }\n    - unplug: { seconds: 0.5 }\n",
            Path::new("h.yaml"),
        )
        .unwrap();
        let track = HandTrack::new(DVec3::ZERO, script.hands["grip"].clone());
        assert_eq!(track.at(0.2).target, DVec3::new(0.0, 0.02, 0.0));
        let mid = track.at(1.0);
        assert!((mid.target.y - 0.0).abs() < 1e-12 && (mid.velocity.y + 0.04).abs() < 1e-12);
        let push = track.at(2.0);
        assert_eq!((push.target.y, push.push.y), (-0.02, -4.0));
        assert!(track.at(2.7).unplugged && !track.at(3.1).unplugged);
        assert_eq!(track.at(10.0).target, DVec3::new(0.0, -0.02, 0.0));
    }

    #[test]
    fn a_finger_squeezes_while_it_moves_holds_or_shakes_if_told() {
        let script = Script::parse(
            "hands:\n  index:\n    - move: { to: [0.02, 0, 0], seconds: 1, squeeze: [-2, 0, 0] }\n    - hold: { seconds: 1 }\n    - shake: { amplitude: [0.01, 0, 0], frequency: 1, seconds: 1, squeeze: [0, 1, 0] }\n",
            Path::new("h.yaml"),
        )
        .unwrap();
        let hand = HandTrack::new(DVec3::ZERO, script.hands["index"].clone());
        let moving = hand.at(0.5);
        assert_eq!(moving.squeeze, DVec3::new(-2.0, 0.0, 0.0));
        assert!((moving.target.x - 0.01).abs() < 1e-12);
        assert_eq!(hand.at(1.5).squeeze, DVec3::ZERO);
        assert_eq!(hand.at(2.5).squeeze, DVec3::Y);
        let e = Script::parse(
            "hands:\n  index:\n    - hold: { seconds: 1, squeeze: [.nan, 0, 0] }\n",
            Path::new("h.yaml"),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("hands.index[0].hold.squeeze: must be finite"),
            "{e}"
        );
    }

    #[test]
    fn turns_add_up_and_the_wrist_keeps_the_last() {
        let script = Script::parse(
            "hands:\n  grip:\n    - turn: { rate: [0, 0, 2], seconds: 1 }\n    - move: { to: [0.01, 0, 0], seconds: 1 }\n    - turn: { rate: [0, 0, 2], seconds: 1.5 }\n",
            Path::new("h.yaml"),
        )
        .unwrap();
        let hand = HandTrack::new(DVec3::ZERO, script.hands["grip"].clone());
        let angle_about_z = |t: f64| {
            let c = hand.at(t);
            (rotation_vector(c.turn).z, c.spin.z)
        };
        let close = |(a, s): (f64, f64), (angle, spin): (f64, f64)| {
            (a - angle).abs() < 1e-12 && (s - spin).abs() < 1e-12
        };
        assert!(close(angle_about_z(0.5), (1.0, 2.0)));
        assert!(close(angle_about_z(1.5), (2.0, 0.0)));
        assert!(close(angle_about_z(2.25), (2.5, 2.0)));
        // 2 + 3 rad is past half a turn: the same orientation as 5 − 2π.
        assert!(close(
            angle_about_z(9.0),
            (5.0 - std::f64::consts::TAU, 0.0)
        ));
        assert_eq!(hand.at(9.0).target, DVec3::new(0.01, 0.0, 0.0));
        let e = Script::parse(
            "hands:\n  grip:\n    - turn: { rate: [80, 80, 0], seconds: 1 }\n",
            Path::new("h.yaml"),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("hands.grip[0].turn.rate: turns faster than 100 rad/s"),
            "{e}"
        );
    }

    #[test]
    fn a_trace_goes_round_its_circle() {
        let step = Step::Trace {
            centre: [0.0; 3],
            radius: 0.1,
            normal: [0.0, 1.0, 0.0],
            period: 4.0,
            seconds: 4.0,
        };
        let track = HandTrack::new(DVec3::new(0.1, 0.0, 0.0), vec![step]);
        for t in [0.0, 0.7, 1.9, 3.3] {
            let c = track.at(t);
            assert!((c.target.length() - 0.1).abs() < 1e-12);
            assert!((c.velocity.length() - 0.1 * std::f64::consts::TAU / 4.0).abs() < 1e-12);
        }
        assert!((track.at(4.0).target - DVec3::new(0.1, 0.0, 0.0)).length() < 1e-12);
    }

    #[test]
    fn a_recorded_path_is_followed_between_its_samples() {
        let dir = std::env::temp_dir().join(format!("hapticd-hand-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("path.csv"),
            "tick,time,state,pose_x,pose_y,pose_z\n9999,10.0,running,0,0,0\n10499,10.5,running,0.01,0,0\n10999,11.0,running,0.01,-0.02,0\n",
        )
        .unwrap();
        let script = Script::parse(
            "hands:\n  grip:\n    - path: { file: path.csv }\n",
            &dir.join("h.yaml"),
        )
        .unwrap();
        let track = HandTrack::new(DVec3::ZERO, script.hands["grip"].clone());
        let c = track.at(0.25);
        assert!((c.target - DVec3::new(0.005, 0.0, 0.0)).length() < 1e-12);
        assert!((c.velocity - DVec3::new(0.02, 0.0, 0.0)).length() < 1e-12);
        assert!((track.at(0.75).target - DVec3::new(0.01, -0.01, 0.0)).length() < 1e-12);
        assert_eq!(track.at(5.0).target, DVec3::new(0.01, -0.02, 0.0));
        std::fs::write(dir.join("bad.csv"), "time,x\n0,1\n").unwrap();
        assert!(
            Script::parse(
                "hands:\n  grip:\n    - path: { file: bad.csv }\n",
                &dir.join("s.yaml")
            )
            .is_err()
        );
        std::fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn bad_scripts_are_refused_each_at_its_place() {
        let parse = |text: &str| Script::parse(text, Path::new("h.yaml"));
        assert!(parse("hands:\n  grip:\n    - wave: { seconds: 1 }\n").is_err());
        assert!(parse("hands:\n  grip:\n    - hold: { seconds: 1, colour: red }\n").is_err());
        let e = parse(
            "hands:\n  grip:\n    - hold: { seconds: -1 }\n    - move: { to: [.nan, 0, 0], seconds: 1 }\n    - trace: { centre: [0, 0, 0], radius: 0.1, normal: [0, 0, 0], period: 0, seconds: 1 }\n    - trace: { centre: [0, 0, 0], radius: 0.1, normal: [-1e308, 1, 0], period: 1, seconds: 1 }\n    - shake: { amplitude: [0.01, 0, 0], frequency: 1e308, seconds: 1 }\n",
        )
        .unwrap_err()
        .to_string();
        let lines: Vec<_> = e.lines().collect();
        assert_eq!(
            lines,
            [
                "h.yaml:3:24: error: hands.grip[0].hold.seconds: must be a number from 0 to 1000000 s, not -1",
                "h.yaml:4:19: error: hands.grip[1].move.to: must be finite, each within ±10 m",
                "h.yaml:5:56: error: hands.grip[2].trace.normal: must not be zero",
                "h.yaml:5:75: error: hands.grip[2].trace.period: must be a number from 0.01 to 1000000 s, not 0",
                "h.yaml:6:56: error: hands.grip[3].trace.normal: must be finite, each within ±1000000 (a direction)",
                "h.yaml:7:52: error: hands.grip[4].shake.frequency: must be a number from 0 to 1000 Hz, not 1e308",
            ]
        );
    }
}
