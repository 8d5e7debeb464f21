//! What a pointer touches: the body, where, along which normal, and whether it slides, as a
//! scene says it after each tick for contact events.

use glam::DVec3;
use hapticd_plugin_api::HAPTICD_NO_BODY;

/// What a pointer touches after a tick, as its scene tells it (for contact events).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Touch {
    /// Whether it touches anything.
    pub touching: bool,
    /// The body touched (its id), or [`HAPTICD_NO_BODY`] for a solid that is no body or a
    /// scene that cannot say.
    pub body: u32,
    /// Where, metres.
    pub point: DVec3,
    /// Unit normal of the surface touched, out of it; zero when the scene cannot say.
    pub normal: DVec3,
    /// Whether it slides along the surface (dynamic friction) instead of sticking.
    pub slipping: bool,
}

impl Touch {
    /// Touching nothing.
    pub const NONE: Touch = Touch {
        touching: false,
        body: HAPTICD_NO_BODY,
        point: DVec3::ZERO,
        normal: DVec3::ZERO,
        slipping: false,
    };
}

impl Default for Touch {
    fn default() -> Self {
        Touch::NONE
    }
}
