//! A scene's solids in a sealed memfd of their own, sized by the scene (the layout is
//! [`hapticd_core::world_geometry`]): hapticd makes one whenever a device swaps a scene in
//! and hands it out (`OpenGeometry`) with the `scene_switches` it belongs to; a reader maps
//! it once, copies it, and asks again when the world's frames count another switch.

use std::io;
use std::os::fd::OwnedFd;

use hapticd_core::world_geometry;
use hapticd_plugin_api::Geometry;

use crate::shared_memory::{MapError, Mapping, read_only_descriptor, sealed};

/// One scene's solids, written once.
pub struct SceneGeometryFile {
    fd: OwnedFd,
    scene_switches: u32,
}

impl SceneGeometryFile {
    /// The solids of `geometry`, the scene the frames count as `scene_switches`. The file
    /// is written whole before this returns and sealed: nobody can write it again.
    pub fn create(scene_switches: u32, geometry: &Geometry) -> io::Result<Self> {
        let (fd, mapping) = sealed("hapticd-geometry", world_geometry::block_size(geometry))?;
        // SAFETY: the mapping holds block_size bytes, page-aligned, writable, ours alone;
        // it is dropped (unmapped) right after.
        unsafe { world_geometry::write(mapping.address().cast(), scene_switches, geometry) };
        drop(mapping);
        Ok(Self { fd, scene_switches })
    }

    /// The frames' `scene_switches` of its scene.
    pub fn scene_switches(&self) -> u32 {
        self.scene_switches
    }

    /// A new descriptor of the file, open for reading alone, to hand to a reader.
    pub fn share(&self) -> io::Result<OwnedFd> {
        read_only_descriptor(&self.fd)
    }
}

/// The `scene_switches` and the solids in the file `fd` (handed out by `OpenGeometry`).
pub fn read(fd: &OwnedFd) -> Result<(u32, Geometry), MapError> {
    let mapping = Mapping::read_only(fd).map_err(|error| MapError::Map {
        what: "a scene's geometry",
        error,
    })?;
    // SAFETY: the mapping holds `len` bytes, page-aligned, sealed against writes, alive
    // across the call.
    unsafe { world_geometry::read(mapping.address().cast(), mapping.len()) }
        .map_err(|e| MapError::Layout(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use hapticd_plugin_api::{HAPTICD_SHAPE_SPHERE, HapticdSolid, HapticdTriangle};

    #[test]
    fn a_reader_gets_the_scene_written_and_cannot_write_it() {
        let mut geometry = Geometry::default();
        let body = geometry.add_body();
        geometry.add_solid(HapticdSolid {
            body,
            shape: HAPTICD_SHAPE_SPHERE,
            size: [0.02, 0.0, 0.0],
            ..HapticdSolid::placed([0.0, 0.1, 0.0], [1.0, 0.0, 0.0, 0.0])
        });
        let corners = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]];
        geometry.add_triangles(
            HapticdSolid::placed([0.0; 3], [1.0, 0.0, 0.0, 0.0]),
            [HapticdTriangle { corners }; 3],
        );
        let file = SceneGeometryFile::create(4, &geometry).unwrap();
        assert_eq!(file.scene_switches(), 4);
        let shared = file.share().unwrap();
        assert_eq!(read(&shared).unwrap(), (4, geometry));
        crate::shared_memory::tests::assert_sealed(&shared);
    }
}
