//! [rt] Soft bodies in a penalty world (issue: soft bodies, thesis 7.2), stepped once a
//! device tick: each keeps its solve's buffers and its obstacles' planes, changed in place,
//! so a tick allocates nothing. Its nodes are kept out of the pointers and the fixed
//! bodies; what it presses on a pointer with is felt there.

use glam::DVec3;
use hapticd_core::kinematics::Wrench;
use hapticd_soft::body::SoftBody;
use hapticd_soft::contact::{Friction, Obstacle, Obstacles, Touch};
use hapticd_soft::implicit::{Solve, Solver, Stepped};

use crate::body::Body;

/// The device tick a soft body's solve is factored for (1 kHz), s: other ticks are solved
/// with each node's own diagonal, more slowly.
pub const SOFT_TICK: f64 = 0.001;

/// A tick's solve: done with every node's velocity within 0.1 mm/s (its position within
/// 0.1 µm of the tick's solution), in at most 20 iterations.
const TICK: Solve = Solve {
    budget: 20,
    tolerance: 1e-4,
};

/// A soft body of a scene, ready to step.
#[derive(Debug, Clone)]
pub struct SoftPart {
    /// Its name in the scene.
    pub name: String,
    /// The body.
    pub body: SoftBody,
    solver: Solver,
    /// The world bodies it may not enter: the fixed ones, then the pointers.
    touching: Vec<usize>,
    planes: Vec<(DVec3, f64)>,
    solids: Vec<Obstacle>,
    touches: Vec<Touch>,
    /// The friction its nodes hold on the solids they touch with.
    pub friction: Friction,
    /// A force pushing it besides gravity, N, spread over its nodes by their mass.
    pub load: DVec3,
    /// What its last tick's solve did.
    pub stepped: Stepped,
}

impl SoftPart {
    /// `body` called `name`, solved by `solver`, in a world of `bodies` whose pointers
    /// start at `first_pointer`, touching them with `friction`: its obstacles sized.
    pub fn new(
        name: String,
        (body, solver): (SoftBody, Solver),
        bodies: &[Body],
        first_pointer: usize,
        friction: Friction,
    ) -> SoftPart {
        let touching: Vec<usize> = (0..bodies.len())
            .filter(|&i| i >= first_pointer || bodies[i].fixed)
            .collect();
        let mut solids = Vec::new();
        let mut faces = 0;
        for &i in &touching {
            for piece in &bodies[i].pieces {
                solids.push(Obstacle {
                    faces: (faces, piece.planes.len()),
                    ..Obstacle::default()
                });
                faces += piece.planes.len();
            }
        }
        SoftPart {
            name,
            body,
            solver,
            touching,
            planes: vec![(DVec3::ZERO, 0.0); faces],
            touches: vec![Touch::default(); solids.len()],
            solids,
            friction,
            load: DVec3::ZERO,
            stepped: Stepped {
                iterations: 0,
                residual: 0.0,
            },
        }
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
        self.stepped = self.body.step(
            dt,
            gravity,
            obstacles,
            &mut self.touches,
            TICK,
            &mut self.solver,
        );
        for (i, t) in self.touches_by_body(bodies) {
            if let Some(out) = i.checked_sub(first_pointer).and_then(|k| felt.get_mut(k)) {
                *out = *out
                    + Wrench {
                        force: t.force,
                        torque: t.torque,
                    };
            }
        }
    }

    /// [rt] What it pressed on world body `i` with over the last tick, if anything: the
    /// force, N, and where its nodes pressed (weighed by their push).
    pub fn pressed_on(&self, i: usize, bodies: &[Body]) -> Option<(DVec3, DVec3)> {
        let mut sum = Touch::default();
        for (_, t) in self.touches_by_body(bodies).filter(|&(j, _)| j == i) {
            sum.force += t.force;
            sum.moment += t.moment;
            sum.push += t.push;
        }
        Some((sum.force, sum.point()?))
    }

    /// [rt] What it pressed on each solid of the world bodies it touches over the last
    /// tick, with the world body the solid is a piece of.
    fn touches_by_body<'a>(
        &'a self,
        bodies: &'a [Body],
    ) -> impl Iterator<Item = (usize, &'a Touch)> + 'a {
        self.touching
            .iter()
            .flat_map(|&i| std::iter::repeat_n(i, bodies[i].pieces.len()))
            .zip(&self.touches)
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
