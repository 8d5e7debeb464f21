//! A direct scene: the plugin steps its world inside every haptic tick.

use hapticd_plugin_api::*;

use hapticd_core::haptics::shading::SmoothMesh;
use hapticd_core::haptics::surface::{Material, Surfaces};
use hapticd_core::kinematics::Wrench;
use hapticd_core::scene::control::SceneControl;
use hapticd_core::scene::output_check::{OutputFault, WrenchChecker};
use hapticd_core::scene::{Pointer, Scene, Touch};

use super::{Commands, Instance};

/// A direct scene: the plugin runs inside the haptic tick.
pub(super) struct DirectScene {
    pub(super) name: String,
    pub(super) instance: Instance,
    pub(super) geometry: Geometry,
    /// The control plane's end of its world's control, until taken.
    pub(super) control: Option<SceneControl>,
    /// The stepping side's.
    pub(super) commands: Option<Commands>,
    pub(super) pointers: Vec<HapticdPointer>,
    pub(super) wrenches: Vec<HapticdWrench>,
    pub(super) failed: bool,
    pub(super) check: WrenchChecker,
    /// Why the plugin was disabled, when it was for its wrenches.
    pub(super) fault: Option<OutputFault>,
    /// The materials of its bodies' surfaces.
    pub(super) surfaces: Surfaces,
}

impl Scene for DirectScene {
    fn name(&self) -> &str {
        &self.name
    }

    fn render(&mut self, pointers: &[Pointer], dt: f64, wrenches: &mut [Wrench]) -> bool {
        wrenches.fill(Wrench::ZERO);
        if self.failed {
            return false;
        }
        if let Some((incoming, replies)) = &mut self.commands {
            while let Some(request) = incoming.due() {
                self.instance.carry_out(&request, replies);
            }
        }
        for (out, p) in self.pointers.iter_mut().zip(pointers) {
            *out = p.to_abi();
        }
        let step = self.instance.vtable.step_direct.expect("checked at load");
        // SAFETY: buffers hold one element per pointer; the instance is this thread's.
        let status = unsafe {
            step(
                self.instance.pointer,
                dt,
                self.pointers.as_ptr(),
                self.pointers.len() as u32,
                self.wrenches.as_mut_ptr(),
            )
        };
        if status != HAPTICD_OK {
            self.failed = true;
            return false;
        }
        for (out, w) in wrenches.iter_mut().zip(&self.wrenches) {
            *out = Wrench::from(*w);
        }
        // Wrenches no world gives disable the plugin, as a failure does, instead of being
        // clamped and felt.
        if let Err(fault) = self.check.check(wrenches) {
            wrenches.fill(Wrench::ZERO);
            (self.failed, self.fault) = (true, Some(fault));
            return false;
        }
        true
    }

    fn reset(&mut self, _pointers: &[Pointer]) {}

    fn set_wrench_limits(&mut self, max_force: f64, max_torque: f64) {
        self.check.set_limits(max_force, max_torque);
    }

    fn fault(&self) -> Option<OutputFault> {
        self.fault
    }

    fn write_bodies(&mut self, poses: &mut [HapticdBodyPose]) -> usize {
        self.instance.poses(poses)
    }

    fn write_corners(&mut self, corners: &mut [[f32; 3]]) -> usize {
        self.instance.corners(corners)
    }

    fn take_control(&mut self) -> Option<SceneControl> {
        self.control.take()
    }

    fn write_touches(&self, touches: &mut [Touch]) {
        if !self.failed {
            self.instance.touches(touches);
        }
    }

    fn set_surfaces(&mut self, mut surfaces: Surfaces) {
        surfaces.shade(&self.geometry);
        self.surfaces = surfaces;
    }

    fn material(&self, _pointer: usize, touch: &Touch) -> Option<&Material> {
        self.surfaces.of(touch.body)
    }

    fn smooth_mesh(&self, touch: &Touch) -> Option<&SmoothMesh> {
        self.surfaces.smooth(touch.body)
    }

    fn needs_quiet(&self) -> bool {
        self.commands.as_ref().is_some_and(|(i, _)| i.holding())
    }

    fn quiet(&mut self) {
        if let Some((incoming, replies)) = &mut self.commands
            && let Some(request) = incoming.release()
        {
            self.instance.carry_out(&request, replies);
        }
    }

    fn geometry(&self) -> &Geometry {
        &self.geometry
    }
}
