//! The three formats read to the same triangles, and bad files are refused with their name
//! and why. Each file is written here, from its format's specification, not by the readers'
//! crates.

use std::path::{Path, PathBuf};

use crate::support;

use glam::{DMat3, DVec3};
use hapticd_mesh::properties::{closure, mass_properties};
use hapticd_mesh::{Budget, Format, Limits, MeshError, TriangleMesh, load, read};

/// The unit cube's corners and its twelve triangles, counter-clockwise from outside.
fn cube() -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let corners = (0..8)
        .map(|k| [(k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64])
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    (corners, triangles)
}

fn obj_text(corners: &[[f64; 3]], triangles: &[[usize; 3]]) -> String {
    let mut text = String::from("# the unit cube\no cube\n");
    for c in corners {
        text += &format!("v {} {} {}\n", c[0], c[1], c[2]);
    }
    for t in triangles {
        text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    text
}

fn stl_ascii(corners: &[[f64; 3]], triangles: &[[usize; 3]]) -> String {
    let mut text = String::from("solid cube\n");
    for t in triangles {
        text += "  facet normal 0 0 0\n    outer loop\n";
        for &k in t {
            text += &format!(
                "      vertex {} {} {}\n",
                corners[k][0], corners[k][1], corners[k][2]
            );
        }
        text += "    endloop\n  endfacet\n";
    }
    text + "endsolid cube\n"
}

fn stl_binary(corners: &[[f64; 3]], triangles: &[[usize; 3]]) -> Vec<u8> {
    let mut bytes = vec![0u8; 80];
    bytes.extend((triangles.len() as u32).to_le_bytes());
    for t in triangles {
        bytes.extend([0f32; 3].iter().flat_map(|v| v.to_le_bytes()));
        for &k in t {
            bytes.extend(corners[k].iter().flat_map(|&v| (v as f32).to_le_bytes()));
        }
        bytes.extend([0u8; 2]);
    }
    bytes
}

/// The binary buffer of a glTF mesh: f32 positions, then u32 indices.
fn gltf_buffer(corners: &[[f64; 3]], triangles: &[[usize; 3]]) -> Vec<u8> {
    let mut bytes: Vec<u8> = corners
        .iter()
        .flatten()
        .flat_map(|&v| (v as f32).to_le_bytes())
        .collect();
    bytes.extend(
        triangles
            .iter()
            .flatten()
            .flat_map(|&k| (k as u32).to_le_bytes()),
    );
    bytes
}

/// A glTF document of one node (moved by `translation`) with one mesh whose buffer is at
/// `uri` (None: a GLB's binary chunk).
fn gltf_json(corners: usize, triangles: usize, uri: Option<&str>, translation: [f64; 3]) -> String {
    let positions = corners * 12;
    let indices = triangles * 12;
    let uri = uri.map_or(String::new(), |u| format!(r#""uri": "{u}", "#));
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
 "nodes": [{{"mesh": 0, "translation": [{}, {}, {}]}}],
 "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
 "buffers": [{{{uri}"byteLength": {}}}],
 "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": {positions}}},
                 {{"buffer": 0, "byteOffset": {positions}, "byteLength": {indices}}}],
 "accessors": [{{"bufferView": 0, "componentType": 5126, "count": {corners}, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 1]}},
               {{"bufferView": 1, "componentType": 5125, "count": {}, "type": "SCALAR"}}]}}"#,
        translation[0],
        translation[1],
        translation[2],
        positions + indices,
        triangles * 3
    )
}

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let pad = |mut v: Vec<u8>, with: u8| {
        while !v.len().is_multiple_of(4) {
            v.push(with);
        }
        v
    };
    let json = pad(json.as_bytes().to_vec(), b' ');
    let bin = pad(bin.to_vec(), 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut bytes = b"glTF".to_vec();
    bytes.extend(2u32.to_le_bytes());
    bytes.extend((total as u32).to_le_bytes());
    bytes.extend((json.len() as u32).to_le_bytes());
    bytes.extend(b"JSON");
    bytes.extend(json);
    bytes.extend((bin.len() as u32).to_le_bytes());
    bytes.extend(b"BIN\0");
    bytes.extend(bin);
    bytes
}

fn base64(bytes: &[u8]) -> String {
    const DIGITS: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut text = String::new();
    for chunk in bytes.chunks(3) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |n, (i, &b)| n | u32::from(b) << (16 - 8 * i));
        for i in 0..=chunk.len() {
            text.push(DIGITS[(n >> (18 - 6 * i) & 63) as usize] as char);
        }
        text.push_str(&"=".repeat(3 - chunk.len()));
    }
    text
}

/// The triangles as sorted corner triples, each starting at its least corner (winding kept).
fn canonical(mesh: &TriangleMesh) -> Vec<[[i64; 3]; 3]> {
    let mut all: Vec<[[i64; 3]; 3]> = mesh
        .corners()
        .map(|t| {
            let t = t.map(|p| p.to_array().map(|c| (c * 1e6).round() as i64));
            let first = (0..3).min_by_key(|&i| t[i]).unwrap();
            [t[first], t[(first + 1) % 3], t[(first + 2) % 3]]
        })
        .collect();
    all.sort();
    all
}

fn loaded(file: &Path) -> TriangleMesh {
    load(file, 1.0, Limits::DEFAULT, None).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn the_same_cube_in_every_format_loads_to_the_same_triangles_and_solid() {
    let dir = support::scratch("mesh", "formats");
    let (corners, triangles) = cube();
    std::fs::write(dir.join("cube.obj"), obj_text(&corners, &triangles)).unwrap();
    std::fs::write(dir.join("ascii.stl"), stl_ascii(&corners, &triangles)).unwrap();
    std::fs::write(dir.join("binary.stl"), stl_binary(&corners, &triangles)).unwrap();
    let buffer = gltf_buffer(&corners, &triangles);
    std::fs::write(dir.join("cube.bin"), &buffer).unwrap();
    std::fs::write(
        dir.join("external.gltf"),
        gltf_json(8, 12, Some("cube.bin"), [0.0; 3]),
    )
    .unwrap();
    let uri = format!("data:application/octet-stream;base64,{}", base64(&buffer));
    std::fs::write(
        dir.join("embedded.gltf"),
        gltf_json(8, 12, Some(&uri), [0.0; 3]),
    )
    .unwrap();
    std::fs::write(
        dir.join("cube.glb"),
        glb(&gltf_json(8, 12, None, [0.0; 3]), &buffer),
    )
    .unwrap();
    let reference = loaded(&dir.join("cube.obj"));
    assert_eq!(
        (reference.vertices.len(), reference.triangles.len()),
        (8, 12)
    );
    for name in [
        "ascii.stl",
        "binary.stl",
        "external.gltf",
        "embedded.gltf",
        "cube.glb",
    ] {
        let mesh = loaded(&dir.join(name));
        assert_eq!(canonical(&mesh), canonical(&reference), "{name}");
        assert_eq!(mesh.vertices.len(), 8, "{name}: shared corners are merged");
    }
    // The unit cube as a solid: the box's volume and inertia, to 1e-12.
    assert!(closure(&reference).is_closed());
    let p = mass_properties(&reference);
    assert!((p.volume - 1.0).abs() < 1e-12);
    assert!((p.centre - DVec3::splat(0.5)).length() < 1e-12);
    let box_inertia = DMat3::from_diagonal(DVec3::splat(2.0 / 12.0));
    let worst = (p.inertia - box_inertia)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(worst < 1e-12, "{:?}", p.inertia);
    // A node's transform places its mesh, and `scale` scales it.
    std::fs::write(
        dir.join("moved.gltf"),
        gltf_json(8, 12, Some("cube.bin"), [1.0, 2.0, 3.0]),
    )
    .unwrap();
    let (low, high) = loaded(&dir.join("moved.gltf")).bounds();
    assert_eq!(
        (low, high),
        (DVec3::new(1.0, 2.0, 3.0), DVec3::new(2.0, 3.0, 4.0))
    );
    let scaled = load(&dir.join("cube.obj"), 0.001, Limits::DEFAULT, None).unwrap();
    assert!((mass_properties(&scaled).volume - 1e-9).abs() < 1e-21);
}

/// The error `load` gives for `file`, rendered.
fn refused(file: &Path, limits: Limits, within: Option<&Path>) -> String {
    load(file, 1.0, limits, within)
        .err()
        .unwrap_or_else(|| panic!("{} was read", file.display()))
        .to_string()
}

#[test]
fn bad_files_are_refused_with_their_name_and_why() {
    let dir = support::scratch("mesh", "bad");
    let (corners, triangles) = cube();
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    };
    let text = obj_text(&corners, &triangles);
    for (name, bytes, says) in [
        (
            "missing.obj",
            text.replacen("\nf ", "\nf 99 ", 1).into_bytes(),
            "index out of bounds",
        ),
        (
            "nan.obj",
            text.replacen("v 0 0 0", "v nan 0 0", 1).into_bytes(),
            "not finite",
        ),
        ("empty.obj", b"# nothing\n".to_vec(), "no triangles"),
        (
            "truncated.stl",
            stl_binary(&corners, &triangles)[..200].to_vec(),
            "STL",
        ),
        ("garbage.glb", b"glTF\x02\0\0\0garbage".to_vec(), "glTF"),
        ("cube.ply", b"ply\n".to_vec(), ".obj, .stl, .gltf or .glb"),
    ] {
        let path = write(name, &bytes);
        let e = refused(&path, Limits::DEFAULT, None);
        assert!(
            e.starts_with(&format!("{}: error: ", path.display())),
            "{e}"
        );
        assert!(e.contains(says), "{name}: {e}");
    }
    // The same refusals, typed: a caller tells their kinds apart without reading words.
    let kind = |name: &str| read(&dir.join(name), 1.0, Limits::DEFAULT, None).unwrap_err();
    assert!(matches!(
        kind("missing.obj"),
        MeshError::Malformed {
            format: Format::Obj,
            ..
        }
    ));
    assert_eq!(kind("nan.obj"), MeshError::NotFinite(1));
    assert_eq!(kind("empty.obj"), MeshError::Empty);
    assert!(matches!(
        kind("truncated.stl"),
        MeshError::Malformed {
            format: Format::Stl,
            ..
        }
    ));
    assert!(matches!(
        kind("garbage.glb"),
        MeshError::Malformed {
            format: Format::Gltf,
            ..
        }
    ));
    assert_eq!(kind("cube.ply"), MeshError::UnknownFormat);
    assert!(matches!(kind("nowhere.obj"), MeshError::Unreadable(_)));
    // A bomb: more than the limits allow, refused before it is used.
    let cube_file = write("cube.obj", text.as_bytes());
    let small = Limits {
        triangles: 11,
        ..Limits::DEFAULT
    };
    assert!(refused(&cube_file, small, None).contains("12 triangles; a mesh has at most 11"));
    assert!(matches!(
        read(&cube_file, 1.0, small, None),
        Err(MeshError::TooLarge {
            budget: Budget::Triangles,
            ..
        })
    ));
    let tiny = Limits {
        bytes: 16,
        ..Limits::DEFAULT
    };
    assert!(refused(&cube_file, tiny, None).contains("more than the 16"));
    // A buffer that lies, or lies outside the file's directory.
    let buffer = gltf_buffer(&corners, &triangles);
    std::fs::write(dir.join("short.bin"), &buffer[..40]).unwrap();
    let short = write(
        "short.gltf",
        gltf_json(8, 12, Some("short.bin"), [0.0; 3]).as_bytes(),
    );
    assert!(refused(&short, Limits::DEFAULT, None).contains("holds 40 bytes"));
    let outside = support::scratch("mesh", "outside");
    std::fs::write(outside.join("cube.bin"), &buffer).unwrap();
    let escape = write(
        "escape.gltf",
        gltf_json(8, 12, Some("../hapticd-mesh-outside/cube.bin"), [0.0; 3])
            .replace(
                "hapticd-mesh-outside",
                &outside.file_name().unwrap().to_string_lossy(),
            )
            .as_bytes(),
    );
    assert!(refused(&escape, Limits::DEFAULT, None).contains("outside"));
    // A mesh named by a bus caller must lie in the scene's directory.
    std::os::unix::fs::symlink(outside.join("cube.bin"), dir.join("link.obj")).unwrap();
    let e = refused(&dir.join("link.obj"), Limits::DEFAULT, Some(&dir));
    assert!(e.contains("outside"), "{e}");
    let e = load(&cube_file, f64::NAN, Limits::DEFAULT, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("scale must be"), "{e}");
    assert!(matches!(
        read(&cube_file, -1.0, Limits::DEFAULT, None),
        Err(MeshError::Scale(s)) if s == -1.0
    ));
}

/// The shipped example meshes (written by config/scenes/meshes/make-meshes.py): each as OBJ and as
/// glTF the same closed solid, of the volume of the polygons the script draws.
#[test]
fn the_example_meshes_are_closed_solids_of_their_drawn_volumes() {
    let dir = support::repo_dir().join("config/scenes/meshes");
    let segments = 32.0;
    // The area of the regular polygon of `segments` sides the script puts on a circle.
    let polygon = |r: f64| segments / 2.0 * r * r * (2.0 * std::f64::consts::PI / segments).sin();
    for (name, volume, tolerance) in [
        // The 50 mm square plate, 6 mm thick, less its hole.
        ("bracket", (0.05 * 0.05 - polygon(0.008)) * 0.006, 1e-12),
        // The cup less its inside, and the handle: a 5 mm tube along half of a 25 mm circle
        // (its polygon's length, less what the bends pinch).
        (
            "mug",
            polygon(0.040) * 0.090 - polygon(0.036) * 0.084
                + polygon(0.005) * 16.0 * 2.0 * 0.025 * (std::f64::consts::PI / 32.0).sin(),
            2e-7,
        ),
    ] {
        let obj = loaded(&dir.join(format!("{name}.obj")));
        let gltf = loaded(&dir.join(format!("{name}.gltf")));
        assert_eq!(canonical(&obj), canonical(&gltf), "{name}");
        assert!(closure(&obj).is_closed(), "{name}: {:?}", closure(&obj));
        let p = mass_properties(&obj);
        assert!(
            (p.volume - volume).abs() < tolerance,
            "{name}: {} m³, drawn {volume} m³",
            p.volume
        );
    }
}

/// `text` written to `name` in `dir`: its path.
fn written(dir: &Path, name: &str, text: String) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// A glTF document whose scene has `roots` (a JSON list) among `nodes` (a JSON list), each
/// node that names mesh 0 placing the unit cube, its buffer embedded; `stride` is the
/// positions' byteStride, if any.
fn cube_scene(roots: &str, nodes: &str, stride: Option<usize>) -> String {
    let (corners, triangles) = cube();
    let buffer = gltf_buffer(&corners, &triangles);
    let stride = stride.map_or(String::new(), |s| format!(r#", "byteStride": {s}"#));
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": {roots}}}],
 "nodes": {nodes},
 "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
 "buffers": [{{"uri": "data:application/octet-stream;base64,{}", "byteLength": {}}}],
 "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 96{stride}}},
                 {{"buffer": 0, "byteOffset": 96, "byteLength": 144}}],
 "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 1]}},
               {{"bufferView": 1, "componentType": 5125, "count": 36, "type": "SCALAR"}}]}}"#,
        base64(&buffer),
        buffer.len()
    )
}

/// Nodes as a JSON list: node k has `children(k)` and, when `mesh(k)`, places mesh 0.
fn nodes_json(
    count: usize,
    children: impl Fn(usize) -> Vec<usize>,
    mesh: impl Fn(usize) -> bool,
) -> String {
    let nodes: Vec<String> = (0..count)
        .map(|k| {
            let children: Vec<String> = children(k).iter().map(usize::to_string).collect();
            let mesh = if mesh(k) { r#""mesh": 0, "# } else { "" };
            format!(
                r#"{{{mesh}"name": "n{k}", "children": [{}]}}"#,
                children.join(",")
            )
        })
        .collect();
    format!("[{}]", nodes.join(",\n"))
}

/// A 40 KB glTF of a node graph that reuses its nodes, or loops, describes billions of
/// triangles: refused at once and by name, as the format's trees are, before anything is
/// expanded; a legal tree that places one mesh many times is held to the triangle budget as
/// it is walked.
#[test]
fn node_graphs_that_reuse_or_loop_are_refused_by_name_before_they_are_expanded() {
    let dir = support::scratch("mesh", "graphs");
    let write = |name: &str, text: String| written(&dir, name, text);
    // Six levels of ten nodes, each node of a level a child of every node of the level
    // above: 10⁶ paths to the cube at the bottom.
    let dag = nodes_json(
        60,
        |k| {
            if k < 50 {
                (10 * (k / 10 + 1)..10 * (k / 10 + 2)).collect()
            } else {
                Vec::new()
            }
        },
        |k| k >= 50,
    );
    let roots = format!(
        "[{}]",
        (0..10).map(|k| k.to_string()).collect::<Vec<_>>().join(",")
    );
    let started = std::time::Instant::now();
    let e = refused(
        &write("dag.gltf", cube_scene(&roots, &dag, None)),
        Limits::DEFAULT,
        None,
    );
    assert!(
        e.contains(r#"node 10 ("n10") is a child of both node 0 ("n0") and node 1 ("n1")"#),
        "{e}"
    );
    // Refused from the graph, not after expanding it (which took minutes and gigabytes).
    assert!(started.elapsed() < std::time::Duration::from_secs(5));
    let own_child = nodes_json(2, |k| vec![k], |_| true);
    let e = refused(
        &write("self.gltf", cube_scene("[0]", &own_child, None)),
        Limits::DEFAULT,
        None,
    );
    assert!(e.contains(r#"node 0 ("n0") is its own child"#), "{e}");
    // Node 1 → 2 → 3 → 1, hanging under no root: still no file hapticd reads.
    let ring = nodes_json(
        4,
        |k| match k {
            1 => vec![2],
            2 => vec![3],
            3 => vec![1],
            _ => Vec::new(),
        },
        |_| true,
    );
    let e = refused(
        &write("ring.gltf", cube_scene("[0]", &ring, None)),
        Limits::DEFAULT,
        None,
    );
    assert!(e.contains("is its own ancestor"), "{e}");
    // A legal tree: a root with 200 children, each placing the cube (12 triangles).
    let wide = nodes_json(
        201,
        |k| {
            if k == 0 {
                (1..201).collect()
            } else {
                Vec::new()
            }
        },
        |k| k > 0,
    );
    let path = write("wide.gltf", cube_scene("[0]", &wide, None));
    assert_eq!(loaded(&path).triangles.len(), 2400);
    let budget = Limits {
        triangles: 2000,
        ..Limits::DEFAULT
    };
    let e = refused(&path, budget, None);
    assert!(
        e.contains("more than 2000 triangles once primitive 0 of mesh 0, placed by node"),
        "{e}"
    );
    let few_nodes = Limits {
        nodes: 100,
        ..Limits::DEFAULT
    };
    assert!(refused(&path, few_nodes, None).contains("201 nodes; a mesh file has at most 100"));
}

/// Accessors that lie about their layout are refused with what is wrong, where the glTF
/// crate's reader would panic (a stride shorter than an element) or read past its data.
#[test]
fn accessors_that_lie_about_their_layout_are_refused_not_read() {
    let dir = support::scratch("mesh", "accessors");
    let write = |name: &str, text: String| written(&dir, name, text);
    let one = nodes_json(1, |_| Vec::new(), |_| true);
    let path = write("stride.gltf", cube_scene("[0]", &one, Some(4)));
    let e = refused(&path, Limits::DEFAULT, None);
    assert!(
        e.contains("accessor 0 has elements of 12 bytes 4 bytes apart"),
        "{e}"
    );
    for (name, from, to, says) in [
        (
            "count.gltf",
            r#""count": 8,"#,
            r#""count": 9,"#,
            "of 9 elements does not fit in buffer view 0's 96 bytes",
        ),
        (
            "huge.gltf",
            r#""count": 8,"#,
            r#""count": 4294967295,"#,
            "does not fit",
        ),
        (
            "empty.gltf",
            r#""count": 8,"#,
            r#""count": 0,"#,
            "holds no element",
        ),
        (
            "type.gltf",
            r#""count": 8, "type": "VEC3""#,
            r#""count": 8, "type": "VEC2""#,
            "holds Vec2 of F32, not three 32-bit floats",
        ),
        (
            "view.gltf",
            r#""byteOffset": 96, "byteLength": 144"#,
            r#""byteOffset": 200, "byteLength": 144"#,
            "ends past buffer 0's 240 bytes",
        ),
    ] {
        let text = cube_scene("[0]", &one, None);
        assert!(text.contains(from), "{name}");
        let e = refused(
            &write(name, text.replacen(from, to, 1)),
            Limits::DEFAULT,
            None,
        );
        assert!(e.contains(says), "{name}: {e}");
    }
}

/// STL as exporters write it: a tab after `solid`, several solids, a binary header that
/// starts with `solid`, a loop of four corners; and counts that lie.
#[test]
fn stl_files_as_exporters_write_them_are_read_and_lying_counts_refused() {
    let dir = support::scratch("mesh", "stl");
    let (corners, triangles) = cube();
    let reference = canonical(&TriangleMesh {
        vertices: corners.iter().map(|&c| DVec3::from(c)).collect(),
        triangles: triangles.iter().map(|t| t.map(|k| k as u32)).collect(),
        normals: None,
    });
    let text = stl_ascii(&corners, &triangles);
    let tabbed = text.replacen("solid cube", "solid\tcube", 1);
    let halves: Vec<&str> = text.splitn(8, "  facet").collect();
    let two_solids = format!(
        "{}endsolid a\nsolid b\n  facet{}",
        halves[..7].join("  facet"),
        halves[7]
    );
    let mut labelled = stl_binary(&corners, &triangles);
    labelled[..11].copy_from_slice(b"solid cube ");
    for (name, bytes) in [
        ("tab.stl", tabbed.into_bytes()),
        ("two.stl", two_solids.into_bytes()),
        ("labelled.stl", labelled.clone()),
    ] {
        std::fs::write(dir.join(name), &bytes).unwrap();
        assert_eq!(canonical(&loaded(&dir.join(name))), reference, "{name}");
    }
    // One quadrilateral facet: two triangles.
    let quad = "solid q\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid q\n";
    std::fs::write(dir.join("quad.stl"), quad).unwrap();
    assert_eq!(loaded(&dir.join("quad.stl")).triangles.len(), 2);
    let mut lying = labelled;
    lying[80..84].copy_from_slice(&1_000_000u32.to_le_bytes());
    for (name, bytes, says) in [
        (
            "lying.stl",
            lying,
            "a binary STL of 1000000 triangles is 50000084 bytes long, not 684",
        ),
        (
            "cut.stl",
            text.as_bytes()[..text.len() - 40].to_vec(),
            "ends within facet 12",
        ),
        (
            "word.stl",
            text.replacen("outer loop", "outer lop", 1).into_bytes(),
            "facet 1 has \"lop\" where loop belongs",
        ),
    ] {
        std::fs::write(dir.join(name), &bytes).unwrap();
        let e = refused(&dir.join(name), Limits::DEFAULT, None);
        assert!(e.contains(says), "{name}: {e}");
    }
    let few = Limits {
        triangles: 11,
        ..Limits::DEFAULT
    };
    std::fs::write(dir.join("ascii.stl"), &text).unwrap();
    assert!(refused(&dir.join("ascii.stl"), few, None).contains("more than 11 triangles"));
}
