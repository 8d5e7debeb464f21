//! glTF 2.0 through the gltf crate: the default scene's nodes, each mesh's triangle
//! primitives placed by its node's transform. Buffers come from a `.glb`'s binary chunk, a
//! base64 `data:` URI, or a file beside the `.gltf` (read with the same guards as the file,
//! and never outside its directory).
//!
//! A small file can describe a huge mesh: a node graph that reuses a node at every level,
//! or a node that is its own child, would add a mesh again on each visit. So the nodes must
//! form trees, as the format says (each node at most one parent, no cycles), and the budgets
//! are running counts checked before each piece is read: nodes, buffer bytes, corners and
//! triangles. Every accessor is checked against its buffer view and buffer before the
//! crate's reader sees it, since that reader trusts strides and counts.

use std::path::Path;

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::{Accessor, Document, Node};
use glam::{DMat3, DMat4, DVec3};
use hapticd_core::diagnostics::{FileRules, read_file};

use crate::{Budget, Format, Limits, MeshError, Read};

/// The triangles of glTF `bytes`, read from `file` under `rules` and `limits`.
pub(crate) fn read(
    bytes: &[u8],
    file: &Path,
    rules: FileRules,
    limits: Limits,
) -> Result<Read, MeshError> {
    let unreadable = |e: ::gltf::Error| malformed(format!("not a readable glTF file: {e}"));
    let raw = ::gltf::Gltf::from_slice_without_validation(bytes).map_err(unreadable)?;
    // The crate's validation indexes a primitive's POSITION accessor before it checks that
    // the index is in range (a fuzzed file panicked it): checked here first.
    positions_in_range(raw.document.as_json())?;
    let blob = raw.blob;
    let document = &::gltf::Document::from_json(raw.document.into_json()).map_err(unreadable)?;
    if document.nodes().len() > limits.nodes {
        return Err(MeshError::too_large(
            Budget::Nodes,
            format!(
                "{} nodes; a mesh file has at most {}",
                document.nodes().len(),
                limits.nodes
            ),
        ));
    }
    check_trees(document)?;
    let buffers = buffers((document, blob.as_ref()), file, rules, limits)?;
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| malformed("no scene"))?;
    let mut walk = Walk {
        read: Read {
            positions: Vec::new(),
            triangles: Vec::new(),
            normals: Some(Vec::new()),
        },
        buffers: &buffers,
        limits,
    };
    let mut stack: Vec<(Node, DMat4)> = scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
    while let Some((node, parent)) = stack.pop() {
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if let Some(mesh) = node.mesh() {
            walk.add_mesh(&node, &mesh, world)?;
        }
        stack.extend(node.children().map(|c| (c, world)));
    }
    Ok(walk.read)
}

/// Refuse a primitive whose POSITION names an accessor the file does not have.
fn positions_in_range(root: &::gltf::json::Root) -> Result<(), MeshError> {
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let positions = ::gltf::json::validation::Checked::Valid(::gltf::Semantic::Positions);
            if let Some(index) = primitive.attributes.get(&positions)
                && index.value() >= root.accessors.len()
            {
                return Err(malformed(format!(
                    "primitive {p} of {} names accessor {} for its positions, of {}",
                    named("mesh", m, mesh.name.as_deref()),
                    index.value(),
                    root.accessors.len()
                )));
            }
        }
    }
    Ok(())
}

/// How a node, mesh or accessor is named in an error: its index, and its name if it has one.
fn named(kind: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(name) => format!("{kind} {index} ({name:?})"),
        None => format!("{kind} {index}"),
    }
}

fn node_name(node: &Node) -> String {
    named("node", node.index(), node.name())
}

/// Refuse a node graph that is not a set of trees: a node that is a child twice over, or
/// its own ancestor, or a scene's root that is another node's child.
fn check_trees(document: &Document) -> Result<(), MeshError> {
    let nodes: Vec<Node> = document.nodes().collect();
    let mut parent: Vec<Option<usize>> = vec![None; nodes.len()];
    for node in &nodes {
        for child in node.children() {
            if child.index() == node.index() {
                return Err(malformed(format!("{} is its own child", node_name(node))));
            }
            if let Some(other) = parent[child.index()] {
                return Err(malformed(format!(
                    "{} is a child of both {} and {}: glTF's nodes form trees",
                    node_name(&child),
                    node_name(&nodes[other]),
                    node_name(node)
                )));
            }
            parent[child.index()] = Some(node.index());
        }
    }
    // With one parent each, a cycle is a walk up the parents that comes back; marking each
    // node with the walk that first reached it keeps the whole check linear.
    let mut reached_by: Vec<Option<usize>> = vec![None; nodes.len()];
    for start in 0..nodes.len() {
        let mut at = Some(start);
        while let Some(k) = at {
            match reached_by[k] {
                Some(walk) if walk == start => {
                    return Err(malformed(format!(
                        "{} is its own ancestor",
                        node_name(&nodes[k])
                    )));
                }
                Some(_) => break,
                None => reached_by[k] = Some(start),
            }
            at = parent[k];
        }
    }
    for scene in document.scenes() {
        for root in scene.nodes() {
            if let Some(p) = parent[root.index()] {
                return Err(malformed(format!(
                    "{} is a root of {} and a child of {}",
                    node_name(&root),
                    named("scene", scene.index(), scene.name()),
                    node_name(&nodes[p])
                )));
            }
        }
    }
    Ok(())
}

/// The data of every buffer, together at most `limits.bytes` beyond the file itself.
fn buffers(
    (document, blob): (&Document, Option<&Vec<u8>>),
    file: &Path,
    rules: FileRules,
    limits: Limits,
) -> Result<Vec<Vec<u8>>, MeshError> {
    let dir = hapticd_core::diagnostics::directory_of(file);
    let mut left = limits.bytes;
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let too_large = || {
            MeshError::too_large(
                Budget::Bytes,
                format!(
                    "buffer {}: its data would pass the {} bytes a mesh's buffers may hold",
                    buffer.index(),
                    limits.bytes
                ),
            )
        };
        if buffer.length() as u64 > left {
            return Err(too_large());
        }
        let data = match buffer.source() {
            ::gltf::buffer::Source::Bin => blob
                .cloned()
                .ok_or_else(|| malformed("a buffer names the binary chunk, and there is none"))?,
            ::gltf::buffer::Source::Uri(uri) => match uri.strip_prefix("data:") {
                Some(data) => {
                    let (_, encoded) = data
                        .split_once(";base64,")
                        .ok_or_else(|| malformed("a data: URI that is not base64"))?;
                    base64(encoded).ok_or_else(|| malformed("a data: URI with bad base64"))?
                }
                None => {
                    // Beside the file: its own directory bounds where a buffer may be.
                    let path = dir.join(uri);
                    let confined = FileRules {
                        within: Some(rules.within.unwrap_or(dir)),
                        max_bytes: left,
                    };
                    read_file(&path, confined).map_err(|e| {
                        MeshError::Unreadable(format!("buffer {uri:?}: {}", e.message()))
                    })?
                }
            },
        };
        if data.len() < buffer.length() {
            return Err(malformed(format!(
                "buffer {} holds {} bytes of the {} it declares",
                buffer.index(),
                data.len(),
                buffer.length()
            )));
        }
        left = left.checked_sub(data.len() as u64).ok_or_else(too_large)?;
        buffers.push(data);
    }
    Ok(buffers)
}

/// The node walk's output so far, and its budgets.
struct Walk<'a> {
    read: Read,
    buffers: &'a [Vec<u8>],
    limits: Limits,
}

/// What an accessor must hold.
#[derive(Clone, Copy, PartialEq)]
enum Holds {
    /// Three 32-bit floats an element: positions, normals.
    Vec3,
    /// One unsigned integer an element: indices.
    Index,
}

impl Walk<'_> {
    /// Add the triangle primitives of `mesh`, placed by `world` for `node`, within the
    /// budgets left.
    fn add_mesh(
        &mut self,
        node: &Node,
        mesh: &::gltf::Mesh,
        world: DMat4,
    ) -> Result<(), MeshError> {
        let turn = DMat3::from_mat4(world).inverse().transpose();
        for primitive in mesh.primitives() {
            if primitive.mode() != ::gltf::mesh::Mode::Triangles {
                continue;
            }
            let at = || {
                format!(
                    "{} of {}, placed by {}",
                    named("primitive", primitive.index(), None),
                    named("mesh", mesh.index(), mesh.name()),
                    node_name(node)
                )
            };
            let in_primitive = |e: MeshError| e.within(&at());
            let positions = primitive
                .get(&::gltf::Semantic::Positions)
                .ok_or_else(|| in_primitive(malformed("no positions")))?;
            let count = self
                .checked(&positions, Holds::Vec3)
                .map_err(in_primitive)?;
            let corners = match primitive.indices() {
                Some(indices) => self.checked(&indices, Holds::Index).map_err(in_primitive)?,
                None => count,
            };
            let normals = match primitive.get(&::gltf::Semantic::Normals) {
                Some(normals) => Some(self.checked(&normals, Holds::Vec3).map_err(in_primitive)?)
                    .filter(|&n| n == count),
                None => None,
            };
            if !corners.is_multiple_of(3) {
                return Err(in_primitive(malformed(format!(
                    "{corners} corners do not make whole triangles"
                ))));
            }
            // The budgets, before anything is read: a file cannot make the walk allocate
            // more than the limits allow, however often its meshes are placed.
            let triangles = self.read.triangles.len() + corners / 3;
            if triangles > self.limits.triangles {
                return Err(MeshError::too_large(
                    Budget::Triangles,
                    format!(
                        "more than {} triangles once {} is placed; a mesh has at most {}",
                        self.limits.triangles,
                        at(),
                        self.limits.triangles
                    ),
                ));
            }
            let most_corners = 3 * self.limits.triangles;
            if self.read.positions.len() + count > most_corners {
                return Err(MeshError::too_large(
                    Budget::Positions,
                    format!(
                        "more than {most_corners} positions once {} is placed (three for each \
                         of the {} triangles a mesh may have)",
                        at(),
                        self.limits.triangles
                    ),
                ));
            }
            self.add_primitive(&primitive, world, turn, count, normals.is_some())
                .map_err(in_primitive)?;
        }
        Ok(())
    }

    /// Read `primitive` (its `count` positions, with normals when `with_normals`), every
    /// accessor already checked.
    fn add_primitive(
        &mut self,
        primitive: &::gltf::Primitive,
        world: DMat4,
        turn: DMat3,
        count: usize,
        with_normals: bool,
    ) -> Result<(), MeshError> {
        let buffers = self.buffers;
        let reader = primitive.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let read = &mut self.read;
        let first = read.positions.len();
        read.positions.extend(
            reader
                .read_positions()
                .ok_or_else(|| malformed("its positions cannot be read"))?
                .map(|p| world.transform_point3(DVec3::from(p.map(f64::from)))),
        );
        if read.positions.len() != first + count {
            return Err(malformed("its positions end early"));
        }
        let indices: Vec<usize> = match reader.read_indices() {
            Some(i) => i.into_u32().map(|k| k as usize).collect(),
            None => (0..count).collect(),
        };
        let normals: Option<Vec<DVec3>> = reader.read_normals().filter(|_| with_normals).map(|n| {
            n.map(|v| (turn * DVec3::from(v.map(f64::from))).normalize_or_zero())
                .collect()
        });
        for corners in indices.chunks_exact(3) {
            if let Some(&k) = corners.iter().find(|&&k| k >= count) {
                return Err(malformed(format!(
                    "a triangle names vertex {} of the primitive's {count}",
                    k + 1
                )));
            }
            read.triangles.push([0, 1, 2].map(|i| first + corners[i]));
            let normal = |i: usize| normals.as_ref().and_then(|n| n.get(corners[i]).copied());
            match (&mut read.normals, [normal(0), normal(1), normal(2)]) {
                (Some(all), [Some(a), Some(b), Some(c)]) => all.push([a, b, c]),
                (n, _) => *n = None,
            }
        }
        Ok(())
    }

    /// The element count of `accessor`, once it is known to hold what `holds` needs and to
    /// lie within its buffer view and buffer (the reader would otherwise panic or read
    /// past them).
    fn checked(&self, accessor: &Accessor, holds: Holds) -> Result<usize, MeshError> {
        let name = named("accessor", accessor.index(), accessor.name());
        let fail = |why: String| Err(malformed(format!("{name} {why}")));
        if accessor.sparse().is_some() {
            return fail("is sparse, which hapticd does not read".into());
        }
        let Some(view) = accessor.view() else {
            return fail("has no buffer view".into());
        };
        let fits = match holds {
            Holds::Vec3 => {
                accessor.dimensions() == Dimensions::Vec3 && accessor.data_type() == DataType::F32
            }
            Holds::Index => {
                accessor.dimensions() == Dimensions::Scalar
                    && matches!(
                        accessor.data_type(),
                        DataType::U8 | DataType::U16 | DataType::U32
                    )
            }
        };
        if !fits {
            return fail(format!(
                "holds {:?} of {:?}, not {}",
                accessor.dimensions(),
                accessor.data_type(),
                match holds {
                    Holds::Vec3 => "three 32-bit floats",
                    Holds::Index => "unsigned integers",
                }
            ));
        }
        let count = accessor.count();
        if count == 0 {
            return fail("holds no element".into());
        }
        let element = accessor.size();
        let stride = view.stride().unwrap_or(element);
        if stride < element || (holds == Holds::Index && stride != element) {
            return fail(format!(
                "has elements of {element} bytes {stride} bytes apart (buffer view {}'s \
                 byteStride)",
                view.index()
            ));
        }
        let end = stride
            .checked_mul(count - 1)
            .and_then(|n| n.checked_add(element))
            .and_then(|n| n.checked_add(accessor.offset()));
        if end.is_none_or(|end| end > view.length()) {
            return fail(format!(
                "of {count} elements does not fit in buffer view {}'s {} bytes",
                view.index(),
                view.length()
            ));
        }
        let buffer = &self.buffers[view.buffer().index()];
        if view
            .offset()
            .checked_add(view.length())
            .is_none_or(|end| end > buffer.len())
        {
            return fail(format!(
                "is in buffer view {}, which ends past buffer {}'s {} bytes",
                view.index(),
                view.buffer().index(),
                buffer.len()
            ));
        }
        Ok(count)
    }
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

/// The file breaks glTF as `reason` says.
fn malformed(reason: impl Into<String>) -> MeshError {
    MeshError::malformed(Format::Gltf, reason)
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
