//! How a locally moved body answers an impulse: by its mass and inertia when free, through
//! its joints when held by them (a door pushed at its handle swings as a mass I/r² would
//! and does not move along its hinge).

use glam::{DMat3, DVec3};
use hapticd_plugin_api::HapticdMobility;

/// The 6×6 mobility of a body as four 3×3 blocks: an impulse `p` and an angular impulse
/// `l` (about the centre of mass at the published state) change the centre's velocity by
/// `linear·p + coupling·l` and the spin by `couplingᵀ·p + angular·l`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mobility {
    linear: DMat3,
    coupling: DMat3,
    angular: DMat3,
    /// The acceleration without the hand or contacts: the centre's and the spin's.
    acceleration: (DVec3, DVec3),
    /// A free body's inverse mass; None when joints hold the body: its velocity field then
    /// turns with it (a door swung on keeps its hinge still), where a free body's centre
    /// keeps its velocity.
    free: Option<f64>,
}

impl Mobility {
    /// A free body of `inverse_mass` and `inverse_inertia` (world axes), accelerated by
    /// `gravity`.
    pub fn free(inverse_mass: f64, inverse_inertia: DMat3, gravity: DVec3) -> Self {
        Mobility {
            linear: DMat3::from_diagonal(DVec3::splat(inverse_mass)),
            coupling: DMat3::ZERO,
            angular: inverse_inertia,
            acceleration: (gravity, DVec3::ZERO),
            free: Some(inverse_mass),
        }
    }

    /// A jointed body as the plugin describes it; None when a number of it is not finite,
    /// or the matrix is not symmetric or has a negative diagonal (no body answers a push by
    /// moving against it).
    pub fn jointed(m: &HapticdMobility) -> Option<Self> {
        let at = |row: usize, column: usize| m.mobility[row][column];
        let block = |row: usize, column: usize| {
            DMat3::from_cols_array_2d(
                &[0, 1, 2].map(|c| [0, 1, 2].map(|r| at(row + r, column + c))),
            )
        };
        let scale = (0..6).map(|k| at(k, k).abs()).fold(0.0, f64::max);
        let symmetric = (0..6).all(|r| (0..6).all(|c| (at(r, c) - at(c, r)).abs() <= 1e-6 * scale));
        let finite = m
            .mobility
            .iter()
            .flatten()
            .chain(&m.acceleration)
            .all(|x| x.is_finite());
        let positive = (0..6).all(|k| at(k, k) >= 0.0);
        (finite && symmetric && positive).then(|| Mobility {
            linear: block(0, 0),
            coupling: block(0, 3),
            angular: block(3, 3),
            acceleration: (
                DVec3::from_slice(&m.acceleration[..3]),
                DVec3::from_slice(&m.acceleration[3..]),
            ),
            free: None,
        })
    }

    /// The change of (centre's velocity, spin) an impulse `p` and an angular impulse `l`
    /// about the centre give, the centre `shift` away from where it was published: a
    /// jointed body's mobility holds about the point its centre was published at, as the
    /// joints were then; a free body's about its centre wherever it is.
    pub fn respond(&self, p: DVec3, l: DVec3, shift: DVec3) -> (DVec3, DVec3) {
        let shift = self.lever(shift);
        let l = l + shift.cross(p);
        let spin = self.coupling.transpose() * p + self.angular * l;
        (
            self.linear * p + self.coupling * l + spin.cross(shift),
            spin,
        )
    }

    /// The change an impulse of 1 N·s along `direction` at `r` from the centre gives, the
    /// centre `shift` away from where it was published, and the point's inverse mass along
    /// it (0: the joints hold it; a free body's reckoned as it always was).
    pub fn unit(&self, r: DVec3, direction: DVec3, shift: DVec3) -> (DVec3, DVec3, f64) {
        let arm = r.cross(direction);
        let (v, w) = self.respond(direction, arm, shift);
        let inverse = match self.free {
            Some(inverse_mass) => inverse_mass + arm.dot(w),
            None => (v + w.cross(r)).dot(direction),
        };
        (v, w, inverse.max(0.0))
    }

    /// The change of the centre's velocity an impulse of `amount` along `direction` gives,
    /// `moves` being what a unit one gives ([`Mobility::unit`]). A free body's is reckoned
    /// as it always was, to the last bit: the motion of a body tipped over by a finger
    /// follows its rounding.
    pub fn moved(&self, direction: DVec3, moves: DVec3, amount: f64) -> DVec3 {
        match self.free {
            Some(inverse_mass) => direction * (amount * inverse_mass),
            None => moves * amount,
        }
    }

    /// The acceleration without the hand or contacts, the centre `shift` away from where it
    /// was published.
    pub fn acceleration(&self, shift: DVec3) -> (DVec3, DVec3) {
        let (linear, angular) = self.acceleration;
        (linear + angular.cross(self.lever(shift)), angular)
    }

    /// How far the centre is from the point the mobility holds about.
    fn lever(&self, shift: DVec3) -> DVec3 {
        if self.free.is_none() {
            shift
        } else {
            DVec3::ZERO
        }
    }

    /// How much faster than the hand a push may send the point it pushes. The proxy's
    /// spring gives back what it stored: struck by a hand of any mass, a body leaves at up
    /// to twice its speed (an elastic strike off a moving wall), and a door swung open at
    /// its handle does (measured at 1 kHz physics, `hapticctl experiment door`). A jointed
    /// body may: its joints keep it where it is. A free body is held to the hand's speed,
    /// lest a light one under a deep finger be thrown across the scene.
    pub fn release(&self) -> f64 {
        if self.free.is_none() { 2.0 } else { 1.0 }
    }

    /// Whether joints hold the body.
    pub fn is_jointed(&self) -> bool {
        self.free.is_none()
    }
}
