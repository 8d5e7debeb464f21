//! Every haptic tick, for programs outside the daemon: a ring of fixed-size `#[repr(C)]`
//! slots in shared memory (a sealed memfd the daemon hands out, `OpenTelemetry` on the bus)
//! that the haptic thread fills one slot a tick. Each slot has a sequence lock of its own, so
//! the writer never waits: a reader copies a slot, checks its sequence did not move and that
//! it still holds the tick it wanted, and otherwise knows that tick was overwritten (it read
//! too slowly) and how many it missed. Readers never slow the writer; they only miss slots.
//!
//! Nothing here allocates or calls the system: the daemon maps the memory and passes it in.

use std::sync::atomic::{AtomicU64, Ordering, fence};

use hapticd_plugin_api::{HAPTICD_NO_BODY, HapticdBodyPose, HapticdWrench};

use crate::haptic_loop::Frame;
use crate::kinematics::MAX_EFFECTORS;
use crate::shared_header::{Header, WrongLayout};
use crate::transport::CHANNELS;
use crate::wire::{Decoder, Encoder};
use crate::world_state::{body_pose, state_code};

/// First bytes of a telemetry ring, so that a reader knows what it mapped.
pub const MAGIC: [u8; 8] = *b"hapticdT";

/// Layout version: raised with any change to [`Sample`] or [`SharedTelemetry`].
pub const VERSION: u32 = 3;

/// Slots in the ring: 0.8 s of ticks at 10 kHz, 8 s at 1 kHz, for a reader to fall behind by
/// before it misses any.
pub const SLOTS: usize = 8192;

/// One tick as the haptic loop left it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Ticks since the loop started, from 0.
    pub tick: u64,
    /// Loop time, seconds.
    pub time: f64,
    /// The device's state, numbered as [`state_code`] numbers it.
    pub state: u32,
    /// Effectors in use.
    pub effectors: u32,
    /// Strings in use.
    pub strings: u32,
    /// Bit k set while effector k displays a force: it touches something.
    pub contacts: u32,
    /// Bit k set while effector k slides along what it touches (dynamic friction).
    pub slipping: u32,
    /// The body each effector touches (its id), or `HAPTICD_NO_BODY`: touching nothing, a
    /// solid that is no body, or a scene that cannot say.
    pub touched: [u32; MAX_EFFECTORS],
    /// Each effector's grip pose.
    pub poses: [HapticdBodyPose; MAX_EFFECTORS],
    /// Each effector's grip velocity, m/s.
    pub velocities: [[f64; 3]; MAX_EFFECTORS],
    /// Each effector's grip angular velocity, rad/s (zero for three degrees of freedom).
    pub angular_velocities: [[f64; 3]; MAX_EFFECTORS],
    /// The wrench each effector displays.
    pub wrenches: [HapticdWrench; MAX_EFFECTORS],
    /// Where each effector touches, metres.
    pub touch_points: [[f64; 3]; MAX_EFFECTORS],
    /// The outward normal of what each effector touches (zero when the scene cannot say).
    pub touch_normals: [[f64; 3]; MAX_EFFECTORS],
    /// Each string's tension, newtons.
    pub tensions: [f64; CHANNELS],
    /// Each motor's D/A value as sent.
    pub dac: [i16; CHANNELS],
}

impl Sample {
    /// No tick at all.
    pub const EMPTY: Sample = Sample {
        tick: 0,
        time: 0.0,
        state: 0,
        effectors: 0,
        strings: 0,
        contacts: 0,
        slipping: 0,
        touched: [HAPTICD_NO_BODY; MAX_EFFECTORS],
        poses: [HapticdBodyPose {
            position: [0.0; 3],
            orientation: [1.0, 0.0, 0.0, 0.0],
        }; MAX_EFFECTORS],
        velocities: [[0.0; 3]; MAX_EFFECTORS],
        angular_velocities: [[0.0; 3]; MAX_EFFECTORS],
        wrenches: [HapticdWrench {
            force: [0.0; 3],
            torque: [0.0; 3],
        }; MAX_EFFECTORS],
        touch_points: [[0.0; 3]; MAX_EFFECTORS],
        touch_normals: [[0.0; 3]; MAX_EFFECTORS],
        tensions: [0.0; CHANNELS],
        dac: [0; CHANNELS],
    };

    /// Tick number `tick` of a loop that left `frame`, as the ring would hold it.
    pub fn of(tick: u64, frame: &Frame) -> Sample {
        let mut sample = Sample::EMPTY;
        sample.fill(tick, frame);
        sample
    }

    /// [rt] Tick number `tick` of a loop that left `frame`.
    fn fill(&mut self, tick: u64, frame: &Frame) {
        self.tick = tick;
        self.time = frame.time;
        self.state = state_code(frame.state);
        self.effectors = frame.effectors as u32;
        self.strings = frame.strings as u32;
        self.contacts = 0;
        self.slipping = 0;
        for k in 0..MAX_EFFECTORS {
            let touch = &frame.touches[k];
            self.touched[k] = if touch.touching {
                touch.body
            } else {
                HAPTICD_NO_BODY
            };
            self.touch_points[k] = touch.point.to_array();
            self.touch_normals[k] = touch.normal.to_array();
            if touch.touching && touch.slipping {
                self.slipping |= 1 << k;
            }
            let wrench = &frame.wrenches[k];
            self.poses[k] = body_pose(&frame.poses[k]);
            self.velocities[k] = frame.velocities[k].to_array();
            self.angular_velocities[k] = frame.angular_velocities[k].to_array();
            self.wrenches[k] = HapticdWrench {
                force: wrench.force.to_array(),
                torque: wrench.torque.to_array(),
            };
            if k < frame.effectors && (wrench.force.length() > 0.0 || wrench.torque.length() > 0.0)
            {
                self.contacts |= 1 << k;
            }
        }
        self.tensions = frame.tensions;
        self.dac = frame.dac;
    }
}

/// One slot: its sample under its sequence.
#[repr(C)]
pub struct Slot {
    /// Even when the sample is whole, odd while it is written.
    pub sequence: AtomicU64,
    /// The sample.
    pub sample: Sample,
}

/// The shared block: a header and the ring.
#[repr(C)]
pub struct SharedTelemetry {
    /// [`MAGIC`], [`VERSION`] and [`SHARED_SIZE`].
    pub header: Header,
    /// Haptic ticks per second.
    pub rate: f64,
    /// Ticks written so far: the next tick's number.
    pub written: AtomicU64,
    /// Tick t lives in slot t mod [`SLOTS`].
    pub slots: [Slot; SLOTS],
}

/// Bytes of a telemetry ring.
pub const SHARED_SIZE: usize = std::mem::size_of::<SharedTelemetry>();

/// What a telemetry ring starts with.
const HEADER: Header = Header::new(MAGIC, VERSION, SHARED_SIZE);

/// The writing side, over a block the caller mapped.
pub struct TelemetryWriter {
    shared: *mut SharedTelemetry,
}

// SAFETY: the writer is the block's one writer; it moves to the haptic thread once.
unsafe impl Send for TelemetryWriter {}

impl TelemetryWriter {
    /// A writer over `shared` for a loop of `rate` ticks a second, which it initialises: no
    /// tick written.
    ///
    /// # Safety
    /// `shared` is valid for writes of [`SHARED_SIZE`] bytes, aligned for
    /// `SharedTelemetry`, for as long as the writer lives, and no one else writes it.
    pub unsafe fn new(shared: *mut SharedTelemetry, rate: f64) -> Self {
        // SAFETY: per this function's contract; each part written in place (the block is
        // megabytes, never passed through the stack).
        unsafe {
            use std::ptr::addr_of_mut;
            addr_of_mut!((*shared).header).write(HEADER);
            addr_of_mut!((*shared).rate).write(rate);
            addr_of_mut!((*shared).written).write(AtomicU64::new(0));
            let slots = addr_of_mut!((*shared).slots).cast::<Slot>();
            for k in 0..SLOTS {
                slots.add(k).write(Slot {
                    sequence: AtomicU64::new(0),
                    sample: Sample::EMPTY,
                });
            }
        }
        Self { shared }
    }

    /// [rt] Write the tick that left `frame` as the next one. Copies, never allocates.
    pub fn write(&mut self, frame: &Frame) {
        // SAFETY: valid for the writer's life (see `new`); readers only read.
        let shared = unsafe { &mut *self.shared };
        let tick = shared.written.load(Ordering::Relaxed);
        let slot = &mut shared.slots[(tick % SLOTS as u64) as usize];
        let sequence = slot.sequence.load(Ordering::Relaxed);
        slot.sequence.store(sequence + 1, Ordering::Relaxed);
        // The odd sequence is seen before any byte of the sample changes.
        fence(Ordering::Release);
        slot.sample.fill(tick, frame);
        slot.sequence.store(sequence + 2, Ordering::Release);
        shared.written.store(tick + 1, Ordering::Release);
    }
}

/// What reading one tick found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Read {
    /// The tick, whole, copied out.
    Whole,
    /// Not written yet.
    Ahead,
    /// Overwritten before it was read: the oldest tick the ring still holds.
    Missed {
        /// The oldest tick still in the ring.
        oldest: u64,
    },
}

/// The reading side, over a block mapped read-only.
pub struct TelemetryReader {
    shared: *const SharedTelemetry,
}

// SAFETY: the reader only reads the block, through volatile copies checked by the sequence.
unsafe impl Send for TelemetryReader {}

impl TelemetryReader {
    /// A reader over `shared`, checked to be a telemetry ring of this layout.
    ///
    /// # Safety
    /// `shared` is valid for reads of `len` bytes, aligned for `SharedTelemetry`, for as
    /// long as the reader lives.
    pub unsafe fn new(shared: *const SharedTelemetry, len: usize) -> Result<Self, WrongLayout> {
        // SAFETY: per this function's contract; the header is the block's first field.
        unsafe { HEADER.check(shared.cast::<Header>(), len, "a telemetry ring") }?;
        Ok(Self { shared })
    }

    /// Haptic ticks per second.
    pub fn rate(&self) -> f64 {
        // SAFETY: in the block (see `new`), written once before the block was shared.
        unsafe { std::ptr::addr_of!((*self.shared).rate).read_volatile() }
    }

    /// Ticks written so far: the next tick's number.
    pub fn written(&self) -> u64 {
        // SAFETY: in the block (see `new`), only used atomically.
        unsafe { &(*self.shared).written }.load(Ordering::Acquire)
    }

    /// Copy tick `tick` into `out`, if the ring still holds it whole (`out` is left as it
    /// was, or torn, otherwise).
    pub fn read(&self, tick: u64, out: &mut Sample) -> Read {
        let written = self.written();
        if tick >= written {
            return Read::Ahead;
        }
        let oldest = written.saturating_sub(SLOTS as u64 - 1);
        if tick < oldest {
            return Read::Missed { oldest };
        }
        // SAFETY: the slot lies in the block (see `new`); its sequence is only used
        // atomically and its sample only copied, the copy checked below.
        let slot = unsafe {
            std::ptr::addr_of!((*self.shared).slots)
                .cast::<Slot>()
                .add((tick % SLOTS as u64) as usize)
        };
        // SAFETY: as above.
        let sequence = unsafe { &(*slot).sequence };
        let before = sequence.load(Ordering::Acquire);
        // SAFETY: as above.
        *out = unsafe { std::ptr::addr_of!((*slot).sample).read_volatile() };
        fence(Ordering::Acquire);
        if before % 2 == 0 && sequence.load(Ordering::Relaxed) == before && out.tick == tick {
            Read::Whole
        } else {
            // Written over while read: the writer is a lap ahead.
            Read::Missed {
                oldest: self.written().saturating_sub(SLOTS as u64 - 1),
            }
        }
    }
}

/// Bytes of a sample as [`Sample::encode`] writes it.
pub const ENCODED_SIZE: usize =
    8 + 8 + 5 * 4 + MAX_EFFECTORS * (4 + 7 * 8 + 6 * 8 + 6 * 8 + 6 * 8) + CHANNELS * (8 + 2);

impl Sample {
    /// The sample as bytes for another machine: every field in order, little-endian, with no
    /// padding ([`ENCODED_SIZE`] bytes). The network bridge publishes ticks so.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Encoder::with_capacity(ENCODED_SIZE);
        out.u64(self.tick);
        out.f64s(&[self.time]);
        for v in [
            self.state,
            self.effectors,
            self.strings,
            self.contacts,
            self.slipping,
        ] {
            out.u32(v);
        }
        for k in 0..MAX_EFFECTORS {
            out.u32(self.touched[k]);
            out.f64s(&self.poses[k].position);
            out.f64s(&self.poses[k].orientation);
            out.f64s(&self.velocities[k]);
            out.f64s(&self.angular_velocities[k]);
            out.f64s(&self.wrenches[k].force);
            out.f64s(&self.wrenches[k].torque);
            out.f64s(&self.touch_points[k]);
            out.f64s(&self.touch_normals[k]);
        }
        out.f64s(&self.tensions);
        for d in &self.dac {
            out.i16(*d);
        }
        out.into_bytes()
    }

    /// A sample from the bytes [`Sample::encode`] wrote; None for any other length.
    pub fn decode(bytes: &[u8]) -> Option<Sample> {
        if bytes.len() != ENCODED_SIZE {
            return None;
        }
        let mut from = Decoder::new(bytes);
        let mut s = Sample::EMPTY;
        s.tick = from.u64()?;
        [s.time] = from.array()?;
        for v in [
            &mut s.state,
            &mut s.effectors,
            &mut s.strings,
            &mut s.contacts,
            &mut s.slipping,
        ] {
            *v = from.u32()?;
        }
        for k in 0..MAX_EFFECTORS {
            s.touched[k] = from.u32()?;
            from.f64s(&mut s.poses[k].position)?;
            from.f64s(&mut s.poses[k].orientation)?;
            from.f64s(&mut s.velocities[k])?;
            from.f64s(&mut s.angular_velocities[k])?;
            from.f64s(&mut s.wrenches[k].force)?;
            from.f64s(&mut s.wrenches[k].torque)?;
            from.f64s(&mut s.touch_points[k])?;
            from.f64s(&mut s.touch_normals[k])?;
        }
        from.f64s(&mut s.tensions)?;
        for d in &mut s.dac {
            *d = from.i16()?;
        }
        Some(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::haptic_loop::DeviceState;
    use crate::kinematics::{Pose, Wrench};
    use glam::DVec3;

    /// A block on the heap, for tests (the daemon's is a memfd).
    fn block() -> Vec<SharedTelemetryBytes> {
        (0..SHARED_SIZE.div_ceil(64))
            .map(|_| SharedTelemetryBytes([0; 64]))
            .collect()
    }

    #[repr(C, align(64))]
    struct SharedTelemetryBytes([u8; 64]);

    fn frame(k: usize) -> Frame {
        let mut frame = Frame {
            time: k as f64 * 1e-3,
            state: DeviceState::Running,
            effectors: 1,
            strings: 4,
            ..Frame::default()
        };
        frame.poses[0] = Pose {
            position: DVec3::new(k as f64, 0.0, 0.0),
            ..Pose::IDENTITY
        };
        frame.wrenches[0] = Wrench::force(DVec3::new(0.0, (k % 2) as f64, 0.0));
        frame.dac[3] = k as i16;
        frame
    }

    #[test]
    fn every_tick_is_read_back_until_the_writer_laps_the_reader() {
        let mut memory = block();
        let shared = memory.as_mut_ptr().cast::<SharedTelemetry>();
        // SAFETY: the block is SHARED_SIZE bytes or more, 64-byte aligned, and ours.
        let mut writer = unsafe { TelemetryWriter::new(shared, 1000.0) };
        // SAFETY: as above, read through the same block.
        let reader = unsafe { TelemetryReader::new(shared, SHARED_SIZE) }.unwrap();
        assert_eq!(reader.rate(), 1000.0);
        let mut s = Sample::EMPTY;
        assert_eq!(reader.read(0, &mut s), Read::Ahead);
        for k in 0..100 {
            writer.write(&frame(k));
        }
        for k in 0..100u64 {
            assert_eq!(reader.read(k, &mut s), Read::Whole, "tick {k}");
            assert_eq!(
                (s.tick, s.poses[0].position[0], s.dac[3]),
                (k, k as f64, k as i16)
            );
            assert_eq!(s.contacts, (k % 2) as u32, "tick {k}");
            assert_eq!(s.state, state_code(DeviceState::Running));
        }
        assert_eq!(reader.read(100, &mut s), Read::Ahead);
        // A lap and more later, the first ticks are gone and the reader is told from where
        // the ring holds them.
        for k in 100..SLOTS + 200 {
            writer.write(&frame(k));
        }
        let written = (SLOTS + 200) as u64;
        assert_eq!(reader.written(), written);
        let oldest = written - SLOTS as u64 + 1;
        assert_eq!(reader.read(5, &mut s), Read::Missed { oldest });
        assert_eq!(reader.read(oldest, &mut s), Read::Whole);
        assert_eq!(s.tick, oldest);
        assert_eq!(reader.read(written - 1, &mut s), Read::Whole);
        assert_eq!(s.tick, written - 1);
    }

    #[test]
    fn a_block_of_another_layout_is_refused() {
        let mut memory = block();
        let shared = memory.as_mut_ptr().cast::<SharedTelemetry>();
        // SAFETY: as in the test above.
        unsafe { TelemetryWriter::new(shared, 1000.0) };
        // SAFETY: as above.
        assert!(unsafe { TelemetryReader::new(shared, SHARED_SIZE - 1) }.is_err());
        memory[0].0[0] = b'x';
        // SAFETY: as above.
        let e = unsafe { TelemetryReader::new(shared, SHARED_SIZE) }
            .err()
            .unwrap();
        assert!(e.0.contains("not a telemetry ring"), "{e}");
    }

    #[test]
    fn a_sample_comes_back_whole_from_its_bytes() {
        let mut s = Sample::EMPTY;
        s.tick = 123_456_789_012;
        s.time = -1.5e-300;
        (s.state, s.effectors, s.strings, s.contacts, s.slipping) = (1, 2, 8, 3, 2);
        s.touched[1] = 7;
        s.poses[1].position = [0.1, f64::MAX, -0.0];
        s.poses[0].orientation = [0.5, -0.5, 0.5, -0.5];
        s.velocities[1] = [1.0, 2.0, 3.0];
        s.angular_velocities[0] = [-3.0, 0.25, f64::MAX];
        s.wrenches[0].force = [4.0, 5.0, 6.0];
        s.wrenches[1].torque = [-7.0, 8.0, f64::MIN_POSITIVE];
        s.touch_points[0] = [9.0; 3];
        s.touch_normals[1] = [0.0, 1.0, 0.0];
        s.tensions[7] = 12.5;
        s.dac[7] = i16::MIN;
        let bytes = s.encode();
        assert_eq!(bytes.len(), ENCODED_SIZE);
        assert_eq!(Sample::decode(&bytes), Some(s));
        assert_eq!(
            bytes[..8],
            123_456_789_012u64.to_le_bytes(),
            "little-endian, tick first"
        );
        assert_eq!(Sample::decode(&bytes[1..]), None);
        assert_eq!(Sample::decode(&[bytes.clone(), vec![0]].concat()), None);
    }
}
