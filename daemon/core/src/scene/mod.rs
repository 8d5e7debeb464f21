//! Scenes: what the user touches. A scene turns the pointers' motion (one pointer per end
//! effector) into the wrench each one should feel.
//!
//! - [`control`]: a running world changed from outside, between steps;
//! - [`engine`]: which engine runs a scene file;
//! - [`static_scene`]: fixed floors, walls, boxes and spheres rendered through the proxy;
//! - [`local_dynamics`]: the bodies near a pointer, moved at the haptic rate between
//!   physics steps (thesis 6.5.4);
//! - [`exact_shapes`]: the balls and boxes of a multi-rate world's bodies, touched as
//!   themselves where local dynamics has them each tick;
//! - [`held_part`]: a body a pointer holds in a multi-rate world, rendered by a 6-DOF
//!   god-object that pushes the bodies moved here (thesis 7.2);
//! - [`multirate`]: the haptic side of a world stepped at a low rate elsewhere (thesis
//!   Ch. 6): interpolated planes, the proxy and the impulses handed back;
//! - [`output_check`]: a plugin's planes and wrenches checked before they are used;
//! - [`remote`]: a world stepped on another machine, and the messages that carry it;
//!   [`world_link`]: the memory those messages pass through between daemon and bridge;
//! - scenes from plugins, direct or multi-rate, live in the daemon (they load code).

pub mod control;
pub mod engine;
pub mod exact_shapes;
pub mod held_part;
pub mod ledger;
pub mod local_dynamics;
pub mod multirate;
pub mod output_check;
pub mod remote;
pub mod shared_world;
pub mod static_scene;
pub mod world_link;

use glam::DVec3;

use crate::haptics::proxy::ProxyParameters;
use crate::haptics::shading::SmoothMesh;
use crate::haptics::surface::{Material, Surfaces};
pub use crate::haptics::touch::Touch;
use crate::kinematics::{Pose, Wrench, quat_to_wxyz};
use crate::mechanism::Mechanism;
use hapticd_plugin_api::{Geometry, HapticdBodyPose, HapticdPointer};

/// One pointer as the scene sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pointer {
    /// Grip pose.
    pub pose: Pose,
    /// Grip velocity, m/s.
    pub velocity: DVec3,
}

impl Pointer {
    /// The pointer as a scene plugin sees it.
    pub fn to_abi(&self) -> HapticdPointer {
        HapticdPointer {
            position: self.pose.position.to_array(),
            orientation: quat_to_wxyz(self.pose.orientation),
            velocity: self.velocity.to_array(),
        }
    }

    /// One pointer per effector of `mechanism`, at rest at its calibration pose.
    pub fn at_calibration(mechanism: &Mechanism) -> Vec<Pointer> {
        mechanism
            .effectors
            .iter()
            .map(|e| Pointer {
                pose: e.calibration,
                velocity: DVec3::ZERO,
            })
            .collect()
    }
}

/// Most bodies a picture shows (a larger world shows its first ones), and the most the
/// loop reads the poses of for effects that move with them.
pub const MAX_BODIES: usize = 4096;

/// A world the haptic loop renders.
pub trait Scene: Send {
    /// [main] The scene's name.
    fn name(&self) -> &str;

    /// [rt] The wrench to present on each pointer (torque about the grip) after a tick of
    /// `dt` seconds. `wrenches` has one slot per pointer. Returns false when the scene has failed
    /// (a plugin error, stale physics): the loop then ramps the forces to zero.
    fn render(&mut self, pointers: &[Pointer], dt: f64, wrenches: &mut [Wrench]) -> bool;

    /// [rt] Forget contact state (after a fault, or when the pointers jumped).
    fn reset(&mut self, pointers: &[Pointer]);

    /// [rt] Render with these proxy parameters from now on (scenes without a proxy ignore
    /// them).
    fn set_proxy(&mut self, _parameters: &ProxyParameters) {}

    /// [main] The proxy parameters the scene renders with, if it renders through a proxy
    /// (before the loop tunes it: those its file gives).
    fn proxy(&self) -> Option<ProxyParameters> {
        None
    }

    /// [rt] Judge the wrenches asked for against the device's limits from now on (MaxForce,
    /// newtons; MaxTorque, newton-metres): a scene from a plugin takes one far beyond them
    /// for a broken plugin. Others ignore them.
    fn set_wrench_limits(&mut self, _max_force: f64, _max_torque: f64) {}

    /// [rt] Why the scene failed, when its plugin's output was refused at the boundary
    /// (None while it renders, or when it failed for another reason). The daemon logs it.
    fn fault(&self) -> Option<output_check::OutputFault> {
        None
    }

    /// [rt] For pictures: where each pointer's proxy rests (one per pointer in `proxies`),
    /// or false, leaving them, when the scene renders without a proxy.
    fn write_proxies(&self, _proxies: &mut [DVec3]) -> bool {
        false
    }

    /// [rt] For pictures: the poses of the world's first bodies, in the order of their ids,
    /// written to `poses` (as many as it holds); returns how many bodies the world has.
    fn write_bodies(&mut self, _poses: &mut [HapticdBodyPose]) -> usize {
        0
    }

    /// [rt] For pictures: where the corners of the world's deforming solids stand now, the
    /// first ones written to `corners` (as many as it holds); returns how many there are.
    fn write_corners(&mut self, _corners: &mut [[f32; 3]]) -> usize {
        0
    }

    /// [rt, after `render`] What each pointer touches (one slot per pointer in `touches`,
    /// each [`Touch::NONE`] when called); the default says nothing.
    fn write_touches(&self, _touches: &mut [Touch]) {}

    /// [main, before the loop gets the scene] Render `surfaces` on the world's bodies (by
    /// body id): a physics scene file's materials, which the daemon reads. Scenes that know
    /// their own surfaces ignore them.
    fn set_surfaces(&mut self, _surfaces: Surfaces) {}

    /// [rt, after `write_touches`] The material of the surface pointer `pointer` touches
    /// (`touch`, as the scene wrote it): its texture and transient, if it has one; the
    /// default has none.
    fn material(&self, _pointer: usize, _touch: &Touch) -> Option<&Material> {
        None
    }

    /// [rt, after `write_touches`] The smoothly shaded mesh of the body `touch` is on (in the
    /// body's frame), whose blended normal the loop turns the scene's push to; None where the
    /// scene shades its surfaces itself, or the body's faces are felt flat.
    fn smooth_mesh(&self, _touch: &Touch) -> Option<&SmoothMesh> {
        None
    }

    /// [main] The control of the world's bodies from outside, taken once before the loop
    /// gets the scene (None: it cannot be changed from outside, or was taken).
    fn take_control(&mut self) -> Option<control::SceneControl> {
        None
    }

    /// [rt] Whether a change from outside waits for the forces to be at zero (one that would
    /// jump them): the loop ramps them down while it does, and then calls
    /// [`quiet`](Self::quiet).
    fn needs_quiet(&self) -> bool {
        false
    }

    /// [rt] The forces are at zero: carry out what waited for it.
    fn quiet(&mut self) {}

    /// [rt] For pictures: the world's solids, placed by the poses of their bodies (body
    /// *i* is the *i*-th pose [`write_bodies`](Self::write_bodies) writes). Read once per
    /// scene; the default has none.
    fn geometry(&self) -> &Geometry {
        static NONE: Geometry = Geometry {
            body_count: 0,
            solids: Vec::new(),
            triangles: Vec::new(),
        };
        &NONE
    }
}
