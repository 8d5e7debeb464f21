//! Loop timing statistics, like pw-top's: WAIT (how late the thread woke after its
//! deadline), BUSY (how long the tick computed), overruns, and a latency histogram.

/// Histogram buckets, one microsecond wide; the last one collects everything longer.
pub const BUCKETS: usize = 1000;

/// Timing of a real-time loop since it started.
///
/// ```
/// use hapticd_core::stats::LoopStats;
///
/// let mut stats = LoopStats::default();
/// for tick in 0..100u64 {
///     // Woke 2.5 µs late, computed for 40 µs; the last tick woke 80 µs late and overran.
///     let late = if tick == 99 { 80_000 } else { 2_500 };
///     stats.record(late, 40_000, tick == 99);
/// }
/// assert_eq!((stats.ticks, stats.overruns, stats.overruns_woken_late), (100, 1, 1));
/// assert_eq!(stats.wait_percentile_ns(0.5), 3_000); // the 1 µs bucket's upper edge
/// assert_eq!(stats.wait_max_tick, 100);
/// assert_eq!(stats.busy_mean_ns(), 40_000);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopStats {
    /// Ticks run.
    pub ticks: u64,
    /// Ticks that ended after the next deadline.
    pub overruns: u64,
    /// Of those, the ticks that woke later than they then took to compute: late from
    /// outside (the kernel, the machine), not from their own work.
    pub overruns_woken_late: u64,
    /// Longest wake-up latency, nanoseconds.
    pub wait_max_ns: u64,
    /// The tick (counted from 1) that woke that late: whether a spike comes at start-up or
    /// later tells its cause.
    pub wait_max_tick: u64,
    /// Longest tick computation, nanoseconds.
    pub busy_max_ns: u64,
    /// Sum of tick computation times, nanoseconds.
    pub busy_total_ns: u64,
    /// Wake-up latencies by microsecond.
    pub wait_histogram: [u32; BUCKETS],
}

impl Default for LoopStats {
    fn default() -> Self {
        Self {
            ticks: 0,
            overruns: 0,
            overruns_woken_late: 0,
            wait_max_ns: 0,
            wait_max_tick: 0,
            busy_max_ns: 0,
            busy_total_ns: 0,
            wait_histogram: [0; BUCKETS],
        }
    }
}

impl LoopStats {
    /// [rt] Account for one tick.
    pub fn record(&mut self, wait_ns: u64, busy_ns: u64, overrun: bool) {
        self.ticks += 1;
        self.overruns += u64::from(overrun);
        self.overruns_woken_late += u64::from(overrun && wait_ns > busy_ns);
        if wait_ns > self.wait_max_ns {
            self.wait_max_ns = wait_ns;
            self.wait_max_tick = self.ticks;
        }
        self.busy_max_ns = self.busy_max_ns.max(busy_ns);
        self.busy_total_ns += busy_ns;
        let bucket = ((wait_ns / 1000) as usize).min(BUCKETS - 1);
        self.wait_histogram[bucket] = self.wait_histogram[bucket].saturating_add(1);
    }

    /// Wake-up latency below which a fraction `p` of ticks woke, nanoseconds (bucket upper
    /// edge; the maximum for the overflow bucket).
    pub fn wait_percentile_ns(&self, p: f64) -> u64 {
        let total: u64 = self.wait_histogram.iter().map(|&c| u64::from(c)).sum();
        let wanted = (p * total as f64).ceil() as u64;
        let mut seen = 0;
        for (i, &c) in self.wait_histogram.iter().enumerate() {
            seen += u64::from(c);
            if seen >= wanted && seen > 0 {
                return if i == BUCKETS - 1 {
                    self.wait_max_ns
                } else {
                    (i as u64 + 1) * 1000
                };
            }
        }
        0
    }

    /// Mean tick computation time, nanoseconds.
    pub fn busy_mean_ns(&self) -> u64 {
        self.busy_total_ns / self.ticks.max(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_come_from_the_histogram() {
        let mut s = LoopStats::default();
        for i in 0..100u64 {
            s.record(i * 1000 + 500, 2000, i == 99);
        }
        assert_eq!(s.wait_percentile_ns(0.5), 50_000);
        assert_eq!(s.wait_percentile_ns(0.99), 99_000);
        assert_eq!(
            (s.overruns, s.busy_mean_ns(), s.wait_max_ns),
            (1, 2000, 99_500)
        );
        // The 100th tick woke latest; a later tick as late does not move it.
        assert_eq!(s.wait_max_tick, 100);
        s.record(99_500, 2000, false);
        assert_eq!(s.wait_max_tick, 100);
    }
}
