//! Wavefront OBJ through tobj: every object's faces, triangulated (fans of polygons), with
//! the normals the file gives; materials and texture coordinates are not read.

use glam::DVec3;

use crate::{Budget, Format, Limits, MeshError, Read};

/// The triangles of OBJ `bytes`, at most `limits.triangles` of them.
pub(crate) fn read(bytes: &[u8], limits: Limits) -> Result<Read, MeshError> {
    within_budget(bytes, limits)?;
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    // A material library is another file: not read (a mesh's colour comes from its scene).
    let no_materials = |_: &std::path::Path| Err(tobj::LoadError::OpenFileFailed);
    let (models, _) = tobj::load_obj_buf(&mut &bytes[..], &options, no_materials)
        .map_err(|e| MeshError::malformed(Format::Obj, format!("not a readable OBJ file: {e}")))?;
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

/// Refuse a file that would make more triangles, or more positions, than `limits` allow,
/// counted from its lines before the reader builds anything: a polygon of n corners is
/// n − 2 triangles.
fn within_budget(bytes: &[u8], limits: Limits) -> Result<(), MeshError> {
    let (mut positions, mut triangles) = (0usize, 0usize);
    for line in bytes.split(|&b| b == b'\n') {
        let mut words = line
            .split(u8::is_ascii_whitespace)
            .filter(|w| !w.is_empty());
        match words.next() {
            Some(b"v") => positions += 1,
            Some(b"f") => triangles += words.count().saturating_sub(2),
            _ => {}
        }
    }
    if triangles > limits.triangles {
        return Err(MeshError::too_large(
            Budget::Triangles,
            format!(
                "{triangles} triangles; a mesh has at most {}",
                limits.triangles
            ),
        ));
    }
    if positions > 3 * limits.triangles {
        return Err(MeshError::too_large(
            Budget::Positions,
            format!(
                "{positions} vertices; a mesh file has at most {} (three for each of the {} \
             triangles a mesh may have)",
                3 * limits.triangles,
                limits.triangles
            ),
        ));
    }
    Ok(())
}
