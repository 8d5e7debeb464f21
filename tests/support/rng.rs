//! The seeded random numbers every test draws its cases from (the physics tests include
//! this file too), so a failing case can be drawn again.

use glam::{DQuat, DVec3};

/// SplitMix64: deterministic, seedable, good enough to draw test cases.
pub struct Rng(u64);

impl Rng {
    /// A generator with its own seed.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform direction.
    pub fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let n = v.length();
            if n > 0.1 && n <= 1.0 {
                return v / n;
            }
        }
    }

    /// Vector with every component uniform in [−a, a].
    pub fn cube(&mut self, a: f64) -> DVec3 {
        DVec3::new(self.range(-a, a), self.range(-a, a), self.range(-a, a))
    }

    /// Rotation about a random axis by an angle uniform in [0, max].
    pub fn rotation(&mut self, max: f64) -> DQuat {
        DQuat::from_axis_angle(self.unit(), self.range(0.0, max))
    }
}
