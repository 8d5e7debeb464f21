//! Wavefront OBJ through tobj: every object's faces, triangulated (fans of polygons), with
//! the normals the file gives; materials and texture coordinates are not read.

use glam::DVec3;

use crate::Read;

/// The triangles of OBJ `bytes`.
pub(crate) fn read(bytes: &[u8]) -> Result<Read, String> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    // A material library is another file: not read (a mesh's colour comes from its scene).
    let no_materials = |_: &std::path::Path| Err(tobj::LoadError::OpenFileFailed);
    let (models, _) = tobj::load_obj_buf(&mut &bytes[..], &options, no_materials)
        .map_err(|e| format!("not a readable OBJ file: {e}"))?;
    let mut read = Read {
        positions: Vec::new(),
        triangles: Vec::new(),
        normals: Some(Vec::new()),
    };
    for model in &models {
        let mesh = &model.mesh;
        let first = read.positions.len();
        read.positions.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|p| DVec3::new(p[0], p[1], p[2])),
        );
        let normal = |k: u32| {
            let k = 3 * k as usize;
            mesh.normals
                .get(k..k + 3)
                .map(|n| DVec3::new(n[0], n[1], n[2]))
        };
        for corners in mesh.indices.chunks_exact(3) {
            read.triangles
                .push([0, 1, 2].map(|i| first + corners[i] as usize));
            let normals = [0, 1, 2].map(|i| normal(corners[i]));
            match (&mut read.normals, normals) {
                (Some(all), [Some(a), Some(b), Some(c)]) => all.push([a, b, c]),
                (n, _) => *n = None,
            }
        }
    }
    Ok(read)
}
