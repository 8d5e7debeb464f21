//! Scene extension `"hapticd.scene.held/1"`: a held body and the exact surfaces it meets.
//!
//! A scene plugin offers it through [`HapticdSceneVtable::get_extension`](crate::HapticdSceneVtable::get_extension);
//! its C declarations are the header's section of the same name.
//!
//! A multi-rate world whose first pointer holds one of its bodies hands the held body to the
//! haptic side, which renders it by a 6-DOF god-object: a proxy pose that follows the grip
//! and never enters what it touches, found every tick against the bodies' own triangles.
//! The world puts the held body where the pointer's proxy record says (its position is the
//! point the grip holds, its orientation the body's), and hands over as local bodies those
//! near it, which the god-object's contacts push.
//!
//! A world serves the surfaces whether or not anything is held: a piece that is exactly a
//! ball or a box says so, and a fingertip on a body moved here touches that solid where the
//! body is each tick, not the plane the last step found.

use std::ffi::c_void;

use crate::abi::*;
use crate::ext::scene_geometry::HapticdTriangle;

/// The id of [`HapticdSceneHeld`] (since ABI 1.12).
pub const HAPTICD_EXT_SCENE_HELD: &std::ffi::CStr = c"hapticd.scene.held/1";

/// A body a pointer holds, and the spring the hand feels it by.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdHeld {
    /// The pointer that holds it.
    pub pointer: u32,
    /// The body (its number among the world's bodies, as its poses are written).
    pub body: u32,
    /// The point the grip holds, in the body's frame (about its centre of mass), metres.
    pub grip: [f64; 3],
    /// Spring between grip and proxy, N/m (above 0).
    pub stiffness: f64,
    /// Damper between grip and proxy, N·s/m.
    pub damping: f64,
    /// Rotational spring, N·m/rad (above 0).
    pub rotational_stiffness: f64,
    /// Rotational damper, N·m·s/rad.
    pub rotational_damping: f64,
    /// Coulomb's coefficient of friction of the held body's contacts.
    pub friction: f64,
}

/// The `object` of a piece that is no one object (a mesh's whole surface, whatever pieces
/// the world collides it as).
pub const HAPTICD_NO_OBJECT: u32 = u32::MAX;

/// One closed piece of a body's surface.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HapticdSurfacePiece {
    /// How many triangles it has.
    pub triangle_count: u32,
    /// 1 when its body does not move, else 0.
    pub fixed: u32,
    /// The object it is (the `object` of its planes), or [`HAPTICD_NO_OBJECT`].
    pub object: u32,
    /// [`HAPTICD_SHAPE_BOX`](crate::HAPTICD_SHAPE_BOX) or
    /// [`HAPTICD_SHAPE_SPHERE`](crate::HAPTICD_SHAPE_SPHERE) when the piece is exactly that
    /// solid (its triangles then draw it), else
    /// [`HAPTICD_SHAPE_TRIANGLES`](crate::HAPTICD_SHAPE_TRIANGLES).
    pub shape: u32,
    /// The solid's sizes as its shape reads them (a box's half edges, a ball's radius
    /// first), metres.
    pub size: [f64; 3],
    /// The solid's frame in its body's frame.
    pub offset: HapticdBodyPose,
    /// Where its body is now (its centre of mass, the frame of the triangles).
    pub pose: HapticdBodyPose,
}

/// Extension [`HAPTICD_EXT_SCENE_HELD`] of a multi-rate scene plugin.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct HapticdSceneHeld {
    /// `sizeof(HapticdSceneHeld)` as the plugin was compiled.
    pub struct_size: u32,
    /// [main] Write the held body to `out` and return [`HAPTICD_OK`], or
    /// [`HAPTICD_ERROR_ARGUMENT`] when no pointer holds one.
    pub held: Option<unsafe extern "C" fn(instance: *mut c_void, out: *mut HapticdHeld) -> i32>,
    /// [main] Describe piece `piece` of body `body`'s surface in `info` and write its first
    /// `capacity` triangles (counter-clockwise seen from outside, in the body's frame) to
    /// `out` (which may be null when `capacity` is 0); [`HAPTICD_ERROR_ARGUMENT`] past the
    /// body's last piece or the world's last body. Every piece is a closed surface.
    pub surface: Option<
        unsafe extern "C" fn(
            instance: *mut c_void,
            body: u32,
            piece: u32,
            info: *mut HapticdSurfacePiece,
            out: *mut HapticdTriangle,
            capacity: u32,
        ) -> i32,
    >,
}
