//! How often the log may say a thing that can happen again and again: the first gets a line;
//! what keeps happening gets a count per interval, not a line each (a world too slow for its
//! rate once flipped a device into fault 1 840 times in 40 s, an ERROR each; any peer of a
//! world host could fill the journal with a new host name a message).

/// The interval events are counted over after one was said, seconds.
pub const INTERVAL: f64 = 10.0;

/// Events of one kind, said or counted (times on any steady clock, seconds).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogLines {
    interval: f64,
    /// Since when events are counted instead of said; None: the next one is said.
    counting_since: Option<f64>,
    counted: u32,
}

impl LogLines {
    /// Events said at most once per `interval` seconds, the others counted.
    pub const fn new(interval: f64) -> Self {
        Self {
            interval,
            counting_since: None,
            counted: 0,
        }
    }

    /// An event at `now`: whether to say it (else it is counted for [`LogLines::summary`]).
    pub fn event(&mut self, now: f64) -> bool {
        if self.counting_since.is_some() {
            self.counted += 1;
            return false;
        }
        (self.counting_since, self.counted) = (Some(now), 0);
        true
    }

    /// The events counted in the interval that ended by `now`, once it has, if any. Counting
    /// goes on over another interval after a count (it still happens); after an interval
    /// without one, the next event is said again.
    pub fn summary(&mut self, now: f64) -> Option<u32> {
        let since = self.counting_since?;
        if now - since < self.interval {
            return None;
        }
        let counted = std::mem::take(&mut self.counted);
        self.counting_since = (counted > 0).then_some(now);
        (counted > 0).then_some(counted)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_single_event_is_said_and_nothing_follows() {
        let mut lines = LogLines::new(10.0);
        assert!(lines.event(1.0));
        assert_eq!(lines.summary(5.0), None);
        assert_eq!(lines.summary(11.0), None);
        // The interval passed quietly: the next fault is said again.
        assert!(lines.event(30.0));
    }

    #[test]
    fn what_keeps_happening_is_counted_per_interval() {
        let mut lines = LogLines::new(10.0);
        assert!(lines.event(0.0));
        // A fault every 20 ms for 40 s: one line, then a count every 10 s.
        let mut said = 1;
        let mut counts = Vec::new();
        for k in 1..2000 {
            let now = k as f64 / 50.0;
            counts.extend(lines.summary(now));
            said += lines.event(now) as u32;
        }
        counts.extend(lines.summary(40.0));
        assert_eq!(said, 1);
        assert_eq!(counts, [499, 500, 500, 500]);
        // It stopped flapping: one more quiet interval, and a new fault is said.
        assert_eq!(lines.summary(50.0), None);
        assert!(lines.event(51.0));
    }
}
