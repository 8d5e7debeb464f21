//! Haptic effects: forces that do not come from the scene's solids (springs, dampers,
//! friction, vibrations, constant forces, fields about shapes, magnets), up to
//! [`MAX_EFFECTS`] of them on a device at once, each on one effector or all, each with its
//! [`Envelope`].
//!
//! The loop asks for each effector's two sums every tick ([`EffectSet::wrenches`]): the
//! passive effects' wrench, which joins the scene's before the passivity controller (so
//! the observer watches it too), and the active effects' wrench, added after it like a
//! commanded wrench, then bounded by the limits like everything else. Starting, stopping
//! and changing an effect never step the force faster than the force-rate limit: ramps are
//! never shorter than an effect's strongest force over that rate, a change cross-fades the
//! old effect into the new over such a time, and the active sum is slew-limited at the rate
//! besides (a square wave's edges included). Nothing here allocates.

mod envelope;
mod kind;
mod shape;
pub mod spec;

pub use envelope::Envelope;
pub use kind::{Anchor, Easing, Grip, Keep, Kind, Wave};
pub use shape::Shape;

use glam::DVec3;
use kind::Memory;

use hapticd_plugin_api::HapticdBodyPose;

use crate::kinematics::{MAX_EFFECTORS, Pose, Wrench, pose_of};

/// Effects a device holds at once.
pub const MAX_EFFECTS: usize = 64;

/// Slots of a set: room for as many more fading out after a change or a removal.
const SLOTS: usize = 2 * MAX_EFFECTS;

/// One effect: what it does, on which effector, when.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Effect {
    /// Its kind and parameters.
    pub kind: Kind,
    /// The effector it acts on (None: every one).
    pub effector: Option<usize>,
    /// The body it moves with (None: the world): its shapes and anchors are in the body's
    /// frame.
    pub body: Option<u32>,
    /// When, and how strongly.
    pub envelope: Envelope,
}

/// A change to a device's effects, by id (the caller numbers them).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EffectCommand {
    /// Start this effect.
    Add(u32, Effect),
    /// Cross-fade that effect into this one.
    Change(u32, Effect),
    /// Fade that effect out, then forget it.
    Remove(u32),
    /// Fade every effect out.
    Clear,
}

/// Why an effect command could not be carried out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EffectError {
    /// Every slot holds an effect.
    Full,
    /// No effect has that id.
    Unknown(u32),
}

/// An effect on its way out after a change: faded linearly from `gain` over `over` seconds
/// from `since`; its own time began at `began` (loop seconds).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Outgoing {
    effect: Effect,
    memory: [Memory; MAX_EFFECTORS],
    began: f64,
    since: f64,
    gain: f64,
    over: f64,
}

/// One held effect.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Slot {
    id: u32,
    effect: Effect,
    /// Its envelope with ramps no faster than the force-rate limit.
    envelope: Envelope,
    memory: [Memory; MAX_EFFECTORS],
    /// When it was added, loop seconds.
    added: f64,
    /// When it was told to stop, seconds after it was added.
    stopped: Option<f64>,
    outgoing: Option<Outgoing>,
}

impl Slot {
    /// Its strength now, `t` seconds after it was added.
    fn gain(&self, t: f64) -> f64 {
        self.envelope.gain(t, self.stopped)
    }
}

/// The effects of one device.
#[derive(Debug, Clone)]
pub struct EffectSet {
    /// The effects held, packed: the first `len` hold one, the rest none (a tick visits
    /// only those). On the heap: a loop is moved whole to its thread.
    slots: Box<[Option<Slot>]>,
    len: usize,
    time: f64,
    max_force: f64,
    max_force_rate: f64,
    /// Each effector's active sum last tick, for the slew limit.
    active: [DVec3; MAX_EFFECTORS],
}

impl EffectSet {
    /// No effects yet, for forces of at most `max_force` N changing at most `max_force_rate`
    /// N/s.
    pub fn new(max_force: f64, max_force_rate: f64) -> Self {
        Self {
            slots: vec![None; SLOTS].into_boxed_slice(),
            len: 0,
            time: 0.0,
            max_force,
            max_force_rate,
            active: [DVec3::ZERO; MAX_EFFECTORS],
        }
    }

    /// Effects held (fading ones included).
    pub fn count(&self) -> usize {
        self.len
    }

    /// Change the limits, from the next tick.
    pub fn set_limits(&mut self, max_force: f64, max_force_rate: f64) {
        (self.max_force, self.max_force_rate) = (max_force, max_force_rate);
    }

    /// [rt] Carry out `command`.
    pub fn command(&mut self, command: EffectCommand) -> Result<(), EffectError> {
        match command {
            EffectCommand::Add(id, effect) => {
                if self.find(id).is_some() {
                    // An id used again replaces its effect, cross-faded.
                    return self.command(EffectCommand::Change(id, effect));
                }
                if self.len == SLOTS {
                    return Err(EffectError::Full);
                }
                let envelope = self.rated(&effect.envelope, &effect.kind);
                let added = self.time;
                self.len += 1;
                self.slots[self.len - 1] = Some(Slot {
                    id,
                    effect,
                    envelope,
                    memory: [Memory::default(); MAX_EFFECTORS],
                    added,
                    stopped: None,
                    outgoing: None,
                });
                Ok(())
            }
            EffectCommand::Change(id, effect) => {
                let index = self.find(id).ok_or(EffectError::Unknown(id))?;
                let now = self.time;
                let old = self.slots[index].expect("found");
                let t = now - old.added;
                let gain = old.gain(t);
                let peaks = old.effect.kind.peak_force(self.max_force)
                    + effect.kind.peak_force(self.max_force);
                let over = self
                    .fade_time(peaks)
                    .max(old.envelope.fade)
                    .max(effect.envelope.attack);
                // The new one rises over the same time the old one falls; neither starts
                // over from its own delay.
                let envelope = Envelope {
                    start: 0.0,
                    attack: over,
                    ..self.rated(&effect.envelope, &effect.kind)
                };
                self.slots[index] = Some(Slot {
                    id,
                    effect,
                    envelope,
                    memory: old.memory,
                    added: now,
                    stopped: None,
                    outgoing: Some(Outgoing {
                        effect: old.effect,
                        memory: old.memory,
                        began: old.added + old.envelope.start,
                        since: now,
                        gain,
                        over,
                    }),
                });
                Ok(())
            }
            EffectCommand::Remove(id) => {
                let index = self.find(id).ok_or(EffectError::Unknown(id))?;
                let now = self.time;
                if let Some(slot) = &mut self.slots[index] {
                    slot.stopped.get_or_insert(now - slot.added);
                }
                Ok(())
            }
            EffectCommand::Clear => {
                let now = self.time;
                for slot in self.slots[..self.len].iter_mut().flatten() {
                    slot.stopped.get_or_insert(now - slot.added);
                }
                Ok(())
            }
        }
    }

    /// The slot holding effect `id`, unless it is on its way out.
    fn find(&self, id: u32) -> Option<usize> {
        self.slots[..self.len]
            .iter()
            .position(|s| s.is_some_and(|s| s.id == id && s.stopped.is_none()))
    }

    /// The shortest ramp for `peak` newtons at the force-rate limit, seconds.
    fn fade_time(&self, peak: f64) -> f64 {
        if self.max_force_rate > 0.0 {
            peak / self.max_force_rate
        } else {
            0.0
        }
    }

    /// `envelope` of an effect of `kind`, its ramps no faster than the force-rate limit.
    fn rated(&self, envelope: &Envelope, kind: &Kind) -> Envelope {
        envelope.within_rate(kind.peak_force(self.max_force), self.max_force_rate)
    }

    /// [rt] Move on by `dt`: effects that have faded out are forgotten.
    pub fn advance(&mut self, dt: f64) {
        self.time += dt;
        let now = self.time;
        let mut k = 0;
        while k < self.len {
            let slot = self.slots[k].as_mut().expect("packed");
            if slot.envelope.is_over(now - slot.added, slot.stopped) {
                // The last one takes its place.
                self.len -= 1;
                self.slots[k] = self.slots[self.len].take();
                continue;
            }
            if slot.outgoing.is_some_and(|o| now - o.since >= o.over) {
                slot.outgoing = None;
            }
            k += 1;
        }
    }

    /// [rt] Effector `effector`'s passive and active wrenches this tick of `dt`, at `grip`;
    /// `ringing`, the contact transient it feels, joins the active sum (and its slew limit).
    pub fn wrenches(
        &mut self,
        effector: usize,
        grip: &Grip,
        dt: f64,
        ringing: DVec3,
        bodies: &[HapticdBodyPose],
    ) -> (Wrench, Wrench) {
        let now = self.time;
        let (mut passive, mut active) = (Wrench::ZERO, Wrench::force(ringing));
        for slot in self.slots[..self.len].iter_mut().flatten() {
            if slot.effect.effector.is_some_and(|e| e != effector) {
                continue;
            }
            let t = now - slot.added;
            let mut w = on_body(&slot.effect, grip, bodies, |grip| {
                slot.effect.kind.wrench(
                    grip,
                    t - slot.envelope.start,
                    dt,
                    &mut slot.memory[effector],
                )
            }) * slot.gain(t);
            if let Some(o) = &mut slot.outgoing {
                let left = o.gain * (1.0 - (now - o.since) / o.over).max(0.0);
                let old = on_body(&o.effect, grip, bodies, |grip| {
                    o.effect
                        .kind
                        .wrench(grip, now - o.began, dt, &mut o.memory[effector])
                });
                w = w + old * left;
            }
            if slot.effect.kind.is_passive() {
                passive = passive + w;
            } else {
                active = active + w;
            }
        }
        // The active sum moves no faster than the force-rate limit.
        if self.max_force_rate > 0.0 {
            let last = self.active[effector];
            let step =
                crate::kinematics::clamp_length(active.force - last, self.max_force_rate * dt);
            active.force = last + step;
        }
        self.active[effector] = active.force;
        (passive, active)
    }

    /// [rt] How many of the world's first bodies the effects move with (0: none): the
    /// poses [`wrenches`](Self::wrenches) needs.
    pub fn bodies_needed(&self) -> usize {
        let mut needed = 0;
        for slot in self.slots[..self.len].iter().flatten() {
            for effect in [
                Some(&slot.effect),
                slot.outgoing.as_ref().map(|o| &o.effect),
            ] {
                if let Some(body) = effect.and_then(|e| e.body) {
                    needed = needed.max(body as usize + 1);
                }
            }
        }
        needed
    }
}

/// [rt] `wrench` of `grip`, for an `effect` on a body seen in the body's frame (among
/// `bodies`' poses) and turned back into the world's; nothing when its body is not there.
#[inline]
fn on_body(
    effect: &Effect,
    grip: &Grip,
    bodies: &[HapticdBodyPose],
    wrench: impl FnOnce(&Grip) -> Wrench,
) -> Wrench {
    let Some(body) = effect.body else {
        return wrench(grip);
    };
    let Some(pose) = bodies.get(body as usize).map(pose_of) else {
        return Wrench::ZERO;
    };
    let back = pose.orientation.inverse();
    let local = Grip {
        pose: Pose {
            position: pose.inverse_transform_point(grip.pose.position),
            orientation: back * grip.pose.orientation,
        },
        velocity: back * grip.velocity,
    };
    let w = wrench(&local);
    Wrench {
        force: pose.orientation * w.force,
        torque: pose.orientation * w.torque,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 1e-3;

    fn resting() -> Grip {
        Grip {
            pose: Pose::default(),
            velocity: DVec3::ZERO,
        }
    }

    fn constant(force: DVec3, attack: f64) -> Effect {
        Effect {
            kind: Kind::Constant {
                force,
                torque: DVec3::ZERO,
            },
            effector: None,
            body: None,
            envelope: Envelope {
                attack,
                ..Envelope::default()
            },
        }
    }

    /// The active force on effector 0 at each of `ticks` ticks.
    fn run(set: &mut EffectSet, ticks: usize) -> Vec<DVec3> {
        (0..ticks)
            .map(|_| {
                set.advance(DT);
                set.wrenches(0, &resting(), DT, DVec3::ZERO, &[]).1.force
            })
            .collect()
    }

    fn steepest(forces: &[DVec3]) -> f64 {
        forces
            .windows(2)
            .map(|w| (w[1] - w[0]).length() / DT)
            .fold(0.0, f64::max)
    }

    #[test]
    fn starting_changing_and_stopping_never_step_faster_than_the_rate_limit() {
        let rate = 1000.0;
        let mut set = EffectSet::new(10.0, rate);
        set.command(EffectCommand::Add(1, constant(DVec3::X * 8.0, 0.0)))
            .unwrap();
        let mut forces = run(&mut set, 20);
        // 8 N at 1000 N/s: 8 ms to rise, then held.
        assert!((forces[19].x - 8.0).abs() < 1e-9, "{:?}", forces[19]);
        set.command(EffectCommand::Change(1, constant(-DVec3::X * 8.0, 0.0)))
            .unwrap();
        forces.extend(run(&mut set, 30));
        assert!((forces[49].x + 8.0).abs() < 1e-9, "{:?}", forces[49]);
        set.command(EffectCommand::Remove(1)).unwrap();
        forces.extend(run(&mut set, 20));
        assert_eq!(forces[69], DVec3::ZERO);
        assert_eq!(set.count(), 0, "faded out and forgotten");
        assert!(
            steepest(&forces) <= rate * (1.0 + 1e-9),
            "{}",
            steepest(&forces)
        );
    }

    #[test]
    fn a_square_wave_edges_at_the_rate_limit_and_keeps_its_amplitude() {
        let rate = 2000.0;
        let mut set = EffectSet::new(10.0, rate);
        let square = Effect {
            kind: Kind::Periodic {
                wave: Wave::Square,
                frequency: 10.0,
                amplitude: 2.0,
                direction: DVec3::Y,
                phase: 0.0,
            },
            effector: None,
            body: None,
            envelope: Envelope::default(),
        };
        set.command(EffectCommand::Add(7, square)).unwrap();
        let forces = run(&mut set, 300);
        assert!(steepest(&forces) <= rate * (1.0 + 1e-9));
        let high = forces.iter().map(|f| f.y).fold(f64::MIN, f64::max);
        let low = forces.iter().map(|f| f.y).fold(f64::MAX, f64::min);
        assert!(
            (high - 2.0).abs() < 1e-9 && (low + 2.0).abs() < 1e-9,
            "{high} {low}"
        );
    }

    #[test]
    fn effects_act_on_their_effector_and_split_into_passive_and_active() {
        let mut set = EffectSet::new(10.0, 0.0);
        let spring = Effect {
            kind: Kind::Spring {
                anchor: Anchor::Point(DVec3::X),
                stiffness: 100.0,
                dead_band: 0.0,
                saturation: 0.0,
            },
            effector: Some(1),
            body: None,
            envelope: Envelope::default(),
        };
        set.command(EffectCommand::Add(1, spring)).unwrap();
        set.command(EffectCommand::Add(2, constant(DVec3::Z, 0.0)))
            .unwrap();
        set.advance(DT);
        let (passive0, active0) = set.wrenches(0, &resting(), DT, DVec3::ZERO, &[]);
        let (passive1, active1) = set.wrenches(1, &resting(), DT, DVec3::ZERO, &[]);
        assert_eq!((passive0.force, active0.force), (DVec3::ZERO, DVec3::Z));
        assert_eq!(
            (passive1.force, active1.force),
            (DVec3::X * 100.0, DVec3::Z)
        );
        assert_eq!(
            set.command(EffectCommand::Remove(9)),
            Err(EffectError::Unknown(9))
        );
        for id in 3..=SLOTS as u32 {
            set.command(EffectCommand::Add(id, constant(DVec3::Z, 0.0)))
                .unwrap();
        }
        assert_eq!(
            set.command(EffectCommand::Add(1000, constant(DVec3::Z, 0.0))),
            Err(EffectError::Full)
        );
    }

    /// A magnet on a body (an active effect) snaps to the body's surface where the body is
    /// now: its box, in the body's frame, turned and moved with it; nothing where the body
    /// was, or when the world has no such body.
    #[test]
    fn a_magnet_on_a_body_moves_with_it() {
        let magnet = Effect {
            kind: Kind::Magnet {
                shape: Shape::Box {
                    centre: DVec3::ZERO,
                    half: DVec3::new(0.02, 0.01, 0.01),
                    radius: 0.0,
                },
                reach: 0.01,
                force: 2.0,
            },
            effector: None,
            body: Some(1),
            envelope: Envelope::default(),
        };
        let mut set = EffectSet::new(10.0, 0.0);
        set.command(EffectCommand::Add(0, magnet)).unwrap();
        set.advance(DT);
        // Body 1 at (0.1, 0, 0), turned a quarter about z: its long side now along y.
        let turned = glam::DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2);
        let bodies = [
            HapticdBodyPose::default(),
            HapticdBodyPose {
                position: [0.1, 0.0, 0.0],
                orientation: [turned.w, turned.x, turned.y, turned.z],
            },
        ];
        let at = |p: DVec3, bodies: &[HapticdBodyPose], set: &mut EffectSet| {
            let grip = Grip {
                pose: Pose {
                    position: p,
                    ..Pose::default()
                },
                velocity: DVec3::ZERO,
            };
            set.wrenches(0, &grip, DT, DVec3::ZERO, bodies).1.force
        };
        // 5 mm beyond its face at x = 0.1 + 0.01: pulled back along -x, at half reach the
        // smooth profile's half.
        let pulled = at(DVec3::new(0.115, 0.015, 0.0), &bodies, &mut set);
        assert!(
            (pulled - DVec3::new(-1.0, 0.0, 0.0)).length() < 1e-6,
            "{pulled}"
        );
        // Its face is at x = 0.11 now, and x = 0.125 is 1.5 cm clear of it: past the reach,
        // nothing.
        assert_eq!(
            at(DVec3::new(0.125, 0.0, 0.0), &bodies, &mut set),
            DVec3::ZERO
        );
        // Where an unturned box at the origin would pull, nothing; nor without the body.
        assert_eq!(
            at(DVec3::new(0.025, 0.0, 0.0), &bodies, &mut set),
            DVec3::ZERO
        );
        assert_eq!(
            at(DVec3::new(0.115, 0.015, 0.0), &bodies[..1], &mut set),
            DVec3::ZERO
        );
        assert_eq!(set.bodies_needed(), 2);
    }
}
