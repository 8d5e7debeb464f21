//! What each kind of effect does: the wrench it puts on a grip, from the grip's motion (and
//! for some from time), and whether it is passive (it can only take energy from the hand:
//! springs, dampers, friction, fields about shapes) or active (it gives it: forces that
//! follow time, inertia rendered from a differentiated velocity, and magnets' snaps).

use std::f64::consts::{FRAC_2_PI, TAU};

use glam::{DQuat, DVec3};

use super::shape::Shape;
use crate::kinematics::{Pose, Wrench, clamp_length, rotation_vector};

/// A periodic waveform, from -1 to 1 over a period.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wave {
    /// sin θ.
    Sine,
    /// +1 over the first half period, -1 over the second.
    Square,
    /// Rising from -1 to 1 over the half period about θ = 0, falling back over the other.
    Triangle,
    /// Rising from -1 to 1 over each period.
    SawUp,
    /// Falling from 1 to -1 over each period.
    SawDown,
}

impl Wave {
    /// The wave at phase `theta`, radians.
    #[inline]
    pub fn at(self, theta: f64) -> f64 {
        let turn = (theta / TAU).rem_euclid(1.0);
        match self {
            Wave::Sine => theta.sin(),
            Wave::Square => {
                if turn < 0.5 {
                    1.0
                } else {
                    -1.0
                }
            }
            Wave::Triangle => FRAC_2_PI * theta.sin().asin(),
            Wave::SawUp => 2.0 * turn - 1.0,
            Wave::SawDown => 1.0 - 2.0 * turn,
        }
    }
}

/// What a spring pulls toward.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Anchor {
    /// A point.
    Point(DVec3),
    /// A line.
    Line {
        /// A point of it.
        point: DVec3,
        /// Its unit direction.
        direction: DVec3,
    },
    /// A plane.
    Plane {
        /// A point of it.
        point: DVec3,
        /// Its unit normal.
        normal: DVec3,
    },
}

impl Anchor {
    /// From `p` to the nearest point of the anchor.
    #[inline]
    fn offset(&self, p: DVec3) -> DVec3 {
        match *self {
            Anchor::Point(a) => a - p,
            Anchor::Line { point, direction } => {
                let v = point - p;
                v - direction * v.dot(direction)
            }
            Anchor::Plane { point, normal } => normal * (point - p).dot(normal),
        }
    }
}

/// Which side of a shape a field keeps the grip on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Keep {
    /// Outside: the shape is a solid the grip is pushed out of.
    Out,
    /// Inside: the grip is pulled back in when it leaves.
    In,
    /// On the surface: pulled to it from either side (a virtual fixture).
    On,
}

/// How a field's force grows with depth over its width.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Easing {
    /// In proportion.
    Linear,
    /// 3s² − 2s³: gently at first and at the full force.
    Smooth,
}

impl Easing {
    /// The profile at `s` from 0 to 1.
    #[inline]
    fn at(self, s: f64) -> f64 {
        let s = s.clamp(0.0, 1.0);
        match self {
            Easing::Linear => s,
            Easing::Smooth => s * s * (3.0 - 2.0 * s),
        }
    }
}

/// A kind of effect, with its parameters.
// Held by value (a waveform's samples inline): an effect reaches and leaves the haptic
// thread without an allocation to free there.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// A constant force and torque.
    Constant {
        /// N.
        force: DVec3,
        /// N·m.
        torque: DVec3,
    },
    /// A force going in a straight line from one value to another, then held.
    Ramp {
        /// Where it starts, N.
        from: DVec3,
        /// Where it ends, N.
        to: DVec3,
        /// Seconds it takes.
        over: f64,
    },
    /// A periodic force along a direction.
    Periodic {
        /// Its waveform.
        wave: Wave,
        /// Hz.
        frequency: f64,
        /// N.
        amplitude: f64,
        /// Unit direction.
        direction: DVec3,
        /// Where in its period it starts, radians.
        phase: f64,
    },
    /// A spring toward an anchor.
    Spring {
        /// What it pulls toward.
        anchor: Anchor,
        /// N/m.
        stiffness: f64,
        /// Metres about the anchor where it is slack.
        dead_band: f64,
        /// Its strongest force, N (0: unbounded but for MaxForce).
        saturation: f64,
    },
    /// A rotational spring turning the grip to an orientation.
    Twist {
        /// The orientation it turns to.
        orientation: DQuat,
        /// N·m/rad.
        stiffness: f64,
        /// Its strongest torque, N·m (0: unbounded but for MaxTorque).
        saturation: f64,
    },
    /// Viscosity.
    Damper {
        /// N·s/m.
        damping: f64,
        /// Where it acts (None: everywhere).
        region: Option<Shape>,
    },
    /// A mass carried by the grip.
    Inertia {
        /// kg.
        mass: f64,
    },
    /// Coulomb friction: the grip sticks to a point held by a spring until it pulls harder
    /// than the friction force, then slides.
    Friction {
        /// The Coulomb force, N.
        force: f64,
        /// The spring holding it where it sticks, N/m.
        stiffness: f64,
    },
    /// A field about a shape keeping the grip on one side of its surface.
    Field {
        /// The shape.
        shape: Shape,
        /// The side it keeps the grip on.
        keep: Keep,
        /// N/m.
        stiffness: f64,
        /// Depth over which the force eases up to `stiffness × width` and holds, m (0: in
        /// proportion to the depth without bound).
        width: f64,
        /// How it eases.
        easing: Easing,
    },
    /// A force following samples along a direction, played at a rate, once or over again.
    Waveform {
        /// The samples, N (the first `len`).
        samples: [f32; MAX_SAMPLES],
        /// How many there are.
        len: usize,
        /// Samples a second.
        rate: f64,
        /// Unit direction.
        direction: DVec3,
        /// Whether it starts again after the last sample (or ends there).
        repeat: bool,
    },
    /// Stick-slip: the grip sticks to a point held by a spring until it pulls harder than
    /// `force`, then slips free and sticks again where it is (a sawtooth under a steady drag,
    /// as a squeaking hinge or a bowed string).
    StickSlip {
        /// The force it slips at, N.
        force: f64,
        /// The spring holding it where it sticks, N/m.
        stiffness: f64,
    },
    /// A pull toward a shape's surface from outside it (none inside), growing smoothly as
    /// the grip nears it.
    Magnet {
        /// The shape.
        shape: Shape,
        /// Metres from the surface it pulls from.
        reach: f64,
        /// Its strongest pull, at the surface, N.
        force: f64,
    },
}

/// Most samples of a waveform.
pub const MAX_SAMPLES: usize = 64;

/// What an effect keeps of a grip between ticks.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Memory {
    /// Where friction holds the grip.
    stuck_at: Option<DVec3>,
    /// The grip's velocity last tick.
    velocity: Option<DVec3>,
}

/// A grip as an effect sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grip {
    /// Its pose.
    pub pose: Pose,
    /// Its velocity, m/s.
    pub velocity: DVec3,
}

impl Kind {
    /// Whether it only ever takes energy from the hand (given time-invariant parameters).
    /// A magnet is not: it gives the hand the energy of its pull as it snaps it to the
    /// surface (to the passivity controller, which cannot know where the hand began, that
    /// would look like energy to take back, and it would damp the snap away).
    pub fn is_passive(&self) -> bool {
        !matches!(
            self,
            Kind::Constant { .. }
                | Kind::Ramp { .. }
                | Kind::Periodic { .. }
                | Kind::Waveform { .. }
                | Kind::Inertia { .. }
                | Kind::Magnet { .. }
        )
    }

    /// The strongest force it can give, newtons, `max_force` standing for unbounded.
    pub fn peak_force(&self, max_force: f64) -> f64 {
        let bounded = |f: f64| if f > 0.0 { f.min(max_force) } else { max_force };
        match *self {
            Kind::Constant { force, .. } => force.length(),
            Kind::Ramp { from, to, .. } => from.length().max(to.length()),
            Kind::Periodic { amplitude, .. } => amplitude,
            Kind::Waveform { samples, len, .. } => samples[..len]
                .iter()
                .fold(0.0, |most, s| f64::max(most, f64::from(s.abs()))),
            Kind::StickSlip { force, .. } => force,
            Kind::Spring { saturation, .. } => bounded(saturation),
            Kind::Twist { .. } => 0.0,
            Kind::Friction { force, .. } => force,
            Kind::Field {
                stiffness, width, ..
            } => bounded(stiffness * width),
            Kind::Magnet { force, .. } => force,
            Kind::Damper { .. } | Kind::Inertia { .. } => max_force,
        }
    }

    /// [rt] Its wrench on `grip`, `t` seconds after it began, over a tick of `dt`.
    #[inline]
    pub fn wrench(&self, grip: &Grip, t: f64, dt: f64, memory: &mut Memory) -> Wrench {
        let p = grip.pose.position;
        match *self {
            Kind::Constant { force, torque } => Wrench { force, torque },
            Kind::Ramp { from, to, over } => {
                let s = if over > 0.0 { (t / over).min(1.0) } else { 1.0 };
                Wrench::force(from.lerp(to, s))
            }
            Kind::Periodic {
                wave,
                frequency,
                amplitude,
                direction,
                phase,
            } => Wrench::force(direction * amplitude * wave.at(TAU * frequency * t + phase)),
            Kind::Spring {
                anchor,
                stiffness,
                dead_band,
                saturation,
            } => {
                let offset = anchor.offset(p);
                let stretch = (offset.length() - dead_band).max(0.0);
                let force = offset.normalize_or_zero() * stiffness * stretch;
                Wrench::force(saturated(force, saturation))
            }
            Kind::Twist {
                orientation,
                stiffness,
                saturation,
            } => {
                let turn = rotation_vector(orientation * grip.pose.orientation.inverse());
                Wrench {
                    force: DVec3::ZERO,
                    torque: saturated(turn * stiffness, saturation),
                }
            }
            Kind::Damper { damping, region } => match region {
                Some(shape) if shape.distance(p) > 0.0 => Wrench::ZERO,
                _ => Wrench::force(-grip.velocity * damping),
            },
            Kind::Inertia { mass } => {
                let before = memory.velocity.replace(grip.velocity);
                let acceleration = before.map_or(DVec3::ZERO, |v| (grip.velocity - v) / dt);
                Wrench::force(-acceleration * mass)
            }
            Kind::Waveform {
                samples,
                len,
                rate,
                direction,
                repeat,
            } => Wrench::force(direction * played(&samples[..len], t * rate, repeat)),
            Kind::StickSlip { force, stiffness } => {
                let stuck = *memory.stuck_at.get_or_insert(p);
                // Pulled past the force it holds: it slips and sticks again here.
                let stuck = if (stuck - p).length() * stiffness > force {
                    p
                } else {
                    stuck
                };
                memory.stuck_at = Some(stuck);
                Wrench::force((stuck - p) * stiffness)
            }
            Kind::Friction { force, stiffness } => {
                let stuck = *memory.stuck_at.get_or_insert(p);
                let stretch = p - stuck;
                // Past the stick region the point it sticks to follows the grip.
                let region = force / stiffness;
                let stuck = if stretch.length() > region {
                    p - stretch.normalize() * region
                } else {
                    stuck
                };
                memory.stuck_at = Some(stuck);
                Wrench::force((stuck - p) * stiffness)
            }
            Kind::Field {
                shape,
                keep,
                stiffness,
                width,
                easing,
            } => Wrench::force(field(&shape, keep, stiffness, (width, easing), p)),
            Kind::Magnet {
                shape,
                reach,
                force,
            } => {
                let d = shape.distance(p);
                if d <= 0.0 || d >= reach {
                    return Wrench::ZERO;
                }
                Wrench::force(-shape.normal(p) * force * Easing::Smooth.at(1.0 - d / reach))
            }
        }
    }
}

/// [rt] A field's force at `p` about `shape`, keeping to the side `keep`, of `stiffness`
/// eased over `width` by `easing`.
#[inline]
fn field(
    shape: &Shape,
    keep: Keep,
    stiffness: f64,
    (width, easing): (f64, Easing),
    p: DVec3,
) -> DVec3 {
    let d = shape.distance(p);
    // How far on the wrong side, and which way is back.
    let (depth, back) = match keep {
        Keep::Out => (-d, 1.0),
        Keep::In => (d, -1.0),
        Keep::On => (d.abs(), -d.signum()),
    };
    if depth <= 0.0 {
        return DVec3::ZERO;
    }
    let magnitude = if width > 0.0 {
        stiffness * width * easing.at(depth / width)
    } else {
        stiffness * depth
    };
    shape.normal(p) * back * magnitude
}

/// [rt] `samples` played at sample `at` (straight between them), over again when `repeat`,
/// else nothing past the last.
#[inline]
fn played(samples: &[f32], at: f64, repeat: bool) -> f64 {
    let len = samples.len();
    let at = if repeat {
        at.rem_euclid(len as f64)
    } else {
        at
    };
    if at >= len as f64 {
        return 0.0;
    }
    let k = at.floor() as usize;
    let next = match (samples.get(k + 1), repeat) {
        (Some(next), _) => *next,
        (None, true) => samples[0],
        (None, false) => samples[k],
    };
    let here = f64::from(samples[k]);
    here + (f64::from(next) - here) * at.fract()
}

/// `v` no longer than `most` (0: as it is).
#[inline]
fn saturated(v: DVec3, most: f64) -> DVec3 {
    if most > 0.0 { clamp_length(v, most) } else { v }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grip(p: DVec3, v: DVec3) -> Grip {
        Grip {
            pose: Pose {
                position: p,
                ..Pose::default()
            },
            velocity: v,
        }
    }

    #[test]
    fn waves_take_their_values_at_the_quarters() {
        let quarter = TAU / 4.0;
        let at = |w: Wave| [0.0, 1.0, 2.0, 3.0].map(|k| w.at(k * quarter + 1e-12));
        let close = |a: [f64; 4], b: [f64; 4]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9);
        assert!(close(at(Wave::Sine), [0.0, 1.0, 0.0, -1.0]));
        assert!(close(at(Wave::Square), [1.0, 1.0, -1.0, -1.0]));
        assert!(close(at(Wave::Triangle), [0.0, 1.0, 0.0, -1.0]));
        assert!(close(at(Wave::SawUp), [-1.0, -0.5, 0.0, 0.5]));
        assert!(close(at(Wave::SawDown), [1.0, 0.5, 0.0, -0.5]));
    }

    #[test]
    fn a_spring_pulls_by_its_stretch_past_the_dead_band_up_to_its_saturation() {
        let spring = Kind::Spring {
            anchor: Anchor::Point(DVec3::ZERO),
            stiffness: 200.0,
            dead_band: 0.005,
            saturation: 3.0,
        };
        let mut m = Memory::default();
        let f = |x: f64, m: &mut Memory| {
            spring
                .wrench(&grip(DVec3::X * x, DVec3::ZERO), 0.0, 1e-3, m)
                .force
        };
        assert_eq!(f(0.004, &mut m), DVec3::ZERO);
        assert!((f(0.015, &mut m).x - -200.0 * 0.010).abs() < 1e-12);
        assert!((f(0.5, &mut m).x - -3.0).abs() < 1e-12);
        let plane = Kind::Spring {
            anchor: Anchor::Plane {
                point: DVec3::ZERO,
                normal: DVec3::Y,
            },
            stiffness: 100.0,
            dead_band: 0.0,
            saturation: 0.0,
        };
        let on = plane.wrench(
            &grip(DVec3::new(0.3, 0.02, -0.1), DVec3::ZERO),
            0.0,
            1e-3,
            &mut m,
        );
        assert!((on.force - DVec3::new(0.0, -2.0, 0.0)).length() < 1e-12);
    }

    #[test]
    fn friction_holds_within_its_region_and_slides_past_it() {
        let friction = Kind::Friction {
            force: 1.0,
            stiffness: 500.0,
        };
        let mut m = Memory::default();
        let at = |x: f64, m: &mut Memory| {
            friction
                .wrench(&grip(DVec3::X * x, DVec3::ZERO), 0.0, 1e-3, m)
                .force
                .x
        };
        assert_eq!(at(0.0, &mut m), 0.0);
        assert!((at(0.001, &mut m) + 0.5).abs() < 1e-12);
        // Past 2 mm it slides: the force stays at the Coulomb force, 1 N.
        assert!((at(0.01, &mut m) + 1.0).abs() < 1e-12);
        assert!((at(0.02, &mut m) + 1.0).abs() < 1e-12);
        // Back a little: the point it sticks to stayed 2 mm behind.
        assert!((at(0.019, &mut m) + 0.5).abs() < 1e-12);
    }

    #[test]
    fn stick_slip_saws_under_a_steady_drag() {
        let kind = Kind::StickSlip {
            force: 1.0,
            stiffness: 500.0,
        };
        let mut m = Memory::default();
        let mut forces = Vec::new();
        for k in 0..=50 {
            let x = k as f64 * 1e-4;
            forces.push(
                kind.wrench(&grip(DVec3::X * x, DVec3::ZERO), 0.0, 1e-3, &mut m)
                    .force
                    .x,
            );
        }
        // It builds to 1 N over 2 mm, drops to nothing, and builds again.
        assert!((forces[20] + 1.0).abs() < 1e-9);
        assert_eq!(forces[21], 0.0);
        assert!((forces[31] + 0.5).abs() < 1e-9);
        assert!(forces.iter().all(|f| *f <= 0.0 && *f >= -1.0));
    }

    #[test]
    fn a_waveform_plays_its_samples_between_them_straight() {
        let mut samples = [0.0; MAX_SAMPLES];
        samples[..3].copy_from_slice(&[0.0, 2.0, -1.0]);
        let wave = |repeat| Kind::Waveform {
            samples,
            len: 3,
            rate: 100.0,
            direction: DVec3::Y,
            repeat,
        };
        let mut m = Memory::default();
        let at = |k: &Kind, t: f64, m: &mut Memory| {
            k.wrench(&grip(DVec3::ZERO, DVec3::ZERO), t, 1e-3, m)
                .force
                .y
        };
        for (t, expected) in [
            (0.0, 0.0),
            (0.005, 1.0),
            (0.01, 2.0),
            (0.015, 0.5),
            (0.025, -0.5),
        ] {
            assert!((at(&wave(true), t, &mut m) - expected).abs() < 1e-6, "{t}");
        }
        // Again after three samples, or nothing.
        assert!((at(&wave(true), 0.035, &mut m) - 1.0).abs() < 1e-6);
        assert_eq!(at(&wave(false), 0.035, &mut m), 0.0);
        assert!((wave(true).peak_force(10.0) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_field_pushes_out_of_a_solid_and_a_fixture_to_its_surface() {
        let ball = Shape::Sphere {
            centre: DVec3::ZERO,
            radius: 0.1,
        };
        let field = |keep| Kind::Field {
            shape: ball,
            keep,
            stiffness: 1000.0,
            width: 0.0,
            easing: Easing::Linear,
        };
        let mut m = Memory::default();
        let at = |k: &Kind, x: f64, m: &mut Memory| {
            k.wrench(&grip(DVec3::X * x, DVec3::ZERO), 0.0, 1e-3, m)
                .force
        };
        assert!((at(&field(Keep::Out), 0.09, &mut m).x - 10.0).abs() < 1e-6);
        assert_eq!(at(&field(Keep::Out), 0.11, &mut m), DVec3::ZERO);
        assert!((at(&field(Keep::In), 0.11, &mut m).x + 10.0).abs() < 1e-6);
        assert!((at(&field(Keep::On), 0.11, &mut m).x + 10.0).abs() < 1e-6);
        assert!((at(&field(Keep::On), 0.09, &mut m).x - 10.0).abs() < 1e-6);
        let eased = Kind::Field {
            shape: ball,
            keep: Keep::Out,
            stiffness: 1000.0,
            width: 0.004,
            easing: Easing::Smooth,
        };
        // Half the width deep: half of the full 4 N (3s² − 2s³ at ½), and full past it.
        assert!((at(&eased, 0.098, &mut m).x - 2.0).abs() < 1e-6);
        assert!((at(&eased, 0.05, &mut m).x - 4.0).abs() < 1e-6);
    }
}
