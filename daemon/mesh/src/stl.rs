//! STL, binary or ASCII, through stl_io (which tells them apart); STL gives no corner
//! normals, only a face's.

use glam::DVec3;

use crate::Read;

/// The triangles of STL `bytes`.
pub(crate) fn read(bytes: &[u8]) -> Result<Read, String> {
    let mesh = stl_io::read_stl(&mut std::io::Cursor::new(bytes))
        .map_err(|e| format!("not a readable STL file: {e}"))?;
    Ok(Read {
        positions: mesh
            .vertices
            .iter()
            .map(|v| DVec3::from(v.0.map(f64::from)))
            .collect(),
        triangles: mesh.faces.iter().map(|f| f.vertices).collect(),
        normals: None,
    })
}
