//! When an effect acts, and how strongly: it waits `start` seconds, rises over its attack,
//! holds for its `duration` (or until removed), and falls over its fade. No ramp is shorter
//! than the effect's strongest force over the force-rate limit, so starting and stopping an
//! effect never step the force faster than that limit.

/// An effect's timing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Envelope {
    /// Seconds from when the effect is added until it begins.
    pub start: f64,
    /// Seconds it holds at full strength once risen (infinite: until removed).
    pub duration: f64,
    /// Seconds it takes to rise to full strength.
    pub attack: f64,
    /// Seconds it takes to fall to nothing.
    pub fade: f64,
}

impl Default for Envelope {
    fn default() -> Self {
        Self {
            start: 0.0,
            duration: f64::INFINITY,
            attack: 0.0,
            fade: 0.0,
        }
    }
}

impl Envelope {
    /// Whether every time is a number of seconds from 0 (the duration may be infinite).
    pub fn is_valid(&self) -> bool {
        let time = |t: f64| t.is_finite() && t >= 0.0;
        time(self.start) && time(self.attack) && time(self.fade) && self.duration >= 0.0
    }

    /// The envelope with its ramps no shorter than `peak` newtons over `rate` N/s.
    pub fn within_rate(&self, peak: f64, rate: f64) -> Envelope {
        let shortest = if rate > 0.0 { peak / rate } else { 0.0 };
        Envelope {
            attack: self.attack.max(shortest),
            fade: self.fade.max(shortest),
            ..*self
        }
    }

    /// Its strength `t` seconds after it was added, from 0 to 1; `stopped`: the time it was
    /// told to stop at, if it was.
    pub fn gain(&self, t: f64, stopped: Option<f64>) -> f64 {
        let rising = |t: f64| {
            let since = t - self.start;
            match since {
                s if s <= 0.0 => 0.0,
                s if self.attack > 0.0 => (s / self.attack).min(1.0),
                _ => 1.0,
            }
        };
        // It falls from where it was when told to stop, or once its duration is over.
        let falling_from = self.falling_from(stopped);
        if t <= falling_from {
            return rising(t);
        }
        let left = if self.fade > 0.0 {
            (1.0 - (t - falling_from) / self.fade).max(0.0)
        } else {
            0.0
        };
        rising(falling_from) * left
    }

    /// When it begins to fall: told to stop, or its duration over.
    fn falling_from(&self, stopped: Option<f64>) -> f64 {
        let ends = self.start + self.attack + self.duration;
        stopped.map_or(ends, |s| s.min(ends))
    }

    /// Whether it has faded out for good `t` seconds after it was added.
    pub fn is_over(&self, t: f64, stopped: Option<f64>) -> bool {
        t > self.falling_from(stopped) + self.fade
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn it_waits_rises_holds_and_falls() {
        let e = Envelope {
            start: 1.0,
            duration: 2.0,
            attack: 0.5,
            fade: 0.25,
        };
        assert_eq!(e.gain(0.5, None), 0.0);
        assert!((e.gain(1.25, None) - 0.5).abs() < 1e-15);
        assert_eq!(e.gain(2.0, None), 1.0);
        assert_eq!(e.gain(3.5, None), 1.0);
        assert!((e.gain(3.625, None) - 0.5).abs() < 1e-12);
        assert_eq!(e.gain(3.8, None), 0.0);
        assert!(e.is_over(3.8, None) && !e.is_over(3.6, None));
        // Stopped while rising: it falls from where it got to, never jumps up.
        let stopped = Some(1.25);
        assert!((e.gain(1.25, stopped) - 0.5).abs() < 1e-12);
        assert!((e.gain(1.3125, stopped) - 0.375).abs() < 1e-12);
        assert_eq!(e.gain(1.6, stopped), 0.0);
    }

    #[test]
    fn ramps_are_never_shorter_than_the_rate_limit_allows() {
        let e = Envelope::default().within_rate(8.0, 1000.0);
        assert_eq!((e.attack, e.fade), (0.008, 0.008));
        let slow = Envelope {
            attack: 0.5,
            ..Envelope::default()
        }
        .within_rate(8.0, 1000.0);
        assert_eq!(slow.attack, 0.5);
    }
}
