//! Contacts between two bodies' pieces: their intersection clipped, a point contact's or
//! a patch's spring, damper and friction, and the wrench each body gets (thesis 5.3).

use glam::DVec3;
use hapticd_core::kinematics::Wrench;

use super::{Aabb, ContactModel, Material, Pair, World};
use crate::body::Body;
use crate::contact::{damper, spring};
use crate::friction::{ContactPatch, Loading, friction};
use crate::polyhedron::Polyhedron;

/// The deepest-point contact: the overlap's lowest vertex along the normal carries a
/// spring-damper on the overlap's thickness, and Coulomb friction, fading below the slip
/// speed one step of it can take away (`slip_per_newton` per newton of friction).
fn point_contact(
    overlap: &Polyhedron,
    normal: DVec3,
    m: &Material,
    slip_per_newton: f64,
    velocity: impl Fn(DVec3) -> DVec3,
) -> Wrench {
    let along = |v: &DVec3| v.dot(normal);
    let deepest = overlap
        .vertices
        .iter()
        .copied()
        .min_by(|a, b| along(a).total_cmp(&along(b)));
    let top = overlap
        .vertices
        .iter()
        .map(along)
        .fold(f64::NEG_INFINITY, f64::max);
    let Some(point) = deepest else {
        return Wrench::default();
    };
    let v = velocity(point);
    let push = (m.stiffness * (top - along(&point)) - m.damping * v.dot(normal)).max(0.0);
    let slip = v.reject_from_normalized(normal);
    let mu = m.friction.dynamic_coefficient;
    let fade = m.friction.slip_speed.max(mu * push * slip_per_newton);
    let friction = -mu * push * slip / slip.length().max(fade);
    let force = push * normal + friction;
    Wrench {
        force,
        torque: point.cross(force),
    }
}

/// The torque on `bodies.1` that damps the rocking of two bodies on their contact `patch`
/// as the normal damper damps their approach.
///
/// The normal damper, spread evenly over the patch, damps rocking about the patch's
/// tangential axes by c·I_A (I_A: the patch's second moment), against a spring of k·I_A:
/// a damping ratio that falls with the patch's size. A tall block on a small patch, as when
/// it leans onto one edge, then rocks for seconds after a load changes, and every swing
/// asks its friction for more than the load does. This adds what brings rocking up to the
/// normal damper's own ratio of critical damping (at most critical), for bodies pivoting
/// about the patch, about the `tangents` across the normal; the normal contact's stiffness,
/// damping (as set, as stabilised) and the pair's mobility along the normal at `at` come
/// with them, and `shares` is each body's number of contacts. Applied explicitly, it takes
/// at most a quarter of the bodies' relative spin in a step, and with the normal damper's
/// own part never more than all of it.
fn rocking_damper(
    (a, b): (&Body, &Body),
    shares: (f64, f64),
    patch: &ContactPatch,
    (normal, tangents): (DVec3, [DVec3; 2]),
    at: DVec3,
    (stiffness, damping, stable_damping, normal_mobility): (f64, f64, f64, f64),
    dt: f64,
) -> DVec3 {
    // The normal damper's share of critical damping, ζ = c·A/(2√(k·A·m)).
    let ratio = (damping * patch.area * normal_mobility.sqrt()
        / (2.0 * (stiffness * patch.area).sqrt()))
    .min(1.0);
    let second_moment = patch.polar / 2.0;
    let line = patch.point_on(at, normal);
    let relative_spin = b.spin - a.spin;
    let mut torque = DVec3::ZERO;
    for t in tangents {
        let pivoting = 1.0 / a.inertia_about_line(line, t) + 1.0 / b.inertia_about_line(line, t);
        let turning = a.inverse_inertia_about(t) * shares.0 + b.inverse_inertia_about(t) * shares.1;
        if pivoting <= 0.0 || turning <= 0.0 {
            continue;
        }
        let extra =
            ratio * 2.0 * (stiffness * second_moment / pivoting).sqrt() - damping * second_moment;
        let room = (ROCKING_ROOM / (dt * turning))
            .min(1.0 / (dt * turning) - stable_damping * second_moment);
        let c = (extra / (1.0 + extra * dt * turning)).min(room);
        if c > 0.0 {
            torque -= c * relative_spin.dot(t) * t;
        }
    }
    torque
}

/// The damping `c` over `area` that implicit Euler applies in `dt` to a pair of `inverse_mass`.
fn stable(c: f64, area: f64, inverse_mass: f64, dt: f64) -> f64 {
    // An explicit damper of c over a step overshoots once c·dt/m nears 2 (a fast impact
    // bounces off harder than it came). Damping c/(1 + c·dt/m) is what implicit Euler
    // applies to the pair's relative motion: it can at most stop that motion in one step. m
    // is the pair's effective mass at the contact, along the damped direction, turning
    // included.
    c / (1.0 + c * area * dt * inverse_mass)
}

/// The largest share of a body's spin the rocking damper may take away in one step.
const ROCKING_ROOM: f64 = 0.25;

/// How far (radians) two bodies may turn relative to each other before their contact normal
/// is searched for again: it is found again to within this.
const NORMAL_TURN: f64 = 1e-4;
/// How far (in sizes of their overlap) two bodies may move relative to each other before
/// their contact normal is searched for again.
const NORMAL_SHIFT: f64 = 1e-2;

/// Largest one-step phase ω·dt of a contact's friction springs.
const FRICTION_PHASE: f64 = 0.5;

impl World {
    /// Add the contact wrenches between bodies `i` < `j`, whose boxes overlap, for a step
    /// of `dt`: between each piece of one and each piece of the other. Whether they touch.
    pub(super) fn collide(&mut self, i: usize, j: usize, dt: f64) -> bool {
        let (a, b) = (&self.bodies[i], &self.bodies[j]);
        let guided = |k: usize, other: &Body| self.guided == Some(k) && other.fixed;
        if (a.fixed && b.fixed && !a.kinematic && !b.kinematic)
            || guided(i, b)
            || guided(j, a)
            || self.ignored_pairs.contains(&(i, j))
            || self.joined(i, j)
        {
            return false;
        }
        let mut touched = false;
        let single = a.pieces.len() == 1 && b.pieces.len() == 1;
        for ka in 0..a.pieces.len() {
            for kb in 0..self.bodies[j].pieces.len() {
                let (a, b) = (&self.bodies[i], &self.bodies[j]);
                // Single pieces are their bodies, whose boxes were just found to overlap.
                if single
                    || Aabb::around(&a.world_pieces()[ka..=ka])
                        .overlaps(&Aabb::around(&b.world_pieces()[kb..=kb]))
                {
                    touched |= self.collide_pieces((i, ka), (j, kb), dt);
                }
            }
        }
        touched
    }

    /// Add the contact wrenches between piece `ka` of body `i` and piece `kb` of body `j`;
    /// whether they touch.
    fn collide_pieces(
        &mut self,
        (i, ka): (usize, usize),
        (j, kb): (usize, usize),
        dt: f64,
    ) -> bool {
        let pieces = self.first_piece[self.bodies.len()];
        let pair = (self.first_piece[i] + ka) * pieces + self.first_piece[j] + kb;
        if self.pairs[pair].touched + 1 != self.steps {
            // A new contact: no previous normal or force, friction springs not yet attached.
            self.pairs[pair] = Pair::default();
        }
        self.clip_pieces((i, ka), (j, kb));
        if self.overlap.faces.is_empty() {
            return false;
        }
        self.pairs[pair].touched = self.steps;
        self.counting[i] += 1;
        self.counting[j] += 1;
        let normal = self.normal((i, ka), (j, kb), pair);
        let (a, b) = (&self.bodies[i], &self.bodies[j]);
        // Forces on j, pushing it away from i along the normal.
        let (mut m, at) = (self.material, self.overlap_centre());
        self.pair_friction(&mut m, i, j);
        let inverse_mass = |d: DVec3| a.inverse_mass_at(at, d) + b.inverse_mass_at(at, d);
        let normal_mobility = inverse_mass(normal);
        let (t1, t2) = normal.any_orthonormal_pair();
        let tangent_mobility = inverse_mass(t1).max(inverse_mass(t2));
        let mobility = (normal_mobility, tangent_mobility);
        if m.model == ContactModel::Point {
            let on_j = self.point_wrench((i, j), normal, m, mobility, dt);
            self.apply(i, j, on_j);
            return true;
        }
        let on_j = self.patch_wrench((i, j, pair), (normal, [t1, t2]), m, at, mobility, dt);
        self.pairs[pair].force = on_j.force;
        self.apply(i, j, on_j);
        true
    }

    /// Clip piece `ka` of body `i` and piece `kb` of body `j` into the overlap.
    fn clip_pieces(&mut self, (i, ka): (usize, usize), (j, kb): (usize, usize)) {
        let (piece_a, piece_b) = (
            &self.bodies[i].world_pieces()[ka],
            &self.bodies[j].world_pieces()[kb],
        );
        // The same overlap either way; cutting the smaller piece by the larger's planes takes
        // fewer cuts (a block on a table: the table's top face alone, not the block's four
        // sides and bottom).
        let span = |p: &Polyhedron| {
            let around = Aabb::around(std::slice::from_ref(p));
            (around.max - around.min).length_squared()
        };
        if span(piece_a) <= span(piece_b) {
            self.clipper.intersect(piece_a, piece_b, &mut self.overlap);
        } else {
            self.clipper.intersect(piece_b, piece_a, &mut self.overlap);
        }
    }

    /// The point model's wrench on body `j` from body `i`, with material `m` and `mobility`.
    fn point_wrench(
        &self,
        (i, j): (usize, usize),
        normal: DVec3,
        mut m: Material,
        mobility: (f64, f64),
        dt: f64,
    ) -> Wrench {
        let (normal_mobility, tangent_mobility) = mobility;
        let (a, b) = (&self.bodies[i], &self.bodies[j]);
        if let Some(scaling) = m.scaling {
            scaling.apply(&mut m, 1.0, mobility, dt);
        }
        m.damping = stable(m.damping, 1.0, normal_mobility, dt);
        let slip_per_newton = dt * tangent_mobility;
        point_contact(&self.overlap, normal, &m, slip_per_newton, |x| {
            b.velocity_at(x) - a.velocity_at(x)
        })
    }

    /// The patch model's wrench on body `j` from body `i`: spring, dampers and friction.
    fn patch_wrench(
        &mut self,
        (i, j, pair): (usize, usize, usize),
        (normal, [t1, t2]): (DVec3, [DVec3; 2]),
        mut m: Material,
        at: DVec3,
        mobility: (f64, f64),
        dt: f64,
    ) -> Wrench {
        let (normal_mobility, tangent_mobility) = mobility;
        let (a, b) = (&self.bodies[i], &self.bodies[j]);
        // A body between several contacts (a block in a stack) takes every one's damper
        // in the same step: each may stop only its share of the motion, or together they
        // overshoot and the stack rings from step to step.
        let shares = |k: usize| f64::from(self.contacts[k].max(1));
        let damped_mobility =
            |d: DVec3| a.inverse_mass_at(at, d) * shares(i) + b.inverse_mass_at(at, d) * shares(j);
        let patch = ContactPatch::of(&self.overlap, normal);
        if let Some(scaling) = m.scaling {
            scaling.apply(&mut m, patch.area, mobility, dt);
        }
        let raw_damping = m.damping;
        m.damping = stable(m.damping, patch.area, damped_mobility(normal), dt);
        let rocking = rocking_damper(
            (a, b),
            (shares(i), shares(j)),
            &patch,
            (normal, [t1, t2]),
            at,
            (m.stiffness, raw_damping, m.damping, normal_mobility),
            dt,
        );
        let tangent_shared = damped_mobility(t1).max(damped_mobility(t2));
        m.friction.damping = stable(m.friction.damping, patch.area, tangent_shared, dt);
        // A friction spring stiffer than the step allows (explicitly integrated, with the
        // bodies' turning at the contact and their other contacts) rings between sticking
        // and slipping for ever: hold its one-step phase ω·dt to what the integrator takes
        // with room.
        let stiffest = FRICTION_PHASE.powi(2) / (tangent_shared * dt * dt * patch.area);
        m.friction.stiffness = m.friction.stiffness.min(stiffest);
        // The spring's force is k_N·V whichever point of the contact's normal line it is
        // taken from.
        let push = spring(&self.overlap, at, normal, m.stiffness);
        // Sliding friction must fade out over more than the speed one step of it
        // takes away, or it reverses the slide every step instead of stopping it.
        let kick = m.friction.dynamic_coefficient * push.force.dot(normal) * dt;
        m.friction.slip_speed = m.friction.slip_speed.max(kick * tangent_mobility);
        let mut resist = damper(&self.overlap, normal, m.damping, |x| {
            a.velocity_at(x) - b.velocity_at(x)
        });
        // The damper may slow a separation but never pull the bodies together.
        let (pushing, resisting) = (push.force.dot(normal), resist.force.dot(normal));
        if pushing + resisting < 0.0 {
            let keep = -pushing / resisting;
            resist = Wrench {
                force: keep * resist.force,
                torque: keep * resist.torque,
            };
        }
        let loading = self.loading(i, j, pair, normal);
        push + resist
            + Wrench {
                force: DVec3::ZERO,
                torque: rocking,
            }
            + friction(
                &mut self.pairs[pair].friction,
                &self.overlap,
                &patch,
                normal,
                (push.force + resist.force).dot(normal),
                m.stiffness,
                &m.friction,
                |x| b.velocity_at(x) - a.velocity_at(x),
                b.spin - a.spin,
                loading.as_ref(),
                dt,
            )
    }

    /// The contact normal between piece `ka` of body `i` and piece `kb` of body `j`, whose
    /// overlap has just been found, for their `pair`. The normal of the last step, carried
    /// along by body i, serves again while body j has moved less than a tolerance relative
    /// to i since it was searched for: at rest the search of 5.3.2 would find it again.
    fn normal(&mut self, (i, ka): (usize, usize), (j, kb): (usize, usize), pair: usize) -> DVec3 {
        let (bi, bj) = (&self.bodies[i], &self.bodies[j]);
        let turn = bi.orientation.inverse() * bj.orientation;
        let shift = bi.orientation.inverse() * (bj.position - bi.position);
        let (found_turn, found_shift, found_normal) = self.pairs[pair].found;
        let previous = self.pairs[pair].normal;
        let size = {
            let around = Aabb::around(std::slice::from_ref(&self.overlap));
            (around.max - around.min).length()
        };
        let still = previous != DVec3::ZERO
            && turn.dot(found_turn).abs() > (NORMAL_TURN / 2.0).cos()
            && (shift - found_shift).length() < NORMAL_SHIFT * size;
        let normal = if still {
            bi.orientation * found_normal
        } else {
            let (piece_a, piece_b) = (&bi.world_pieces()[ka], &bj.world_pieces()[kb]);
            let normal = self
                .separation_normal(piece_a, piece_b, previous, size)
                .unwrap_or_else(|| self.contact_normal(piece_b));
            self.pairs[pair].found = (turn, shift, bi.orientation.inverse() * normal);
            normal
        };
        self.pairs[pair].normal = normal;
        normal
    }

    /// What the rest of the world asks of the contact `pair` between bodies `i` and `j`
    /// across `normal`: what else acted on each at the last step, as the force it would
    /// take to hold their centroids' accelerations together. None when the contact cannot
    /// move either body.
    fn loading(&self, i: usize, j: usize, pair: usize, normal: DVec3) -> Option<Loading> {
        let (a, b) = (&self.bodies[i], &self.bodies[j]);
        let inverse = |body: &Body| if body.fixed { 0.0 } else { 1.0 / body.mass };
        let movable = inverse(a) + inverse(b);
        (movable > 0.0).then(|| {
            let contact = self.pairs[pair].force;
            let apart =
                (self.forces[j] - contact) * inverse(b) - (self.forces[i] + contact) * inverse(a);
            let asked = apart / movable;
            Loading {
                load: asked.reject_from_normalized(normal),
                pressing: -asked.dot(normal),
                turning: 1.0 / (a.inverse_inertia_about(normal) + b.inverse_inertia_about(normal)),
            }
        })
    }

    /// Add the contact wrench `on_j` to body `j` and its reaction to body `i`.
    fn apply(&mut self, i: usize, j: usize, on_j: Wrench) {
        self.wrenches[j] = self.wrenches[j] + on_j;
        self.wrenches[i] = self.wrenches[i]
            + Wrench {
                force: -on_j.force,
                torque: -on_j.torque,
            };
    }
}
