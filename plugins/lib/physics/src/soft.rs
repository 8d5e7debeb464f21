//! [rt] Soft bodies in a penalty world (issue: soft bodies, thesis 7.2), stepped once a
//! device tick: each keeps its solve's buffers and its obstacles' planes, changed in place,
//! so a tick allocates nothing. Its nodes are kept out of every rigid body: what it presses
//! on a pointer placed at its grip with is felt there, and what it presses on a body that
//! moves (a coupled pointer's too) pushes that body over the next tick.

use glam::DVec3;
use hapticd_core::kinematics::{Wrench, quat_to_wxyz};
use hapticd_core::scene::control::{MOST_DAMPING, POISSON_RANGE, YOUNG_RANGE};
use hapticd_mesh::triangle::nearest_weights;
use hapticd_plugin_api::{
    HAPTICD_COMMAND_IMPULSE, HAPTICD_COMMAND_IMPULSE_AT_CENTRE, HAPTICD_COMMAND_PIN,
    HAPTICD_COMMAND_QUERY, HAPTICD_COMMAND_RELEASE, HAPTICD_COMMAND_SET_FORCE,
    HAPTICD_COMMAND_SET_FRICTION, HAPTICD_COMMAND_SET_MATERIAL, HAPTICD_COMMAND_SET_VELOCITY,
    HapticdBodyState, HapticdSceneCommand,
};
use hapticd_soft::body::SoftBody;
use hapticd_soft::contact::{Friction, Obstacle, Obstacles, Touch};
use hapticd_soft::implicit::{Solve, Solver, Stepped};

use crate::body::Body;
use crate::soft_factoring::{Aside, Factoring};

/// The device tick a soft body's solve is factored for (1 kHz), s: other ticks are solved
/// with each node's own diagonal, more slowly.
pub const SOFT_TICK: f64 = 0.001;

/// A tick's solve: done with every node's velocity within 0.1 mm/s (its position within
/// 0.1 µm of the tick's solution), in at most 20 iterations.
const TICK: Solve = Solve {
    budget: 20,
    tolerance: 1e-4,
};

/// The point of a soft body's surface nearest a point, as it stands now.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    /// How far it is, metres.
    pub distance: f64,
    /// The point.
    pub point: DVec3,
    /// Its triangle's outward unit normal.
    pub normal: DVec3,
    /// Its triangle's nodes, and how much of the point each is.
    pub weights: [(usize, f64); 3],
    /// How fast it moves, m/s.
    pub velocity: DVec3,
}

/// Steps a compliance is answered from the last solve for the same point, at most.
pub const GIVE_KEPT: usize = 30;

/// How far a normal may turn before the compliance along it is asked anew, radians.
const GIVE_TURN: f64 = 0.01;

/// A compliance answered: where and along what, for steps of what length, and how many
/// steps ago.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Given {
    weights: [(usize, f64); 3],
    normal: DVec3,
    dt: f64,
    compliance: f64,
    age: usize,
}

/// Nodes of a soft body held to a moving rigid body, which they pull on.
#[derive(Debug, Clone, PartialEq)]
pub struct Attachment {
    /// The rigid body, by its place in the world.
    pub body: usize,
    /// Each held node and where it stands in the body's frame, from its centre of mass, m.
    pub nodes: Vec<(usize, DVec3)>,
    /// What the held nodes gave the body over the last tick, as a mean force and torque
    /// about its centre of mass: what pushes it over the next.
    pub pull: Wrench,
}

/// The load that moves rigid body `body` over a tick as it would move with the soft nodes
/// that pressed on it: its own load `own` and the soft bodies' `push` over that tick,
/// `(added, turning)` what they moved and turned along with it ([`Touch::inertia`],
/// [`Touch::turning`]), under `gravity`.
///
/// The push comes a tick late, given for the body's motion of the last tick. Nodes that
/// outweigh the body would throw it back harder each tick (the push answers its change of
/// velocity with their inertia): so the body's whole imbalance, its weight included, moves
/// it as though they moved with it, (own + push + m·g)·m/(m + added) − m·g, and its torque
/// turns it as though they turned with it, shared likewise with its moment about the push's
/// torque; a steady push is left as it is. Pushed as given, a slab of 3.6 g on a soft block
/// shook at 1 cm/s and stood 6 % too high; so moved, it rested. A scene keeps such bodies
/// heavy enough besides (see `scene::soft::rests_on`): the nodes' stiffness is pushed a
/// tick late all the same.
pub fn pushed_load(
    own: Wrench,
    push: Wrench,
    (added, turning): (f64, f64),
    body: &Body,
    gravity: DVec3,
) -> Wrench {
    if added <= 0.0 {
        return own + push;
    }
    let weight = gravity * body.mass;
    let torque = own.torque + push.torque;
    let share = match push.torque.try_normalize() {
        Some(axis) => {
            let local = body.orientation.inverse() * axis;
            let moment = local.dot(body.inertia * local);
            moment / (moment + turning)
        }
        None => 1.0,
    };
    Wrench {
        force: (own.force + push.force + weight) * (body.mass / (body.mass + added)) - weight,
        torque: torque * share,
    }
}

/// [rt] What the solids `touches` (one per piece of each of the world bodies `touching`, in
/// turn) were pressed with over the last tick, taken together by body.
fn touches_by_body<'a>(
    touching: &'a [usize],
    touches: &'a [Touch],
    bodies: &'a [Body],
) -> impl Iterator<Item = (usize, Touch)> + 'a {
    let mut solid = 0;
    touching.iter().map(move |&i| {
        let pieces = bodies[i].pieces.len();
        let on = touches[solid..solid + pieces].iter().copied().sum();
        solid += pieces;
        (i, on)
    })
}

/// A soft body of a scene, ready to step.
#[derive(Debug, Clone)]
pub struct SoftPart {
    /// Its name in the scene.
    pub name: String,
    /// The body.
    pub body: SoftBody,
    solver: Solver,
    /// The world bodies it may not enter: every one, the pointers last.
    touching: Vec<usize>,
    /// What it pressed on each of them with over the last tick (a mean force, and torque
    /// about its centre of mass), where it moves on its own, and what the tick moved along
    /// with it ([`Touch::inertia`], kg): nothing for the fixed ones and the pointers placed
    /// at their grips.
    pushes: Vec<(Wrench, (f64, f64))>,
    planes: Vec<(DVec3, f64)>,
    solids: Vec<Obstacle>,
    touches: Vec<Touch>,
    /// The friction its nodes hold on the solids they touch with.
    pub friction: Friction,
    /// A force pushing it besides gravity, N, spread over its nodes by their mass.
    pub load: DVec3,
    /// What its last tick's solve did.
    pub stepped: Stepped,
    /// The last compliances answered (one for each finger on it, up to four).
    given: [Option<Given>; 4],
    /// Whether its material or pins changed since its solve was factored.
    changed: bool,
    /// Its nodes held to a moving rigid body, if any.
    pub attached: Option<Attachment>,
    /// Its helper thread factoring its rest system anew after a change, in a penalty scene.
    factoring: Aside,
}

impl SoftPart {
    /// `body` called `name`, solved by `solver`, in a world of `bodies` whose pointers
    /// start at `first_pointer`, touching them with `friction` (the moving ones where
    /// `moving`, see [`SoftPart::meet`]): its obstacles sized.
    pub fn new(
        name: String,
        (body, solver): (SoftBody, Solver),
        (bodies, first_pointer, moving): (&[Body], usize, bool),
        friction: Friction,
    ) -> SoftPart {
        let mut part = SoftPart {
            name,
            body,
            solver,
            touching: Vec::new(),
            pushes: Vec::new(),
            planes: Vec::new(),
            solids: Vec::new(),
            touches: Vec::new(),
            friction,
            load: DVec3::ZERO,
            stepped: Stepped {
                iterations: 0,
                residual: 0.0,
            },
            given: [None; 4],
            changed: false,
            attached: None,
            factoring: Aside::default(),
        };
        part.meet(bodies, first_pointer, moving);
        part
    }

    /// Touch `bodies` from now on, the fixed ones and the pointers (from `first_pointer`),
    /// and where `moving` the others too (a world that keeps them where they are): its
    /// obstacles sized for them.
    pub fn meet(&mut self, bodies: &[Body], first_pointer: usize, moving: bool) {
        self.touching = (0..bodies.len())
            .filter(|&i| moving || i >= first_pointer || bodies[i].fixed)
            .collect();
        self.pushes = vec![(Wrench::default(), (0.0, 0.0)); self.touching.len()];
        self.solids.clear();
        let mut faces = 0;
        for &i in &self.touching {
            for piece in &bodies[i].pieces {
                self.solids.push(Obstacle {
                    faces: (faces, piece.planes.len()),
                    ..Obstacle::default()
                });
                faces += piece.planes.len();
            }
        }
        self.planes = vec![(DVec3::ZERO, 0.0); faces];
        self.touches = vec![Touch::default(); self.solids.len()];
    }

    /// [rt] Step `dt` under `gravity` against `bodies` where the tick leaves them; each pointer
    /// (from `first_pointer`) gets what the body pressed on it with added to `felt`.
    pub fn step(
        &mut self,
        dt: f64,
        gravity: DVec3,
        bodies: &[Body],
        first_pointer: usize,
        felt: &mut [Wrench],
    ) {
        let mut solid = 0;
        for &i in &self.touching {
            let b = &bodies[i];
            for piece in b.world_pieces() {
                let o = &mut self.solids[solid];
                let (first, count) = o.faces;
                for (out, plane) in self.planes[first..first + count]
                    .iter_mut()
                    .zip(&piece.planes)
                {
                    *out = (plane.normal, plane.offset);
                }
                (o.centre, o.velocity, o.spin) = (b.position, b.velocity, b.spin);
                solid += 1;
            }
        }
        let obstacles = Obstacles {
            planes: &self.planes,
            solids: &self.solids,
            friction: self.friction,
        };
        if self.load != DVec3::ZERO {
            let share = self.load / self.body.mass();
            for (f, m) in self.body.forces.iter_mut().zip(&self.body.masses) {
                *f += share * *m;
            }
        }
        for g in &mut self.given {
            *g = g.filter(|g| g.age < GIVE_KEPT).map(|g| Given {
                age: g.age + 1,
                ..g
            });
        }
        if let Some(f) = self.factoring.0.as_mut() {
            f.take(&mut self.solver);
            let stiff = self.body.material.step_factor(dt);
            if self.changed && f.ask(&self.body, stiff) {
                self.changed = false;
            }
        }
        if let Some(a) = &self.attached {
            // Its held nodes go where the body's motion over the tick has taken them.
            let b = &bodies[a.body];
            for &(n, at) in &a.nodes {
                let target = b.position + b.orientation * at;
                self.body.pin_velocities[n] = (target - self.body.positions[n]) / dt;
            }
        }
        self.stepped = self.body.step(
            dt,
            gravity,
            obstacles,
            &mut self.touches,
            TICK,
            &mut self.solver,
        );
        if let Some(a) = &mut self.attached {
            let centre = bodies[a.body].position;
            a.pull = Wrench::default();
            for &(n, _) in &a.nodes {
                let push = self.body.reactions[n] / dt;
                a.pull.force += push;
                a.pull.torque += (self.body.positions[n] - centre).cross(push);
            }
        }
        let touched = touches_by_body(&self.touching, &self.touches, bodies);
        for ((i, on), push) in touched.zip(&mut self.pushes) {
            *push = (Wrench::default(), (0.0, 0.0));
            let b = &bodies[i];
            let touch = Wrench {
                force: on.force,
                torque: on.torque,
            };
            if b.kinematic {
                if let Some(out) = i.checked_sub(first_pointer).and_then(|k| felt.get_mut(k)) {
                    *out = *out + touch;
                }
            } else if !b.fixed {
                *push = (touch, (on.inertia, on.turning));
            }
        }
    }

    /// [rt] What it pressed on each moving world body with over the last tick, and what
    /// that tick moved and turned along with the body, kg and kg·m²: see
    /// [`Touch::inertia`] and [`pushed_load`].
    pub fn pushes(&self) -> impl Iterator<Item = (usize, Wrench, (f64, f64))> + '_ {
        self.touching
            .iter()
            .zip(&self.pushes)
            .filter(|(_, (_, (inertia, _)))| *inertia > 0.0)
            .map(|(&i, &(push, inertia))| (i, push, inertia))
    }

    /// [rt] What it pressed on world body `i` with over the last tick, if anything: the
    /// force, N, and where its nodes pressed (weighed by their push).
    pub fn pressed_on(&self, i: usize, bodies: &[Body]) -> Option<(DVec3, DVec3)> {
        let (_, on) =
            touches_by_body(&self.touching, &self.touches, bodies).find(|&(j, _)| j == i)?;
        Some((on.force, on.point()?))
    }

    /// [physics] The point of its surface nearest `x`, if it has a surface.
    pub fn nearest(&self, x: DVec3) -> Option<Nearest> {
        let (positions, velocities) = (&self.body.positions, &self.body.velocities);
        let mut best: Option<Nearest> = None;
        for t in &self.body.mesh.surface {
            let nodes = t.map(|n| n as usize);
            let corners = nodes.map(|n| positions[n]);
            let w = nearest_weights(x, corners);
            let point = corners[0] * w[0] + corners[1] * w[1] + corners[2] * w[2];
            let distance = point.distance(x);
            if best.is_some_and(|b| b.distance <= distance) {
                continue;
            }
            let Some(normal) = (corners[1] - corners[0])
                .cross(corners[2] - corners[0])
                .try_normalize()
            else {
                continue;
            };
            best = Some(Nearest {
                distance,
                point,
                normal,
                weights: [0, 1, 2].map(|k| (nodes[k], w[k])),
                velocity: (0..3).map(|k| velocities[nodes[k]] * w[k]).sum(),
            });
        }
        best
    }

    /// [physics] Push it with `force`, N, at its surface's point nearest `at`, over its next
    /// step (shared among that triangle's nodes).
    pub fn push(&mut self, at: DVec3, force: DVec3) {
        if let Some(near) = self.nearest(at) {
            for (node, w) in near.weights {
                self.body.forces[node] += force * w;
            }
        }
    }

    /// [physics] How far a step of `dt` moves the surface at `weights` (a triangle's
    /// nodes) along `normal` for each newton pressed on it there, m/N
    /// ([`SoftBody::compliance`]). It changes as slowly as the body turns: a finger held on
    /// one spot is answered from the last time it was asked there (each answer costs a
    /// solve through the factored system, most of a large body's step), asked anew once the
    /// point, the normal or [`GIVE_KEPT`] steps have passed.
    pub fn compliance(
        &mut self,
        dt: f64,
        weights: &[(usize, f64); 3],
        normal: DVec3,
    ) -> Option<f64> {
        let same = |g: &Given| {
            g.weights
                .iter()
                .zip(weights)
                .all(|(a, b)| a.0 == b.0 && (a.1 - b.1).abs() < 0.02)
                && g.normal.dot(normal) > GIVE_TURN.cos()
                && g.dt == dt
        };
        if let Some(g) = self.given.iter().flatten().find(|g| same(g)) {
            return Some(g.compliance);
        }
        let compliance = self
            .body
            .compliance(&mut self.solver, dt, weights, normal)?;
        // In the place of the oldest.
        let slot = (0..self.given.len())
            .max_by_key(|&k| self.given[k].map_or(usize::MAX, |g| g.age))
            .unwrap_or(0);
        self.given[slot] = Some(Given {
            weights: *weights,
            normal,
            dt,
            compliance,
            age: 0,
        });
        Some(compliance)
    }

    /// Its state now, taken whole: its orientation the turn of its rest shape that best
    /// fits it.
    pub fn state(&self) -> HapticdBodyState {
        let body = &self.body;
        HapticdBodyState {
            position: body.centre().to_array(),
            orientation: quat_to_wxyz(body.turn()),
            velocity: body.velocity().to_array(),
            spin: body.spin().to_array(),
            mass: body.mass(),
            friction: self.friction.slide,
            force: self.load.to_array(),
        }
    }

    /// Carry out `command` (checked finite) on it taken whole, as on a rigid body, or on its
    /// material and held nodes: None for what it cannot take (moving it to a pose or
    /// changing its mass, which would take its solve made anew; a material out of range).
    /// A new material or new pins leave its factored rest system behind: its solve goes on
    /// through it as far as it fits, until its helper ([`SoftPart::factor_aside`]) or
    /// [`SoftPart::refactor`], where the stepping thread may take the time, makes it anew.
    pub fn apply(&mut self, command: &HapticdSceneCommand) -> Option<()> {
        let (body, vector) = (&mut self.body, DVec3::from(command.vector));
        match command.kind {
            HAPTICD_COMMAND_QUERY => {}
            HAPTICD_COMMAND_SET_VELOCITY => body.set_motion(vector, DVec3::from(command.spin)),
            HAPTICD_COMMAND_IMPULSE => body.give_impulse(vector, DVec3::from(command.position)),
            HAPTICD_COMMAND_IMPULSE_AT_CENTRE => {
                let centre = body.centre();
                body.give_impulse(vector, centre);
            }
            HAPTICD_COMMAND_SET_FORCE => self.load = vector,
            HAPTICD_COMMAND_SET_FRICTION if command.value >= 0.0 => {
                // The static coefficient keeps its ratio to the dynamic one.
                let Friction { stick, slide } = self.friction;
                let ratio = if slide > 0.0 { stick / slide } else { 1.0 };
                self.friction = Friction {
                    stick: command.value * ratio,
                    slide: command.value,
                };
            }
            HAPTICD_COMMAND_SET_MATERIAL => {
                let [young, poisson, damping] = command.vector;
                let fits = |(least, most): (f64, f64), value: f64| (least..=most).contains(&value);
                if !(fits(YOUNG_RANGE, young)
                    && fits(POISSON_RANGE, poisson)
                    && fits((0.0, MOST_DAMPING), damping))
                {
                    return None;
                }
                body.set_material(young, poisson, damping);
                self.changed = true;
            }
            HAPTICD_COMMAND_PIN | HAPTICD_COMMAND_RELEASE => {
                let held = command.kind == HAPTICD_COMMAND_PIN;
                self.changed |= body.pin_where(vector, command.value, held) > 0;
            }
            _ => return None,
        }
        Some(())
    }

    /// Whether its solve is preconditioned by a factor of its material and pins as they
    /// are, for steps of `dt`.
    pub fn factored_for(&self, dt: f64) -> bool {
        self.solver.factored_for(&self.body, dt)
    }

    /// From now on, factor its rest system anew on a helper thread after its material or
    /// pins change, the new factor taken in by a later step (for a device tick, which may
    /// not take the time); without a thread, it is solved as far as its factor fits.
    pub fn factor_aside(&mut self) {
        self.factoring = Aside(Factoring::start(&self.name, &self.body));
    }

    /// Make its solve's factored rest system anew if its material or pins changed since it
    /// was made, for steps of `dt` (allocates, and takes a while for a large body: for a
    /// physics thread, not a device tick). A body that cannot be factored (none can that
    /// its scene took) keeps its solve's buffers and is solved by its nodes' diagonals.
    pub fn refactor(&mut self, dt: f64) {
        if std::mem::take(&mut self.changed) {
            if let Ok(solver) = Solver::factored(&self.body, dt) {
                self.solver = solver;
            }
            self.given = [None; 4];
        }
    }

    /// The corners of its surface's triangles where the nodes stand now, triangle by
    /// triangle (turned outward).
    pub fn corners(&self) -> impl Iterator<Item = DVec3> + '_ {
        let positions = &self.body.positions;
        self.body
            .mesh
            .surface
            .iter()
            .flat_map(move |t| t.map(|n| positions[n as usize]))
    }

    /// Whether every node is where a finite number puts it.
    pub fn is_finite(&self) -> bool {
        self.body.positions.iter().all(|p| p.is_finite())
    }
}
