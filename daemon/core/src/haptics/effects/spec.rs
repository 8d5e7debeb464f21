//! Effects as people write them: one entry of a scene file's `effects:` list, or the text
//! a client hands the bus, checked into an [`Effect`] with every mistake located.
//!
//! ```yaml
//! - kind: sine              # constant, ramp, sine, square, triangle, saw_up, saw_down,
//!                           # waveform, spring, rotational_spring, damper, inertia,
//!                           # friction, stick_slip, fixture, shape, magnet
//!   effector: grip          # default: every effector
//!   direction: [0, 1, 0]
//!   amplitude: 1.5          # N
//!   frequency: 40           # Hz
//!   attack: 0.1             # s, and fade, start, duration
//! ```

use std::path::Path;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::kind::MAX_SAMPLES;
use super::{Anchor, Easing, Effect, Envelope, Keep, Kind, Shape, Wave};
use crate::diagnostics::{self, Diagnostics, Findings, key_path};

/// One effect as written.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct EffectSpec {
    /// What it is.
    pub kind: String,
    /// The effector it acts on, by name (default: every one).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effector: Option<String>,
    /// Constant, ramp (its start): force, N.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force: Option<[f64; 3]>,
    /// Constant: torque, N·m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub torque: Option<[f64; 3]>,
    /// Ramp: the force it ends at, N.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub to: Option<[f64; 3]>,
    /// Ramp: seconds it takes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub over: Option<f64>,
    /// Periodic kinds: unit direction of the force.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub direction: Option<[f64; 3]>,
    /// Periodic kinds: Hz.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frequency: Option<f64>,
    /// Periodic kinds: N.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub amplitude: Option<f64>,
    /// Periodic kinds: where in its period it starts, radians.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub phase: Option<f64>,
    /// Waveform: its samples, N.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub samples: Option<Vec<f64>>,
    /// Waveform: samples a second.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rate: Option<f64>,
    /// Waveform: whether it starts again after its last sample (default: true).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub repeat: Option<bool>,
    /// Spring, fixture: the point it pulls toward (with `axis`: a line; `normal`: a plane).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub anchor: Option<[f64; 3]>,
    /// Spring, fixture: the line's direction.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// Spring, fixture: the plane's normal.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub normal: Option<[f64; 3]>,
    /// Spring, rotational spring, fixture, shape, friction: N/m (N·m/rad).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stiffness: Option<f64>,
    /// Damper: N·s/m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub damping: Option<f64>,
    /// Spring: metres about the anchor where it is slack.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dead_band: Option<f64>,
    /// Spring, rotational spring: its strongest force (N·m for the rotational one).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub saturation: Option<f64>,
    /// Rotational spring: the orientation it turns the grip to, `[w, x, y, z]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation: Option<[f64; 4]>,
    /// Inertia: kg.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mass: Option<f64>,
    /// Friction: the Coulomb force, N (stick-slip: the force it slips at; magnet: its
    /// strongest pull).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
    /// Damper: where it acts (default: everywhere).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub region: Option<ShapeSpec>,
    /// Fixture, shape, magnet: the shape.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shape: Option<ShapeSpec>,
    /// Fixture: `on` (default), `in` or `out` of the shape.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub keep: Option<String>,
    /// Fixture, shape: the depth over which the force eases up to `stiffness × width`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub width: Option<f64>,
    /// Fixture, shape: `linear` (default) or `smooth`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub easing: Option<String>,
    /// Magnet: the body whose surface it snaps to, by name (its `shape` then in the body's
    /// frame, moving with it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub body: Option<String>,
    /// Magnet: metres from the surface it pulls from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reach: Option<f64>,
    /// Seconds to rise to full strength.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub attack: Option<f64>,
    /// Seconds to fall to nothing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fade: Option<f64>,
    /// Seconds before it begins.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start: Option<f64>,
    /// Seconds it holds (default: until removed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub duration: Option<f64>,
}

/// A shape as written: one of `sphere`, `box`, `capsule`, `cylinder`, `plane`, `cone`.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ShapeSpec {
    /// A ball of this radius, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sphere: Option<f64>,
    /// A box of these edges, m (rounded by `radius`).
    #[serde(rename = "box")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cuboid: Option<[f64; 3]>,
    /// A capsule between these two points, of `radius`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub capsule: Option<[[f64; 3]; 2]>,
    /// A cylinder between these two points, of `radius`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cylinder: Option<[[f64; 3]; 2]>,
    /// A half-space behind the plane of this outward normal through `point`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plane: Option<[f64; 3]>,
    /// A cone of this half-angle (degrees), its tip at `point`, opening along `axis`,
    /// `height` long.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cone: Option<f64>,
    /// The centre of a sphere or box (default: the origin).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub center: Option<[f64; 3]>,
    /// A point of the plane, the cone's tip (default: the origin).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub point: Option<[f64; 3]>,
    /// The radius of a capsule or cylinder, the rounding of a box's edges, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    /// The cone's axis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// The cone's height, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub height: Option<f64>,
}

/// What an effect is checked against.
#[derive(Debug, Clone, Copy)]
pub struct Limits<'a> {
    /// The device's effectors, by name.
    pub effectors: &'a [String],
    /// The device's MaxForce, N.
    pub max_force: f64,
    /// The loop's rate, Hz: a periodic effect stays below half of it.
    pub rate: f64,
    /// The world's bodies, by name (body *i* the *i*-th): a magnet may move with one.
    pub bodies: &'a [String],
}

/// Farthest an effect's point may be, metres: well outside any SPIDAR's frame.
const EXTENT: f64 = 10.0;
/// Stiffest spring, N/m, as the proxy's (the Stiffness parameter's range).
const MAX_STIFFNESS: f64 = 100_000.0;
/// Most viscosity, N·s/m, as the Damping parameter's.
const MAX_DAMPING: f64 = 500.0;
/// Heaviest inertia, kg.
const MAX_MASS: f64 = 5.0;

/// The keys each kind takes besides `kind`, `effector` and the envelope's.
fn keys_of(kind: &str) -> Option<&'static [&'static str]> {
    Some(match kind {
        "constant" => &["force", "torque"],
        "ramp" => &["force", "to", "over"],
        "sine" | "square" | "triangle" | "saw_up" | "saw_down" => {
            &["direction", "frequency", "amplitude", "phase"]
        }
        "spring" => &[
            "anchor",
            "axis",
            "normal",
            "stiffness",
            "dead_band",
            "saturation",
        ],
        "rotational_spring" => &["orientation", "stiffness", "saturation"],
        "damper" => &["damping", "region"],
        "inertia" => &["mass"],
        "waveform" => &["samples", "rate", "direction", "repeat"],
        "friction" | "stick_slip" => &["friction", "stiffness"],
        "fixture" => &[
            "anchor",
            "axis",
            "normal",
            "shape",
            "keep",
            "stiffness",
            "width",
            "easing",
        ],
        "shape" => &["shape", "stiffness", "width", "easing"],
        "magnet" => &["shape", "reach", "friction", "body"],
        _ => return None,
    })
}

/// Every kind, for the message that names them.
const KINDS: &str = "constant, ramp, sine, square, triangle, saw_up, saw_down, waveform, \
                     spring, rotational_spring, damper, inertia, friction, stick_slip, fixture, \
                     shape, magnet";

impl EffectSpec {
    /// The keys given besides `kind` and `effector`, by name.
    fn given(&self) -> Vec<&'static str> {
        let present = [
            ("force", self.force.is_some()),
            ("torque", self.torque.is_some()),
            ("to", self.to.is_some()),
            ("over", self.over.is_some()),
            ("direction", self.direction.is_some()),
            ("frequency", self.frequency.is_some()),
            ("amplitude", self.amplitude.is_some()),
            ("phase", self.phase.is_some()),
            ("samples", self.samples.is_some()),
            ("rate", self.rate.is_some()),
            ("repeat", self.repeat.is_some()),
            ("anchor", self.anchor.is_some()),
            ("axis", self.axis.is_some()),
            ("normal", self.normal.is_some()),
            ("stiffness", self.stiffness.is_some()),
            ("damping", self.damping.is_some()),
            ("dead_band", self.dead_band.is_some()),
            ("saturation", self.saturation.is_some()),
            ("orientation", self.orientation.is_some()),
            ("mass", self.mass.is_some()),
            ("friction", self.friction.is_some()),
            ("region", self.region.is_some()),
            ("shape", self.shape.is_some()),
            ("keep", self.keep.is_some()),
            ("width", self.width.is_some()),
            ("easing", self.easing.is_some()),
            ("reach", self.reach.is_some()),
            ("body", self.body.is_some()),
        ];
        present
            .iter()
            .filter(|(_, given)| *given)
            .map(|(k, _)| *k)
            .collect()
    }

    /// The effect this entry (at field path `at`) describes, every mistake an error in `f`;
    /// None when there was one.
    pub fn check(&self, at: &str, limits: &Limits, f: &mut Findings) -> Option<Effect> {
        let key = |k: &str| key_path(at, k);
        let Some(takes) = keys_of(&self.kind) else {
            f.error(
                key("kind"),
                format!("{:?} is no kind of effect: one of {KINDS}", self.kind),
            );
            return None;
        };
        let mut bad = false;
        for given in self.given() {
            if !takes.contains(&given) {
                f.error(key(given), format!("is no key of a {} effect", self.kind));
                bad = true;
            }
        }
        let effector = match &self.effector {
            Some(name) => match limits.effectors.iter().position(|e| e == name) {
                Some(index) => Some(index),
                None => {
                    f.error(
                        key("effector"),
                        format!(
                            "no effector {name:?}: the device has {:?}",
                            limits.effectors
                        ),
                    );
                    bad = true;
                    None
                }
            },
            None => None,
        };
        let body = match &self.body {
            Some(name) => match limits.bodies.iter().position(|b| b == name) {
                Some(index) => Some(index as u32),
                None => {
                    f.error(
                        key("body"),
                        format!("no body {name:?}: the world has {:?}", limits.bodies),
                    );
                    bad = true;
                    None
                }
            },
            None => None,
        };
        let envelope = self.envelope(at, f);
        let mut checker = Checker {
            spec: self,
            at,
            limits,
            f,
            bad: false,
        };
        let kind = checker.kind();
        match (kind, envelope, bad || checker.bad) {
            (Some(kind), Some(envelope), false) => Some(Effect {
                kind,
                effector,
                body,
                envelope,
            }),
            _ => None,
        }
    }

    /// Its envelope; None when a time was wrong (said in `f`).
    fn envelope(&self, at: &str, f: &mut Findings) -> Option<Envelope> {
        let mut e = Envelope::default();
        let mut good = true;
        for (name, value, slot, most) in [
            ("attack", self.attack, &mut e.attack, 3600.0),
            ("fade", self.fade, &mut e.fade, 3600.0),
            ("start", self.start, &mut e.start, 3600.0),
            ("duration", self.duration, &mut e.duration, 1e9),
        ] {
            if let Some(v) = value {
                good &= f.within(key_path(at, name), v, 0.0, most, " s");
                *slot = v;
            }
        }
        good.then_some(e)
    }
}

/// The checks of one entry's kind.
struct Checker<'a, 'b, 'c> {
    spec: &'a EffectSpec,
    at: &'a str,
    limits: &'a Limits<'a>,
    f: &'b mut Findings<'c>,
    /// An optional key was out of range (said in `f`): the kind stands, the effect does not.
    bad: bool,
}

impl Checker<'_, '_, '_> {
    fn key(&self, k: &str) -> String {
        key_path(self.at, k)
    }

    /// `value` of key `k`, which the kind needs.
    fn needed<T: Copy>(&mut self, k: &str, value: Option<T>) -> Option<T> {
        if value.is_none() {
            self.f
                .error(self.key(k), format!("a {} effect needs it", self.spec.kind));
        }
        value
    }

    /// A number of key `k` in `lo..=hi`.
    fn number(
        &mut self,
        k: &str,
        value: Option<f64>,
        (lo, hi): (f64, f64),
        unit: &str,
    ) -> Option<f64> {
        let v = self.needed(k, value)?;
        self.f.within(self.key(k), v, lo, hi, unit).then_some(v)
    }

    /// An optional number of key `k` in `lo..=hi`, else `default`.
    fn or(
        &mut self,
        k: &str,
        value: Option<f64>,
        (lo, hi): (f64, f64),
        unit: &str,
        default: f64,
    ) -> f64 {
        match value {
            Some(v) if self.f.within(self.key(k), v, lo, hi, unit) => v,
            Some(_) => {
                self.bad = true;
                default
            }
            None => default,
        }
    }

    /// A point of key `k`.
    fn point(&mut self, k: &str, value: Option<[f64; 3]>) -> Option<DVec3> {
        let v = self.needed(k, value)?;
        self.f
            .coordinates(self.key(k), &v, EXTENT, "m")
            .then(|| DVec3::from(v))
    }

    /// A force of key `k`, at most MaxForce long.
    fn force(&mut self, k: &str, value: Option<[f64; 3]>) -> Option<DVec3> {
        let v = DVec3::from(self.needed(k, value)?);
        let most = self.limits.max_force;
        if !(v.is_finite() && v.length() <= most) {
            self.f.error(
                self.key(k),
                format!("must be finite and at most MaxForce, {most} N, long"),
            );
            return None;
        }
        Some(v)
    }

    /// A unit direction of key `k` (any length but zero, made unit).
    fn direction(&mut self, k: &str, value: Option<[f64; 3]>) -> Option<DVec3> {
        let v = DVec3::from(self.needed(k, value)?);
        let unit = v.try_normalize().filter(|_| v.is_finite());
        if unit.is_none() {
            self.f
                .error(self.key(k), "must be a finite direction, not zero");
        }
        unit
    }

    fn kind(&mut self) -> Option<Kind> {
        let s = self.spec;
        let most = self.limits.max_force;
        Some(match s.kind.as_str() {
            "constant" => Kind::Constant {
                force: match s.force {
                    Some(_) => self.force("force", s.force)?,
                    None => DVec3::ZERO,
                },
                torque: match s.torque {
                    Some(t) => {
                        let t = DVec3::from(t);
                        if !t.is_finite() || t.length() > 10.0 {
                            self.f.error(
                                self.key("torque"),
                                "must be finite and at most 10 N·m long",
                            );
                            return None;
                        }
                        t
                    }
                    None => DVec3::ZERO,
                },
            },
            "ramp" => Kind::Ramp {
                from: self.force("force", s.force)?,
                to: self.force("to", s.to)?,
                over: self.number("over", s.over, (0.0, 3600.0), " s")?,
            },
            "sine" | "square" | "triangle" | "saw_up" | "saw_down" => self.periodic()?,
            "waveform" => self.waveform()?,
            "spring" => Kind::Spring {
                anchor: self.anchor()?,
                stiffness: self.number("stiffness", s.stiffness, (0.0, MAX_STIFFNESS), " N/m")?,
                dead_band: self.or("dead_band", s.dead_band, (0.0, 1.0), " m", 0.0),
                saturation: self.or("saturation", s.saturation, (0.0, most), " N", 0.0),
            },
            "rotational_spring" => Kind::Twist {
                orientation: {
                    let wxyz = self.needed("orientation", s.orientation)?;
                    let at = self.key("orientation");
                    self.f.unit_quaternion(at, wxyz)
                },
                stiffness: self.number("stiffness", s.stiffness, (0.0, 100.0), " N·m/rad")?,
                saturation: self.or("saturation", s.saturation, (0.0, 10.0), " N·m", 0.0),
            },
            "damper" => Kind::Damper {
                damping: self.number("damping", s.damping, (0.0, MAX_DAMPING), " N·s/m")?,
                region: match &s.region {
                    Some(r) => Some(self.shape("region", r)?),
                    None => None,
                },
            },
            "inertia" => Kind::Inertia {
                mass: self.number("mass", s.mass, (0.0, MAX_MASS), " kg")?,
            },
            "friction" => Kind::Friction {
                force: self.number("friction", s.friction, (0.0, most), " N")?,
                stiffness: self.number("stiffness", s.stiffness, (1.0, MAX_STIFFNESS), " N/m")?,
            },
            "stick_slip" => Kind::StickSlip {
                force: self.number("friction", s.friction, (0.0, most), " N")?,
                stiffness: self.number("stiffness", s.stiffness, (1.0, MAX_STIFFNESS), " N/m")?,
            },
            "fixture" | "shape" => self.field()?,
            "magnet" => Kind::Magnet {
                shape: {
                    let written = self.needed("shape", s.shape.as_ref())?;
                    self.shape("shape", written)?
                },
                reach: self.number("reach", s.reach, (0.0, 1.0), " m")?,
                force: self.number("friction", s.friction, (0.0, most), " N")?,
            },
            _ => unreachable!("keys_of knows every kind"),
        })
    }

    /// A periodic kind: its wave, direction, frequency (below half the loop's rate, where
    /// it is still a wave), amplitude and phase.
    fn periodic(&mut self) -> Option<Kind> {
        let s = self.spec;
        Some(Kind::Periodic {
            wave: match s.kind.as_str() {
                "sine" => Wave::Sine,
                "square" => Wave::Square,
                "triangle" => Wave::Triangle,
                "saw_up" => Wave::SawUp,
                _ => Wave::SawDown,
            },
            direction: self.direction("direction", s.direction)?,
            frequency: self.number(
                "frequency",
                s.frequency,
                (0.0, 0.5 * self.limits.rate),
                " Hz",
            )?,
            amplitude: self.number("amplitude", s.amplitude, (0.0, self.limits.max_force), " N")?,
            phase: self.or("phase", s.phase, (-1e3, 1e3), " rad", 0.0),
        })
    }

    /// A waveform: 1 to [`MAX_SAMPLES`] samples within MaxForce, played at most at the
    /// loop's rate, along a direction.
    fn waveform(&mut self) -> Option<Kind> {
        let s = self.spec;
        let written = self.needed("samples", s.samples.as_ref())?;
        let most = self.limits.max_force;
        if written.is_empty() || written.len() > MAX_SAMPLES {
            self.f.error(
                self.key("samples"),
                format!("must list 1 to {MAX_SAMPLES} forces, not {}", written.len()),
            );
            return None;
        }
        if let Some(bad) = written.iter().find(|x| !(-most..=most).contains(*x)) {
            self.f.error(
                self.key("samples"),
                format!("each must be a number from -{most} to {most} N, not {bad}"),
            );
            return None;
        }
        let mut samples = [0.0; MAX_SAMPLES];
        for (out, x) in samples.iter_mut().zip(written) {
            *out = *x as f32;
        }
        Some(Kind::Waveform {
            samples,
            len: written.len(),
            rate: self.number("rate", s.rate, (0.0, self.limits.rate), " Hz")?,
            direction: self.direction("direction", s.direction)?,
            repeat: s.repeat.unwrap_or(true),
        })
    }

    /// A fixture or a shape: a field about a shape kept out of (a shape), or on or in (a
    /// fixture); a fixture on a line or a plane is a spring to it.
    fn field(&mut self) -> Option<Kind> {
        let s = self.spec;
        let keep = match (s.kind.as_str(), s.keep.as_deref()) {
            ("shape", _) | (_, Some("out")) => Keep::Out,
            (_, None | Some("on")) => Keep::On,
            (_, Some("in")) => Keep::In,
            (_, Some(other)) => {
                self.f
                    .error(self.key("keep"), format!("{other:?}: `on`, `in` or `out`"));
                return None;
            }
        };
        let stiffness = self.number("stiffness", s.stiffness, (0.0, MAX_STIFFNESS), " N/m")?;
        if s.shape.is_none() && s.kind == "fixture" {
            return Some(Kind::Spring {
                anchor: self.anchor()?,
                stiffness,
                dead_band: 0.0,
                saturation: 0.0,
            });
        }
        let written = self.needed("shape", s.shape.as_ref())?;
        let shape = self.shape("shape", written)?;
        let easing = match s.easing.as_deref() {
            None | Some("linear") => Easing::Linear,
            Some("smooth") => Easing::Smooth,
            Some(other) => {
                self.f.error(
                    self.key("easing"),
                    format!("{other:?}: `linear` or `smooth`"),
                );
                return None;
            }
        };
        Some(Kind::Field {
            shape,
            keep,
            stiffness,
            width: self.or("width", s.width, (0.0, 1.0), " m", 0.0),
            easing,
        })
    }

    /// A spring's anchor: a point, a line (`axis`) or a plane (`normal`).
    fn anchor(&mut self) -> Option<Anchor> {
        let s = self.spec;
        let point = self.point("anchor", s.anchor)?;
        Some(match (s.axis, s.normal) {
            (Some(_), Some(_)) => {
                self.f.error(
                    self.key("normal"),
                    "give `axis` (a line) or `normal` (a plane), not both",
                );
                return None;
            }
            (Some(_), None) => Anchor::Line {
                point,
                direction: self.direction("axis", s.axis)?,
            },
            (None, Some(_)) => Anchor::Plane {
                point,
                normal: self.direction("normal", s.normal)?,
            },
            (None, None) => Anchor::Point(point),
        })
    }

    /// The shape written at key `k`.
    fn shape(&mut self, k: &str, spec: &ShapeSpec) -> Option<Shape> {
        let at = self.key(k);
        let point = |v: Option<[f64; 3]>| DVec3::from(v.unwrap_or_default());
        let radius = spec.radius.unwrap_or(0.0);
        let given = [
            spec.sphere.is_some(),
            spec.cuboid.is_some(),
            spec.capsule.is_some(),
            spec.cylinder.is_some(),
            spec.plane.is_some(),
            spec.cone.is_some(),
        ];
        if given.iter().filter(|g| **g).count() != 1 {
            self.f.error(
                at,
                "give one of sphere, box, capsule, cylinder, plane or cone",
            );
            return None;
        }
        let shape = if let Some(r) = spec.sphere {
            Shape::Sphere {
                centre: point(spec.center),
                radius: r,
            }
        } else if let Some(edges) = spec.cuboid {
            Shape::Box {
                centre: point(spec.center),
                half: DVec3::from(edges) * 0.5,
                radius,
            }
        } else if let Some([a, b]) = spec.capsule {
            Shape::Capsule {
                a: DVec3::from(a),
                b: DVec3::from(b),
                radius,
            }
        } else if let Some([a, b]) = spec.cylinder {
            Shape::Cylinder {
                a: DVec3::from(a),
                b: DVec3::from(b),
                radius,
            }
        } else if let Some(n) = spec.plane {
            Shape::Plane {
                point: point(spec.point),
                normal: DVec3::from(n).normalize_or_zero(),
            }
        } else {
            Shape::Cone {
                apex: point(spec.point),
                axis: DVec3::from(spec.axis.unwrap_or([0.0, 1.0, 0.0])).normalize_or_zero(),
                angle: spec.cone.unwrap_or_default().to_radians(),
                height: spec.height.unwrap_or(0.0),
            }
        };
        let inside = |p: DVec3| p.is_finite() && p.abs().max_element() <= EXTENT;
        let placed = match shape {
            Shape::Sphere { centre, radius } | Shape::Box { centre, radius, .. } => {
                inside(centre) && radius <= EXTENT
            }
            Shape::Capsule { a, b, radius } | Shape::Cylinder { a, b, radius } => {
                inside(a) && inside(b) && radius <= EXTENT
            }
            Shape::Plane { point, .. } => inside(point),
            Shape::Cone { apex, height, .. } => inside(apex) && height <= EXTENT,
        };
        if !(placed && shape.is_valid()) {
            self.f.error(
                at,
                "is no shape: sizes must be finite and positive (a box's rounding at most half \
                 its smallest edge, a cone's angle under 90°), within 10 m of the origin",
            );
            return None;
        }
        Some(shape)
    }
}

/// The `effects:` of the scene file `file`, each checked against `limits` (its bodies those
/// of the file's `bodies:`) with its place in the file; a file without any has none.
pub fn listed_in(file: &Path, limits: &Limits) -> Result<Vec<(Effect, EffectSpec)>, Diagnostics> {
    /// The keys read here (the bodies' names, for magnets on them); the scene's loader
    /// reads the rest.
    #[derive(Deserialize, Default)]
    struct Listed {
        #[serde(default)]
        effects: Vec<EffectSpec>,
        #[serde(default)]
        bodies: Vec<Named>,
    }
    /// A body, of which only its name is read here.
    #[derive(Deserialize, Default)]
    struct Named {
        #[serde(default)]
        name: String,
    }
    let parsed = diagnostics::parse_yaml::<Listed>(&diagnostics::read_text(file)?, file)?;
    let map = parsed.map;
    let locate = |field: &str| map.find(field);
    let mut f = Findings::after_schema(file, &locate, parsed.schema);
    let names: Vec<String> = parsed.value.bodies.iter().map(|b| b.name.clone()).collect();
    let limits = Limits {
        bodies: &names,
        ..*limits
    };
    let effects: Vec<_> = parsed
        .value
        .effects
        .iter()
        .enumerate()
        .filter_map(|(k, spec)| {
            let effect = spec.check(&format!("effects[{k}]"), &limits, &mut f)?;
            Some((effect, spec.clone()))
        })
        .collect();
    f.finish()?;
    Ok(effects)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every mistake, an optional key's too, leaves no effect and an error at its place.
    #[test]
    fn an_out_of_range_optional_key_leaves_no_effect() {
        let effectors = ["grip".to_string()];
        let limits = Limits {
            effectors: &effectors,
            max_force: 10.0,
            rate: 1000.0,
            bodies: &[],
        };
        let path = Path::new("e");
        let check = |text: &str| {
            let spec: EffectSpec = diagnostics::parse_yaml(text, path).unwrap().value;
            let mut f = Findings::new(path, &|_| None);
            let effect = spec.check("", &limits, &mut f);
            (effect, f.finish().err().map(|e| e.to_string()))
        };
        let (good, none) =
            check("{kind: spring, anchor: [0, 0, 0], stiffness: 100, dead_band: 0.01}");
        assert!(good.is_some() && none.is_none());
        let (bad, said) = check("{kind: spring, anchor: [0, 0, 0], stiffness: 100, dead_band: 5}");
        assert_eq!(bad, None);
        assert!(
            said.unwrap()
                .contains("dead_band: must be a number from 0 to 1 m, not 5")
        );
    }
}
