//! The one light pictures are lit by, and its view of the scene for shadows: parallel rays
//! from above, in front and to the left, over the part of the world the camera looks at.

use glam::{DMat4, DVec3};

use crate::camera::Camera;

/// Towards the light (the fragment shader lights faces from the same direction).
pub fn direction() -> DVec3 {
    DVec3::new(-0.4, 1.0, 0.6).normalize()
}

/// World to the light's clip space (depth 0 to 1): an orthographic view along the light's
/// rays of a cube around what `camera` looks at, as wide as the camera is far from it, so
/// that the shadow map's texels are spent where the picture is.
pub fn view_projection(camera: &Camera) -> DMat4 {
    let centre = camera.target;
    let reach = (camera.eye - camera.target).length();
    let eye = centre + direction() * 2.0 * reach;
    let view = DMat4::look_at_rh(eye, centre, DVec3::Y);
    DMat4::orthographic_rh(-reach, reach, -reach, reach, 0.0, 4.0 * reach) * view
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_target_is_mid_map_and_nearer_the_light_is_shallower() {
        let camera = Camera::orbit(DVec3::new(0.1, 0.0, -0.2), 0.5, 0.45, 0.55);
        let m = view_projection(&camera);
        let at = |p: DVec3| m.project_point3(p);
        let target = at(camera.target);
        assert!(target.x.abs() < 1e-12 && target.y.abs() < 1e-12, "{target}");
        assert!((target.z - 0.5).abs() < 1e-12, "{target}");
        // A point towards the light is in front of the target, on the same texel.
        let above = at(camera.target + direction() * 0.1);
        assert!(above.z < target.z);
        assert!((above.x - target.x).abs() < 1e-12 && (above.y - target.y).abs() < 1e-12);
        // The cube's side: the camera's distance either way.
        let side = direction().cross(DVec3::Y).normalize();
        assert!((at(camera.target + side * 0.5).truncate().length() - 1.0).abs() < 1e-9);
    }
}
