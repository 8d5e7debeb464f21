//! Extension `"hapticd.scene.geometry/1"` served from a [`SceneInstance`]'s geometry.

use crate::abi::*;
use crate::ext::scene_geometry::*;
use crate::geometry::Geometry;

use super::{guard, instance_mut, write_out};
/// The instance's geometry, if it has one.
///
/// # Safety
/// As [`instance_mut`].
unsafe fn geometry_of<'a>(instance: *mut std::ffi::c_void) -> Option<&'a Geometry> {
    if instance.is_null() {
        return None;
    }
    // SAFETY: per this function's contract.
    let scene = unsafe { instance_mut(instance) };
    let mut found = None;
    guard(|| {
        found = scene.geometry().map(|g| g as *const Geometry);
        HAPTICD_OK
    });
    // SAFETY: the geometry lives in the instance, which outlives the caller's use of it.
    found.map(|g| unsafe { &*g })
}

unsafe extern "C" fn geometry_counts(
    instance: *mut std::ffi::c_void,
    out: *mut HapticdGeometryCounts,
) -> i32 {
    // SAFETY: the host keeps the extension's contract: a live instance, a valid `out`.
    unsafe {
        let counts =
            geometry_of(instance).map_or_else(HapticdGeometryCounts::default, Geometry::counts);
        write_out(out, Some(counts))
    }
}

unsafe extern "C" fn geometry_solid(
    instance: *mut std::ffi::c_void,
    index: u32,
    out: *mut HapticdSolid,
) -> i32 {
    // SAFETY: as in geometry_counts.
    unsafe {
        let solid = geometry_of(instance).and_then(|g| g.solids.get(index as usize).copied());
        write_out(out, solid)
    }
}

unsafe extern "C" fn geometry_triangles(
    instance: *mut std::ffi::c_void,
    first: u32,
    count: u32,
    out: *mut HapticdTriangle,
) -> i32 {
    // SAFETY: as in geometry_counts.
    let Some(geometry) = (unsafe { geometry_of(instance) }) else {
        return HAPTICD_ERROR_ARGUMENT;
    };
    let (first, count) = (first as usize, count as usize);
    let Some(triangles) = geometry.triangles.get(first..first.saturating_add(count)) else {
        return HAPTICD_ERROR_ARGUMENT;
    };
    if out.is_null() && count > 0 {
        return HAPTICD_ERROR_ARGUMENT;
    }
    // SAFETY: `out` holds `count` triangles, per the extension's contract.
    unsafe { std::ptr::copy_nonoverlapping(triangles.as_ptr(), out, count) };
    HAPTICD_OK
}

/// The geometry extension every Rust scene plugin serves, around
/// [`SceneInstance::geometry`].
pub(super) static SCENE_GEOMETRY: HapticdSceneGeometry = HapticdSceneGeometry {
    struct_size: std::mem::size_of::<HapticdSceneGeometry>() as u32,
    counts: Some(geometry_counts),
    solid: Some(geometry_solid),
    triangles: Some(geometry_triangles),
};
