//! Where a picture is taken from: an eye looking at a target, a vertical field of view, and
//! the picture's shape.

use glam::{DMat4, DVec3};

/// A perspective camera, y up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Where the eye is, metres.
    pub eye: DVec3,
    /// The point looked at, metres.
    pub target: DVec3,
    /// Vertical field of view, radians.
    pub fov: f64,
}

impl Camera {
    /// A camera looking at `target` from `distance` away, down `elevation` radians and
    /// turned `azimuth` radians about the vertical (0: from +z).
    pub fn orbit(target: DVec3, distance: f64, azimuth: f64, elevation: f64) -> Self {
        let direction = DVec3::new(
            elevation.cos() * azimuth.sin(),
            elevation.sin(),
            elevation.cos() * azimuth.cos(),
        );
        Self {
            eye: target + direction * distance,
            target,
            fov: 40f64.to_radians(),
        }
    }

    /// Whether every number is finite, the eye is off the target and the view not straight
    /// up or down, and the field of view between 1° and 170°.
    pub fn is_valid(&self) -> bool {
        let look = self.target - self.eye;
        self.eye.is_finite()
            && self.target.is_finite()
            && look.length() > 1e-6
            && look.normalize().cross(DVec3::Y).length() > 1e-6
            && (1f64.to_radians()..=170f64.to_radians()).contains(&self.fov)
    }

    /// World to clip space (y up, depth 0 to 1) for a picture `aspect` wide per unit of
    /// height. The shaders turn y down for Vulkan (naga's coordinate adjustment).
    pub fn view_projection(&self, aspect: f64) -> DMat4 {
        let view = DMat4::look_at_rh(self.eye, self.target, DVec3::Y);
        let distance = (self.target - self.eye).length();
        DMat4::perspective_rh(self.fov, aspect, distance * 0.01, distance * 20.0) * view
    }
}
