//! Stepping a soft body: backward Euler on its co-rotated linear elasticity. With each
//! element's turn held over the step, the nodes' forces are linear in their positions,
//! f(x) = −K_R·(x − x_rest turned), so the step's new velocities solve
//!
//! (M + (β·dt + dt²)·K_R)·v⁺ = M·v + dt·(f(x) + f_ext),
//!
//! β the material's damping, by conjugate gradients warm-started from the last velocities,
//! preconditioned by the rest system factored once ([`Factor`]) or else by each node's own
//! stiffness; pinned nodes stay still. No step is too long for it: the solve damps what it
//! cannot follow.

use glam::{DMat3, DQuat, DVec3};

use crate::body::{SoftBody, gradient_at};
use crate::capacitance::Capacitance;
use crate::contact::{Friction, Held, Obstacles, Touch};
use crate::element::{MOST_NODES, Order};
use crate::factor::{Factor, FactorError};

/// How a step's linear solve ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solve {
    /// The most conjugate-gradient iterations (the time a tick can give it).
    pub budget: usize,
    /// How far off any node's new velocity may be left, m/s (its residual over its own
    /// diagonal): done there.
    pub tolerance: f64,
}

/// What a step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stepped {
    /// Conjugate-gradient iterations taken.
    pub iterations: usize,
    /// How far off the new velocities may be left at most, m/s.
    pub residual: f64,
}

/// Turns toward each element's rotation a step makes, warm-started from the last.
const TURNS_PER_STEP: usize = 2;

/// A step's first turn smaller than this (rad) is its last: what is left of the element's
/// rotation is of the order of the turn times its strain, and the next step turns on from
/// there. At the device rate nearly every element turns less in a tick, and a tick of 2 058
/// tetrahedra took 363 µs where two turns took 473 µs at the fastest (the turns were a
/// third of it); a physics step of 1/60 s still takes both where its elements turn.
const SETTLED_TURN: f64 = 1e-3;

/// How far a node may stand off a face it pressed on last step and still be held to it, or
/// stand inside one it did not and be let be, m: the rounding of taking it to the face.
const SLACK: f64 = 1e-9;

/// How slowly a node that comes onto a face may slip along it and stick, m/s.
const STICKING: f64 = 1e-3;

/// Solves a step may take, letting go after each the nodes that would pull on their faces.
const RELEASES: usize = 3;

/// A step long enough that inertia is nothing beside stiffness: a static solve, s.
const SETTLING_STEP: f64 = 1e3;

/// The buffers of a step's solve, made once, and its preconditioner: a step allocates
/// nothing.
#[derive(Debug, Clone)]
pub struct Solver {
    /// The rest system factored for the steps it is made for; each node's own diagonal
    /// otherwise.
    factor: Option<Factor>,
    /// Its answer corrected for the held nodes, where it is factored.
    capacitance: Option<Capacitance>,
    /// Each node's turn: the mean of its elements' (the factored rest system is turned by
    /// them, so elements that turned a long way still find it near their own).
    node_turns: Vec<DQuat>,
    sums: Vec<DQuat>,
    /// The residual turned back into the rest frame.
    turned: Vec<DVec3>,
    /// The nodes held on obstacles this step.
    held: Vec<Held>,
    /// Each held node's friction in the last solve, while its nodes are let go or turned.
    applied: Vec<(usize, DVec3)>,
    /// Whether each node is among them.
    holding: Vec<bool>,
    /// Whether each node pressed on an obstacle last step.
    pressing: Vec<bool>,
    /// The friction on each node that slid last step (zero for one that did not): it
    /// starts the step sliding under it.
    sliding: Vec<DVec3>,
    /// Whether each node ended last step in friction's kinetic regime ([`Held::kinetic`]).
    kinetic: Vec<bool>,
    /// The velocities the step started from, whose momentum it carries.
    before: Vec<DVec3>,
    residual: Vec<DVec3>,
    preconditioned: Vec<DVec3>,
    direction: Vec<DVec3>,
    product: Vec<DVec3>,
}

impl Solver {
    /// Buffers for a body of `nodes` nodes, preconditioned by each node's own diagonal.
    pub fn new(nodes: usize) -> Solver {
        Solver {
            factor: None,
            capacitance: None,
            node_turns: vec![DQuat::IDENTITY; nodes],
            sums: vec![DQuat::IDENTITY; nodes],
            turned: vec![DVec3::ZERO; nodes],
            held: Vec::with_capacity(nodes),
            applied: Vec::with_capacity(nodes),
            holding: vec![false; nodes],
            pressing: vec![false; nodes],
            sliding: vec![DVec3::ZERO; nodes],
            kinetic: vec![false; nodes],
            before: vec![DVec3::ZERO; nodes],
            residual: vec![DVec3::ZERO; nodes],
            preconditioned: vec![DVec3::ZERO; nodes],
            direction: vec![DVec3::ZERO; nodes],
            product: vec![DVec3::ZERO; nodes],
        }
    }
}

impl Solver {
    /// Buffers for `body` to [`SoftBody::settle`] it, preconditioned by its rest system
    /// factored for that.
    pub fn settling(body: &SoftBody) -> Result<Solver, FactorError> {
        Solver::factored(body, SETTLING_STEP)
    }

    /// Buffers for `body`, preconditioned by its rest system factored for steps of `dt`:
    /// made outside the tick (it allocates and orders), once a body's pins are set.
    pub fn factored(body: &SoftBody, dt: f64) -> Result<Solver, FactorError> {
        Ok(Solver {
            factor: Some(Factor::new(body, body.material.step_factor(dt))?),
            capacitance: Some(Capacitance::new(body.positions.len())),
            ..Solver::new(body.positions.len())
        })
    }

    /// Whether it is preconditioned by a factor made of `body`'s material and pins for
    /// steps of `dt`.
    pub fn factored_for(&self, body: &SoftBody, dt: f64) -> bool {
        let stiff = body.material.step_factor(dt);
        self.factor.as_ref().is_some_and(|f| {
            f.made_for(body, stiff) && (0..body.pinned.len()).all(|i| f.holds(i) != body.pinned[i])
        })
    }

    /// Precondition with `factor` from now on; the factor it had before, if any (to be let
    /// go where freeing memory may take the time).
    pub fn swap_factor(&mut self, factor: Factor) -> Option<Factor> {
        if let Some(c) = &mut self.capacitance {
            c.forget();
        }
        self.factor.replace(factor)
    }
}

impl SoftBody {
    /// Step `dt` under `gravity` (m/s²) and the forces in [`SoftBody::forces`] (then
    /// cleared), its nodes kept out of `obstacles`, solving as `solve` says with `solver`'s
    /// buffers; `touches` (one per obstacle) gets what the body pressed on each with.
    pub fn step(
        &mut self,
        dt: f64,
        gravity: DVec3,
        obstacles: Obstacles,
        touches: &mut [Touch],
        solve: Solve,
        solver: &mut Solver,
    ) -> Stepped {
        self.follow_turns(TURNS_PER_STEP, SETTLED_TURN);
        if solver.factor.is_some() {
            self.node_turns(&mut solver.node_turns, &mut solver.sums);
        }
        let stiff = self.material.step_factor(dt);
        self.hold(dt, obstacles, solver);
        if let (Some(factor), Some(capacitance)) = (
            solver.factor.as_mut().filter(|f| f.made_for(self, stiff)),
            &mut solver.capacitance,
        ) {
            capacitance.step(factor, &solver.held);
        }
        // The last velocities, whose momentum the step starts from; the solve starts from
        // them too, pinned and held nodes as they must go.
        solver.before.copy_from_slice(&self.velocities);
        for ((v, &pin), held) in
            (self.velocities.iter_mut().zip(&self.pinned)).zip(&self.pin_velocities)
        {
            if pin {
                *v = *held;
            }
        }
        for h in &solver.held {
            let v = &mut self.velocities[h.node];
            *v = h.held_velocity(*v);
        }
        // A node that would have to pull on its face to stay there is let go, and one that
        // would take more friction to stick than its push gives slides: the step is solved
        // again. Contact only pushes.
        let mut stepped = Stepped {
            iterations: 0,
            residual: 0.0,
        };
        // The residual is made from the elements for the first solve, and for one after
        // nodes were stopped on faces (their velocities set); otherwise the search's own
        // stands for the next, but for the frictions that changed.
        let mut fresh = true;
        for pass in 1..=RELEASES {
            if fresh {
                self.initial_residual(dt, stiff, gravity, solver);
            }
            stepped = self.solve(stiff, solve, solver, stepped.iterations);
            // The last solve stands with the contacts it was made with; but a node it would
            // carry into a solid is still stopped on the face (its push left out).
            if pass == RELEASES {
                self.enter(dt, obstacles, solver);
                break;
            }
            solver.applied.clear();
            solver
                .applied
                .extend(solver.held.iter().map(|h| (h.node, h.friction)));
            let velocities = &self.velocities;
            let released = release(
                &mut solver.held,
                (&solver.residual, velocities),
                dt,
                obstacles.friction,
            );
            fresh = self.enter(dt, obstacles, solver);
            if !(fresh || released) {
                break;
            }
            if !fresh {
                // The residual carried on, b holding dt·friction at each held node.
                for &(n, f) in &solver.applied {
                    solver.residual[n] -= dt * f;
                }
                for h in &solver.held {
                    solver.residual[h.node] += dt * h.friction;
                }
            }
        }
        if !self.reactions.is_empty() {
            // What is left of each pinned node's balance is what held it: b − A·v there.
            self.residual(dt, stiff, gravity, solver);
            for ((out, r), &pin) in self
                .reactions
                .iter_mut()
                .zip(&solver.residual)
                .zip(&self.pinned)
            {
                *out = if pin { *r } else { DVec3::ZERO };
            }
        }
        self.forces.fill(DVec3::ZERO);
        for (x, v) in self.positions.iter_mut().zip(&self.velocities) {
            *x += dt * *v;
        }
        self.pressed(dt, obstacles, touches, solver);
        stepped
    }

    /// Solve the step's velocities from where they stand and the residual b − A·v in the
    /// solver, as `solve` says, counting on from `iterations` already taken.
    fn solve(
        &mut self,
        stiff: f64,
        solve: Solve,
        solver: &mut Solver,
        iterations: usize,
    ) -> Stepped {
        // The held directions are no unknowns: the preconditioner leaves them out, and so
        // every direction searched along; the residual keeps them, what holds the nodes.
        if let Some(c) = &mut solver.capacitance {
            c.prepare(&solver.held, &solver.node_turns);
        }
        self.precondition(stiff, solver);
        solver.direction.copy_from_slice(&solver.preconditioned);
        let mut along = dot(&solver.residual, &solver.preconditioned);
        let mut stepped = Stepped {
            iterations,
            residual: largest(&solver.preconditioned),
        };
        while stepped.iterations < solve.budget && stepped.residual > solve.tolerance {
            self.system_times(stiff, &solver.direction, &mut solver.product);
            let curvature = dot(&solver.direction, &solver.product);
            if curvature <= 0.0 {
                break;
            }
            let alpha = along / curvature;
            for i in 0..self.positions.len() {
                self.velocities[i] += alpha * solver.direction[i];
                solver.residual[i] -= alpha * solver.product[i];
            }
            // β of the flexible form (Polak–Ribière): the preconditioner works in single
            // precision, not quite symmetric, and with β = next/along the search stalled
            // at a ten-millionth of the residual (a static solve to 10⁻¹⁸ stopped at 10⁻⁷).
            let last = dot(&solver.residual, &solver.preconditioned);
            self.precondition(stiff, solver);
            let next = dot(&solver.residual, &solver.preconditioned);
            let beta = (next - last) / along;
            along = next;
            for i in 0..self.positions.len() {
                solver.direction[i] = solver.preconditioned[i] + beta * solver.direction[i];
            }
            stepped.iterations += 1;
            stepped.residual = largest(&solver.preconditioned);
        }
        stepped
    }

    /// The step's first residual b − A·v into the solver, b = M·v₀ + dt·(f(x) + m·g +
    /// f_ext) with v₀ the velocities the step started from: the momentum
    /// terms cancel but where v differs from v₀, and each element's part is one product
    /// with its stiffness, −R·K_e·(dt·(Rᵀ·x − X) + s·Rᵀ·v).
    fn initial_residual(&self, dt: f64, stiff: f64, gravity: DVec3, solver: &mut Solver) {
        self.residual(dt, stiff, gravity, solver);
        for (r, &pin) in solver.residual.iter_mut().zip(&self.pinned) {
            if pin {
                *r = DVec3::ZERO;
            }
        }
    }

    /// b − A·v at every node into the solver's residual, the pinned ones' too.
    fn residual(&self, dt: f64, stiff: f64, gravity: DVec3, solver: &mut Solver) {
        let residual = &mut solver.residual;
        for (i, r) in residual.iter_mut().enumerate() {
            let m = self.masses[i];
            *r = m * (solver.before[i] - self.velocities[i]) + dt * (m * gravity + self.forces[i]);
        }
        for h in &solver.held {
            residual[h.node] += dt * h.friction;
        }
        if self.mesh.order == Order::Linear {
            self.linear_forces(residual, |e, turn| {
                // Rᵀ·F(x) − I (the rest positions' gradient is I) and Rᵀ·F(v).
                let strained = turn.transpose() * self.deformations[e] - DMat3::IDENTITY;
                let moving = turn.transpose() * self.gradient_of(e, &self.velocities);
                -(self.stress_at(&strained) * dt + self.linear_stress(&moving) * stiff)
            });
        } else {
            self.element_forces(dt, stiff, residual);
        }
    }

    /// Less each element's share of the first residual, from its stress at its quadrature
    /// points: the law's at its positions, the linear one at its velocities.
    fn element_forces(&self, dt: f64, stiff: f64, residual: &mut [DVec3]) {
        let mut k = [DVec3::ZERO; MOST_NODES];
        for e in 0..self.volumes.len() {
            let turn = self.rotations[e];
            let back = turn.transpose();
            let (u, n) = self.displacements(e, &back, &self.positions, true);
            let (v, _) = self.displacements(e, &back, &self.velocities, false);
            self.element_forces_of(e, &mut k, |shape| {
                self.stress_at(&gradient_at(&u[..n], shape)) * dt
                    + self.linear_stress(&gradient_at(&v[..n], shape)) * stiff
            });
            for (f, &node) in k.iter().zip(self.mesh.element(e)) {
                residual[node as usize] -= turn * *f;
            }
        }
    }

    /// Linear elements: add to `out` each element's nodal forces R·σ·∇λₖ·V for the stress
    /// σ (in its rest frame) that `stress` gives from its index and turn. One stress an
    /// element, and its corners' gradients sum to zero, so the first corner's force is the
    /// others' negated.
    fn linear_forces(&self, out: &mut [DVec3], stress: impl Fn(usize, &DMat3) -> DMat3) {
        for e in 0..self.volumes.len() {
            let turn = self.rotations[e];
            let push = turn * stress(e, &turn) * self.volumes[e];
            let g = &self.gradients[e];
            let nodes = self.mesh.element(e);
            let [f1, f2, f3] = [1, 2, 3].map(|k| push * g[k]);
            out[nodes[0] as usize] -= f1 + f2 + f3;
            out[nodes[1] as usize] += f1;
            out[nodes[2] as usize] += f2;
            out[nodes[3] as usize] += f3;
        }
    }

    /// Find the nodes held on obstacles over the coming step of `dt`: those inside one or
    /// that would be by the step's end at their velocity, and those on a face that they
    /// pressed on last step.
    fn hold(&self, dt: f64, obstacles: Obstacles, solver: &mut Solver) {
        solver.held.clear();
        for i in 0..self.positions.len() {
            if self.pinned[i] {
                continue;
            }
            let slack = if solver.pressing[i] { SLACK } else { -SLACK };
            if let Some(h) = self.contact(i, dt, obstacles, solver, slack) {
                solver.held.push(h);
            }
        }
    }

    /// After a solve: hold too the free nodes it would take into a solid, each on the face
    /// it would cross, its velocity set as held; whether there were any. Else a node
    /// springing back toward a solid that draws away (a finger passing over a bulge) would
    /// enter it between ticks and be thrown out again, a tick in and a tick out.
    fn enter(&mut self, dt: f64, obstacles: Obstacles, solver: &mut Solver) -> bool {
        solver.holding.fill(false);
        for h in &solver.held {
            solver.holding[h.node] = true;
        }
        let before = solver.held.len();
        for i in 0..self.positions.len() {
            if self.pinned[i] || solver.holding[i] {
                continue;
            }
            let end = self.positions[i] + dt * self.velocities[i];
            if !(0..obstacles.solids.len()).any(|k| obstacles.depth(k, end, -SLACK).is_some()) {
                continue;
            }
            if let Some(h) = self.contact(i, dt, obstacles, solver, -SLACK) {
                let v = &mut self.velocities[i];
                *v = h.held_velocity(*v);
                solver.held.push(h);
            }
        }
        solver.held.len() > before
    }

    /// Node `i` held on the obstacle it would be deepest in at the step's end at its
    /// velocity, or else is deepest in now (within `slack`), if any: on that face, its
    /// speed along the normal what brings it there from where it is (in across a gap, or
    /// out of a depth), sticking or sliding as it did and as it comes in.
    fn contact(
        &self,
        i: usize,
        dt: f64,
        obstacles: Obstacles,
        solver: &Solver,
        slack: f64,
    ) -> Option<Held> {
        let deepest = |at: DVec3| {
            (0..obstacles.solids.len())
                .filter_map(|k| {
                    obstacles
                        .depth(k, at, slack)
                        .map(|(depth, n)| (k, depth, n))
                })
                .filter(|&(_, depth, _)| depth > -slack)
                .max_by(|a, b| a.1.total_cmp(&b.1))
        };
        let (x, v) = (self.positions[i], self.velocities[i]);
        let ahead = deepest(x + dt * v).map(|(k, depth, n)| (k, depth + dt * n.dot(v), n));
        let (k, depth, normal) = ahead.or_else(|| deepest(x))?;
        let surface = obstacles.solids[k].velocity_at(x);
        let slip = v - surface;
        let slip = slip - normal * slip.dot(normal);
        // It sticks on as it stuck, and a new contact sticks where it does not slip: one
        // that comes sliding in slides on (its friction set by its push once the solve
        // finds it).
        let (stuck, kinetic) = if solver.pressing[i] {
            (solver.sliding[i] == DVec3::ZERO, solver.kinetic[i])
        } else {
            let stuck = slip.length() < STICKING;
            (stuck, !stuck)
        };
        Some(Held {
            node: i,
            obstacle: k,
            normal,
            speed: depth / dt,
            stuck: obstacles.friction.stick > 0.0 && stuck,
            kinetic,
            surface,
            friction: solver.sliding[i],
        })
    }

    /// What held each node on its face over the step: (A·v − b)·n/dt along its normal, the
    /// residual's part there turned round, summed as each obstacle's touch.
    fn pressed(&self, dt: f64, obstacles: Obstacles, touches: &mut [Touch], solver: &mut Solver) {
        touches.fill(Touch::default());
        let stiff = self.material.step_factor(dt);
        solver.pressing.fill(false);
        solver.sliding.fill(DVec3::ZERO);
        solver.kinetic.fill(false);
        for h in &solver.held {
            let held = -solver.residual[h.node] / dt;
            let push = held.dot(h.normal).max(0.0);
            solver.pressing[h.node] = push > 0.0;
            let along = if h.stuck {
                held - h.normal * held.dot(h.normal)
            } else {
                solver.sliding[h.node] = h.friction;
                h.friction
            };
            // A node comes to rest on its face once it is held with half the kinetic
            // friction to spare.
            solver.kinetic[h.node] =
                h.kinetic && along.length() > 0.5 * obstacles.friction.slide * push;
            let (on, at) = (-(h.normal * push + along), self.positions[h.node]);
            let touch = &mut touches[h.obstacle];
            touch.force += on;
            touch.torque += (at - obstacles.solids[h.obstacle].centre).cross(on);
            touch.moment += at * push;
            touch.push += push;
            if push > 0.0 {
                let inertia = self.masses[h.node] + stiff * self.own_stiffness[h.node];
                touch.inertia += inertia;
                touch.turning +=
                    inertia * (at - obstacles.solids[h.obstacle].centre).length_squared();
            }
        }
    }

    /// Bring the body to rest under `gravity`: steps so long that each is a static solve,
    /// `rounds` of them to bring the elements' turns up to date with what they bend to;
    /// the velocities are left at zero.
    pub fn settle(&mut self, gravity: DVec3, rounds: usize, solver: &mut Solver) {
        // Velocities of a step of 1000 s: displacements to 10⁻¹⁵ m.
        let exact = Solve {
            budget: 100 * self.positions.len(),
            tolerance: 1e-18,
        };
        for _ in 0..rounds {
            self.step(
                SETTLING_STEP,
                gravity,
                Obstacles::NONE,
                &mut [],
                exact,
                solver,
            );
        }
        self.velocities.fill(DVec3::ZERO);
    }

    /// The step's system times `field`: (M + stiff·K_R)·field, its pinned nodes' rows left
    /// out (their velocities, zero, are no unknowns).
    pub(crate) fn system_times(&self, stiff: f64, field: &[DVec3], out: &mut [DVec3]) {
        out.fill(DVec3::ZERO);
        if self.mesh.order == Order::Linear {
            self.linear_forces(out, |e, turn| {
                self.linear_stress(&(turn.transpose() * self.gradient_of(e, field))) * stiff
            });
        } else {
            let mut k = [DVec3::ZERO; MOST_NODES];
            for e in 0..self.volumes.len() {
                let turn = self.rotations[e];
                let (u, _) = self.displacements(e, &turn.transpose(), field, false);
                self.stiffness_times(e, &u, &mut k);
                let turn = turn * stiff;
                for (f, &n) in k.iter().zip(self.mesh.element(e)) {
                    out[n as usize] += turn * *f;
                }
            }
        }
        for (i, o) in out.iter_mut().enumerate() {
            *o = if self.pinned[i] {
                DVec3::ZERO
            } else {
                *o + self.masses[i] * field[i]
            };
        }
    }

    /// Each node's turn into `turns`: the mean of its elements' turns, each taken on the
    /// side of the node's last turn (in `turns`), summed in `sums`.
    fn node_turns(&self, turns: &mut [DQuat], sums: &mut [DQuat]) {
        sums.fill(DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0));
        for e in 0..self.volumes.len() {
            let q = self.turns[e];
            for &n in self.mesh.element(e) {
                let n = n as usize;
                sums[n] += if turns[n].dot(q) < 0.0 { -q } else { q };
            }
        }
        for (turn, sum) in turns.iter_mut().zip(sums.iter()) {
            if sum.length_squared() > 0.0 {
                *turn = sum.normalize();
            }
        }
    }

    /// How far a step of `dt` moves the point where `weights` share a push among the nodes,
    /// along `normal`, for each newton pushed there along it, m/N: dt²·nᵀ(M + s·K)⁻¹n
    /// through the rest system `solver` factored, turned with the nodes as the last step
    /// left them (what a press between two steps meets, thesis 6.5.5). None when `solver`
    /// was not factored for steps of `dt`.
    pub fn compliance(
        &self,
        solver: &mut Solver,
        dt: f64,
        weights: &[(usize, f64)],
        normal: DVec3,
    ) -> Option<f64> {
        let stiff = self.material.step_factor(dt);
        let factor = solver.factor.as_mut().filter(|f| f.made_for(self, stiff))?;
        solver.turned.fill(DVec3::ZERO);
        for &(node, w) in weights {
            solver.turned[node] += solver.node_turns[node].conjugate() * (normal * w);
        }
        factor.solve(&solver.turned, &mut solver.preconditioned);
        let moved: f64 = weights
            .iter()
            .map(|&(node, w)| w * normal.dot(solver.node_turns[node] * solver.preconditioned[node]))
            .sum();
        Some(dt * dt * moved.max(0.0))
    }

    /// The residual preconditioned: through the factored rest system where it was made for
    /// this step and material, else each node's over its own diagonal (mass and own
    /// stiffness). Nodes pinned or let go since it was made are left out of it: a pinned
    /// one gets nothing, a free one it does not hold its own diagonal's share.
    fn precondition(&self, stiff: f64, solver: &mut Solver) {
        let (residual, out) = (&solver.residual, &mut solver.preconditioned);
        let own = |i: usize| residual[i] / (self.masses[i] + stiff * self.own_stiffness[i]);
        if let Some(factor) = solver.factor.as_mut().filter(|f| f.made_for(self, stiff)) {
            for ((t, r), q) in solver
                .turned
                .iter_mut()
                .zip(residual)
                .zip(&solver.node_turns)
            {
                *t = q.conjugate() * *r;
            }
            for h in &solver.held {
                let n = solver.node_turns[h.node].conjugate() * h.normal;
                let t = &mut solver.turned[h.node];
                *t = if h.stuck {
                    DVec3::ZERO
                } else {
                    *t - n * n.dot(*t)
                };
            }
            factor.solve(&solver.turned, out);
            if let Some(c) = &mut solver.capacitance {
                c.correct(out);
            }
            for (i, (o, q)) in out.iter_mut().zip(&solver.node_turns).enumerate() {
                *o = if self.pinned[i] {
                    DVec3::ZERO
                } else if factor.holds(i) {
                    *q * *o
                } else {
                    own(i)
                };
            }
        } else {
            for (i, o) in out.iter_mut().enumerate() {
                *o = if self.pinned[i] { DVec3::ZERO } else { own(i) };
            }
        }
        filter(out, &solver.held);
    }
}

/// Take out of `field` what the held nodes may not move by: a stuck node's whole, a
/// sliding one's along its normal.
fn filter(field: &mut [DVec3], held: &[Held]) {
    for h in held {
        let v = &mut field[h.node];
        *v = if h.stuck {
            DVec3::ZERO
        } else {
            *v - h.normal * h.normal.dot(*v)
        };
    }
}

/// After a solve that left `residual` and `velocities`: let go the held nodes that would
/// pull on their faces; set sliding those whose hold along the face takes more than
/// `friction` allows (the static coefficient at rest, less in the kinetic regime), under
/// the kinetic friction of their push the way they were held;
/// set sticking again those that slide against their friction faster than [`STICKING`]
/// (it would have stopped them); and bring each sliding node's friction to its push.
/// Whether the step must be solved again: a node let go or turned, or a friction changed
/// by more than a hundredth.
fn release(
    held: &mut Vec<Held>,
    (residual, velocities): (&[DVec3], &[DVec3]),
    dt: f64,
    friction: Friction,
) -> bool {
    let before = held.len();
    held.retain(|h| residual[h.node].dot(h.normal) <= 0.0);
    let mut changed = held.len() != before;
    for h in held.iter_mut() {
        // What held the node over the step, N: its push and its hold along the face.
        let force = -residual[h.node] / dt;
        let push = force.dot(h.normal);
        let along = force - h.normal * push;
        let slip = velocities[h.node] - h.surface;
        let slip = slip - h.normal * slip.dot(h.normal);
        // Once sliding, a node slides again beyond half-way from the kinetic friction to
        // the static one: at the kinetic friction itself, a node dragged along would stick
        // and slip in turn, tick by tick.
        let limit = if h.kinetic {
            (0.5 * (friction.stick + friction.slide)).max(1.05 * friction.slide)
        } else {
            friction.stick
        };
        if h.stuck && along.length() > limit * push {
            (h.stuck, h.kinetic) = (false, true);
            h.friction = along.normalize_or_zero() * (friction.slide * push);
            changed = true;
        } else if !h.stuck && slip.dot(h.friction) > 0.0 && slip.length() > STICKING {
            (h.stuck, h.friction) = (true, DVec3::ZERO);
            changed = true;
        } else if !h.stuck {
            // Against the slip, as the push now is; the way it was where the slip is too
            // slow to tell (a node dragged along at nearly the finger's speed).
            let way = if slip.length() > STICKING {
                -slip.normalize()
            } else {
                h.friction.normalize_or_zero()
            };
            let now = way * (friction.slide * push);
            changed |= (now - h.friction).length() > 0.01 * h.friction.length();
            h.friction = now;
        }
    }
    changed
}

fn dot(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x.dot(*y)).sum()
}

fn largest(field: &[DVec3]) -> f64 {
    field
        .iter()
        .map(|v| v.length_squared())
        .fold(0.0, f64::max)
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::{Obstacle, Obstacles, Touch};
    use crate::element::Order;
    use crate::lattice::cut_box;
    use crate::material::Material;
    use crate::rotation;

    const GRAVITY: DVec3 = DVec3::new(0.0, -9.81, 0.0);

    /// A floor: the box 2 m wide below y = 0 (its top's outward normal +y).
    const FLOOR: [(DVec3, f64); 6] = [
        (DVec3::Y, 0.0),
        (DVec3::NEG_Y, 1.0),
        (DVec3::X, 1.0),
        (DVec3::NEG_X, 1.0),
        (DVec3::Z, 1.0),
        (DVec3::NEG_Z, 1.0),
    ];

    impl Obstacle {
        /// [`FLOOR`], still.
        fn floor() -> Obstacle {
            Obstacle {
                faces: (0, FLOOR.len()),
                ..Obstacle::default()
            }
        }
    }

    fn rubber(young: f64) -> Material {
        Material {
            young,
            poisson: 0.3,
            density: 1000.0,
            damping: 0.0,
        }
    }

    const EXACT: Solve = Solve {
        budget: 100_000,
        tolerance: 1e-15,
    };

    /// A cantilever `length` long of square section `depth`, clamped at x = 0, cut at
    /// `resolution`: its tip's mean sag at rest under its weight, m.
    fn sag(order: Order, young: f64, length: f64, depth: f64, resolution: f64) -> f64 {
        let half = DVec3::new(length, depth, depth) / 2.0;
        let mesh = cut_box(half, half, resolution, order);
        let mut body = SoftBody::new(mesh, rubber(young));
        body.pin_below(0, 0.0);
        let mut solver = Solver::new(body.positions.len());
        body.settle(GRAVITY, 4, &mut solver);
        let tip: Vec<usize> = (0..body.positions.len())
            .filter(|&i| body.mesh.nodes[i].x >= length - 1e-12)
            .collect();
        -tip.iter()
            .map(|&i| body.positions[i].y - body.mesh.nodes[i].y)
            .sum::<f64>()
            / tip.len() as f64
    }

    /// A slender cantilever (20 times as long as deep) of quadratic elements, two through
    /// its depth, sags under its own weight as Euler–Bernoulli says, q·L⁴/(8·E·I), within
    /// 2 %, for any stiffness; linear elements lock (the measure for them is the
    /// same beam in scikit-fem, in the end-to-end tests).
    #[test]
    fn a_slender_cantilever_sags_as_euler_bernoulli_says() {
        let (length, depth): (f64, f64) = (0.4, 0.02);
        for young in [1e8, 1e9] {
            let q = 1000.0 * 9.81 * depth * depth;
            let exact = q * length.powi(4) / (8.0 * young * depth.powi(4) / 12.0);
            let found = sag(Order::Quadratic, young, length, depth, 0.01);
            println!("E {young:e}: sag {found:.6e} m, Euler–Bernoulli {exact:.6e} m");
            assert!((found / exact - 1.0).abs() < 0.02, "{found} vs {exact}");
        }
    }

    /// What a press between two steps meets: through the rest system factored for a
    /// settling step (inertia nothing beside stiffness), a slender cantilever's tip gives
    /// L³/(3·E·I) a newton, within 2 % (shear adds 0.2 % at this slenderness); through one
    /// factored for a 1 ms step, a newton moves it as far as the step itself moves it.
    #[test]
    fn a_cantilever_tip_gives_as_euler_bernoulli_says_and_as_a_step_moves_it() {
        let (length, depth): (f64, f64) = (0.4, 0.02);
        let half = DVec3::new(length, depth, depth) / 2.0;
        let mesh = cut_box(half, half, 0.01, Order::Quadratic);
        let young = 1e8;
        let mut body = SoftBody::new(mesh, rubber(young));
        body.pin_below(0, 0.0);
        let tip: Vec<usize> = (0..body.positions.len())
            .filter(|&i| body.mesh.nodes[i].x >= length - 1e-12)
            .collect();
        let weights: Vec<(usize, f64)> = tip.iter().map(|&i| (i, 1.0 / tip.len() as f64)).collect();
        let mut solver = Solver::settling(&body).unwrap();
        let found = body
            .compliance(&mut solver, SETTLING_STEP, &weights, DVec3::NEG_Y)
            .unwrap();
        let exact = length.powi(3) / (3.0 * young * depth.powi(4) / 12.0);
        println!("tip compliance {found:.6e} m/N, Euler–Bernoulli {exact:.6e} m/N");
        assert!((found / exact - 1.0).abs() < 0.02, "{found} vs {exact}");
        assert_eq!(
            body.compliance(&mut solver, 0.001, &weights, DVec3::Y),
            None
        );

        // A newton down on the tip for one step from rest, no gravity.
        let dt = 0.001;
        let mut solver = Solver::factored(&body, dt).unwrap();
        let predicted = body
            .compliance(&mut solver, dt, &weights, DVec3::NEG_Y)
            .unwrap();
        for &(i, w) in &weights {
            body.forces[i] = DVec3::NEG_Y * w;
        }
        let free = Obstacles {
            planes: &[],
            solids: &[],
            friction: Friction::default(),
        };
        body.step(dt, DVec3::ZERO, free, &mut [], EXACT, &mut solver);
        let moved: f64 = weights
            .iter()
            .map(|&(i, w)| -w * (body.positions[i].y - body.mesh.nodes[i].y))
            .sum();
        println!("one step: moved {moved:.6e} m, predicted {predicted:.6e} m");
        assert!(
            (moved / predicted - 1.0).abs() < 1e-6,
            "{moved} vs {predicted}"
        );
    }

    /// Falling freely, a body's elements stay at rest among themselves and every node gains
    /// g·dt a step, exactly: the elastic forces sum to nothing.
    #[test]
    fn a_falling_body_falls_whole() {
        for order in [Order::Linear, Order::Quadratic] {
            let mesh = cut_box(DVec3::ZERO, DVec3::new(0.05, 0.03, 0.04), 0.02, order);
            let mut body = SoftBody::new(mesh, rubber(1e5));
            let mut solver = Solver::new(body.positions.len());
            for _ in 0..100 {
                body.step(0.001, GRAVITY, Obstacles::NONE, &mut [], EXACT, &mut solver);
            }
            for v in &body.velocities {
                assert!((*v - GRAVITY * 0.1).length() < 1e-9, "{v}");
            }
            assert!(body.elastic_energy() < 1e-12);
        }
    }

    /// A block squeezed and let go, with no damping and no gravity, loses energy each step
    /// and never gains any, at a step a hundred times longer than its fastest wave crosses
    /// an element, until it keeps less than 10⁻⁸ of what the squeeze stored (measured
    /// 3.2·10⁻⁹, where each element's turn, held over a step, leaves its forces not quite the
    /// energy's gradient); there the energy wobbles by 10⁻¹¹ of it at most (measured
    /// 3·10⁻¹³).
    #[test]
    fn a_squeezed_block_let_go_only_loses_energy() {
        for order in [Order::Linear, Order::Quadratic] {
            let mesh = cut_box(DVec3::ZERO, DVec3::splat(0.02), 0.01, order);
            let mut body = SoftBody::new(mesh, rubber(1e7));
            for (x, rest) in body.positions.iter_mut().zip(&body.mesh.nodes) {
                *x = *rest * DVec3::new(1.0, 0.8, 1.1);
            }
            let stored = body.elastic_energy();
            let crossing = 0.01 / body.material.wave_speed();
            let mut solver = Solver::new(body.positions.len());
            let mut last = stored;
            for _ in 0..50 {
                body.step(
                    100.0 * crossing,
                    DVec3::ZERO,
                    Obstacles::NONE,
                    &mut [],
                    EXACT,
                    &mut solver,
                );
                let energy = body.kinetic_energy() + body.elastic_energy();
                assert!(
                    energy.is_finite() && energy <= last + 1e-11 * stored,
                    "{order:?}: {energy} J after {last} J of {stored} J"
                );
                last = energy;
            }
            assert!(last < 1e-8 * stored, "{order:?}: {last} J of {stored} J");
        }
    }

    /// A cube (ν = 0.45) squeezed by a fifth of its height between two plates it slides on
    /// freely keeps the volume its law gives a free uniaxial squeeze: stretched evenly by s
    /// across, where μ·‖ε‖² + λ/2·(J − 1)² is least, J = 0.8·s² (0.974, where linear strain's
    /// (1 − ε)(1 + ν·ε)² would lose 5 %); to the solve's rounding, as the squeeze is even.
    #[test]
    fn a_cube_squeezed_a_fifth_keeps_its_volume_as_its_law_says() {
        let (side, squeeze) = (0.02, 0.8);
        let material = Material {
            poisson: 0.45,
            damping: 0.01,
            ..rubber(1e5)
        };
        let [lambda, mu] = [material.lambda(), material.mu()];
        // The stretch across where the energy's slope along it is nought, by halving.
        let slope =
            |s: f64| 4.0 * mu * (s - 1.0) + lambda * (squeeze * s * s - 1.0) * 2.0 * squeeze * s;
        let (mut low, mut high) = (1.0, 1.5);
        for _ in 0..100 {
            let mid = 0.5 * (low + high);
            if slope(mid) < 0.0 {
                low = mid
            } else {
                high = mid
            }
        }
        let kept = squeeze * low * low;
        for order in [Order::Linear, Order::Quadratic] {
            let mesh = cut_box(
                DVec3::new(0.0, side / 2.0, 0.0),
                DVec3::splat(side / 2.0),
                side / 4.0,
                order,
            );
            let mut body = SoftBody::new(mesh, material);
            let rest = body.rest_volume();
            let mut solver = Solver::factored(&body, 0.001).unwrap();
            // The floor, and a plate above coming down to 0.8 of the side in 0.4 s, then held.
            let mut planes = [(DVec3::ZERO, 0.0); 12];
            planes[..6].copy_from_slice(&FLOOR);
            let steps = 400;
            for k in 1..=steps + 1000 {
                let top = side * (1.0 - (1.0 - squeeze) * (k.min(steps) as f64 / steps as f64));
                let speed = if k <= steps {
                    (1.0 - squeeze) * side / (steps as f64 * 0.001)
                } else {
                    0.0
                };
                planes[6..].copy_from_slice(&[
                    (DVec3::NEG_Y, -top),
                    (DVec3::Y, top + 1.0),
                    (DVec3::X, 1.0),
                    (DVec3::NEG_X, 1.0),
                    (DVec3::Z, 1.0),
                    (DVec3::NEG_Z, 1.0),
                ]);
                let solids = [
                    Obstacle::floor(),
                    Obstacle {
                        faces: (6, 6),
                        centre: DVec3::new(0.0, top + 0.5, 0.0),
                        velocity: DVec3::new(0.0, -speed, 0.0),
                        spin: DVec3::ZERO,
                    },
                ];
                let plates = Obstacles {
                    planes: &planes,
                    solids: &solids,
                    friction: Friction::NONE,
                };
                body.step(
                    0.001,
                    DVec3::ZERO,
                    plates,
                    &mut [Touch::default(); 2],
                    EXACT,
                    &mut solver,
                );
            }
            let height = body.positions.iter().map(|p| p.y).fold(f64::MIN, f64::max);
            let volume = body.volume() / rest;
            println!(
                "{order:?}: squeezed to {:.5} of its side, keeps {volume:.6} of its volume (its law: {kept:.6})",
                height / side
            );
            assert!((height / side - squeeze).abs() < 1e-6, "{height}");
            assert!(
                (volume / kept - 1.0).abs() < 1e-4,
                "{order:?}: {volume} against {kept}"
            );
        }
    }

    /// A bar factored free and then pinned at one end while it runs settles as the same bar
    /// pinned when it was factored (its factor's unknowns of the newly pinned nodes left
    /// out of the solve); made four times as stiff it sags a quarter as far (the sag is
    /// small); and let go it falls at g, the nodes its factor never held moved through
    /// their own diagonal.
    #[test]
    fn a_bar_pinned_stiffened_and_let_go_while_it_runs_moves_as_one_made_so() {
        let mesh = cut_box(
            DVec3::new(0.025, 0.0, 0.0),
            DVec3::new(0.025, 0.005, 0.005),
            0.005,
            Order::Linear,
        );
        let material = Material {
            damping: 0.01,
            ..rubber(1e6)
        };
        // The mean sag of the nodes at the free end (by where they stood).
        let tip = |body: &SoftBody| -> f64 {
            let at: Vec<f64> = (body.positions.iter().zip(&body.mesh.nodes))
                .filter(|(_, rest)| rest.x > 0.05 - 1e-9)
                .map(|(p, rest)| rest.y - p.y)
                .collect();
            at.iter().sum::<f64>() / at.len() as f64
        };
        let mut made = SoftBody::new(mesh.clone(), material);
        made.pin_below(0, 0.0);
        let mut solver = Solver::settling(&made).unwrap();
        made.settle(GRAVITY, 4, &mut solver);
        let mut pinned = SoftBody::new(mesh.clone(), material);
        let mut solver = Solver::settling(&pinned).unwrap();
        assert_eq!(pinned.pin_where(DVec3::X, 1e-9, true), 9);
        pinned.settle(GRAVITY, 4, &mut solver);
        let (sag, apart) = (
            tip(&made),
            pinned
                .positions
                .iter()
                .zip(&made.positions)
                .map(|(a, b)| a.distance(*b))
                .fold(0.0, f64::max),
        );
        println!("pinned at load: tip sags {sag:.6e} m; pinned while running: {apart:.2e} m apart");
        assert!(sag > 1e-4 && apart < 1e-9 * sag, "{sag} {apart}");
        pinned.set_material(4e6, 0.3, 0.01);
        pinned.settle(GRAVITY, 4, &mut solver);
        let stiffer = tip(&pinned);
        println!(
            "four times as stiff: {stiffer:.6e} m, {:.5} of it",
            stiffer / sag
        );
        assert!((stiffer / sag - 0.25).abs() < 1e-3, "{stiffer} {sag}");
        assert_eq!(pinned.pin_where(DVec3::X, 1.0, false), 9);
        let before = pinned.centre();
        let mut solver = Solver::factored(&made, 0.001).unwrap();
        let steps = 100;
        for _ in 0..steps {
            pinned.step(0.001, GRAVITY, Obstacles::NONE, &mut [], EXACT, &mut solver);
        }
        // Its centre of mass, which its own forces do not move.
        let fallen = before.y - pinned.centre().y;
        // Backward Euler's fall: g·dt²·n(n + 1)/2.
        let exact = 9.81 * 1e-6 * (steps * (steps + 1)) as f64 / 2.0;
        println!("let go: fell {fallen:.6e} m in 0.1 s, backward Euler {exact:.6e} m");
        assert!((fallen / exact - 1.0).abs() < 1e-9, "{fallen} {exact}");
    }

    /// A squeezed block turned a quarter round as a whole is solved as fast as one not
    /// turned: the factored rest system is turned with each node's elements, so it is the
    /// turned block's own system: one iteration each, where the rest system unturned took 35
    /// for the turned block.
    #[test]
    fn a_turned_block_is_solved_as_fast_as_one_not_turned() {
        let turn = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 0.5).normalize(), 1.6);
        let mut counts = Vec::new();
        for turned in [false, true] {
            let mesh = cut_box(
                DVec3::ZERO,
                DVec3::new(0.03, 0.02, 0.01),
                0.01,
                Order::Linear,
            );
            let mut body = SoftBody::new(mesh, rubber(1e5));
            for (x, rest) in body.positions.iter_mut().zip(&body.mesh.nodes) {
                let squeezed = *rest * DVec3::new(0.9, 1.0, 1.05);
                *x = if turned { turn * squeezed } else { squeezed };
            }
            // Turns found whole before the first step.
            body.follow_turns(rotation::TURNS, 0.0);
            let mut solver = Solver::factored(&body, 0.001).unwrap();
            let tick = Solve {
                budget: 50,
                tolerance: 1e-9,
            };
            let stepped = body.step(
                0.001,
                DVec3::ZERO,
                Obstacles::NONE,
                &mut [],
                tick,
                &mut solver,
            );
            counts.push(stepped.iterations);
        }
        println!("iterations: {counts:?}");
        assert!(counts[1] <= counts[0], "{counts:?}");
    }

    /// A block let down onto a floor comes to rest on it: no node below it, and the floor
    /// bears the block's weight, to a millionth; thrown upward, it leaves the floor.
    #[test]
    fn a_block_rests_on_a_floor_with_its_weight() {
        let tick = Solve {
            budget: 1000,
            tolerance: 1e-12,
        };
        for order in [Order::Linear, Order::Quadratic] {
            let mesh = cut_box(
                DVec3::new(0.0, 0.0201, 0.0),
                DVec3::new(0.03, 0.02, 0.02),
                0.01,
                order,
            );
            let material = Material {
                damping: 0.01,
                ..rubber(5e4)
            };
            let mut body = SoftBody::new(mesh, material);
            let (planes, solids) = (FLOOR, [Obstacle::floor()]);
            let floor = Obstacles {
                planes: &planes,
                solids: &solids,
                friction: Friction {
                    stick: 0.5,
                    slide: 0.4,
                },
            };
            let mut solver = Solver::factored(&body, 0.001).unwrap();
            let mut touch = [Touch::default()];
            for _ in 0..500 {
                body.step(0.001, GRAVITY, floor, &mut touch, tick, &mut solver);
            }
            let weight = body.mass() * 9.81;
            let lowest = body
                .positions
                .iter()
                .map(|p| p.y)
                .fold(f64::INFINITY, f64::min);
            println!(
                "{order:?}: floor bears {:?} of {weight} N; lowest node {lowest:e} m",
                touch[0]
            );
            assert!(lowest > -1e-12, "{lowest}");
            assert!((touch[0].force + DVec3::new(0.0, weight, 0.0)).length() < 1e-6 * weight);
            assert!(body.kinetic_energy() < 1e-12, "{}", body.kinetic_energy());
            body.velocities.fill(DVec3::new(0.0, 1.0, 0.0));
            for _ in 0..2 {
                body.step(0.001, GRAVITY, floor, &mut touch, tick, &mut solver);
            }
            assert_eq!(touch[0], Touch::default());
            assert!(body.positions.iter().all(|p| p.y > 1e-4));
        }
    }

    /// A block on a floor with friction (μs = 0.5, μk = 0.4) pushed along it by a force
    /// spread over its mass, a times its weight: at a = 0.3 it sticks (it comes to rest
    /// sheared, its base's edges slipping microns where the floor presses them least, and
    /// the floor holds 0.3 of its weight along it); at a = 0.6 it slides,
    /// its middle speeding up at (a − μk)·g, as Coulomb's law says of any block, and the
    /// floor holds μk times its weight.
    #[test]
    fn a_block_pushed_along_a_floor_sticks_below_its_friction_and_slides_above() {
        let tick = Solve {
            budget: 200,
            tolerance: 1e-10,
        };
        let friction = Friction {
            stick: 0.5,
            slide: 0.4,
        };
        for (a, slides) in [(0.3, false), (0.6, true)] {
            let mesh = cut_box(
                DVec3::new(0.0, 0.01, 0.0),
                DVec3::new(0.02, 0.01, 0.015),
                0.005,
                Order::Linear,
            );
            let material = Material {
                damping: 0.01,
                ..rubber(5e4)
            };
            let mut body = SoftBody::new(mesh, material);
            let (planes, solids) = (FLOOR, [Obstacle::floor()]);
            let floor = Obstacles {
                planes: &planes,
                solids: &solids,
                friction,
            };
            let mut solver = Solver::factored(&body, 0.001).unwrap();
            let mut touch = [Touch::default()];
            // At rest on the floor first.
            for _ in 0..300 {
                body.step(0.001, GRAVITY, floor, &mut touch, tick, &mut solver);
            }
            let weight = body.mass() * 9.81;
            let mean_speed = |b: &SoftBody| {
                b.velocities
                    .iter()
                    .zip(&b.masses)
                    .map(|(v, m)| v.x * m)
                    .sum::<f64>()
                    / b.mass()
            };
            let bottom: Vec<usize> = (0..body.positions.len())
                .filter(|&i| body.positions[i].y < 1e-9)
                .collect();
            let start: Vec<DVec3> = bottom.iter().map(|&i| body.positions[i]).collect();
            let (x0, steps) = (body.centre().x, 200);
            let mut speeds = Vec::new();
            for _ in 0..steps {
                for (f, m) in body.forces.iter_mut().zip(&body.masses) {
                    *f = DVec3::new(a * 9.81 * m, 0.0, 0.0);
                }
                let st = body.step(0.001, GRAVITY, floor, &mut touch, tick, &mut solver);
                if speeds.len() % 40 == 0 {
                    println!(
                        "{st:?} held {} stuck {}",
                        solver.held.len(),
                        solver.held.iter().filter(|h| h.stuck).count()
                    );
                }
                speeds.push(mean_speed(&body));
            }
            let along = touch[0].force.x / weight;
            let moved: f64 = bottom
                .iter()
                .zip(&start)
                .map(|(&i, s)| (body.positions[i] - *s).length())
                .fold(0.0, f64::max);
            println!(
                "a = {a}: floor holds {along} of the weight along it; bottom moved {moved:e} m, \
                 middle {:e} m",
                body.centre().x - x0
            );
            if slides {
                // Speeding up at (a − μk)·g from the first tick: over the last 100 ticks.
                let gained = (speeds[steps - 1] - speeds[steps - 101]) / 0.1;
                let expected = (a - friction.slide) * 9.81;
                assert!(
                    (gained / expected - 1.0).abs() < 0.01,
                    "{gained} vs {expected}"
                );
                assert!((along - friction.slide).abs() < 0.01, "{along}");
            } else {
                // Measured: 6 µm at the base's edges, against 40 mm when it slides.
                assert!(moved < 1e-5, "{moved}");
                assert!(speeds[steps - 1].abs() < 1e-6, "{speeds:?}");
                assert!((along - a).abs() < 0.01, "{along}");
            }
        }
    }
}
