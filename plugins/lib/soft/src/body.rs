//! A soft body: its nodes where they are and how fast they move, their lumped masses and
//! pins, and what each element keeps of its rest shape (its corners' barycentric gradients,
//! its volume) and of its last turn.

use glam::{DMat3, DQuat, DVec3};

use crate::element::{MOST_NODES, Order, barycentric_gradients, signed_volume};
use crate::lattice::TetMesh;
use crate::material::Material;
use crate::rotation;

/// A soft body.
#[derive(Debug, Clone)]
pub struct SoftBody {
    /// Its mesh as it was cut: nodes at rest, elements, surface.
    pub mesh: TetMesh,
    /// What it is made of.
    pub material: Material,
    /// Each node now, m.
    pub positions: Vec<DVec3>,
    /// Each node's velocity, m/s.
    pub velocities: Vec<DVec3>,
    /// Each node's lumped mass, kg.
    pub masses: Vec<f64>,
    /// Nodes held where they are.
    pub pinned: Vec<bool>,
    /// Forces on the nodes for the next step alone (the hand's), N.
    pub forces: Vec<DVec3>,
    /// The velocity each pinned node moves at over the next step, m/s: zero for one held
    /// to the world, its body's for one held to a moving body.
    pub pin_velocities: Vec<DVec3>,
    /// Where asked for (not empty), the impulse each pinned node gave what holds it over
    /// the last step, N·s (zero at the free ones).
    pub reactions: Vec<DVec3>,
    /// Each element's corners' barycentric gradients at rest.
    pub(crate) gradients: Vec<[DVec3; 4]>,
    /// Each element's volume at rest, m³.
    pub(crate) volumes: Vec<f64>,
    /// Each element's turn from rest, as last found.
    pub(crate) turns: Vec<DQuat>,
    /// The same turns as matrices, made once a step for the step's many products.
    pub(crate) rotations: Vec<DMat3>,
    /// Each element's deformation gradient as its turn was last found from it (a step's
    /// positions do not change until its end).
    pub(crate) deformations: Vec<DMat3>,
    /// Each node's stiffness along itself, a third of its block's trace (N/m): the
    /// solver's preconditioner.
    pub(crate) own_stiffness: Vec<f64>,
    /// The material's λ and μ, Pa.
    pub(crate) lame: [f64; 2],
}

impl SoftBody {
    /// The body of `mesh`, at rest, made of `material`.
    pub fn new(mesh: TetMesh, material: Material) -> SoftBody {
        let count = mesh.nodes.len();
        let order = mesh.order;
        let (mut gradients, mut volumes) = (Vec::new(), Vec::new());
        let mut masses = vec![0.0; count];
        for e in 0..mesh.element_count() {
            let nodes = mesh.element(e);
            let corners = [0, 1, 2, 3].map(|k| mesh.nodes[nodes[k] as usize]);
            let (g, volume) = barycentric_gradients(corners);
            for (k, &n) in nodes.iter().enumerate() {
                masses[n as usize] += material.density * volume * order.mass_share(k);
            }
            gradients.push(g);
            volumes.push(volume);
        }
        let (lambda, mu) = (material.lambda(), material.mu());
        let mut body = SoftBody {
            positions: mesh.nodes.clone(),
            velocities: vec![DVec3::ZERO; count],
            pinned: vec![false; count],
            forces: vec![DVec3::ZERO; count],
            pin_velocities: vec![DVec3::ZERO; count],
            reactions: Vec::new(),
            turns: vec![DQuat::IDENTITY; volumes.len()],
            rotations: vec![DMat3::IDENTITY; volumes.len()],
            deformations: vec![DMat3::IDENTITY; volumes.len()],
            mesh,
            material,
            masses,
            gradients,
            volumes,
            own_stiffness: vec![0.0; count],
            lame: [lambda, mu],
        };
        body.weigh_own_stiffness();
        body
    }

    /// Each node's stiffness along itself, from the material's λ and μ.
    fn weigh_own_stiffness(&mut self) {
        let [lambda, mu] = self.lame;
        // Taken out while the elements are read (an empty vector holds no memory).
        let mut own = std::mem::take(&mut self.own_stiffness);
        own.fill(0.0);
        for e in 0..self.volumes.len() {
            let nodes = self.mesh.element(e);
            self.each_point(e, |shape, w| {
                for (k, &n) in nodes.iter().enumerate() {
                    own[n as usize] += w * (lambda + 4.0 * mu) * shape[k].length_squared() / 3.0;
                }
            });
        }
        self.own_stiffness = own;
    }

    /// Node `i`'s stiffness along itself, N/m: how hard it is held back, moved alone.
    pub fn own_stiffness(&self, i: usize) -> f64 {
        self.own_stiffness[i]
    }

    /// Make it of Young's modulus `young` (Pa), Poisson's ratio `poisson` and damping
    /// `damping` (s), its density, shape and motion kept. Allocates nothing.
    pub fn set_material(&mut self, young: f64, poisson: f64, damping: f64) {
        self.material = Material {
            young,
            poisson,
            damping,
            ..self.material
        };
        self.lame = [self.material.lambda(), self.material.mu()];
        self.weigh_own_stiffness();
    }

    /// Hold still (`held`) or let go the nodes that stand where `normal`·x ≤ `offset` now;
    /// how many changed.
    pub fn pin_where(&mut self, normal: DVec3, offset: f64, held: bool) -> usize {
        let mut changed = 0;
        for (pin, x) in self.pinned.iter_mut().zip(&self.positions) {
            if normal.dot(*x) <= offset && *pin != held {
                *pin = held;
                changed += 1;
            }
        }
        changed
    }

    /// Pin the nodes at or below `value` along `axis` (0, 1, 2: x, y, z) at rest.
    pub fn pin_below(&mut self, axis: usize, value: f64) {
        for (pin, node) in self.pinned.iter_mut().zip(&self.mesh.nodes) {
            *pin |= node[axis] <= value + 1e-12;
        }
    }

    /// Its whole mass, kg.
    pub fn mass(&self) -> f64 {
        self.masses.iter().sum()
    }

    /// Its kinetic energy, J.
    pub fn kinetic_energy(&self) -> f64 {
        self.masses
            .iter()
            .zip(&self.velocities)
            .map(|(m, v)| 0.5 * m * v.length_squared())
            .sum()
    }

    /// Its elastic energy as its elements stand now, each taken along with the rotation
    /// nearest its deformation, J: μ·‖ε‖² + λ/2·(J − 1)² over its volume (see
    /// [`SoftBody::stress_at`]).
    pub fn elastic_energy(&self) -> f64 {
        let [lambda, mu] = self.lame;
        let mut energy = 0.0;
        for e in 0..self.volumes.len() {
            let (mut turn, mut matrix) = (self.turns[e], self.rotations[e]);
            rotation::follow(
                &self.deformation(e),
                &mut turn,
                &mut matrix,
                rotation::TURNS,
                0.0,
            );
            let back = matrix.transpose();
            let (u, n) = self.displacements(e, &back, &self.positions, true);
            self.each_point(e, |shape, w| {
                let h = gradient_at(&u[..n], shape);
                let strain = (h + h.transpose()) * 0.5;
                let squared = [strain.x_axis, strain.y_axis, strain.z_axis]
                    .iter()
                    .map(|c| c.length_squared())
                    .sum::<f64>();
                let j = (strain + DMat3::IDENTITY).determinant();
                energy += w * (mu * squared + 0.5 * lambda * (j - 1.0) * (j - 1.0));
            });
        }
        energy
    }

    /// Its centre of mass now, m.
    pub fn centre(&self) -> DVec3 {
        self.mean(&self.positions)
    }

    /// The mean of `field` over its nodes, each weighed by its mass.
    pub(crate) fn mean(&self, field: &[DVec3]) -> DVec3 {
        let sum: DVec3 = field.iter().zip(&self.masses).map(|(x, m)| *x * *m).sum();
        sum / self.mass()
    }

    /// Its volume now, m³ (each element's corners; a quadratic element's bulges left out).
    pub fn volume(&self) -> f64 {
        (0..self.volumes.len())
            .map(|e| {
                let nodes = self.mesh.element(e);
                signed_volume([0, 1, 2, 3].map(|k| self.positions[nodes[k] as usize]))
            })
            .sum()
    }

    /// Its volume at rest, m³ (each element's corners, as [`SoftBody::volume`] takes them).
    pub fn rest_volume(&self) -> f64 {
        self.volumes.iter().sum()
    }

    /// Turn each element's rotation toward its deformation now, `turns` times at most and
    /// no more once a turn was smaller than `settled` (rad).
    pub(crate) fn follow_turns(&mut self, turns: usize, settled: f64) {
        for e in 0..self.volumes.len() {
            let f = self.deformation(e);
            rotation::follow(
                &f,
                &mut self.turns[e],
                &mut self.rotations[e],
                turns,
                settled,
            );
            self.deformations[e] = f;
        }
    }

    /// Element `e`'s deformation gradient now, from its corners.
    fn deformation(&self, e: usize) -> DMat3 {
        self.gradient_of(e, &self.positions)
    }

    /// Σ field(corner k) ⊗ ∇λₖ over element `e`'s corners: the gradient of `field` over a
    /// linear element (of its positions, its deformation gradient), from its corners'
    /// differences from the first (the gradients sum to zero).
    pub(crate) fn gradient_of(&self, e: usize, field: &[DVec3]) -> DMat3 {
        let nodes = self.mesh.element(e);
        let g = &self.gradients[e];
        let first = field[nodes[0] as usize];
        let mut f = DMat3::ZERO;
        for k in 1..4 {
            let d = field[nodes[k] as usize] - first;
            f += DMat3::from_cols(d * g[k].x, d * g[k].y, d * g[k].z);
        }
        f
    }

    /// Element `e`'s nodes of `field` taken back into its rest frame (turned back by
    /// `turn`'s inverse, `back`), less their rest positions where `from_rest`; and how many
    /// nodes it has.
    pub(crate) fn displacements(
        &self,
        e: usize,
        back: &DMat3,
        field: &[DVec3],
        from_rest: bool,
    ) -> ([DVec3; MOST_NODES], usize) {
        let nodes = self.mesh.element(e);
        let mut u = [DVec3::ZERO; MOST_NODES];
        for (k, &n) in nodes.iter().enumerate() {
            u[k] = back * field[n as usize];
            if from_rest {
                u[k] -= self.mesh.nodes[n as usize];
            }
        }
        (u, nodes.len())
    }

    /// Element `e`'s stiffness times its nodes' displacements `u` (its rest frame), into
    /// `out`: each node's share of ∫ σ(ε(u)) ∇N, σ linear in u.
    pub(crate) fn stiffness_times(
        &self,
        e: usize,
        u: &[DVec3; MOST_NODES],
        out: &mut [DVec3; MOST_NODES],
    ) {
        let n = self.mesh.order.nodes();
        self.element_forces_of(e, out, |shape| {
            self.linear_stress(&gradient_at(&u[..n], shape))
        });
    }

    /// Each node's share of ∫ σ ∇N over element `e` into `out`, σ at each quadrature point
    /// as `stress` gives it from the shape functions' gradients there.
    pub(crate) fn element_forces_of(
        &self,
        e: usize,
        out: &mut [DVec3; MOST_NODES],
        stress: impl Fn(&[DVec3]) -> DMat3,
    ) {
        let n = self.mesh.order.nodes();
        out[..n].fill(DVec3::ZERO);
        self.each_point(e, |shape, w| {
            let stress = stress(shape) * w;
            for k in 0..n {
                out[k] += stress * shape[k];
            }
        });
    }

    /// Each of element `e`'s quadrature points: its shape functions' gradients there, and
    /// its share of the element's volume (m³).
    fn each_point(&self, e: usize, mut at: impl FnMut(&[DVec3], f64)) {
        let order: Order = self.mesh.order;
        let (volume, n) = (self.volumes[e], order.nodes());
        if order == Order::Linear {
            // One quadrature point, the corners' own gradients.
            at(&self.gradients[e], volume);
            return;
        }
        let mut shape = [DVec3::ZERO; MOST_NODES];
        for (point, weight) in order.quadrature() {
            order.gradients(&self.gradients[e], point, &mut shape);
            at(&shape[..n], weight * volume);
        }
    }

    /// The stress of displacement gradient `h` (in the element's rest frame, its turn taken
    /// out), Pa: 2μ·ε + λ·(J − 1)·cof(I + ε), of the energy μ·‖ε‖² + λ/2·(J − 1)², ε the
    /// symmetric part of h and J = det(I + ε) the volume's ratio (the turn being the polar
    /// one, I + ε is the stretch). Its volume term is the volume's own, not the trace of ε,
    /// which under a squeeze lets the sides spread by ν of it as if that added no volume: a
    /// cube squeezed a fifth (ν = 0.45) kept 0.950 of its volume by the trace, keeps 0.974
    /// by J, as a free squeeze of this law does (a neo-Hookean solid's: 0.976). For small h
    /// it is the linear stress. Taken of ε, not of the whole gradient: with the volume of
    /// I + h the rest of a turn left in h met a compressed element's pressure, which the
    /// step's linear system does not see, and a squeezed cube began to ring after 0.6 s.
    pub(crate) fn stress_at(&self, h: &DMat3) -> DMat3 {
        let [lambda, mu] = self.lame;
        let a = (*h + h.transpose()) * 0.5 + DMat3::IDENTITY;
        let cofactor = DMat3::from_cols(
            a.y_axis.cross(a.z_axis),
            a.z_axis.cross(a.x_axis),
            a.x_axis.cross(a.y_axis),
        );
        let j = a.x_axis.dot(cofactor.x_axis);
        (*h + h.transpose()) * mu + cofactor * (lambda * (j - 1.0))
    }

    /// The linear stress of displacement gradient `h`, Pa: 2μ·ε + λ·tr(ε)·I (the stiffness
    /// the step's system and its damping take).
    pub(crate) fn linear_stress(&self, h: &DMat3) -> DMat3 {
        let [lambda, mu] = self.lame;
        let trace = h.x_axis.x + h.y_axis.y + h.z_axis.z;
        (*h + h.transpose()) * mu + DMat3::from_diagonal(DVec3::splat(lambda * trace))
    }
}

/// The gradient Σ field(k) ⊗ ∇Nₖ of a field at a point, from its values at an element's
/// nodes and their shape functions' gradients there.
pub(crate) fn gradient_at(field: &[DVec3], shape: &[DVec3]) -> DMat3 {
    let mut h = DMat3::ZERO;
    for (v, g) in field.iter().zip(shape) {
        h += DMat3::from_cols(*v * g.x, *v * g.y, *v * g.z);
    }
    h
}
