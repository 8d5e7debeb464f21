//! The budget of a multi-rate scene's physics thread: when it may be real-time, and how long
//! it rests between steps.
//!
//! A physics thread runs `SCHED_FIFO` (lowest priority) off the haptic CPUs, so that a busy
//! machine cannot starve it into stale planes. That is only safe while its steps are short:
//! a real-time thread that computes most of the time starves every ordinary thread on its CPU
//! (the kernel leaves them 5 %), the bus and the supervisor included. So the thread is
//! real-time only while its steps, on average over a window of them, take at most half its
//! period (and, when `RLIMIT_RTTIME` is limited, each under a quarter of it: past that the
//! kernel sends SIGXCPU). A world that stops fitting is made an ordinary thread again, and
//! said so once; it becomes real-time again only once it takes under a quarter of its period
//! (hysteresis: a world on the edge does not flip); as an ordinary thread it then yields to
//! the others on its CPU (nice 10). Whatever its scheduling, the thread rests
//! after each step at least as long as the step computed: a world too large for its rate
//! runs slower, using at most about half a CPU, instead of leaving the CPU a sliver. (CPU
//! time, not time on the clock: a plugin that waits, or a thread that others held off its
//! CPU, has left the CPU to others already.)

use std::fmt;

use crate::realtime::{Scheduling, become_ordinary, become_realtime, realtime_budget_ns};
use hapticd_service::clock::{monotonic_ns, sleep_until};

/// SCHED_FIFO priority of a physics thread: the lowest, above every ordinary task and below
/// every haptic thread.
pub const PHYSICS_PRIORITY: i32 = 1;

/// The nice value of a physics thread once its world was found too large: the ordinary
/// threads on its CPU (the daemon's bus and supervisor among them) come first.
pub const TOO_LARGE_NICE: i32 = 10;

/// Steps not judged at the start: building a world's broad phase makes its first steps slow.
const WARM_UP_STEPS: u32 = 3;

/// The window steps are judged over spans about this long, nanoseconds...
const WINDOW_NS: u64 = 250_000_000;

/// ...and holds at least this many steps (a slow rate)...
const MIN_WINDOW: usize = 4;

/// ...and at most this many (a fast one).
const MAX_WINDOW: usize = 64;

/// A world that was found too large for its rate: what the log says about it, once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TooLarge {
    /// The steps' mean CPU time over the window, nanoseconds.
    pub step_ns: u64,
    /// The world's period, nanoseconds.
    pub period_ns: u64,
}

impl TooLarge {
    /// The rate the world gets as an ordinary thread that rests as long as it steps, Hz.
    pub fn rate(&self) -> f64 {
        1e9 / self.period_ns.max(2 * self.step_ns) as f64
    }
}

impl fmt::Display for TooLarge {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "the world is too large for its rate: steps take {:.1} ms of a {:.1} ms period; \
             running it as an ordinary thread (nice {TOO_LARGE_NICE}) at about {:.0} Hz",
            self.step_ns as f64 * 1e-6,
            self.period_ns as f64 * 1e-6,
            self.rate()
        )
    }
}

/// What a physics thread is to do after a step, as [`PhysicsBudget::judge`] decides.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Verdict {
    /// Switch to real-time (true) or to an ordinary thread (false); None: stay as it is.
    pub switch: Option<bool>,
    /// The world was found too large for its rate, the first time.
    pub too_large: Option<TooLarge>,
}

/// The policy of one physics thread, on the times it is told (no clock, no system call).
#[derive(Debug, Clone)]
pub struct PhysicsBudget {
    period_ns: u64,
    /// A step's mean over the window may take this long for the thread to run real-time.
    fit_ns: u64,
    /// RLIMIT_RTTIME, when limited.
    rttime_ns: Option<u64>,
    warm_up: u32,
    /// The last steps' CPU times, a ring of `len` of which `filled` are in.
    window: [u64; MAX_WINDOW],
    len: usize,
    filled: usize,
    at: usize,
    sum: u64,
    realtime: bool,
    /// Once found too large, it must fit in half the budget to be real-time again.
    too_large_once: bool,
    /// Real-time scheduling was refused: it is not asked for again.
    refused: bool,
    /// The deadline of the step the thread rests for.
    next_ns: u64,
}

impl PhysicsBudget {
    /// The budget of a world stepped every `period_ns` from `now_ns` on, in a process whose
    /// RLIMIT_RTTIME is `rttime_ns` (None: unlimited). It starts as an ordinary thread.
    pub fn new(period_ns: u64, rttime_ns: Option<u64>, now_ns: u64) -> Self {
        let period_ns = period_ns.max(1);
        let len = ((WINDOW_NS / period_ns) as usize).clamp(MIN_WINDOW, MAX_WINDOW);
        Self {
            period_ns,
            fit_ns: period_ns / 2,
            rttime_ns,
            warm_up: WARM_UP_STEPS,
            window: [0; MAX_WINDOW],
            len,
            filled: 0,
            at: 0,
            sum: 0,
            realtime: false,
            too_large_once: false,
            refused: false,
            next_ns: now_ns,
        }
    }

    /// Whether the thread is (meant to be) real-time now.
    pub fn realtime(&self) -> bool {
        self.realtime
    }

    /// Real-time scheduling was asked for and refused: the thread stays ordinary, and does
    /// not ask again.
    pub fn refused(&mut self) {
        (self.realtime, self.refused) = (false, true);
    }

    /// Judge the window after a step that cost the thread `cpu_ns` of CPU time.
    pub fn judge(&mut self, cpu_ns: u64) -> Verdict {
        if self.warm_up > 0 {
            self.warm_up -= 1;
            return Verdict::default();
        }
        self.sum = self.sum - self.window[self.at] + cpu_ns;
        self.window[self.at] = cpu_ns;
        self.at = (self.at + 1) % self.len;
        self.filled = (self.filled + 1).min(self.len);
        let mut verdict = Verdict::default();
        // A part-filled window is judged too once its steps alone are over the budget of the
        // whole: a world far too large is said at once, not a window later.
        let len = self.len as u64;
        let over_rttime = self.rttime_ns.is_some_and(|limit| {
            self.window[..self.filled]
                .iter()
                .any(|&step| step >= limit / 4)
        });
        if self.sum > len * self.fit_ns || over_rttime {
            if !self.too_large_once {
                self.too_large_once = true;
                verdict.too_large = Some(TooLarge {
                    step_ns: self.sum / self.filled as u64,
                    period_ns: self.period_ns,
                });
            }
            if self.realtime {
                self.realtime = false;
                verdict.switch = Some(false);
            }
        } else if !self.realtime && !self.refused && self.filled == self.len {
            let fit = if self.too_large_once {
                self.fit_ns / 2
            } else {
                self.fit_ns
            };
            if self.sum <= len * fit {
                self.realtime = true;
                verdict.switch = Some(true);
            }
        }
        verdict
    }

    /// When to wake for the next step, now at `now_ns` after `worked_ns` of CPU time since
    /// the thread last woke: the next deadline, or, where that leaves less rest than the
    /// work took, as much rest as the work (a world behind its rate steps from then on,
    /// instead of catching up). Also whether the world fell behind its rate.
    pub fn wake(&mut self, now_ns: u64, worked_ns: u64) -> (u64, bool) {
        self.next_ns += self.period_ns;
        let rested = now_ns + worked_ns;
        let behind = self.next_ns < rested;
        if behind {
            self.next_ns = rested;
        }
        (self.next_ns, behind)
    }
}

/// [physics] Give the calling thread the nice value [`TOO_LARGE_NICE`] (kept from then on:
/// the nice value does not matter to it while it is real-time).
fn yield_to_others() {
    // SAFETY: plain system calls; a thread id names only the calling thread. A refusal
    // leaves it at its nice value, which is safe.
    unsafe {
        libc::setpriority(
            libc::PRIO_PROCESS,
            libc::gettid() as libc::id_t,
            TOO_LARGE_NICE,
        )
    };
}

/// CPU time the calling thread has used, nanoseconds: what its work cost, however much
/// other threads preempted it.
pub(crate) fn thread_cpu_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec to a valid pointer.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// A physics thread's budget applied: its scheduling switched, the one line said, its rests
/// slept. Made and used on the physics thread (it reads that thread's CPU clock).
pub struct Pacer {
    scene: String,
    budget: PhysicsBudget,
    /// The thread's CPU time when it last woke.
    cpu_ns: u64,
}

impl Pacer {
    /// The pacing of scene `scene`'s world, stepped every `period_ns` from now.
    pub fn new(scene: String, period_ns: u64) -> Self {
        Self {
            scene,
            budget: PhysicsBudget::new(period_ns, realtime_budget_ns(), monotonic_ns()),
            cpu_ns: thread_cpu_ns(),
        }
    }

    /// After a step, before its publishing: switch the scheduling as the budget says (and say
    /// once that the world is too large). Returns whether the world, found too large once, is
    /// stepped by an ordinary thread that yields to others, which the set published tells the haptic side.
    pub fn judge(&mut self) -> bool {
        let verdict = self.budget.judge(thread_cpu_ns() - self.cpu_ns);
        match verdict.switch {
            Some(true) if !matches!(become_realtime(PHYSICS_PRIORITY), Scheduling::Fifo(_)) => {
                self.budget.refused()
            }
            Some(false) => become_ordinary(),
            _ => {}
        }
        if let Some(news) = verdict.too_large {
            yield_to_others();
            tracing::warn!("scene {}: {news}", self.scene);
        }
        self.budget.too_large_once && !self.budget.realtime()
    }

    /// After the publishing: sleep until the next step is due. Returns whether the world fell
    /// behind its rate.
    pub fn rest(&mut self) -> bool {
        let worked = thread_cpu_ns() - self.cpu_ns;
        let (wake, behind) = self.budget.wake(monotonic_ns(), worked);
        sleep_until(wake);
        self.cpu_ns = thread_cpu_ns();
        behind
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    /// A 1 kHz world (window of 64 steps) past its warm-up.
    fn warmed(rttime_ns: Option<u64>) -> PhysicsBudget {
        let mut b = PhysicsBudget::new(MS, rttime_ns, 0);
        for _ in 0..WARM_UP_STEPS {
            assert_eq!(b.judge(100 * MS), Verdict::default());
        }
        b
    }

    #[test]
    fn the_window_spans_a_quarter_second_within_its_bounds() {
        assert_eq!(PhysicsBudget::new(MS, None, 0).len, 64);
        assert_eq!(PhysicsBudget::new(10 * MS, None, 0).len, 25);
        assert_eq!(PhysicsBudget::new(100 * MS, None, 0).len, 4);
    }

    #[test]
    fn a_world_that_fits_half_its_period_turns_real_time_after_a_full_window() {
        let mut b = warmed(None);
        for _ in 0..63 {
            assert_eq!(b.judge(MS / 2), Verdict::default());
        }
        let v = b.judge(MS / 2);
        assert_eq!(v.switch, Some(true));
        assert!(b.realtime());
        assert_eq!(b.judge(MS / 2), Verdict::default());
    }

    #[test]
    fn one_long_step_among_short_ones_is_averaged_not_judged_alone() {
        let mut b = warmed(None);
        for _ in 0..64 {
            b.judge(MS / 10);
        }
        assert!(b.realtime());
        // 64 × 0.5 ms of budget, 63 × 0.1 ms used: one step of 25 ms still fits.
        assert_eq!(b.judge(25 * MS), Verdict::default());
        assert!(b.realtime());
    }

    #[test]
    fn a_world_too_large_is_said_once_and_never_real_time_whatever_the_rttime() {
        let mut b = warmed(None);
        // Two 20 ms steps are more than the whole window's 32 ms.
        assert_eq!(b.judge(20 * MS), Verdict::default());
        let v = b.judge(20 * MS);
        let news = v.too_large.unwrap();
        assert_eq!(v.switch, None, "it never was real-time");
        assert_eq!(
            news,
            TooLarge {
                step_ns: 20 * MS,
                period_ns: MS
            }
        );
        assert_eq!(news.rate(), 25.0);
        assert_eq!(
            news.to_string(),
            "the world is too large for its rate: steps take 20.0 ms of a 1.0 ms period; \
             running it as an ordinary thread (nice 10) at about 25 Hz"
        );
        for _ in 0..1000 {
            assert_eq!(b.judge(20 * MS), Verdict::default());
        }
        assert!(!b.realtime());
    }

    #[test]
    fn a_real_time_world_that_grows_is_demoted_and_promoted_back_only_well_under_budget() {
        let mut b = warmed(None);
        for _ in 0..64 {
            b.judge(MS / 4);
        }
        assert!(b.realtime());
        // 0.6 ms a step: the window (16 ms of its 32 ms budget used) goes over at the 46th,
        // each adding 0.35 ms.
        for _ in 0..45 {
            assert_eq!(b.judge(6 * MS / 10), Verdict::default());
        }
        let v = b.judge(6 * MS / 10);
        assert_eq!(v.switch, Some(false));
        assert!(v.too_large.is_some());
        // Back to 0.4 ms, within half the period: not real-time again (that takes 0.25 ms).
        for _ in 0..200 {
            assert_eq!(b.judge(4 * MS / 10), Verdict::default());
        }
        // Steps of 0.2 ms bring the window from 25.6 ms to 16 ms at the 48th.
        for _ in 0..47 {
            assert_eq!(b.judge(2 * MS / 10), Verdict::default());
        }
        let v = b.judge(2 * MS / 10);
        assert_eq!(
            v,
            Verdict {
                switch: Some(true),
                too_large: None
            }
        );
        // Growing again demotes it again, without a second word: from a window of 0.2 ms
        // steps (12.8 ms), 1 ms steps pass 32 ms at the 25th.
        for _ in 0..64 {
            b.judge(2 * MS / 10);
        }
        let demoted = (0..100).find_map(|k| {
            let v = b.judge(MS);
            assert_eq!(v.too_large, None);
            v.switch.map(|s| (k, s))
        });
        assert_eq!(demoted, Some((24, false)));
    }

    #[test]
    fn with_rlimit_rttime_each_step_must_fit_a_quarter_of_it() {
        let mut b = PhysicsBudget::new(100 * MS, Some(200 * MS), 0);
        for _ in 0..WARM_UP_STEPS {
            b.judge(0);
        }
        for _ in 0..4 {
            b.judge(49 * MS);
        }
        assert!(
            b.realtime(),
            "49 ms fits half of 100 ms and a quarter of 200 ms"
        );
        let v = b.judge(50 * MS);
        assert_eq!(v.switch, Some(false), "50 ms is a quarter of RLIMIT_RTTIME");
        assert!(v.too_large.is_some());
    }

    #[test]
    fn a_refused_thread_is_not_asked_again() {
        let mut b = warmed(None);
        for _ in 0..64 {
            b.judge(MS / 10);
        }
        assert!(b.realtime());
        b.refused();
        for _ in 0..200 {
            assert_eq!(b.judge(MS / 10), Verdict::default());
        }
        assert!(!b.realtime());
    }

    #[test]
    fn a_step_that_waited_instead_of_computing_steps_again_at_once() {
        let mut b = PhysicsBudget::new(20 * MS, None, 0);
        // The plugin slept a second in its step, computing 1 ms: it is behind, and goes on
        // 1 ms later, not a second later.
        assert_eq!(b.wake(1000 * MS, MS), (1001 * MS, true));
        assert_eq!(b.wake(1002 * MS, MS), (1021 * MS, false));
    }

    #[test]
    fn a_world_on_time_keeps_its_deadlines() {
        let mut b = PhysicsBudget::new(MS, None, 1000 * MS);
        // 0.3 ms of work, ending 0.3 ms past the start: wake at the next period.
        assert_eq!(
            b.wake(1000 * MS + 3 * MS / 10, 3 * MS / 10),
            (1001 * MS, false)
        );
        // Half a period of work, ending at half a period: still on time.
        assert_eq!(b.wake(1001 * MS + MS / 2, MS / 2), (1002 * MS, false));
    }

    #[test]
    fn a_world_behind_rests_as_long_as_it_worked() {
        let mut b = PhysicsBudget::new(MS, None, 0);
        // A 20 ms step: rest 20 ms, not a tenth of a period.
        assert_eq!(b.wake(20 * MS, 20 * MS), (40 * MS, true));
        // 0.6 ms of work leaves only 0.4 ms to the deadline: rest 0.6 ms.
        assert_eq!(
            b.wake(40 * MS + 6 * MS / 10, 6 * MS / 10),
            (41 * MS + 2 * MS / 10, true)
        );
        // From there on the deadlines follow the new start.
        assert_eq!(
            b.wake(41 * MS + 3 * MS / 10, MS / 10),
            (42 * MS + 2 * MS / 10, false)
        );
    }
}
