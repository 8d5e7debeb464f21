//! Scene extension `"hapticd.scene.geometry/1"`: what a scene's world looks like.
//!
//! A scene plugin offers it through [`HapticdSceneVtable::get_extension`](crate::HapticdSceneVtable::get_extension);
//! its C declarations are the header's section of the same name.

use std::ffi::c_void;

use crate::abi::*;

/// The id of [`HapticdSceneGeometry`].
pub const HAPTICD_EXT_SCENE_GEOMETRY: &std::ffi::CStr = c"hapticd.scene.geometry/1";

/// Shape: a box of half edges `size`, centred on its frame.
pub const HAPTICD_SHAPE_BOX: u32 = 1;
/// Shape: a ball of radius `size[0]` about its frame's origin.
pub const HAPTICD_SHAPE_SPHERE: u32 = 2;
/// Shape: a round bar of radius `size[0]` and length `size[1]` along its frame's y axis.
pub const HAPTICD_SHAPE_CYLINDER: u32 = 3;
/// Shape: the half-space below its frame's x–z plane (outward normal +y), drawn `size[0]`
/// metres across.
pub const HAPTICD_SHAPE_PLANE: u32 = 4;
/// Shape: the solid's triangles (`first_triangle`, `triangle_count`), in its frame.
pub const HAPTICD_SHAPE_TRIANGLES: u32 = 5;

/// Solid flag: it does not move (a floor, a wall).
pub const HAPTICD_SOLID_FIXED: u32 = 1;
/// Solid flag: it follows a pointer (a finger's solid in the world).
pub const HAPTICD_SOLID_POINTER: u32 = 2;
/// Solid flag (since ABI 1.9): a solid of triangles whose corners move on their own (a soft
/// body); the deformation extension says where they stand now.
pub const HAPTICD_SOLID_DEFORMING: u32 = 4;

/// The `body` of a solid that belongs to no body: it stays where its `offset` puts it.
pub const HAPTICD_NO_BODY: u32 = u32::MAX;

/// How many bodies, solids and triangles a scene's world has.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HapticdGeometryCounts {
    /// Bodies, with ids `0 .. bodies`: `poses` writes them in that order.
    pub bodies: u32,
    /// Solids.
    pub solids: u32,
    /// Triangles, all solids together.
    pub triangles: u32,
}

/// One drawable solid of a scene's world.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdSolid {
    /// The id of the body it moves with (its place in `poses`), or [`HAPTICD_NO_BODY`].
    pub body: u32,
    /// One of the `HAPTICD_SHAPE_` constants.
    pub shape: u32,
    /// `HAPTICD_SOLID_` flags.
    pub flags: u32,
    /// [`HAPTICD_SHAPE_TRIANGLES`]: its first triangle.
    pub first_triangle: u32,
    /// [`HAPTICD_SHAPE_TRIANGLES`]: how many triangles it has.
    pub triangle_count: u32,
    /// Sizes, metres, as its shape reads them.
    pub size: [f64; 3],
    /// Its frame in its body's frame (in the world's when it has no body).
    pub offset: HapticdBodyPose,
    /// Linear RGBA, 0 to 1; all zero: the renderer's colour for its body and flags.
    pub colour: [f32; 4],
}

/// A triangle of a solid, counter-clockwise seen from outside, in the solid's frame.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdTriangle {
    /// Its corners, metres.
    pub corners: [[f64; 3]; 3],
}

/// Extension [`HAPTICD_EXT_SCENE_GEOMETRY`] of a scene plugin: the solids of an instance's
/// world, so that pictures need nothing but the plugin (the host copies them once per scene
/// and the renderer places them by the poses of their bodies).
///
/// [main] Every function, after `create` and before the instance is first stepped.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdSceneGeometry {
    /// `sizeof(HapticdSceneGeometry)` as the plugin was compiled.
    pub struct_size: u32,
    /// Write the instance's counts to `out`.
    pub counts:
        Option<unsafe extern "C" fn(instance: *mut c_void, out: *mut HapticdGeometryCounts) -> i32>,
    /// Write solid `index` (below `counts.solids`) to `out`.
    pub solid: Option<
        unsafe extern "C" fn(instance: *mut c_void, index: u32, out: *mut HapticdSolid) -> i32,
    >,
    /// Write `count` triangles from `first` on (within `counts.triangles`) to `out`.
    pub triangles: Option<
        unsafe extern "C" fn(
            instance: *mut c_void,
            first: u32,
            count: u32,
            out: *mut HapticdTriangle,
        ) -> i32,
    >,
}
