//! Holding an object between fingers (thesis 4.2–4.7).
//!
//! One spring from each finger to the object (the conventional method, 4.4) makes the
//! fingers carry the resultant through the same springs that render the object's shape, so
//! any push squeezes them together: finger distance l − (2f_g + f_r)/k (4.8). The resultant
//! distribution method (4.5, 4.6) separates the two:
//!
//! - a massless **shape shell** ([`shell`]) with the object's shape is held between the
//!   fingers by the grip springs; where it balances, the springs give the grip forces;
//! - the object's dynamics hang from the shell by a spring and damper (the inertia spring,
//!   kr), whose pull is the **resultant** the fingers must give the object;
//! - the resultant goes straight to the fingers, each share along the direction its finger
//!   presses and never against it ([`distribution`], 4.17); what the shares cannot deliver
//!   goes back to the shell as a load, so the springs carry it (an object's weight, by
//!   friction).
//!
//! Finger distance then no longer depends on the resultant: l − 2f_g/k (4.10).
//!
//! Each finger's contact is a god-object on the surface it entered through, sticking by
//! Coulomb friction (μ) while the spring's tangential pull stays inside the cone. The object is
//! a box. Everything per step is allocation-free.

pub mod distribution;
pub mod shell;

use glam::{DQuat, DVec3};

use crate::kinematics::rotation_vector;

use distribution::{Distribution, Press};
use shell::Load;

/// Most fingers a grasp takes.
pub const MAX_FINGERS: usize = 8;

/// How the grasp is rendered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// The shape shell and the resultant distribution (4.5, 4.6).
    Distributed,
    /// One spring per finger to the object itself (4.4), for comparison.
    Conventional,
}

/// Parameters of a grasp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GraspSettings {
    /// Distributed or conventional.
    pub method: Method,
    /// Spring from each finger to the surface it holds, N/m (k).
    pub grip_stiffness: f64,
    /// Spring from the shell to the object, N/m (kr); its moments scale with the object's
    /// size squared.
    pub inertia_stiffness: f64,
    /// Damper beside the inertia spring, N·s/m.
    pub inertia_damping: f64,
    /// Coulomb friction between the fingers and the object (μ).
    pub friction: f64,
}

impl GraspSettings {
    /// The thesis' set-up (4.7.1): both springs 800 N/m, μ = 1.0, and an inertia damper near
    /// critical for its 1 kg box (40 N·s/m).
    pub const fn thesis(method: Method) -> Self {
        Self {
            method,
            grip_stiffness: 800.0,
            inertia_stiffness: 800.0,
            inertia_damping: 40.0,
            friction: 1.0,
        }
    }
}

/// A rigid box: the object held.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Object {
    /// Half its edge lengths, metres.
    pub half: DVec3,
    /// Mass, kilograms.
    pub mass: f64,
    /// Centre, metres.
    pub position: DVec3,
    /// Orientation.
    pub orientation: DQuat,
    /// Velocity of the centre, m/s.
    pub velocity: DVec3,
    /// Angular velocity in the object's own frame, rad/s.
    pub spin: DVec3,
}

impl Object {
    /// A box of edge lengths `size` and `mass` at rest at `position`.
    pub fn at_rest(size: DVec3, mass: f64, position: DVec3) -> Self {
        Self {
            half: size / 2.0,
            mass,
            position,
            orientation: DQuat::IDENTITY,
            velocity: DVec3::ZERO,
            spin: DVec3::ZERO,
        }
    }

    /// Principal moments of inertia, kg·m².
    fn inertia(&self) -> DVec3 {
        let h2 = self.half * self.half;
        self.mass / 3.0 * DVec3::new(h2.y + h2.z, h2.x + h2.z, h2.x + h2.y)
    }

    /// Advance `dt` under `force` and `torque` (world frame) and `gravity` (a body of its
    /// own, for experiments; in a world, the world moves it).
    pub fn advance(&mut self, force: DVec3, torque: DVec3, gravity: DVec3, dt: f64) {
        self.velocity += (force / self.mass + gravity) * dt;
        self.position += self.velocity * dt;
        let inertia = self.inertia();
        let w = self.spin;
        let t = self.orientation.inverse() * torque;
        self.spin += (t - w.cross(inertia * w)) / inertia * dt;
        self.orientation = (self.orientation * DQuat::from_scaled_axis(self.spin * dt)).normalize();
    }
}

/// A finger's god-object on the held surface, in that surface's frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Contact {
    touching: bool,
    /// Face entered: axis × 2, + 1 for the positive side.
    face: usize,
    /// Where the god-object rests, in the frame of the held surface.
    local: DVec3,
}

impl Contact {
    /// Outward unit normal of the face, in the surface's frame.
    fn normal(&self) -> DVec3 {
        let mut n = DVec3::ZERO;
        n[self.face / 2] = if self.face % 2 == 1 { 1.0 } else { -1.0 };
        n
    }

    /// Follow the finger at `x` (surface frame) into and along a box of half-size `half`.
    fn update(&mut self, half: DVec3, x: DVec3, friction: f64) {
        let depth = |face: usize| {
            let sign = if face % 2 == 1 { 1.0 } else { -1.0 };
            half[face / 2] - sign * x[face / 2]
        };
        if !self.touching {
            if (0..3).any(|a| x[a].abs() >= half[a]) {
                return;
            }
            // Entered through the face it is least deep below.
            self.face = (0..6)
                .min_by(|&a, &b| depth(a).total_cmp(&depth(b)))
                .unwrap_or(0);
            self.touching = true;
            self.local = x;
        }
        let d = depth(self.face);
        if d <= 0.0 {
            self.touching = false;
            return;
        }
        let axis = self.face / 2;
        // The god-object keeps its place on the face while the spring's tangential pull
        // stays within the friction cone, and is dragged along its edge otherwise.
        let mut slip = self.local - x;
        slip[axis] = 0.0;
        let limit = friction.max(0.0) * d;
        if slip.length() > limit {
            slip *= limit / slip.length();
        }
        let mut p = x + slip;
        p[axis] = self.normal()[axis] * half[axis];
        for a in (0..3).filter(|&a| a != axis) {
            p[a] = p[a].clamp(-half[a], half[a]);
        }
        self.local = p;
    }
}

/// What one step gives each finger.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GraspFrame {
    /// Force on each finger (what its device renders), newtons.
    pub forces: [DVec3; MAX_FINGERS],
    /// Each finger's grip force: the normal push of the surface it holds, newtons.
    pub grips: [f64; MAX_FINGERS],
    /// Outward normal of the surface each touching finger presses (zero for the others).
    pub normals: [DVec3; MAX_FINGERS],
    /// Each finger's share of the resultant, newtons (0 for the conventional method).
    pub shares: [f64; MAX_FINGERS],
    /// The force the fingers give the object, newtons.
    pub resultant: DVec3,
    /// Their moment on it about its centre, newton-metres.
    pub moment: DVec3,
    /// Whether fingers hold the object from opposite sides.
    pub grasped: bool,
}

/// How fingers touch, push and hold an object. The object moves elsewhere (in a world, or
/// by [`Object::advance`]): each step takes it as it is and says what the fingers give it.
#[derive(Debug, Clone)]
pub struct Grasp {
    settings: GraspSettings,
    /// The shell's pose.
    shell_position: DVec3,
    shell_orientation: DQuat,
    contacts: [Contact; MAX_FINGERS],
    /// What the fingers' shares gave the object last step (force, moment): the shell's
    /// springs carry the rest of the resultant.
    delivered: (DVec3, DVec3),
    distribution: Distribution,
}

impl Grasp {
    /// A grasp rendered with `settings`, nothing touched yet.
    pub fn new(settings: GraspSettings) -> Self {
        Self {
            settings,
            shell_position: DVec3::ZERO,
            shell_orientation: DQuat::IDENTITY,
            contacts: [Contact::default(); MAX_FINGERS],
            delivered: (DVec3::ZERO, DVec3::ZERO),
            distribution: Distribution::default(),
        }
    }

    /// [rt] Advance `dt` seconds with the fingers at `fingers` (at most [`MAX_FINGERS`]) on
    /// `object` as it is now; the frame says what they feel and what they give it.
    pub fn step(&mut self, fingers: &[DVec3], object: &Object, dt: f64) -> GraspFrame {
        let n = fingers.len().min(MAX_FINGERS);
        let distributed = self.settings.method == Method::Distributed;
        // The shell is the object's surface until a grasp starts.
        let holding = distributed && self.opposed(n);
        let (centre, rotation) = if holding {
            (self.shell_position, self.shell_orientation)
        } else {
            (object.position, object.orientation)
        };
        for (contact, &x) in self.contacts.iter_mut().zip(&fingers[..n]) {
            contact.update(
                object.half,
                rotation.inverse() * (x - centre),
                self.settings.friction,
            );
        }
        let grasped = self.opposed(n);
        if distributed && grasped {
            if !holding {
                // A grasp starts: the shell from the object's surface.
                (self.shell_position, self.shell_orientation) = (centre, rotation);
                self.delivered = (DVec3::ZERO, DVec3::ZERO);
            }
            self.distributed_step(fingers, n, object, dt)
        } else {
            self.spring_step(fingers, n, object, grasped)
        }
    }

    /// Whether two touching fingers press from opposite sides.
    fn opposed(&self, n: usize) -> bool {
        let touching = || self.contacts[..n].iter().filter(|c| c.touching);
        touching().any(|a| touching().any(|b| a.normal().dot(b.normal()) < -0.5))
    }

    /// The shell balanced between the fingers, the resultant shared among them.
    fn distributed_step(
        &mut self,
        fingers: &[DVec3],
        n: usize,
        object: &Object,
        dt: f64,
    ) -> GraspFrame {
        let k = self.settings.grip_stiffness;
        let (centre, rotation) = (self.shell_position, self.shell_orientation);
        let mut held = [DVec3::ZERO; MAX_FINGERS];
        let mut holding = [DVec3::ZERO; MAX_FINGERS];
        let mut index = [0usize; MAX_FINGERS];
        let mut m = 0;
        for i in (0..n).filter(|&i| self.contacts[i].touching) {
            held[m] = centre + rotation * self.contacts[i].local;
            holding[m] = fingers[i];
            index[m] = i;
            m += 1;
        }
        // The inertia spring and damper pull the shell toward the object: as part of the
        // balance, so the shell and the object settle together (a load that followed a step
        // behind would make the damper, seeing the shell jump, push harder every step).
        let size = object.half.length();
        let (kr, br) = (
            self.settings.inertia_stiffness,
            self.settings.inertia_damping,
        );
        let spin = object.orientation * object.spin;
        let pull = |at: DVec3, moved: DVec3| {
            kr * (at - object.position) + br * (moved / dt - object.velocity)
        };
        let twist = |turned: DQuat, turn: DVec3| {
            size * size
                * (kr * rotation_vector(turned * object.orientation.inverse())
                    + br * (turn / dt - spin))
        };
        let load = Load {
            force: self.delivered.0 - pull(centre, DVec3::ZERO),
            torque: self.delivered.1 - twist(rotation, DVec3::ZERO),
            stiffness: kr + br / dt,
            torsion: size * size * (kr + br / dt),
        };
        let d = shell::balance(&held[..m], &holding[..m], k, centre, &load).unwrap_or_default();
        self.shell_position = centre + d.translation;
        self.shell_orientation = (DQuat::from_scaled_axis(d.rotation) * rotation).normalize();
        let (centre, rotation) = (self.shell_position, self.shell_orientation);
        // What the fingers must give the object.
        let resultant = pull(centre, d.translation);
        let moment = twist(rotation, d.rotation);
        let mut frame = GraspFrame {
            forces: [DVec3::ZERO; MAX_FINGERS],
            grips: [0.0; MAX_FINGERS],
            normals: [DVec3::ZERO; MAX_FINGERS],
            shares: [0.0; MAX_FINGERS],
            resultant,
            moment,
            grasped: true,
        };
        let mut presses = [Press::default(); MAX_FINGERS];
        for j in 0..m {
            let contact = &self.contacts[index[j]];
            let p = centre + rotation * contact.local;
            let outward = rotation * contact.normal();
            let force = k * (p - holding[j]);
            frame.forces[index[j]] = force;
            frame.grips[index[j]] = force.dot(outward).max(0.0);
            frame.normals[index[j]] = outward;
            presses[j] = Press {
                point: p - centre,
                direction: -outward,
                grip: frame.grips[index[j]],
            };
        }
        let mut shares = [0.0; MAX_FINGERS];
        self.distribution.share(
            &presses[..m],
            resultant,
            moment,
            2.0 * size,
            &mut shares[..m],
        );
        self.delivered = (DVec3::ZERO, DVec3::ZERO);
        for j in 0..m {
            let push = shares[j] * presses[j].direction;
            frame.forces[index[j]] -= push;
            frame.shares[index[j]] = shares[j];
            self.delivered.0 += push;
            self.delivered.1 += presses[j].point.cross(push);
        }
        frame
    }

    /// Each touching finger's spring acts on the object itself (the conventional method,
    /// and any touch that is not a grasp).
    fn spring_step(
        &mut self,
        fingers: &[DVec3],
        n: usize,
        object: &Object,
        grasped: bool,
    ) -> GraspFrame {
        let k = self.settings.grip_stiffness;
        let (centre, rotation) = (object.position, object.orientation);
        let mut frame = GraspFrame {
            forces: [DVec3::ZERO; MAX_FINGERS],
            grips: [0.0; MAX_FINGERS],
            normals: [DVec3::ZERO; MAX_FINGERS],
            shares: [0.0; MAX_FINGERS],
            resultant: DVec3::ZERO,
            moment: DVec3::ZERO,
            grasped,
        };
        for i in (0..n).filter(|&i| self.contacts[i].touching) {
            let contact = &self.contacts[i];
            let p = centre + rotation * contact.local;
            let force = k * (p - fingers[i]);
            frame.forces[i] = force;
            let outward = rotation * contact.normal();
            frame.grips[i] = force.dot(outward).max(0.0);
            frame.normals[i] = outward;
            frame.resultant -= force;
            frame.moment -= (p - centre).cross(force);
        }
        frame
    }
}

/// An object alone in the hand (nothing else in its world but gravity): the grasp and the
/// object's motion together, for experiments and measurements.
#[derive(Debug, Clone)]
pub struct Handheld {
    /// How the fingers hold it.
    pub grasp: Grasp,
    /// The object.
    pub object: Object,
    /// Gravity, m/s².
    pub gravity: DVec3,
}

impl Handheld {
    /// [rt] One step of `dt` with the fingers at `fingers`: what they feel, and the object
    /// moved by what they give it.
    pub fn step(&mut self, fingers: &[DVec3], dt: f64) -> GraspFrame {
        let frame = self.grasp.step(fingers, &self.object, dt);
        self.object
            .advance(frame.resultant, frame.moment, self.gravity, dt);
        frame
    }
}

// The project's seeded test generator, shared with the end-to-end and physics tests.
#[cfg(test)]
#[allow(dead_code)]
#[path = "../../../../../tests/support/rng.rs"]
mod test_rng;

#[cfg(test)]
mod tests {
    use super::*;

    use super::test_rng::Rng;

    const K: f64 = 800.0;
    const WIDTH: f64 = 0.06;

    fn box_between_fingers(method: Method, gravity: DVec3) -> Handheld {
        Handheld {
            grasp: Grasp::new(GraspSettings::thesis(method)),
            object: Object::at_rest(DVec3::new(WIDTH, 0.1, 0.06), 1.0, DVec3::ZERO),
            gravity,
        }
    }

    /// Fingers on the x axis, `gap` apart, centred on `centre`.
    fn fingers(centre: f64, gap: f64) -> [DVec3; 2] {
        [
            DVec3::new(centre - gap / 2.0, 0.0, 0.0),
            DVec3::new(centre + gap / 2.0, 0.0, 0.0),
        ]
    }

    #[test]
    fn conventional_finger_distance_falls_with_the_resultant_as_4_8_says() {
        // Fingers 5.5 cm apart squeeze the 6 cm box, pushing it along +x as they move.
        let mut g = box_between_fingers(Method::Conventional, DVec3::ZERO);
        for step in 0..300 {
            let x = fingers(0.002 * (step as f64 * 0.01).sin(), 0.055);
            let frame = g.step(&x, 0.001);
            assert!(frame.grasped);
            let (f1, f2) = (-frame.forces[0].x, -frame.forces[1].x); // on the object
            let fr = f1 + f2;
            let fg = f1.abs().min(f2.abs());
            let distance = x[1].x - x[0].x;
            // (4.8): x2 − x1 = l − (2 f_g + |f_r|)/k, the resultant squeezing the fingers.
            assert!(
                (distance - (WIDTH - (2.0 * fg + fr.abs()) / K)).abs() < 1e-12,
                "step {step}: {distance} vs f_g {fg}, f_r {fr}"
            );
        }
    }

    #[test]
    fn distributed_finger_distance_is_that_of_the_grip_alone_as_4_10_says() {
        // The box hangs sideways (2 m/s² along +x) between fingers 5.5 cm apart: the
        // fingers hold 2 N along x.
        let mut g = box_between_fingers(Method::Distributed, DVec3::new(2.0, 0.0, 0.0));
        let x = fingers(0.0, 0.055);
        let mut frame = g.step(&x, 0.001);
        for _ in 0..4000 {
            frame = g.step(&x, 0.001);
        }
        let (g1, g2) = (frame.grips[0], frame.grips[1]);
        let fr = frame.resultant.x;
        let distance = x[1].x - x[0].x;
        // The shell's springs: x2 − x1 = l − (g1 + g2)/k, and the grips differ only by what
        // the shares leave to the shell (γ3's pull toward small shares: under 0.1 % of the
        // resultant), so (4.10) l − 2f_g/k holds to that, where the conventional method
        // would be off by f_r/k.
        assert!((distance - (WIDTH - (g1 + g2) / K)).abs() < 1e-9);
        assert!((fr + 2.0).abs() < 0.01, "resultant {fr}");
        assert!((g1 - g2).abs() < 1e-3 * fr.abs(), "grips {g1} {g2}");
        assert!((frame.shares[1] - 2.0).abs() < 0.03, "{:?}", frame.shares);
    }

    #[test]
    fn a_held_box_hangs_on_friction_and_slips_when_the_grip_is_too_weak() {
        // g = 2 m/s² down, μ = 1: a grip of 4 N (2.5 mm squeeze) holds 2 N of weight;
        // 0.4 N (0.25 mm) cannot.
        for (gap, holds) in [(0.05, true), (0.0595, false)] {
            let mut g = box_between_fingers(Method::Distributed, DVec3::new(0.0, -2.0, 0.0));
            let x = fingers(0.0, gap);
            for _ in 0..2000 {
                g.step(&x, 0.001);
            }
            let y = g.object.position.y;
            assert_eq!(y > -0.01, holds, "gap {gap}: the box is at y = {y}");
        }
    }

    #[test]
    fn shares_never_loosen_a_grip_over_random_grasps() {
        let mut rng = Rng::new(0x9e37_79b9_7f4a_7c15);
        let mut random = move || rng.range(-1.0, 1.0);
        let mut pushed = 0;
        for _ in 0..100_000 {
            // A box of 2–10 cm edges, moving and turning, that the shell starts from: the
            // inertia spring's damper asks the fingers for a resultant at once.
            let half = DVec3::new(random(), random(), random()) * 0.02 + DVec3::splat(0.03);
            let object = Object {
                velocity: DVec3::new(random(), random(), random()),
                spin: 10.0 * DVec3::new(random(), random(), random()),
                ..Object::at_rest(2.0 * half, 1.0, DVec3::ZERO)
            };
            // Two to four fingers, the first two on opposite faces, each 0.1–3 mm inside
            // the face it presses, away from the face's edges.
            let n = 2 + ((random() + 1.0) * 1.5) as usize % 3;
            let mut fingers = [DVec3::ZERO; MAX_FINGERS];
            let mut outward = [DVec3::ZERO; MAX_FINGERS];
            for (k, (finger, normal)) in fingers.iter_mut().zip(&mut outward).take(n).enumerate() {
                let face = match k {
                    0 => 0,
                    1 => 1,
                    _ => ((random() + 1.0) * 3.0) as usize % 6,
                };
                let (axis, sign) = (face / 2, if face % 2 == 1 { 1.0 } else { -1.0 });
                *finger = 0.6 * half * DVec3::new(random(), random(), random());
                finger[axis] = sign * (half[axis] - 0.0001 - 0.0029 * (random() + 1.0) / 2.0);
                normal[axis] = sign;
            }
            let mut grasp = Grasp::new(GraspSettings::thesis(Method::Distributed));
            let frame = grasp.step(&fingers[..n], &object, 1e-3);
            assert!(frame.grasped);
            for (k, normal) in outward.iter().enumerate().take(n) {
                // Each finger presses the face it was put against (the shell turns a little).
                assert!(frame.normals[k].dot(*normal) > 0.99, "finger {k}");
                // A share only adds to the finger's push away from the surface it presses.
                // (Where the balance moved the shell's face past a finger, its spring pulls
                // it in and its grip counts as 0: nothing to compare with there.)
                assert!(frame.shares[k].is_finite() && frame.shares[k] >= 0.0);
                let along = frame.forces[k].dot(frame.normals[k]);
                assert!(
                    frame.grips[k] == 0.0 || along >= frame.grips[k] - 1e-9,
                    "finger {k}: {along} N outward against a grip of {}",
                    frame.grips[k]
                );
                pushed += usize::from(frame.shares[k] > 0.5);
            }
        }
        // The shares were put to the test: most grasps gave some finger one.
        assert!(pushed > 50_000, "{pushed} shares over 0.5 N");
    }

    #[test]
    fn random_distributions_never_give_a_negative_share() {
        let mut rng = Rng::new(0x9e37_79b9_7f4a_7c15);
        let mut random = move || rng.range(-1.0, 1.0);
        let mut d = Distribution::default();
        for _ in 0..100_000 {
            let n = 2 + ((random() + 1.0) * 2.0) as usize % 4;
            let mut presses = [Press::default(); MAX_FINGERS];
            for p in &mut presses[..n] {
                p.point = 0.05 * DVec3::new(random(), random(), random());
                p.direction = DVec3::new(random(), random(), random()).normalize_or(DVec3::X);
                p.grip = 5.0 * (random() + 1.0);
            }
            let force = 20.0 * DVec3::new(random(), random(), random());
            let torque = 0.5 * DVec3::new(random(), random(), random());
            let mut shares = [0.0; MAX_FINGERS];
            d.share(&presses[..n], force, torque, 0.1, &mut shares[..n]);
            assert!(
                shares[..n].iter().all(|s| s.is_finite() && *s >= 0.0),
                "{shares:?}"
            );
        }
    }

    #[test]
    fn shares_change_continuously_along_a_smooth_path() {
        let presses = [
            Press {
                point: DVec3::new(-0.03, 0.0, 0.0),
                direction: DVec3::X,
                grip: 2.0,
            },
            Press {
                point: DVec3::new(0.03, 0.0, 0.0),
                direction: -DVec3::X,
                grip: 2.0,
            },
            Press {
                point: DVec3::new(0.0, 0.0, 0.03),
                direction: -DVec3::Z,
                grip: 1.0,
            },
        ];
        let mut d = Distribution::default();
        let mut last = [0.0; 3];
        let step = 1e-3;
        for i in 0..=6283 {
            // The resultant turns once round in the x–z plane, 3 N strong.
            let a = i as f64 * step;
            let force = 3.0 * DVec3::new(a.cos(), 0.0, a.sin());
            let mut shares = [0.0; 3];
            d.share(&presses, force, DVec3::ZERO, 0.06, &mut shares);
            if i > 0 {
                let jump = (0..3)
                    .map(|j| (shares[j] - last[j]).abs())
                    .fold(0.0, f64::max);
                // The force moves 3 mN per step; no share may jump more than a few times that.
                assert!(jump < 0.02, "step {i}: {last:?} → {shares:?}");
            }
            last = shares;
        }
    }
}
