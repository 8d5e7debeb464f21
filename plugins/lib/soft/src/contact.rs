//! What a soft body touches: convex solids (a pointer's tip, a floor, a rigid body's convex
//! pieces) that its nodes may not enter. A node inside one where it stands at the end of
//! the step is taken out to the face it is nearest within the step, as a constraint on its
//! velocity along that face's normal (not a penalty spring: nothing to tune, nothing to
//! ring); what holds it there is the force it presses on the solid with. A node the step
//! would carry into a solid is held on its face in that same step. A node that would have
//! to pull to stay is let go, and the step solved again: a contact only pushes.
//!
//! With friction (Coulomb's), a held node first sticks: it moves with the solid's surface,
//! held along the face too. Where holding it along the face takes more than the static
//! coefficient times its push, it slides instead, under the kinetic coefficient times its
//! push along the way it was held, and the step is solved again.

use glam::DVec3;

/// Convex solids the nodes may not enter, where they stand at the end of the step, their
/// faces' planes in one list (so a caller keeps them in buffers of its own, changed in
/// place each tick).
#[derive(Debug, Clone, Copy)]
pub struct Obstacles<'a> {
    /// Every solid's faces' planes: each outward unit normal n and offset d, n·x ≤ d inside.
    pub planes: &'a [(DVec3, f64)],
    /// The solids.
    pub solids: &'a [Obstacle],
    /// Friction between the nodes and every solid.
    pub friction: Friction,
}

/// Coulomb friction between a body's nodes and the solids it touches.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Friction {
    /// The most the force along a face may be, times the push, while a node sticks.
    pub stick: f64,
    /// The force along a face while a node slides, times the push.
    pub slide: f64,
}

impl Friction {
    /// None: the nodes slide freely along every face.
    pub const NONE: Friction = Friction {
        stick: 0.0,
        slide: 0.0,
    };
}

/// A convex solid the nodes may not enter.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Obstacle {
    /// Its faces: the first of its planes in [`Obstacles::planes`], and how many.
    pub faces: (usize, usize),
    /// The point its torque is taken about, m.
    pub centre: DVec3,
    /// Its velocity over the step at `centre`, m/s.
    pub velocity: DVec3,
    /// Its angular velocity over the step, rad/s.
    pub spin: DVec3,
}

impl Obstacle {
    /// The velocity of its surface at `x`, m/s.
    pub fn velocity_at(&self, x: DVec3) -> DVec3 {
        self.velocity + self.spin.cross(x - self.centre)
    }
}

impl Obstacles<'_> {
    /// None at all.
    pub const NONE: Obstacles<'static> = Obstacles {
        planes: &[],
        solids: &[],
        friction: Friction::NONE,
    };

    /// How deep `x` is inside solid `k`, m, and the normal of the face it is nearest; None
    /// outside (or further out than `slack`).
    pub fn depth(&self, k: usize, x: DVec3, slack: f64) -> Option<(f64, DVec3)> {
        let (first, count) = self.solids[k].faces;
        let mut nearest: Option<(f64, DVec3)> = None;
        for &(n, d) in &self.planes[first..first + count] {
            let depth = d - n.dot(x);
            if depth < -slack {
                return None;
            }
            if nearest.is_none_or(|(best, _)| depth < best) {
                nearest = Some((depth, n));
            }
        }
        nearest
    }
}

/// What a body pressed on an obstacle with over a step: force, N, and torque about the
/// obstacle's centre, N·m; and where, as the nodes that pressed stand, each weighed by its
/// push.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Touch {
    /// The force on the obstacle.
    pub force: DVec3,
    /// Its torque about the obstacle's centre.
    pub torque: DVec3,
    /// The pressing nodes' positions, each times its push (N·m).
    pub moment: DVec3,
    /// Their pushes summed, N.
    pub push: f64,
    /// What the step moved along with the obstacle, kg: each pressing node's mass and its
    /// own stiffness times the step's factor (m + s·k, what answers a change of its
    /// velocity within the step). A light body pushed a step late by nodes that outweigh
    /// it would be thrown back harder each step; its pusher weighs its pushes by it.
    pub inertia: f64,
    /// The same about the obstacle's centre, each node's times its distance squared,
    /// kg·m².
    pub turning: f64,
}

impl Touch {
    /// Where the nodes pressed, their pushes weighing them; None where none did.
    pub fn point(&self) -> Option<DVec3> {
        (self.push > 0.0).then(|| self.moment / self.push)
    }
}

/// Touches on obstacles that share a centre (the pieces of one body), taken together.
impl std::iter::Sum for Touch {
    fn sum<I: Iterator<Item = Touch>>(touches: I) -> Touch {
        touches.fold(Touch::default(), |a, t| Touch {
            force: a.force + t.force,
            torque: a.torque + t.torque,
            moment: a.moment + t.moment,
            push: a.push + t.push,
            inertia: a.inertia + t.inertia,
            turning: a.turning + t.turning,
        })
    }
}

/// A node held on an obstacle's face over a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Held {
    /// The node.
    pub node: usize,
    /// The obstacle, by its place in the list stepped with.
    pub obstacle: usize,
    /// The face's outward normal.
    pub normal: DVec3,
    /// The node's velocity along it over the step: out of its depth, or in across the gap
    /// between them, onto the face.
    pub speed: f64,
    /// Whether it sticks to the face: moves with it, held along it too.
    pub stuck: bool,
    /// Whether it has been sliding and is not yet at rest on the face: it then slides
    /// again once holding it takes more than the kinetic friction, before the static one
    /// (else a dragged node would stick and slip in turn, tick by tick).
    pub kinetic: bool,
    /// The velocity of the face where the node is, m/s.
    pub surface: DVec3,
    /// The friction on the node while it slides, N.
    pub friction: DVec3,
}

impl Held {
    /// The velocity the node is held to, from its own `v`: the face's along the face while
    /// it sticks, its own while it slides; out of its depth (or across its gap) onto the
    /// face either way.
    pub fn held_velocity(&self, v: DVec3) -> DVec3 {
        let along = if self.stuck { self.surface } else { v };
        along + self.normal * (self.speed - self.normal.dot(along))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube's depth is the distance to its nearest face, along that face's normal.
    #[test]
    fn a_point_inside_is_as_deep_as_its_nearest_face() {
        let planes: Vec<(DVec3, f64)> = [DVec3::X, DVec3::Y, DVec3::Z]
            .into_iter()
            .flat_map(|a| [(a, 0.5), (-a, 0.5)])
            .collect();
        let solids = [Obstacle {
            faces: (0, 6),
            ..Obstacle::default()
        }];
        let cube = Obstacles {
            planes: &planes,
            solids: &solids,
            friction: Friction::NONE,
        };
        let (depth, normal) = cube.depth(0, DVec3::new(0.1, -0.4, 0.2), 0.0).unwrap();
        assert!((depth - 0.1).abs() < 1e-15 && normal == -DVec3::Y);
        assert!(cube.depth(0, DVec3::new(0.1, 0.6, 0.2), 0.0).is_none());
        assert!(cube.depth(0, DVec3::new(0.1, 0.6, 0.2), 0.2).is_some());
    }
}
