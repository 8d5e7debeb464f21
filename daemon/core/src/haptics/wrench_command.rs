//! A wrench commanded from outside the daemon and added to what the scene displays: what a
//! teleoperated robot feels, sent back to the hand that drives it.
//!
//! The command arrives in a small block of shared memory a privileged program writes (the
//! network bridge, `Device.OpenWrenchInput` on the bus): one wrench per effector under a
//! sequence lock. The haptic thread reads it each tick without waiting: a block being written
//! is read at the next tick, and a writer that holds the lock keeps its command from ever
//! arriving, which makes it stale. Nothing the writer puts there is trusted: a non-finite
//! component zeroes the command, every wrench is bounded by the force and torque limits, it
//! ramps in over the guard's resume time when it starts or resumes, and when no new command has
//! arrived for [`STALE_AFTER`] it is stale: it ramps out fast and is flagged until a new one
//! arrives. The scene's wrench and the command then pass through the safety guard together.

use std::sync::atomic::{AtomicU64, Ordering, fence};

use crate::haptics::safety::SafetyLimits;
use crate::kinematics::{MAX_EFFECTORS, Wrench, clamp_length};
use crate::shared_header::{Header, WrongLayout};

/// First bytes of a command block.
pub const MAGIC: [u8; 8] = *b"hapticdC";

/// Layout version of [`SharedWrenchCommand`].
pub const VERSION: u32 = 1;

/// A command older than this is stale, seconds: it ramps out.
pub const STALE_AFTER: f64 = 0.1;

/// Time for a stale command to ramp out, seconds.
pub const STALE_RAMP: f64 = 0.02;

/// Attempts to read a block being written before this tick goes without.
const READ_ATTEMPTS: usize = 4;

/// The shared block: its header, the sequence lock (odd while being written) and each
/// effector's force and torque as the bits of six doubles.
#[repr(C)]
pub struct SharedWrenchCommand {
    header: Header,
    sequence: AtomicU64,
    wrenches: [[AtomicU64; 6]; MAX_EFFECTORS],
}

/// Bytes of a command block.
pub const SHARED_SIZE: usize = std::mem::size_of::<SharedWrenchCommand>();

impl SharedWrenchCommand {
    /// Initialise the block at `block`: its header, sequence 0, no wrench.
    ///
    /// # Safety
    /// `block` is valid for writes of [`SHARED_SIZE`] bytes and aligned.
    pub unsafe fn init(block: *mut SharedWrenchCommand) {
        // SAFETY: as the caller promises; the block holds only plain integers.
        unsafe {
            block.write_bytes(0, 1);
            std::ptr::addr_of_mut!((*block).header).write(Header::new(MAGIC, VERSION, SHARED_SIZE));
        }
    }

    /// The block at `block` of `len` bytes, checked to be a command block of this layout.
    ///
    /// # Safety
    /// `block` is valid for reads of `len` bytes, aligned, and stays mapped while the
    /// reference is used.
    pub unsafe fn at<'a>(
        block: *const SharedWrenchCommand,
        len: usize,
    ) -> Result<&'a SharedWrenchCommand, WrongLayout> {
        // SAFETY: as the caller promises.
        unsafe {
            Header::new(MAGIC, VERSION, SHARED_SIZE).check(
                block.cast::<Header>(),
                len,
                "a wrench command",
            )?;
            Ok(&*block)
        }
    }

    /// [writer] Command `wrenches`, one per effector (the rest zero).
    pub fn write(&self, wrenches: &[Wrench]) {
        let s = self.sequence.load(Ordering::Relaxed);
        self.sequence.store(s | 1, Ordering::Relaxed);
        fence(Ordering::Release);
        for (k, slot) in self.wrenches.iter().enumerate() {
            let w = wrenches.get(k).copied().unwrap_or(Wrench::ZERO).to_array();
            for (c, v) in slot.iter().zip(w) {
                c.store(v.to_bits(), Ordering::Relaxed);
            }
        }
        self.sequence.store((s | 1) + 1, Ordering::Release);
    }

    /// [rt] The sequence number and wrenches of the last command written, or None while one
    /// is being written.
    fn read(&self, out: &mut [Wrench; MAX_EFFECTORS]) -> Option<u64> {
        for _ in 0..READ_ATTEMPTS {
            let before = self.sequence.load(Ordering::Acquire);
            if before & 1 == 1 {
                std::hint::spin_loop();
                continue;
            }
            for (w, slot) in out.iter_mut().zip(&self.wrenches) {
                let c: [f64; 6] =
                    std::array::from_fn(|i| f64::from_bits(slot[i].load(Ordering::Relaxed)));
                *w = Wrench::from_array(c);
            }
            fence(Ordering::Acquire);
            if self.sequence.load(Ordering::Relaxed) == before {
                return Some(before);
            }
        }
        None
    }
}

/// Where a command comes from: a block that stays mapped as long as its owner lives (the
/// daemon's mapping of the descriptor it handed out).
pub trait WrenchSource: Send {
    /// The block.
    fn block(&self) -> &SharedWrenchCommand;
}

/// What became of the command, as the loop reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CommandState {
    /// No command input was opened.
    #[default]
    None,
    /// Opened, nothing written yet.
    Waiting,
    /// Fresh commands arrive.
    Active,
    /// None arrived for [`STALE_AFTER`], or the last was not finite: ramped out.
    Stale,
}

impl CommandState {
    /// The state in one word, as the bus says it.
    pub fn name(self) -> &'static str {
        match self {
            CommandState::None => "none",
            CommandState::Waiting => "waiting",
            CommandState::Active => "active",
            CommandState::Stale => "stale",
        }
    }
}

/// The commanded wrench of one device, tick by tick.
pub struct WrenchCommand {
    source: Option<Box<dyn WrenchSource>>,
    sequence: u64,
    age: f64,
    gain: f64,
    target: [Wrench; MAX_EFFECTORS],
    state: CommandState,
}

impl Default for WrenchCommand {
    fn default() -> Self {
        Self::new()
    }
}

impl WrenchCommand {
    /// No command.
    pub fn new() -> Self {
        Self {
            source: None,
            sequence: 0,
            age: 0.0,
            gain: 0.0,
            target: [Wrench::ZERO; MAX_EFFECTORS],
            state: CommandState::None,
        }
    }

    /// [rt] Take commands from `source` from now on, waiting for its first (what was
    /// commanded before ramps out meanwhile); the source it replaces, to be freed elsewhere.
    pub fn replace(&mut self, source: Box<dyn WrenchSource>) -> Option<Box<dyn WrenchSource>> {
        self.sequence = source.block().sequence.load(Ordering::Acquire);
        self.age = 0.0;
        self.state = CommandState::Waiting;
        self.source.replace(source)
    }

    /// What became of the command at the last tick.
    pub fn state(&self) -> CommandState {
        self.state
    }

    /// [rt] One tick of `dt` seconds: read the block, and write each effector's commanded
    /// wrench into `out`, bounded by `limits`' force and torque and ramped in over their
    /// resume time.
    pub fn update(&mut self, dt: f64, limits: &SafetyLimits, out: &mut [Wrench]) {
        out.fill(Wrench::ZERO);
        let Some(source) = &self.source else {
            return;
        };
        let mut read = [Wrench::ZERO; MAX_EFFECTORS];
        self.age += dt;
        if let Some(sequence) = source.block().read(&mut read)
            && sequence != self.sequence
        {
            self.sequence = sequence;
            if read.iter().all(Wrench::is_finite) {
                self.age = 0.0;
                for (t, r) in self.target.iter_mut().zip(read) {
                    *t = Wrench {
                        force: clamp_length(r.force, limits.max_force),
                        torque: clamp_length(r.torque, limits.max_torque),
                    };
                }
                self.state = CommandState::Active;
            } else {
                // A command with a NaN in it is no command: stale at once.
                self.state = CommandState::Stale;
            }
        }
        if self.state == CommandState::Active && self.age > STALE_AFTER {
            self.state = CommandState::Stale;
        }
        self.gain = if self.state == CommandState::Active {
            (self.gain + dt / limits.resume_ramp).min(1.0)
        } else {
            (self.gain - dt / STALE_RAMP).max(0.0)
        };
        for (o, t) in out.iter_mut().zip(&self.target) {
            *o = *t * self.gain;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use std::sync::Arc;

    struct Held(Arc<SharedWrenchCommand>);

    impl WrenchSource for Held {
        fn block(&self) -> &SharedWrenchCommand {
            &self.0
        }
    }

    fn block() -> Arc<SharedWrenchCommand> {
        let mut b = Box::<SharedWrenchCommand>::new_uninit();
        // SAFETY: the box holds one aligned block, initialised here before use.
        unsafe {
            SharedWrenchCommand::init(b.as_mut_ptr());
            Arc::from(b.assume_init())
        }
    }

    /// A block, and a command reading it.
    fn reading_a_block() -> (Arc<SharedWrenchCommand>, WrenchCommand) {
        let shared = block();
        let mut command = WrenchCommand::new();
        assert!(command.replace(Box::new(Held(shared.clone()))).is_none());
        (shared, command)
    }

    const DT: f64 = 1e-3;

    /// The command of effector 0 after `ticks` ticks, `write` called before each.
    fn run(
        command: &mut WrenchCommand,
        ticks: usize,
        mut write: impl FnMut(usize),
    ) -> Vec<(Wrench, CommandState)> {
        let limits = SafetyLimits::default();
        let mut out = [Wrench::ZERO; 2];
        (0..ticks)
            .map(|k| {
                write(k);
                command.update(DT, &limits, &mut out);
                (out[0], command.state())
            })
            .collect()
    }

    fn push(newtons: f64) -> Wrench {
        Wrench::force(DVec3::new(0.0, newtons, 0.0))
    }

    #[test]
    fn a_command_ramps_in_and_stays_while_it_keeps_coming() {
        let (shared, mut command) = reading_a_block();
        let seen = run(&mut command, 400, |_| shared.write(&[push(3.0)]));
        let resume = SafetyLimits::default().resume_ramp;
        // A ramp over the resume time: a third of the way after a third of it.
        let third = (resume / 3.0 / DT) as usize;
        assert!(
            (seen[third].0.force.y - 1.0).abs() < 0.05,
            "{:?}",
            seen[third]
        );
        for pair in seen.windows(2) {
            assert!(pair[1].0.force.y >= pair[0].0.force.y);
        }
        assert_eq!(seen[399], (push(3.0), CommandState::Active));
    }

    #[test]
    fn a_command_that_stops_coming_goes_stale_and_ramps_out() {
        let (shared, mut command) = reading_a_block();
        run(&mut command, 300, |_| shared.write(&[push(3.0)]));
        let seen = run(&mut command, 200, |_| {});
        let stale_at = seen
            .iter()
            .position(|(_, s)| *s == CommandState::Stale)
            .unwrap();
        assert!(
            (stale_at as f64 * DT - STALE_AFTER).abs() < 2.0 * DT,
            "{stale_at}"
        );
        assert_eq!(seen[stale_at - 1].0, push(3.0), "full until stale");
        let gone = stale_at + (STALE_RAMP / DT) as usize + 1;
        assert_eq!(seen[gone].0, Wrench::ZERO);
        // A new command brings it back, ramped in again.
        let back = run(&mut command, 2, |_| shared.write(&[push(3.0)]));
        assert_eq!(back[1].1, CommandState::Active);
        assert!(back[1].0.force.y < 0.1);
    }

    #[test]
    fn hostile_commands_are_bounded_or_dropped() {
        let (shared, mut command) = reading_a_block();
        let limits = SafetyLimits::default();
        let huge = Wrench::from_array([0.0, 1e300, 0.0, 0.0, 0.0, -1e300]);
        let seen = run(&mut command, 400, |_| shared.write(&[huge]));
        let last = seen[399].0;
        assert!(
            (last.force.length() - limits.max_force).abs() < 1e-9,
            "{last:?}"
        );
        assert!(
            (last.torque.length() - limits.max_torque).abs() < 1e-9,
            "{last:?}"
        );
        // A NaN anywhere: stale at once, ramped out, never passed on.
        let nan = Wrench::from_array([0.0, 1.0, f64::NAN, 0.0, 0.0, 0.0]);
        let seen = run(&mut command, 40, |_| shared.write(&[push(1.0), nan]));
        assert_eq!(seen[0].1, CommandState::Stale);
        assert!(seen.iter().all(|(w, _)| w.is_finite()));
        assert_eq!(seen[39].0, Wrench::ZERO);
    }

    #[test]
    fn a_writer_that_holds_the_lock_sends_nothing() {
        let (shared, mut command) = reading_a_block();
        run(&mut command, 300, |_| shared.write(&[push(2.0)]));
        // Odd for ever: as a writer that died mid-write leaves it.
        shared.sequence.fetch_or(1, Ordering::Release);
        let seen = run(&mut command, 200, |_| {});
        assert_eq!(seen[199], (Wrench::ZERO, CommandState::Stale));
    }

    #[test]
    fn a_new_source_starts_from_nothing_and_hands_back_the_old() {
        let (first, second) = (block(), block());
        let mut command = WrenchCommand::new();
        command.replace(Box::new(Held(first.clone())));
        run(&mut command, 300, |_| first.write(&[push(2.0)]));
        assert!(command.replace(Box::new(Held(second.clone()))).is_some());
        // The old writer goes on; it is no longer read.
        let seen = run(&mut command, 100, |_| first.write(&[push(5.0)]));
        assert_eq!(seen[99], (Wrench::ZERO, CommandState::Waiting));
        let no_source = run(&mut WrenchCommand::new(), 1, |_| {});
        assert_eq!(no_source[0], (Wrench::ZERO, CommandState::None));
    }
}
