//! The world as pictures show it: one device's bodies, pointers and strings in a fixed-size
//! `#[repr(C)]` block that the haptic thread writes into shared memory (a memfd the daemon
//! hands to the renderer process) at the renderer's frame rate, under a sequence lock: the
//! writer never waits, and a reader copies the block and copies again if a write overlapped.
//!
//! The world's solids are not here: each scene's are a block of their own, sized by the
//! scene ([`crate::world_geometry`]), which a reader asks for when `scene_switches` says
//! the scene changed.
//!
//! Nothing here allocates or calls the system: the daemon maps the memory and passes it in.

use std::sync::atomic::{AtomicU64, Ordering, fence};

use glam::DVec3;
use hapticd_plugin_api::{HapticdBodyPose, HapticdWrench};

use crate::haptic_loop::{DeviceState, HapticLoop};
use crate::kinematics::{Dof, MAX_EFFECTORS, Pose, quat_to_wxyz};
use crate::shared_header::{Header, WrongLayout};
use crate::transport::CHANNELS;

pub use crate::kinematics::pose_of;
pub use crate::scene::MAX_BODIES;

/// Most corners of deforming solids a picture shows (a larger world's are drawn as they
/// stood at load): the surfaces of the largest soft bodies a tick steps, several times over.
pub const MAX_CORNERS: usize = 8192;

/// First bytes of a shared world, so that a reader knows what it mapped.
pub const MAGIC: [u8; 8] = *b"hapticdW";

/// Layout version: raised with any change to [`WorldFrame`] or [`SharedWorld`].
pub const VERSION: u32 = 4;

/// One picture of the world.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct WorldFrame {
    /// Loop time, seconds.
    pub time: f64,
    /// Haptic ticks per second.
    pub rate: f64,
    /// [`DeviceState`] as [`state_code`] numbers it.
    pub state: u32,
    /// Scenes swapped in since start: a change means other bodies.
    pub scene_switches: u32,
    /// Effectors (pointers) in use.
    pub effectors: u32,
    /// Strings in use.
    pub strings: u32,
    /// Bodies in the scene's world (only the first [`MAX_BODIES`] are in `bodies`).
    pub body_count: u32,
    /// 1 when `proxies` holds where each pointer's proxy rests, 0 when the scene has none.
    pub has_proxies: u32,
    /// Each effector's grip pose.
    pub grips: [HapticdBodyPose; MAX_EFFECTORS],
    /// Each effector's degrees of freedom (3 or 6).
    pub dofs: [u32; MAX_EFFECTORS],
    /// Where each pointer's proxy rests, metres.
    pub proxies: [[f64; 3]; MAX_EFFECTORS],
    /// The wrench each effector displays.
    pub wrenches: [HapticdWrench; MAX_EFFECTORS],
    /// The effector each string pulls.
    pub string_effectors: [u32; CHANNELS],
    /// Each string's exit on the frame, metres.
    pub motors: [[f64; 3]; CHANNELS],
    /// Each string's knot, where the grip is now, metres.
    pub knots: [[f64; 3]; CHANNELS],
    /// Each string's tension, newtons.
    pub tensions: [f64; CHANNELS],
    /// Each string's least and greatest tension, newtons.
    pub tension_ranges: [[f64; 2]; CHANNELS],
    /// The first bodies' poses, in the order of their ids.
    pub bodies: [HapticdBodyPose; MAX_BODIES],
    /// Corners of the deforming solids' triangles the world has (only the first
    /// [`MAX_CORNERS`] are in `corners`).
    pub corner_count: u32,
    /// Where the deforming solids' corners stand, metres in each solid's frame, solid by
    /// solid and triangle by triangle in the geometry's order.
    pub corners: [[f32; 3]; MAX_CORNERS],
}

impl WorldFrame {
    /// A picture of nothing: no effector, no string, no body.
    pub fn empty() -> Self {
        Self {
            time: 0.0,
            rate: 0.0,
            state: 0,
            scene_switches: 0,
            effectors: 0,
            strings: 0,
            body_count: 0,
            has_proxies: 0,
            grips: [HapticdBodyPose::default(); MAX_EFFECTORS],
            dofs: [0; MAX_EFFECTORS],
            proxies: [[0.0; 3]; MAX_EFFECTORS],
            wrenches: [HapticdWrench::default(); MAX_EFFECTORS],
            string_effectors: [0; CHANNELS],
            motors: [[0.0; 3]; CHANNELS],
            knots: [[0.0; 3]; CHANNELS],
            tensions: [0.0; CHANNELS],
            tension_ranges: [[0.0; 2]; CHANNELS],
            bodies: [HapticdBodyPose::default(); MAX_BODIES],
            corner_count: 0,
            corners: [[0.0; 3]; MAX_CORNERS],
        }
    }

    /// [rt] Draw `haptic` as its last tick left it: its grips, strings and the wrenches
    /// shown, the proxies and bodies of its scene.
    pub fn capture(&mut self, haptic: &mut HapticLoop, rate: f64) {
        let frame = *haptic.frame();
        self.time = frame.time;
        self.rate = rate;
        self.state = state_code(frame.state);
        self.scene_switches = frame.scene_switches;
        self.effectors = frame.effectors as u32;
        self.strings = frame.strings as u32;
        for (k, effector) in haptic.mechanism().effectors.iter().enumerate() {
            self.grips[k] = body_pose(&frame.poses[k]);
            self.dofs[k] = match effector.dof {
                Dof::Three => 3,
                Dof::Six => 6,
            };
            self.wrenches[k] = frame.wrenches[k].into();
        }
        for (k, string) in haptic.mechanism().strings.iter().enumerate() {
            let pose = &frame.poses[string.effector];
            self.string_effectors[k] = string.effector as u32;
            self.motors[k] = string.motor.to_array();
            self.knots[k] = pose.transform_point(string.knot).to_array();
            self.tensions[k] = frame.tensions[k];
            self.tension_ranges[k] = [string.tension_min, string.tension_max];
        }
        let mut proxies = [DVec3::ZERO; MAX_EFFECTORS];
        let scene = haptic.scene_mut();
        self.has_proxies = scene.write_proxies(&mut proxies) as u32;
        for (out, p) in self.proxies.iter_mut().zip(proxies) {
            *out = p.to_array();
        }
        self.body_count = scene.write_bodies(&mut self.bodies).min(u32::MAX as usize) as u32;
        self.corner_count = scene
            .write_corners(&mut self.corners)
            .min(u32::MAX as usize) as u32;
    }

    /// The corners written, when there are no more than the frame holds (else the
    /// deforming solids are drawn as they stood at load).
    pub fn deformed_corners(&self) -> &[[f32; 3]] {
        self.corners
            .get(..self.corner_count as usize)
            .unwrap_or_default()
    }

    /// The bodies written, as poses.
    pub fn body_poses(&self) -> impl Iterator<Item = Pose> + '_ {
        self.bodies[..(self.body_count as usize).min(MAX_BODIES)]
            .iter()
            .map(pose_of)
    }

    /// The device state written.
    pub fn device_state(&self) -> DeviceState {
        state_of(self.state)
    }
}

/// The [`DeviceState`] written as `code` (see [`state_code`]).
pub fn state_of(code: u32) -> DeviceState {
    match code {
        0 => DeviceState::Running,
        2 => DeviceState::Disconnected,
        3 => DeviceState::Uncalibrated,
        // A number this reader does not know (a newer writer's, or a damaged one) is no
        // sign that all is well: read closed, as a fault.
        _ => DeviceState::Fault,
    }
}

/// The number a [`DeviceState`] is written as.
pub fn state_code(state: DeviceState) -> u32 {
    match state {
        DeviceState::Running => 0,
        DeviceState::Fault => 1,
        DeviceState::Disconnected => 2,
        DeviceState::Uncalibrated => 3,
    }
}

/// A pose as the ABI writes it.
pub fn body_pose(pose: &Pose) -> HapticdBodyPose {
    HapticdBodyPose {
        position: pose.position.to_array(),
        orientation: quat_to_wxyz(pose.orientation),
    }
}

/// The shared block: a header and the frame under its sequence.
#[repr(C)]
pub struct SharedWorld {
    /// [`MAGIC`], [`VERSION`] and [`SHARED_SIZE`].
    pub header: Header,
    /// Even when the frame is whole, odd while it is written; +2 per frame.
    pub sequence: AtomicU64,
    /// The latest frame.
    pub frame: WorldFrame,
}

/// Bytes of a shared world.
pub const SHARED_SIZE: usize = std::mem::size_of::<SharedWorld>();

/// What a shared world starts with.
const HEADER: Header = Header::new(MAGIC, VERSION, SHARED_SIZE);

/// The writing side, over a block the caller mapped.
pub struct WorldWriter {
    shared: *mut SharedWorld,
}

// SAFETY: the writer is the block's one writer; it moves to the haptic thread once.
unsafe impl Send for WorldWriter {}

impl WorldWriter {
    /// A writer over `shared`, which it initialises: an empty frame at sequence 0.
    ///
    /// # Safety
    /// `shared` is valid for writes of [`SHARED_SIZE`] bytes, aligned for `SharedWorld`,
    /// for as long as the writer lives, and no one else writes it.
    pub unsafe fn new(shared: *mut SharedWorld) -> Self {
        // SAFETY: per this function's contract; each part is written in place, so that
        // the block (over a megabyte) never passes through the stack.
        unsafe {
            use std::ptr::addr_of_mut;
            addr_of_mut!((*shared).header).write(HEADER);
            addr_of_mut!((*shared).sequence).write(AtomicU64::new(0));
            addr_of_mut!((*shared).frame).write(WorldFrame::empty());
        }
        Self { shared }
    }

    /// [rt] Picture `haptic` as its last tick left it (see [`WorldFrame::capture`]).
    pub fn capture(&mut self, haptic: &mut HapticLoop, rate: f64) {
        self.write(|picture| picture.capture(haptic, rate));
    }

    /// [rt] Write a frame with `fill`, which finds the last one in place.
    pub fn write(&mut self, fill: impl FnOnce(&mut WorldFrame)) {
        // SAFETY: valid for the writer's life (see `new`); readers only read.
        let shared = unsafe { &mut *self.shared };
        let sequence = shared.sequence.load(Ordering::Relaxed);
        shared.sequence.store(sequence + 1, Ordering::Relaxed);
        // The odd sequence is seen before any byte of the frame changes.
        fence(Ordering::Release);
        fill(&mut shared.frame);
        shared.sequence.store(sequence + 2, Ordering::Release);
    }
}

/// The reading side, over a block mapped read-only.
pub struct WorldReader {
    shared: *const SharedWorld,
}

// SAFETY: the reader only reads the block, through volatile copies checked by the sequence.
unsafe impl Send for WorldReader {}

impl WorldReader {
    /// A reader over `shared`, checked to be a shared world of this layout.
    ///
    /// # Safety
    /// `shared` is valid for reads of `len` bytes, aligned for `SharedWorld`, for as long
    /// as the reader lives.
    pub unsafe fn new(shared: *const SharedWorld, len: usize) -> Result<Self, WrongLayout> {
        // SAFETY: per this function's contract; the header is the block's first field.
        unsafe { HEADER.check(shared.cast::<Header>(), len, "a shared world") }?;
        Ok(Self { shared })
    }

    /// Copy the latest whole frame into `out` and return its sequence; None when every try
    /// overlapped a write (a writer that died mid-write leaves the sequence odd).
    pub fn read(&self, out: &mut WorldFrame) -> Option<u64> {
        const TRIES: usize = 100;
        // SAFETY: the sequence lies in the block (see `new`) and is only used atomically.
        let sequence = unsafe { &(*self.shared).sequence };
        for _ in 0..TRIES {
            let before = sequence.load(Ordering::Acquire);
            if before % 2 == 1 {
                std::hint::spin_loop();
                continue;
            }
            // SAFETY: in the block; a torn copy is detected below and thrown away.
            *out = unsafe { std::ptr::addr_of!((*self.shared).frame).read_volatile() };
            fence(Ordering::Acquire);
            if sequence.load(Ordering::Relaxed) == before {
                return Some(before);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block() -> Box<std::mem::MaybeUninit<SharedWorld>> {
        Box::new_uninit()
    }

    #[test]
    fn a_reader_sees_the_whole_frame_written() {
        let mut memory = block();
        let shared = memory.as_mut_ptr();
        // SAFETY: the box holds one SharedWorld for the test's life.
        let mut writer = unsafe { WorldWriter::new(shared) };
        // SAFETY: as above.
        let reader = unsafe { WorldReader::new(shared, SHARED_SIZE) }.unwrap();
        let mut out = Box::new(WorldFrame::empty());
        assert_eq!(reader.read(&mut out), Some(0));
        writer.write(|f| {
            f.body_count = 2;
            f.bodies[1].position = [1.0, 2.0, 3.0];
            f.time = 0.5;
        });
        assert_eq!(reader.read(&mut out), Some(2));
        assert_eq!((out.body_count, out.time), (2, 0.5));
        assert_eq!(out.bodies[1].position, [1.0, 2.0, 3.0]);
    }

    #[test]
    fn a_frame_being_written_is_not_read() {
        let mut memory = block();
        let shared = memory.as_mut_ptr();
        // SAFETY: the box holds one SharedWorld for the test's life.
        let mut writer = unsafe { WorldWriter::new(shared) };
        // SAFETY: as above.
        let reader = unsafe { WorldReader::new(shared, SHARED_SIZE) }.unwrap();
        let mut out = Box::new(WorldFrame::empty());
        writer.write(|_| {
            let seen = reader.read(&mut WorldFrame::empty());
            assert_eq!(seen, None, "a reader finished a frame still being written");
        });
        assert!(reader.read(&mut out).is_some());
    }

    #[test]
    fn a_block_of_another_layout_is_refused() {
        let mut memory = block();
        let shared = memory.as_mut_ptr();
        // SAFETY: the box holds one SharedWorld for the test's life.
        let _writer = unsafe { WorldWriter::new(shared) };
        // SAFETY: as above.
        let short = unsafe { WorldReader::new(shared, SHARED_SIZE - 1) };
        assert!(short.is_err_and(|e| e.0.contains("bytes")));
        // SAFETY: as above; the header is rewritten in place.
        unsafe { (*shared).header.version = VERSION + 1 };
        // SAFETY: as above.
        let newer = unsafe { WorldReader::new(shared, SHARED_SIZE) };
        assert!(newer.is_err_and(|e| e.0.contains("layout")));
    }

    #[test]
    fn state_codes_round_trip_and_unknown_ones_read_as_a_fault() {
        let mut frame = WorldFrame::empty();
        for state in [
            DeviceState::Running,
            DeviceState::Fault,
            DeviceState::Disconnected,
            DeviceState::Uncalibrated,
        ] {
            frame.state = state_code(state);
            assert_eq!(frame.device_state(), state);
        }
        // A state this reader does not know is read closed: never as running.
        for unknown in [4, 7, u32::MAX] {
            assert_eq!(state_of(unknown), DeviceState::Fault);
        }
    }
}
