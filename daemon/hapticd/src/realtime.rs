//! The real-time thread that runs a [`HapticLoop`] on time.
//!
//! This thread is real-time: `SCHED_FIFO | SCHED_RESET_ON_FORK`, at the configured priority
//! clamped to what the system allows (and if refused, it runs anyway and says so). (A
//! multi-rate scene's physics thread is too, at priority 1, off this thread's CPU, while its
//! steps fit its budget: the physics budget (`physics_budget.rs`).)
//! It sleeps with `clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME)` on absolute deadlines,
//! records WAIT/BUSY/overruns, and talks to the rest of the daemon only through lock-free
//! triple buffers and rings. When asked to stop it writes zero currents before it exits.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicI32, AtomicU64, Ordering};
use std::thread::JoinHandle;

use hapticd_core::haptic_loop::{DeviceState, FaultCause, Frame, HapticLoop, LoopCommand, Retired};
use hapticd_core::scene::output_check::OutputFault;
use hapticd_core::stats::LoopStats;
use hapticd_core::sync::spsc;
use hapticd_core::sync::triple_buffer::{self, Reader};
use hapticd_core::telemetry::TelemetryWriter;
use hapticd_core::world_state::WorldWriter;

use hapticd_device::guardian::Heartbeat;

use hapticd_service::clock::{monotonic_ns, sleep_until};

/// How the loop should run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RealtimeSettings {
    /// SCHED_FIFO priority wanted (1–99).
    pub priority: i32,
    /// Ticks per second.
    pub rate: f64,
    /// The CPU the thread keeps to (see [`crate::cpus`]), or None for any.
    pub cpu: Option<usize>,
}

/// What the scheduler granted.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Scheduling {
    /// SCHED_FIFO at this priority.
    Fifo(i32),
    /// Real-time scheduling was refused; the loop runs as an ordinary thread.
    Refused(String),
}

/// Something the real-time thread wants logged, passed by value through a ring.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LoopEvent {
    /// The device state changed at `time`.
    State {
        /// Loop time, seconds.
        time: f64,
        /// The new state.
        state: DeviceState,
        /// The transport error, if any.
        error: Option<hapticd_core::transport::TransportError>,
        /// Why, when the new state is a fault.
        fault: FaultCause,
    },
    /// The scene's plugin was disabled at `time` for what it output.
    SceneFault {
        /// Loop time, seconds.
        time: f64,
        /// What was wrong.
        fault: OutputFault,
    },
    /// A tick ended after the next deadline.
    Overrun {
        /// Loop time, seconds.
        time: f64,
        /// How late, nanoseconds.
        late_ns: u64,
        /// How late the tick woke, nanoseconds.
        woke_ns: u64,
        /// How long it then took, nanoseconds.
        busy_ns: u64,
    },
}

/// The rings between the real-time thread and the rest of the daemon.
pub struct Channels {
    /// Events to log.
    pub events: spsc::Producer<LoopEvent>,
    /// Every frame, when recording.
    pub recorder: Option<spsc::Producer<Frame>>,
    /// Commands to apply between ticks.
    pub commands: spsc::Consumer<LoopCommand>,
    /// Scenes and links replaced, to be freed off the real-time thread.
    pub retired: spsc::Producer<Retired>,
    /// The world's picture for the renderer, written [`WORLD_RATE`] times a second.
    pub world: Option<WorldWriter>,
    /// Every tick, for readers outside the daemon.
    pub telemetry: Option<TelemetryWriter>,
    /// The beat the guardian watches: a loop that drives and stops ticking is ended.
    pub heartbeat: Option<Heartbeat>,
    /// Where the haptic thread writes its thread id as it starts: the logger reads its page
    /// faults from /proc when it logs an overrun.
    pub thread_id: Arc<AtomicI32>,
}

/// Pictures of the world per second: the renderer's frame rate.
pub const WORLD_RATE: f64 = 60.0;

/// A running real-time loop.
pub struct RealtimeLoop {
    stop: Arc<AtomicBool>,
    heartbeat: Arc<AtomicU64>,
    stats: Reader<LoopStats>,
    frames: Reader<Frame>,
    thread: Option<JoinHandle<HapticLoop>>,
    scheduling: Scheduling,
    pinned: Option<std::io::Result<usize>>,
}

/// Make the calling thread SCHED_FIFO at `priority`, or as close as the system allows.
pub(crate) fn become_realtime(priority: i32) -> Scheduling {
    let set = |priority: i32| {
        let param = libc::sched_param {
            sched_priority: priority,
        };
        // SAFETY: pid 0 is the calling thread; param is valid for the call.
        let r = unsafe {
            libc::sched_setscheduler(0, libc::SCHED_FIFO | libc::SCHED_RESET_ON_FORK, &param)
        };
        if r == 0 {
            Ok(())
        } else {
            Err(std::io::Error::last_os_error())
        }
    };
    // SAFETY: a pure query.
    let max = unsafe { libc::sched_get_priority_max(libc::SCHED_FIFO) }.max(1);
    let wanted = priority.clamp(1, max);
    match set(wanted) {
        Ok(()) => Scheduling::Fifo(wanted),
        Err(first) => {
            let mut limit = libc::rlimit {
                rlim_cur: 0,
                rlim_max: 0,
            };
            // SAFETY: getrlimit writes one rlimit to a valid pointer.
            unsafe { libc::getrlimit(libc::RLIMIT_RTPRIO, &mut limit) };
            let allowed = limit.rlim_cur.min(max as libc::rlim_t) as i32;
            if allowed >= 1 && allowed < wanted && set(allowed).is_ok() {
                return Scheduling::Fifo(allowed);
            }
            Scheduling::Refused(format!(
                "SCHED_FIFO priority {wanted} refused ({first}); RLIMIT_RTPRIO is {}: grant \
                 CAP_SYS_NICE or raise LimitRTPRIO=",
                limit.rlim_cur
            ))
        }
    }
}

/// Make the calling thread an ordinary one again (SCHED_OTHER).
pub(crate) fn become_ordinary() {
    let param = libc::sched_param { sched_priority: 0 };
    // SAFETY: pid 0 is the calling thread; param is valid for the call. Lowering one's own
    // scheduling cannot be refused.
    unsafe { libc::sched_setscheduler(0, libc::SCHED_OTHER, &param) };
}

/// How long a real-time thread may compute without blocking before the kernel sends
/// SIGXCPU (RLIMIT_RTTIME, `LimitRTTIME=` of the unit), nanoseconds; None when unlimited.
pub(crate) fn realtime_budget_ns() -> Option<u64> {
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes one rlimit to a valid pointer.
    let known = unsafe { libc::getrlimit(libc::RLIMIT_RTTIME, &mut limit) } == 0;
    (known && limit.rlim_cur != libc::RLIM_INFINITY).then(|| limit.rlim_cur.saturating_mul(1000))
}

/// Ask the kernel's PM QoS to keep CPUs out of deep idle states while the returned file stays
/// open: waking from them costs tens of microseconds of latency, every tick (cyclictest does
/// the same). `None` when not permitted.
pub fn hold_low_cpu_latency() -> Option<std::fs::File> {
    use std::io::Write;
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/cpu_dma_latency")
        .ok()?;
    file.write_all(&0i32.to_ne_bytes()).ok()?;
    Some(file)
}

/// The page faults, minor and major, thread `tid` of this process has taken (None when it
/// has no such thread, as before the haptic thread has said its id). Read from /proc, off
/// the haptic thread.
pub fn thread_faults(tid: i32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/self/task/{tid}/stat")).ok()?;
    // The fields after the command's closing parenthesis: state is the 3rd, minflt the 10th,
    // majflt the 12th.
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let field = |n: usize| fields.get(n - 3)?.parse::<u64>().ok();
    Some(field(10)? + field(12)?)
}

/// Touch a generous slice of stack now, so the loop never page-faults on it later.
#[inline(never)]
fn prefault_stack() {
    let mut block = [0u8; 256 * 1024];
    std::hint::black_box(&mut block);
}

/// [rt] Tick `haptic` on time until `stop` is set, sharing every frame; then zero the motors.
fn run_loop(
    mut haptic: HapticLoop,
    rate: f64,
    channels: Channels,
    (mut stats_writer, mut frame_writer): (
        triple_buffer::Writer<LoopStats>,
        triple_buffer::Writer<Frame>,
    ),
    stop: &AtomicBool,
    beat: &AtomicU64,
) -> HapticLoop {
    let Channels {
        mut events,
        mut recorder,
        mut commands,
        mut retired,
        mut world,
        mut telemetry,
        heartbeat: guardian_beat,
        thread_id,
    } = channels;
    let period_ns = (1e9 / rate).round() as u64;
    let period = period_ns as f64 * 1e-9;
    // Stats reach the daemon at 10 Hz, however long the ticks take.
    const PUBLISH_NS: u64 = 100_000_000;
    let world_ns = (1e9 / WORLD_RATE) as u64;
    let mut stats = LoopStats::default();
    let mut state = DeviceState::Running;
    // The scene (by its switch count) whose fault was reported.
    let mut reported = None;
    // SAFETY: gettid takes nothing and cannot fail; called once, before the first sleep.
    thread_id.store(unsafe { libc::gettid() }, Ordering::Release);
    let mut next = monotonic_ns();
    let mut published = next;
    let mut pictured = next;
    while !stop.load(Ordering::Acquire) {
        next += period_ns;
        sleep_until(next);
        let woke = monotonic_ns();
        while let Some(command) = commands.pop() {
            haptic.command(command);
        }
        let frame = *haptic.tick(period);
        if let Some(old) = haptic.take_retired()
            && let Err(old) = retired.try_push(old)
        {
            haptic.keep_retired(old);
        }
        frame_writer.publish(|f| *f = frame);
        if let Some(t) = telemetry.as_mut() {
            t.write(&frame);
        }
        if let Some(r) = recorder.as_mut() {
            r.push(frame);
        }
        if let Some(w) = world.as_mut()
            && woke - pictured >= world_ns
        {
            w.capture(&mut haptic, rate);
            pictured = woke;
        }
        report(&mut events, &haptic, &frame, &mut reported, &mut state);
        let done = monotonic_ns();
        // Taken before a skip moves `next`: the late wakes are the ones that matter.
        let wait_ns = woke.saturating_sub(next);
        let overrun = done > next + period_ns;
        if overrun {
            events.push(LoopEvent::Overrun {
                time: frame.time,
                late_ns: done - next - period_ns,
                woke_ns: wait_ns,
                busy_ns: done - woke,
            });
            // Skip the missed deadlines instead of racing to catch up.
            next += (done - next) / period_ns * period_ns;
        }
        stats.record(wait_ns, done - woke, overrun);
        if done - published >= PUBLISH_NS {
            stats_writer.publish(|s| *s = stats);
            published = done;
        }
        beat.store(stats.ticks, Ordering::Release);
        if let Some(b) = &guardian_beat {
            b.beat(stats.ticks);
        }
    }
    let _ = haptic.zero_motors();
    if let Some(b) = &guardian_beat {
        b.rest();
    }
    stats_writer.publish(|s| *s = stats);
    frame_writer.publish(|f| *f = *haptic.frame());
    haptic
}

/// [rt] Send the scene's fault (once a scene) and the device's state when they change.
#[inline]
fn report(
    events: &mut spsc::Producer<LoopEvent>,
    haptic: &HapticLoop,
    frame: &Frame,
    reported: &mut Option<u32>,
    state: &mut DeviceState,
) {
    // Once per scene: its fault never changes once it is found.
    if let Some(fault) = haptic.scene().fault()
        && *reported != Some(frame.scene_switches)
    {
        *reported = Some(frame.scene_switches);
        events.push(LoopEvent::SceneFault {
            time: frame.time,
            fault,
        });
    }
    if frame.state != *state {
        *state = frame.state;
        events.push(LoopEvent::State {
            time: frame.time,
            state: *state,
            error: frame.error,
            fault: frame.fault,
        });
    }
}

impl RealtimeLoop {
    /// Start `haptic` on its own thread, talking through `channels`.
    pub fn start(
        haptic: HapticLoop,
        settings: RealtimeSettings,
        channels: Channels,
    ) -> std::io::Result<Self> {
        let stop = Arc::new(AtomicBool::new(false));
        let heartbeat = Arc::new(AtomicU64::new(0));
        let (stats_writer, stats) = triple_buffer::triple_buffer(LoopStats::default());
        let (frame_writer, frames) = triple_buffer::triple_buffer(*haptic.frame());
        let (granted, scheduling) = std::sync::mpsc::channel();
        let (stop_flag, beat) = (stop.clone(), heartbeat.clone());
        let thread = std::thread::Builder::new()
            .name("hapticd-rt".into())
            .stack_size(2 * 1024 * 1024)
            .spawn(move || {
                let scheduling = become_realtime(settings.priority);
                let pinned = settings
                    .cpu
                    .map(|cpu| hapticd_service::cpus::pin(0, &[cpu]).map(|()| cpu));
                let _ = granted.send((scheduling, pinned));
                prefault_stack();
                let writers = (stats_writer, frame_writer);
                run_loop(haptic, settings.rate, channels, writers, &stop_flag, &beat)
            })?;
        let (scheduling, pinned) = scheduling.recv().unwrap_or_else(|_| {
            (
                Scheduling::Refused("the real-time thread did not start".into()),
                None,
            )
        });
        Ok(Self {
            stop,
            heartbeat,
            stats,
            frames,
            thread: Some(thread),
            scheduling,
            pinned,
        })
    }

    /// The CPU the thread keeps to, or why it could not (None: it was not asked to).
    pub fn pinned(&self) -> Option<&std::io::Result<usize>> {
        self.pinned.as_ref()
    }

    /// What the scheduler granted.
    pub fn scheduling(&self) -> &Scheduling {
        &self.scheduling
    }

    /// Ticks run so far; advances while the loop is alive.
    pub fn heartbeat(&self) -> u64 {
        self.heartbeat.load(Ordering::Acquire)
    }

    /// The latest statistics (updated at 10 Hz).
    pub fn stats(&mut self) -> &LoopStats {
        self.stats.latest()
    }

    /// The latest frame.
    pub fn frame(&mut self) -> &Frame {
        self.frames.latest()
    }

    /// Stop the loop (it writes zero currents first); its statistics to the last tick.
    pub fn stop(mut self) -> LoopStats {
        self.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        // The thread published its last statistics before it returned.
        *self.stats.latest()
    }
}

impl Drop for RealtimeLoop {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
