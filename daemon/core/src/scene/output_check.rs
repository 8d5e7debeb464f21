//! A scene plugin's output checked at the boundary, before the haptic side uses it (issue
//! 24): what no world a hand can touch produces is a plugin fault, not something to clamp and
//! display. The daemon disables the plugin (its scene renders no more, so the loop ramps the
//! forces to zero) and logs the [`OutputFault`] once, off the real-time thread.
//!
//! - Multi-rate planes ([`check_planes`]): more than [`HAPTICD_MAX_PLANES`] for a pointer, a
//!   non-finite point, a normal that is not of unit length, a surface faster than
//!   [`MAX_SURFACE_SPEED`], or two planes of one object under one pointer (the haptic side
//!   pairs a plane with its predecessor, hands impulses back and keeps touched faces by
//!   object, so a repeated object makes it jump between surfaces).
//! - Locally moved bodies ([`check_bodies`]): more than [`HAPTICD_MAX_LOCAL_BODIES`] or a
//!   body with more than [`HAPTICD_MAX_BODY_CONTACTS`] contacts, a state, inertia or contact
//!   that is not finite, no positive mass or inertia, a body faster than
//!   [`MAX_SURFACE_SPEED`] or spinning faster than [`MAX_SPIN`], or one body twice.
//! - How planes give ([`check_compliances`]): a compliance or a load that is not finite, below
//!   zero, or past [`MAX_COMPLIANCE`] or [`MAX_LOAD`].
//! - Direct wrenches ([`WrenchChecker`]): non-finite, beyond [`WRENCH_MARGIN`] times the
//!   device's limits, or zig-zagging by large steps for [`ZIGZAG_TICKS`] ticks in a row.
//!
//! Neither allocates: the wrench checker's history is a fixed array per pointer.

use glam::DVec3;
use hapticd_plugin_api::{
    HAPTICD_MAX_BODY_CONTACTS, HAPTICD_MAX_LOCAL_BODIES, HAPTICD_MAX_PLANES, HapticdLocalBody,
    HapticdMobility, HapticdPlaneCompliance, HapticdPlanes,
};

use super::local_dynamics::Mobility;
use crate::haptics::safety::SafetyLimits;
use crate::kinematics::{MAX_EFFECTORS, Wrench};

/// Fastest surface a plane may report, m/s. A hand moves at a few metres a second (a punch
/// at about 10), a body thrown in a scene at tens; a surface passing a pointer faster than
/// this would carry a proxy resting on it 10 cm in a 1 ms tick.
pub const MAX_SURFACE_SPEED: f64 = 100.0;

/// Fastest spin a locally moved body may report, rad/s: a 1 cm ball rolling at
/// [`MAX_SURFACE_SPEED`] turns at ten thousand.
pub const MAX_SPIN: f64 = 1.0e4;

/// Most a plane may give, m/N: a surface that moves a metre for each newton is not there
/// under a finger (a jelly's gives a few millimetres).
pub const MAX_COMPLIANCE: f64 = 1.0;

/// Most press a plane may say it stands under, N: a hundred times what a device's strings
/// pull (tens of newtons), and more than a proxy's spring gives across a device's whole
/// frame, so that no press a hand can make is taken for a broken world.
pub const MAX_LOAD: f64 = 10_000.0;

/// How far a normal's length may be from 1. Single-precision engines (rapier) normalise to
/// about 1e-7; a normal off by this much changes a contact force by 0.1 %.
pub const NORMAL_TOLERANCE: f64 = 1e-3;

/// How many times the device's MaxForce (and MaxTorque) a direct scene may ask for before it
/// counts as broken. Asking for more than the device gives is normal, and clamped: people push
/// harder than MaxForce through a penalty surface, which answers stiffness × depth (the
/// penalty scene's 1000 N/m point model across the whole 0.53 m frame asks 530 N, about half
/// of this at the default 10 N); nothing a hand can reach asks for more.
pub const WRENCH_MARGIN: f64 = 100.0;

/// Smallest change of a force component, newtons, that counts toward a zig-zag: a few
/// newtons, felt as a buzz. A contact's damper on the loop's filtered velocity changes by
/// less from tick to tick (under 2.5 N for the penalty scene's 50 N·s/m point model, pressed,
/// shaken and left, in the tests below).
pub const ZIGZAG_FORCE_STEP: f64 = 4.0;

/// Smallest change of a torque component, newton-metres, that counts toward a zig-zag: the
/// [`ZIGZAG_FORCE_STEP`] across a grip's 2.25 cm knot radius.
pub const ZIGZAG_TORQUE_STEP: f64 = 0.09;

/// Ticks in a row whose change reverses the last one's, each by a large step, that make a
/// wrench a buzz: the Nyquist frequency sustained (20 ms at 1 kHz). A contact moves the grip
/// at the pace of its spring and the grip's mass, so its force turns back every few ticks; an
/// encoder step under a heavy damper, or the ring of a hard impact, zig-zags for a few ticks
/// (8 at most in the tests below: 100 N·s/m on a bare 50 g grip at 1 kHz), never this long.
pub const ZIGZAG_TICKS: u32 = 20;

/// What was wrong with a plugin's output. Small and `Copy`, so the real-time thread can hand
/// it on without allocating; [`Display`](std::fmt::Display) says it for the log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OutputFault {
    /// More planes for one pointer than the ABI allows.
    TooManyPlanes {
        /// The pointer.
        pointer: usize,
        /// The count published.
        count: u32,
    },
    /// A plane's point is not finite.
    PointNotFinite {
        /// The pointer.
        pointer: usize,
        /// The plane's place in the pointer's set.
        plane: usize,
    },
    /// A plane's normal is not of unit length (or not finite).
    NormalNotUnit {
        /// The pointer.
        pointer: usize,
        /// The plane's place in the pointer's set.
        plane: usize,
        /// The normal's length.
        length: f64,
    },
    /// A plane's surface moves faster than [`MAX_SURFACE_SPEED`] (or its velocity is not
    /// finite).
    SurfaceTooFast {
        /// The pointer.
        pointer: usize,
        /// The plane's place in the pointer's set.
        plane: usize,
        /// The speed, m/s.
        speed: f64,
    },
    /// Two planes of one object under one pointer.
    DuplicateObject {
        /// The pointer.
        pointer: usize,
        /// The object named twice.
        object: u32,
    },
    /// More locally moved bodies than the ABI allows.
    TooManyBodies {
        /// The count published.
        count: u32,
    },
    /// A locally moved body with more contacts than the ABI allows.
    TooManyContacts {
        /// The body's place in the set.
        index: usize,
        /// The count published.
        count: u32,
    },
    /// A locally moved body's state, inertia or a contact is not finite.
    BodyNotFinite {
        /// The body's place in the set.
        index: usize,
    },
    /// A locally moved body without positive mass or inertia.
    BodyWithoutMass {
        /// The body's place in the set.
        index: usize,
    },
    /// A jointed body's mobility is not finite, not symmetric, or moves a point against a
    /// push.
    MobilityUnsound {
        /// The body's place in the set.
        index: usize,
    },
    /// How a plane gives is not finite, below zero or past [`MAX_COMPLIANCE`] or
    /// [`MAX_LOAD`].
    ComplianceUnsound {
        /// The pointer.
        pointer: usize,
        /// The plane's place in its set.
        plane: usize,
    },
    /// A locally moved body faster than [`MAX_SURFACE_SPEED`] or [`MAX_SPIN`].
    BodyTooFast {
        /// The body's place in the set.
        index: usize,
        /// Its speed, m/s.
        speed: f64,
        /// Its spin, rad/s.
        spin: f64,
    },
    /// One body twice in the set.
    DuplicateBody {
        /// The body's number.
        body: u32,
    },
    /// A world host's update that is no whole update (a remote scene's).
    Undecodable {
        /// Its length, bytes.
        bytes: usize,
    },
    /// A wrench is not finite.
    WrenchNotFinite {
        /// The pointer.
        pointer: usize,
    },
    /// A force component beyond [`WRENCH_MARGIN`] × MaxForce.
    ForceTooLarge {
        /// The pointer.
        pointer: usize,
        /// The largest component, newtons (absolute).
        force: f64,
        /// The bound, newtons.
        limit: f64,
    },
    /// A torque component beyond [`WRENCH_MARGIN`] × MaxTorque.
    TorqueTooLarge {
        /// The pointer.
        pointer: usize,
        /// The largest component, newton-metres (absolute).
        torque: f64,
        /// The bound, newton-metres.
        limit: f64,
    },
    /// A wrench component zig-zagged for [`ZIGZAG_TICKS`] ticks.
    ZigZag {
        /// The pointer.
        pointer: usize,
        /// The component: 0–2 force x, y, z; 3–5 torque x, y, z.
        axis: usize,
        /// The smallest change of the run (newtons or newton-metres).
        step: f64,
    },
}

impl std::fmt::Display for OutputFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        const AXES: [&str; 6] = [
            "force x", "force y", "force z", "torque x", "torque y", "torque z",
        ];
        match *self {
            Self::TooManyPlanes { pointer, count } => write!(
                f,
                "pointer {pointer}: {count} planes, more than the {HAPTICD_MAX_PLANES} allowed"
            ),
            Self::PointNotFinite { pointer, plane } => {
                write!(
                    f,
                    "pointer {pointer}, plane {plane}: its point is not finite"
                )
            }
            Self::NormalNotUnit {
                pointer,
                plane,
                length,
            } => write!(
                f,
                "pointer {pointer}, plane {plane}: its normal is {length:.6} long, not a unit \
                 vector"
            ),
            Self::SurfaceTooFast {
                pointer,
                plane,
                speed,
            } => write!(
                f,
                "pointer {pointer}, plane {plane}: its surface moves at {speed:.3e} m/s, beyond \
                 {MAX_SURFACE_SPEED} m/s (no hand or body moves that fast)"
            ),
            Self::DuplicateObject { pointer, object } => write!(
                f,
                "pointer {pointer}: two planes of object {object} (one plane per object and \
                 pointer)"
            ),
            Self::TooManyBodies { count } => write!(
                f,
                "{count} locally moved bodies, more than the {HAPTICD_MAX_LOCAL_BODIES} allowed"
            ),
            Self::TooManyContacts { index, count } => write!(
                f,
                "local body {index}: {count} contacts, more than the \
                 {HAPTICD_MAX_BODY_CONTACTS} allowed"
            ),
            Self::BodyNotFinite { index } => write!(
                f,
                "local body {index}: its state, inertia or a contact is not finite"
            ),
            Self::BodyWithoutMass { index } => {
                write!(f, "local body {index}: no positive mass and inertia")
            }
            Self::MobilityUnsound { index } => write!(
                f,
                "local body {index}: its joints' mobility is not finite, not symmetric or \
                 moves a point against a push"
            ),
            Self::ComplianceUnsound { pointer, plane } => write!(
                f,
                "pointer {pointer}, plane {plane}: how it gives is not finite, below zero or \
                 past {MAX_COMPLIANCE} m/N under {MAX_LOAD} N"
            ),
            Self::BodyTooFast { index, speed, spin } => write!(
                f,
                "local body {index}: it moves at {speed:.3e} m/s and turns at {spin:.3e} rad/s, \
                 beyond {MAX_SURFACE_SPEED} m/s or {MAX_SPIN} rad/s"
            ),
            Self::Undecodable { bytes } => write!(
                f,
                "a world update of {bytes} bytes that is no whole update of a world host"
            ),
            Self::DuplicateBody { body } => {
                write!(f, "body {body} is twice among the locally moved bodies")
            }
            Self::WrenchNotFinite { pointer } => {
                write!(f, "pointer {pointer}: its wrench is not finite")
            }
            Self::ForceTooLarge {
                pointer,
                force,
                limit,
            } => write!(
                f,
                "pointer {pointer}: a force of {force:.3e} N, beyond {limit} N \
                 ({WRENCH_MARGIN} × MaxForce)"
            ),
            Self::TorqueTooLarge {
                pointer,
                torque,
                limit,
            } => write!(
                f,
                "pointer {pointer}: a torque of {torque:.3e} N·m, beyond {limit} N·m \
                 ({WRENCH_MARGIN} × MaxTorque)"
            ),
            Self::ZigZag {
                pointer,
                axis,
                step,
            } => write!(
                f,
                "pointer {pointer}: its {} reversed by {step:.1} or more every tick for \
                 {ZIGZAG_TICKS} ticks (a buzz)",
                AXES[axis]
            ),
        }
    }
}

/// The length of `v`, without overflow for huge components (NaN or infinite when one is).
fn magnitude(v: DVec3) -> f64 {
    let largest = v.abs().max_element();
    if v.is_finite() && largest > 0.0 {
        largest * (v / largest).length()
    } else {
        v.length()
    }
}

/// [physics] Check the planes published for each pointer (one [`HapticdPlanes`] per pointer,
/// in order); the first fault found.
pub fn check_planes(planes: &[HapticdPlanes]) -> Result<(), OutputFault> {
    for (pointer, set) in planes.iter().enumerate() {
        if set.count as usize > HAPTICD_MAX_PLANES {
            return Err(OutputFault::TooManyPlanes {
                pointer,
                count: set.count,
            });
        }
        let used = &set.planes[..set.count as usize];
        for (plane, p) in used.iter().enumerate() {
            if !DVec3::from(p.point).is_finite() {
                return Err(OutputFault::PointNotFinite { pointer, plane });
            }
            let length = magnitude(DVec3::from(p.normal));
            if length.is_nan() || (length - 1.0).abs() > NORMAL_TOLERANCE {
                return Err(OutputFault::NormalNotUnit {
                    pointer,
                    plane,
                    length,
                });
            }
            let speed = magnitude(DVec3::from(p.velocity));
            if speed.is_nan() || speed > MAX_SURFACE_SPEED {
                return Err(OutputFault::SurfaceTooFast {
                    pointer,
                    plane,
                    speed,
                });
            }
            if used[..plane].iter().any(|q| q.object == p.object) {
                return Err(OutputFault::DuplicateObject {
                    pointer,
                    object: p.object,
                });
            }
        }
    }
    Ok(())
}

/// [physics] Check the mobilities a step gives its first `count` bodies (the jointed ones);
/// the first fault found.
pub fn check_mobilities(
    mobilities: &[Option<HapticdMobility>],
    count: u32,
) -> Result<(), OutputFault> {
    for (index, m) in mobilities.iter().take(count as usize).enumerate() {
        if m.is_some_and(|m| Mobility::jointed(&m).is_none()) {
            return Err(OutputFault::MobilityUnsound { index });
        }
    }
    Ok(())
}

/// [physics] Check how the planes of `planes` give (`compliances`, pointer by pointer); the
/// first fault found.
pub fn check_compliances(
    planes: &[HapticdPlanes],
    compliances: &[[HapticdPlaneCompliance; HAPTICD_MAX_PLANES]],
) -> Result<(), OutputFault> {
    for (pointer, (set, gives)) in planes.iter().zip(compliances).enumerate() {
        let count = (set.count as usize).min(HAPTICD_MAX_PLANES);
        for (plane, g) in gives[..count].iter().enumerate() {
            let sound = (0.0..=MAX_COMPLIANCE).contains(&g.compliance)
                && (0.0..=MAX_LOAD).contains(&g.load);
            if !sound {
                return Err(OutputFault::ComplianceUnsound { pointer, plane });
            }
        }
    }
    Ok(())
}

/// [physics] Check the `count` bodies a step publishes for the haptic side to move; the
/// first fault found.
pub fn check_bodies(bodies: &[HapticdLocalBody], count: u32) -> Result<(), OutputFault> {
    if count as usize > HAPTICD_MAX_LOCAL_BODIES.min(bodies.len()) {
        return Err(OutputFault::TooManyBodies { count });
    }
    let used = &bodies[..count as usize];
    for (index, b) in used.iter().enumerate() {
        if b.contact_count as usize > HAPTICD_MAX_BODY_CONTACTS {
            return Err(OutputFault::TooManyContacts {
                index,
                count: b.contact_count,
            });
        }
        let contacts = &b.contacts[..b.contact_count as usize];
        let finite = [b.position, b.velocity, b.spin, b.acceleration]
            .iter()
            .flatten()
            .chain(&b.orientation)
            .chain(&b.inverse_inertia)
            .chain([&b.inverse_mass])
            .chain(
                contacts
                    .iter()
                    .flat_map(|c| c.point.iter().chain(&c.normal)),
            )
            .chain(contacts.iter().flat_map(|c| [&c.gap, &c.friction]))
            .all(|v| v.is_finite());
        if !finite {
            return Err(OutputFault::BodyNotFinite { index });
        }
        let inertia = glam::DMat3::from_cols_array(&b.inverse_inertia);
        let diagonal = DVec3::new(inertia.x_axis.x, inertia.y_axis.y, inertia.z_axis.z);
        if b.inverse_mass <= 0.0 || diagonal.min_element() <= 0.0 {
            return Err(OutputFault::BodyWithoutMass { index });
        }
        let (speed, spin) = (
            magnitude(DVec3::from(b.velocity)),
            magnitude(DVec3::from(b.spin)),
        );
        if speed > MAX_SURFACE_SPEED || spin > MAX_SPIN {
            return Err(OutputFault::BodyTooFast { index, speed, spin });
        }
        if used[..index].iter().any(|o| o.body == b.body) {
            return Err(OutputFault::DuplicateBody { body: b.body });
        }
    }
    Ok(())
}

/// One wrench component's recent history.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Component {
    /// Its value last tick.
    value: f64,
    /// Its change last tick.
    change: f64,
    /// Ticks in a row whose change reversed the one before by at least the step.
    run: u32,
    /// The smallest change of the run.
    smallest: f64,
}

/// [rt] Checks a direct scene's wrenches tick by tick against the device's limits and for a
/// sustained zig-zag. One per scene instance; fixed-size state.
#[derive(Debug, Clone, PartialEq)]
pub struct WrenchChecker {
    max_force: f64,
    max_torque: f64,
    history: [[Component; 6]; MAX_EFFECTORS],
}

impl Default for WrenchChecker {
    /// A checker for the loop's default limits, until it is told the device's.
    fn default() -> Self {
        let limits = SafetyLimits::default();
        Self {
            max_force: limits.max_force,
            max_torque: limits.max_torque,
            history: [[Component::default(); 6]; MAX_EFFECTORS],
        }
    }
}

impl WrenchChecker {
    /// [rt] Judge forces and torques against these limits of the device (MaxForce, MaxTorque)
    /// from now on. A limit of zero (forces off) is judged as 1 N or 1 N·m: what a scene asks
    /// for still has to make sense.
    pub fn set_limits(&mut self, max_force: f64, max_torque: f64) {
        self.max_force = max_force.max(1.0);
        self.max_torque = max_torque.max(1.0);
    }

    /// [rt] Check this tick's wrenches, one per pointer; the first fault found.
    pub fn check(&mut self, wrenches: &[Wrench]) -> Result<(), OutputFault> {
        let (force_limit, torque_limit) = (
            WRENCH_MARGIN * self.max_force,
            WRENCH_MARGIN * self.max_torque,
        );
        for (pointer, w) in wrenches.iter().enumerate().take(MAX_EFFECTORS) {
            if !w.is_finite() {
                return Err(OutputFault::WrenchNotFinite { pointer });
            }
            let force = w.force.abs().max_element();
            if force > force_limit {
                return Err(OutputFault::ForceTooLarge {
                    pointer,
                    force,
                    limit: force_limit,
                });
            }
            let torque = w.torque.abs().max_element();
            if torque > torque_limit {
                return Err(OutputFault::TorqueTooLarge {
                    pointer,
                    torque,
                    limit: torque_limit,
                });
            }
        }
        for (pointer, w) in wrenches.iter().enumerate().take(MAX_EFFECTORS) {
            let values = w.force.to_array().into_iter().chain(w.torque.to_array());
            for (axis, (c, value)) in self.history[pointer].iter_mut().zip(values).enumerate() {
                let step = if axis < 3 {
                    ZIGZAG_FORCE_STEP
                } else {
                    ZIGZAG_TORQUE_STEP
                };
                let change = value - c.value;
                let reversed = change * c.change < 0.0;
                let large = change.abs().min(c.change.abs()) >= step;
                if reversed && large {
                    c.smallest = if c.run == 0 {
                        change.abs().min(c.change.abs())
                    } else {
                        c.smallest.min(change.abs())
                    };
                    c.run += 1;
                } else {
                    c.run = 0;
                }
                (c.value, c.change) = (value, change);
                if c.run >= ZIGZAG_TICKS {
                    return Err(OutputFault::ZigZag {
                        pointer,
                        axis,
                        step: c.smallest,
                    });
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
