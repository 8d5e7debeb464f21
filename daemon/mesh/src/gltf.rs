//! glTF 2.0 through the gltf crate: the default scene's nodes, each mesh's triangle
//! primitives placed by its node's transform. Buffers come from a `.glb`'s binary chunk, a
//! base64 `data:` URI, or a file beside the `.gltf` (read with the same guards as the file,
//! and never outside its directory).

use std::path::Path;

use glam::{DMat3, DMat4, DVec3};
use hapticd_core::diagnostics::{FileRules, read_file};

use crate::Read;

/// The triangles of glTF `bytes`, read from `file` under `rules`.
pub(crate) fn read(bytes: &[u8], file: &Path, rules: FileRules) -> Result<Read, String> {
    let gltf =
        ::gltf::Gltf::from_slice(bytes).map_err(|e| format!("not a readable glTF file: {e}"))?;
    let dir = file.parent().unwrap_or(Path::new("."));
    let mut buffers = Vec::new();
    for buffer in gltf.document.buffers() {
        let data = match buffer.source() {
            ::gltf::buffer::Source::Bin => gltf
                .blob
                .clone()
                .ok_or("a buffer names the binary chunk, and there is none")?,
            ::gltf::buffer::Source::Uri(uri) => match uri.strip_prefix("data:") {
                Some(data) => {
                    let (_, encoded) = data
                        .split_once(";base64,")
                        .ok_or("a data: URI that is not base64")?;
                    base64(encoded).ok_or("a data: URI with bad base64")?
                }
                None => {
                    // Beside the file: its own directory bounds where a buffer may be.
                    let path = dir.join(uri);
                    let confined = FileRules {
                        within: Some(rules.within.unwrap_or(dir)),
                        ..rules
                    };
                    read_file(&path, confined)
                        .map_err(|e| format!("buffer {uri:?}: {}", e.message()))?
                }
            },
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "buffer {} holds {} bytes of the {} it declares",
                buffer.index(),
                data.len(),
                buffer.length()
            ));
        }
        buffers.push(data);
    }
    let scene = gltf
        .document
        .default_scene()
        .or_else(|| gltf.document.scenes().next())
        .ok_or("no scene")?;
    let mut read = Read {
        positions: Vec::new(),
        triangles: Vec::new(),
        normals: Some(Vec::new()),
    };
    let mut stack: Vec<(::gltf::Node, DMat4)> =
        scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
    let mut visited = 0usize;
    while let Some((node, parent)) = stack.pop() {
        visited += 1;
        if visited > 100_000 {
            return Err("more than 100000 nodes".into());
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if let Some(mesh) = node.mesh() {
            add_mesh(&mut read, &mesh, world, &buffers)?;
        }
        stack.extend(node.children().map(|c| (c, world)));
    }
    Ok(read)
}

/// Add the triangle primitives of `mesh`, placed by `world`.
fn add_mesh(
    read: &mut Read,
    mesh: &::gltf::Mesh,
    world: DMat4,
    buffers: &[Vec<u8>],
) -> Result<(), String> {
    let turn = DMat3::from_mat4(world).inverse().transpose();
    for primitive in mesh.primitives() {
        if primitive.mode() != ::gltf::mesh::Mode::Triangles {
            continue;
        }
        let reader = primitive.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let positions: Vec<DVec3> = reader
            .read_positions()
            .ok_or("a primitive without positions")?
            .map(|p| world.transform_point3(DVec3::from(p.map(f64::from))))
            .collect();
        let count = positions.len();
        let indices: Vec<usize> = match reader.read_indices() {
            Some(i) => i.into_u32().map(|k| k as usize).collect(),
            None => (0..count).collect(),
        };
        if !indices.len().is_multiple_of(3) {
            return Err(format!(
                "{} indices do not make whole triangles",
                indices.len()
            ));
        }
        let normals: Option<Vec<DVec3>> = reader.read_normals().map(|n| {
            n.map(|v| (turn * DVec3::from(v.map(f64::from))).normalize_or_zero())
                .collect()
        });
        let first = read.positions.len();
        read.positions.extend(positions);
        for corners in indices.chunks_exact(3) {
            if let Some(&k) = corners.iter().find(|&&k| k >= count) {
                return Err(format!(
                    "a triangle names vertex {} of a primitive of {count}",
                    k + 1
                ));
            }
            read.triangles.push([0, 1, 2].map(|i| first + corners[i]));
            let normal = |i: usize| normals.as_ref().and_then(|n| n.get(corners[i]).copied());
            match (&mut read.normals, [normal(0), normal(1), normal(2)]) {
                (Some(all), [Some(a), Some(b), Some(c)]) => all.push([a, b, c]),
                (n, _) => *n = None,
            }
        }
    }
    Ok(())
}

/// The bytes `text` encodes in standard base64 (with or without padding), or None.
fn base64(text: &str) -> Option<Vec<u8>> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => Some(c - b'A'),
        b'a'..=b'z' => Some(c - b'a' + 26),
        b'0'..=b'9' => Some(c - b'0' + 52),
        b'+' => Some(62),
        b'/' => Some(63),
        _ => None,
    };
    let text = text.trim_end_matches('=');
    let mut out = Vec::with_capacity(text.len() * 3 / 4);
    let (mut bits, mut held) = (0u32, 0);
    for c in text.bytes() {
        bits = (bits << 6 | u32::from(value(c)?)) & 0xff_ffff;
        held += 6;
        if held >= 8 {
            held -= 8;
            out.push((bits >> held) as u8);
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_decodes_what_it_should_and_refuses_the_rest() {
        assert_eq!(base64("aGFwdGljZA==").unwrap(), b"hapticd");
        assert_eq!(base64("aGFwdGljZA").unwrap(), b"hapticd");
        assert_eq!(base64("AAEC/w==").unwrap(), [0, 1, 2, 255]);
        assert!(base64("a b").is_none());
    }
}
