//! A soft body taken whole, as a rigid body is: where its mass is, how far it has turned
//! (the rotation that best carries its rest shape onto its nodes now, as shape matching
//! finds it), its momentum as a velocity and its angular momentum as a spin; and what is
//! done to it whole from outside (a new velocity and spin, an impulse at a point). Its
//! nodes' own motion, the bending, is left as it is by each change but for the change.

use glam::{DMat3, DQuat, DVec3};

use crate::body::SoftBody;
use crate::rotation;

impl SoftBody {
    /// The rotation nearest the map from its rest shape to its shape now, each node
    /// weighed by its mass (about the centres of mass of both).
    pub fn turn(&self) -> DQuat {
        let (now, rest) = (self.centre(), self.rest_centre());
        let mut spread = DMat3::ZERO;
        for ((x, r), m) in self
            .positions
            .iter()
            .zip(&self.mesh.nodes)
            .zip(&self.masses)
        {
            let (d, e) = (*x - now, *r - rest);
            spread += DMat3::from_cols(d * e.x, d * e.y, d * e.z) * *m;
        }
        rotation::nearest(&spread)
    }

    /// Its momentum over its mass: the velocity of its centre of mass, m/s.
    pub fn velocity(&self) -> DVec3 {
        self.mean(&self.velocities)
    }

    /// The spin its angular momentum about its centre of mass would be in a rigid body of
    /// its nodes as they stand, rad/s.
    pub fn spin(&self) -> DVec3 {
        let centre = self.centre();
        let velocity = self.velocity();
        let momentum: DVec3 = (0..self.positions.len())
            .map(|i| {
                let r = self.positions[i] - centre;
                r.cross(self.velocities[i] - velocity) * self.masses[i]
            })
            .sum();
        self.inverse_inertia(centre) * momentum
    }

    /// Give it the velocity `velocity` (m/s) and spin `spin` (rad/s) whole: each node's
    /// velocity changed by what changes the body's; pinned nodes are held again by the
    /// next step.
    pub fn set_motion(&mut self, velocity: DVec3, spin: DVec3) {
        let (dv, dw, centre) = (
            velocity - self.velocity(),
            spin - self.spin(),
            self.centre(),
        );
        for (v, x) in self.velocities.iter_mut().zip(&self.positions) {
            *v += dv + dw.cross(*x - centre);
        }
    }

    /// Give it the momentum `impulse` (N·s) at the point `at`: its momentum changes by it
    /// and its angular momentum by its moment, as a rigid body's of its nodes would.
    pub fn give_impulse(&mut self, impulse: DVec3, at: DVec3) {
        let centre = self.centre();
        let dv = impulse / self.mass();
        let dw = self.inverse_inertia(centre) * (at - centre).cross(impulse);
        for (v, x) in self.velocities.iter_mut().zip(&self.positions) {
            *v += dv + dw.cross(*x - centre);
        }
    }

    /// Its centre of mass at rest, m.
    fn rest_centre(&self) -> DVec3 {
        self.mean(&self.mesh.nodes)
    }

    /// The inverse of its nodes' inertia about `centre` as they stand (zero for nodes on
    /// a line, which no spin about it moves).
    fn inverse_inertia(&self, centre: DVec3) -> DMat3 {
        let mut inertia = DMat3::ZERO;
        for (x, m) in self.positions.iter().zip(&self.masses) {
            let r = *x - centre;
            inertia += (DMat3::from_diagonal(DVec3::splat(r.length_squared()))
                - DMat3::from_cols(r * r.x, r * r.y, r * r.z))
                * *m;
        }
        if inertia.determinant().abs() > f64::MIN_POSITIVE {
            inertia.inverse()
        } else {
            DMat3::ZERO
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::body::SoftBody;
    use crate::element::Order;
    use crate::lattice::cut_box;
    use crate::material::Material;
    use glam::{DQuat, DVec3};

    fn block() -> SoftBody {
        let mesh = cut_box(
            DVec3::new(0.01, 0.02, -0.03),
            DVec3::new(0.02, 0.01, 0.015),
            0.005,
            Order::Linear,
        );
        SoftBody::new(
            mesh,
            Material {
                young: 1e5,
                poisson: 0.45,
                density: 1100.0,
                damping: 0.002,
            },
        )
    }

    /// Momentum and angular momentum summed over the nodes, about `centre`.
    fn momenta(body: &SoftBody, centre: DVec3) -> (DVec3, DVec3) {
        let mut out = (DVec3::ZERO, DVec3::ZERO);
        for i in 0..body.positions.len() {
            let p = body.velocities[i] * body.masses[i];
            out.0 += p;
            out.1 += (body.positions[i] - centre).cross(p);
        }
        out
    }

    /// Turned and moved whole, the body says how; an impulse changes its momentum by
    /// itself and its angular momentum by its moment, summed over the nodes; a motion set
    /// is read back.
    #[test]
    fn a_body_taken_whole_reads_back_its_turn_and_takes_momentum_exactly() {
        let mut body = block();
        let turn = DQuat::from_axis_angle(DVec3::new(0.2, -1.0, 0.4).normalize(), 2.2);
        let shift = DVec3::new(0.3, -0.1, 0.05);
        for (x, rest) in body.positions.iter_mut().zip(&body.mesh.nodes) {
            *x = turn * *rest + shift;
        }
        assert!(
            body.turn().dot(turn).abs() > 1.0 - 1e-12,
            "{:?}",
            body.turn()
        );
        // Bent besides: a wave through its nodes' velocities, which the changes keep.
        for (v, x) in body.velocities.iter_mut().zip(&body.positions) {
            *v = DVec3::new((40.0 * x.y).sin(), (30.0 * x.z).cos(), (20.0 * x.x).sin()) * 0.01;
        }
        let centre = body.centre();
        let before = momenta(&body, centre);
        let (impulse, at) = (
            DVec3::new(0.002, -0.001, 0.003),
            centre + DVec3::new(0.01, 0.02, -0.005),
        );
        body.give_impulse(impulse, at);
        let after = momenta(&body, centre);
        assert!((after.0 - before.0 - impulse).length() < 1e-15);
        let moment = (at - centre).cross(impulse);
        assert!((after.1 - before.1 - moment).length() < 1e-15);
        let (velocity, spin) = (DVec3::new(0.1, 0.2, -0.3), DVec3::new(1.0, -2.0, 0.5));
        body.set_motion(velocity, spin);
        assert!((body.velocity() - velocity).length() < 1e-12);
        assert!((body.spin() - spin).length() < 1e-12);
    }
}
