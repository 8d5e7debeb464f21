//! Encoder counters: hardware counters are 16 or 24 bits wide and wrap; software keeps
//! 64-bit totals by adding the wrapped difference between reads.

/// Unwraps an `bits`-bit hardware counter into a 64-bit count.
///
/// Correct as long as the counter moves less than half its range between two reads
/// (32768 counts for 16 bits: over 0.5 m of string per millisecond).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Unwrapper {
    bits: u32,
    last: Option<u32>,
    total: i64,
}

impl Unwrapper {
    /// An unwrapper for a counter of `bits` bits (at most 32).
    pub const fn new(bits: u32) -> Self {
        Self {
            bits,
            last: None,
            total: 0,
        }
    }

    /// Feed the raw counter value; returns the unwrapped total (the first read is the origin
    /// of the total, taken as the raw value sign-extended).
    pub fn update(&mut self, raw: u32) -> i64 {
        let mask = if self.bits == 32 {
            u32::MAX
        } else {
            (1 << self.bits) - 1
        };
        let raw = raw & mask;
        match self.last {
            None => self.total = sign_extend(raw, self.bits),
            Some(last) => {
                let delta = sign_extend(raw.wrapping_sub(last) & mask, self.bits);
                self.total += delta;
            }
        }
        self.last = Some(raw);
        self.total
    }

    /// Forget the history: the next read becomes the origin again (after a counter clear).
    pub fn reset(&mut self) {
        self.last = None;
        self.total = 0;
    }
}

/// Interpret the low `bits` bits of `raw` as two's complement.
pub fn sign_extend(raw: u32, bits: u32) -> i64 {
    let shift = 64 - bits;
    ((raw as i64) << shift) >> shift
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sixteen_bit_counters_unwrap_across_the_wrap() {
        let mut u = Unwrapper::new(16);
        assert_eq!(u.update(65530), -6);
        assert_eq!(u.update(4), 4); // +10 across the wrap
        assert_eq!(u.update(65535), -1); // −5 back across it
        let mut total = u.update(0);
        // A long walk in steps below half the range keeps an exact total.
        for _ in 0..100 {
            let raw = (total + 30000).rem_euclid(65536) as u32;
            total = u.update(raw);
        }
        assert_eq!(total, 100 * 30000);
    }

    #[test]
    fn twenty_four_bit_values_sign_extend() {
        assert_eq!(sign_extend(0xFF_FFFF, 24), -1);
        assert_eq!(sign_extend(0x80_0000, 24), -(1 << 23));
        assert_eq!(sign_extend(0x7F_FFFF, 24), (1 << 23) - 1);
        let mut u = Unwrapper::new(24);
        assert_eq!(u.update(0xFF_FFFE), -2);
        assert_eq!(u.update(3), 3);
    }
}
