//! A static scene's description and its file: the solids, each with its surface (material
//! and shading), the proxy's parameters, and the meshes and height maps the file names, read
//! through the readers the program gives.

use std::path::Path;

use glam::{DQuat, DVec3};
use hapticd_plugin_api::{
    Geometry, HAPTICD_SHAPE_BOX, HAPTICD_SHAPE_CYLINDER, HAPTICD_SHAPE_PLANE, HAPTICD_SHAPE_SPHERE,
    HAPTICD_SOLID_FIXED, HapticdSolid, HapticdTriangle,
};
use serde::Deserialize;

use crate::diagnostics::{self, Diagnostics, Findings};
use crate::haptics::obstacle::Shape;
use crate::haptics::proxy::ProxyParameters;
use crate::haptics::shading::{Shading, corner_normals};
use crate::haptics::surface::{Material, MaterialSpec, TransientSpec};
use crate::haptics::texture::{ImageReader, TextureSpec};
use crate::kinematics::{SOLID_SIZES, Up, WORLD_EXTENT, quat_to_wxyz};
use crate::parameters::Name;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    name: String,
    #[serde(default)]
    proxy: Option<RawProxy>,
    shapes: Vec<RawEntry>,
    /// The texture of every surface without one of its own.
    #[serde(default)]
    texture: Option<TextureSpec>,
    /// The transient of every surface without one of its own.
    #[serde(default)]
    transient: Option<TransientSpec>,
    /// Haptic effects: the daemon checks them against each device and renders them.
    #[serde(default)]
    #[allow(dead_code)]
    effects: Vec<crate::haptics::effects::spec::EffectSpec>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProxy {
    stiffness: f64,
    damping: f64,
    static_friction: f64,
    dynamic_friction: f64,
}

/// One of `shapes:`: a solid (one key naming its kind) and its material.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEntry {
    floor: Option<RawFloor>,
    plane: Option<RawPlane>,
    sphere: Option<RawSphere>,
    cylinder: Option<RawCylinder>,
    #[serde(rename = "box")]
    cuboid: Option<RawBox>,
    mesh: Option<RawMesh>,
    /// Felt while sliding on this solid.
    texture: Option<TextureSpec>,
    /// Felt on impact with this solid.
    transient: Option<TransientSpec>,
}

impl RawEntry {
    /// Its solid, or None when it names none or several.
    fn shape(self) -> Option<RawShape> {
        let shapes = [
            self.floor.map(RawShape::Floor),
            self.plane.map(RawShape::Plane),
            self.sphere.map(RawShape::Sphere),
            self.cylinder.map(RawShape::Cylinder),
            self.cuboid.map(RawShape::Box),
            self.mesh.map(RawShape::Mesh),
        ];
        let mut named = shapes.into_iter().flatten();
        let shape = named.next();
        shape.filter(|_| named.next().is_none())
    }
}

enum RawShape {
    Floor(RawFloor),
    Plane(RawPlane),
    Sphere(RawSphere),
    Cylinder(RawCylinder),
    Box(RawBox),
    Mesh(RawMesh),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFloor {
    height: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlane {
    point: [f64; 3],
    normal: [f64; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSphere {
    centre: [f64; 3],
    radius: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCylinder {
    point: [f64; 3],
    axis: [f64; 3],
    radius: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBox {
    centre: [f64; 3],
    size: [f64; 3],
    #[serde(default = "identity")]
    orientation: [f64; 4],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMesh {
    file: String,
    #[serde(default)]
    centre: [f64; 3],
    #[serde(default = "identity")]
    orientation: [f64; 4],
    #[serde(default = "unscaled")]
    scale: f64,
    #[serde(default)]
    up: Up,
    /// `smooth`: normals blended across faces (haptic shading); `flat` (the default): each
    /// face's own.
    #[serde(default)]
    shading: Shading,
}

fn identity() -> [f64; 4] {
    [1.0, 0.0, 0.0, 0.0]
}

fn unscaled() -> f64 {
    1.0
}

/// Reads a mesh file a scene names (`file`, in the scene's directory `dir`, which it must not
/// leave): its triangles, in the file's coordinates times `scale`. hapticd and hapticctl read
/// them with hapticd-mesh; the core itself reads no mesh format.
pub type MeshReader<'a> =
    &'a dyn Fn(&Path, &Path, f64) -> Result<MeshFaces, Box<dyn std::error::Error + Send + Sync>>;

/// The readers of the files a scene names, in its own directory: hapticd and hapticctl give
/// hapticd-mesh's; the core itself reads no mesh or image format.
#[derive(Clone, Copy)]
pub struct SceneFiles<'a> {
    /// Mesh files.
    pub meshes: MeshReader<'a>,
    /// Height maps.
    pub images: ImageReader<'a>,
}

/// The triangles of a mesh file, as a [`MeshReader`] gives them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MeshFaces {
    /// The triangles, counter-clockwise seen from outside where there is an outside.
    pub triangles: Vec<[DVec3; 3]>,
    /// Whether they bound a solid (every edge shared by two faces running opposite ways);
    /// an open surface is felt from both sides.
    pub closed: bool,
}

/// Most triangles the meshes of one static scene may have together, as many as one mesh
/// file may hold: the proxy finds those near it through a hierarchy of boxes.
pub const MAX_MESH_TRIANGLES: usize = 500_000;

/// The description of a static scene.
#[derive(Debug, Clone, PartialEq)]
pub struct StaticSceneSpec {
    /// Scene name.
    pub name: String,
    /// Proxy coupling and friction.
    pub proxy: ProxyParameters,
    /// The solids.
    pub shapes: Vec<Shape>,
    /// Each solid's surface (one per shape).
    pub surfaces: Vec<ShapeSurface>,
    /// The materials the surfaces name: the first the scene's own (of every surface without
    /// one), the others the shapes'.
    pub materials: Vec<Option<Material>>,
    /// The corners' blended normals of the smoothly shaded triangles.
    pub corner_normals: Vec<[DVec3; 3]>,
}

/// What a solid's surface is made of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ShapeSurface {
    /// Its material among the scene's (0: the scene's own).
    pub material: u16,
    /// Its corners' normals among the scene's `corner_normals`, when it is smoothly shaded.
    pub normals: Option<u32>,
}

impl StaticSceneSpec {
    /// A scene of bare `shapes` (no texture or transient), touched with `proxy`.
    pub fn bare(name: &str, proxy: ProxyParameters, shapes: Vec<Shape>) -> Self {
        Self {
            name: name.to_string(),
            proxy,
            surfaces: vec![ShapeSurface::default(); shapes.len()],
            shapes,
            materials: vec![None],
            corner_normals: Vec::new(),
        }
    }

    /// Load a scene file that names no mesh.
    pub fn load(path: &Path) -> Result<Self, Diagnostics> {
        Self::load_with_files(path, NO_FILES)
    }

    /// Load a scene file, the files it names read by `files`.
    pub fn load_with_files(path: &Path, files: SceneFiles) -> Result<Self, Diagnostics> {
        Self::parse_with_files(&diagnostics::read_text(path)?, path, files)
    }

    /// Parse and check scene `text`, which names no mesh; `path` names it in diagnostics,
    /// which come all at once, each at its line and column.
    pub fn parse(text: &str, path: &Path) -> Result<Self, Diagnostics> {
        Self::parse_with_files(text, path, NO_FILES)
    }

    /// [`StaticSceneSpec::parse`], the files the scene names read by `files` from the
    /// directory of `path`.
    pub fn parse_with_files(
        text: &str,
        path: &Path,
        files: SceneFiles,
    ) -> Result<Self, Diagnostics> {
        let parsed = diagnostics::parse_yaml::<RawScene>(text, path)?;
        let (raw, map) = (parsed.value, parsed.map);
        let locate = |field: &str| map.find(field);
        let mut f = Findings::after_schema(path, &locate, parsed.schema);
        f.name("name", &raw.name);
        let proxy = match raw.proxy {
            None => ProxyParameters::default(),
            Some(p) => {
                // The ranges a user may tune them in over the bus.
                for (key, name, value) in [
                    ("stiffness", Name::Stiffness, p.stiffness),
                    ("damping", Name::Damping, p.damping),
                    ("static_friction", Name::StaticFriction, p.static_friction),
                    (
                        "dynamic_friction",
                        Name::DynamicFriction,
                        p.dynamic_friction,
                    ),
                ] {
                    if let Err(e) = name.check(value) {
                        f.error(format!("proxy.{key}"), e.to_string());
                    }
                }
                if p.dynamic_friction > p.static_friction {
                    f.error("proxy.dynamic_friction", "must not exceed static_friction");
                }
                ProxyParameters {
                    stiffness: p.stiffness,
                    damping: p.damping,
                    static_friction: p.static_friction,
                    dynamic_friction: p.dynamic_friction,
                }
            }
        };
        let dir = crate::diagnostics::directory_of(path);
        let scene_material = MaterialSpec {
            texture: raw.texture,
            transient: raw.transient,
        };
        let mut solids = Solids {
            materials: vec![scene_material.check("", &mut f, dir, files.images)],
            ..Solids::default()
        };
        for (i, entry) in raw.shapes.into_iter().enumerate() {
            solids.add(&mut f, &format!("shapes[{i}]"), entry, dir, files);
        }
        let Solids {
            shapes,
            surfaces,
            materials,
            corner_normals,
        } = solids;
        let triangles = shapes
            .iter()
            .filter(|s| matches!(s, Shape::Triangle { .. }))
            .count();
        if triangles > MAX_MESH_TRIANGLES {
            f.error(
                "shapes",
                format!(
                    "its meshes have {triangles} triangles; a static scene touches at most \
                     {MAX_MESH_TRIANGLES}"
                ),
            );
        }
        f.finish()?;
        Ok(Self {
            name: raw.name,
            proxy,
            shapes,
            surfaces,
            materials,
            corner_normals,
        })
    }
}

/// A size given in a file (an edge, a radius): within [`SOLID_SIZES`].
fn check_size(f: &mut Findings, field: String, value: f64) {
    let (smallest, largest) = SOLID_SIZES;
    f.within(field, value, smallest, largest, " m");
}

/// A place given in a file: within [`WORLD_EXTENT`] of the origin.
fn check_place(f: &mut Findings, field: String, value: &[f64]) {
    f.coordinates(field, value, WORLD_EXTENT, "m");
}

/// A direction given in a file: finite and not zero, made unit length.
fn direction(f: &mut Findings, field: String, v: [f64; 3]) -> DVec3 {
    let v = DVec3::from(v);
    if f.finite(field.clone(), &v.to_array()) && v.length() <= 1e-9 {
        f.error(field, "must not be zero");
    }
    v.normalize_or(DVec3::Y)
}

/// The readers of programs that read no mesh or image files.
pub const NO_FILES: SceneFiles<'static> = SceneFiles {
    meshes: &|_, _, _| Err(NOT_READ.into()),
    images: &|_, _| Err(NOT_READ.into()),
};

/// Why a program without readers refuses a file.
const NOT_READ: &str = "this program reads no mesh or image files (hapticd and hapticctl do)";

/// A static scene's solids as they are checked.
#[derive(Default)]
struct Solids {
    shapes: Vec<Shape>,
    surfaces: Vec<ShapeSurface>,
    materials: Vec<Option<Material>>,
    corner_normals: Vec<[DVec3; 3]>,
}

impl Solids {
    /// Check shape entry `entry` (at `at`) and add its solids, with its material.
    fn add(&mut self, f: &mut Findings, at: &str, entry: RawEntry, dir: &Path, files: SceneFiles) {
        let spec = MaterialSpec {
            texture: entry.texture.clone(),
            transient: entry.transient,
        };
        let material = match spec.check(at, f, dir, files.images) {
            Some(m) => {
                self.materials.push(Some(m));
                self.materials.len() as u16 - 1
            }
            None => 0,
        };
        let Some(shape) = entry.shape() else {
            f.error(
                at,
                "must be one of floor, plane, sphere, cylinder, box or mesh (with texture and \
                 transient optional)",
            );
            return;
        };
        let smooth = matches!(&shape, RawShape::Mesh(m) if m.shading == Shading::Smooth);
        let added = check_shape(f, at, shape, dir, files.meshes);
        let normals = if smooth {
            corner_normals(&added)
        } else {
            Vec::new()
        };
        let first = self.corner_normals.len();
        self.corner_normals.extend(normals);
        for (k, _) in added.iter().enumerate() {
            self.surfaces.push(ShapeSurface {
                material,
                normals: smooth.then_some((first + k) as u32),
            });
        }
        self.shapes.extend(added);
    }
}

/// The faces of the mesh `file` (in `dir`) a scene places at `centre`, turned by
/// `orientation` and scaled by `scale`, as the proxy's triangles.
fn mesh_faces(
    f: &mut Findings,
    at: &str,
    dir: &Path,
    meshes: MeshReader,
    (file, centre, orientation, scale, up): (&str, [f64; 3], [f64; 4], f64, Up),
) -> Vec<Shape> {
    check_place(f, format!("{at}.mesh.centre"), &centre);
    let rotation = f.unit_quaternion(format!("{at}.mesh.orientation"), orientation) * up.turn();
    if !f.within(format!("{at}.mesh.scale"), scale, 1e-6, 1e3, "") {
        return Vec::new();
    }
    let MeshFaces { triangles, closed } = match meshes(&dir.join(file), dir, scale) {
        Ok(faces) => faces,
        Err(e) => {
            f.error(format!("{at}.mesh.file"), e.to_string());
            return Vec::new();
        }
    };
    let centre = DVec3::from(centre);
    let place = |p: DVec3| rotation * p + centre;
    let placed: Vec<[DVec3; 3]> = triangles.iter().map(|t| t.map(place)).collect();
    let corners: Vec<f64> = placed.iter().flatten().flat_map(|c| c.to_array()).collect();
    if !f.coordinates(format!("{at}.mesh"), &corners, WORLD_EXTENT, "m") {
        return Vec::new();
    }
    let face = if closed {
        Shape::triangle
    } else {
        Shape::sheet
    };
    placed
        .iter()
        .filter_map(|t| face(t[0], t[1], t[2]))
        .collect()
}

/// The obstacles of `shape`: one for a primitive, a mesh's faces for a mesh (read from `dir`
/// by `meshes`).
fn check_shape(
    f: &mut Findings,
    at: &str,
    shape: RawShape,
    dir: &Path,
    meshes: MeshReader,
) -> Vec<Shape> {
    let primitive = match shape {
        RawShape::Floor(RawFloor { height }) => {
            check_place(f, format!("{at}.floor.height"), &[height]);
            Shape::HalfSpace {
                point: DVec3::new(0.0, height, 0.0),
                normal: DVec3::Y,
            }
        }
        RawShape::Plane(RawPlane { point, normal }) => {
            check_place(f, format!("{at}.plane.point"), &point);
            Shape::HalfSpace {
                point: DVec3::from(point),
                normal: direction(f, format!("{at}.plane.normal"), normal),
            }
        }
        RawShape::Sphere(RawSphere { centre, radius }) => {
            check_place(f, format!("{at}.sphere.centre"), &centre);
            check_size(f, format!("{at}.sphere.radius"), radius);
            Shape::Sphere {
                centre: DVec3::from(centre),
                radius,
            }
        }
        RawShape::Cylinder(RawCylinder {
            point,
            axis,
            radius,
        }) => {
            check_place(f, format!("{at}.cylinder.point"), &point);
            check_size(f, format!("{at}.cylinder.radius"), radius);
            Shape::Cylinder {
                point: DVec3::from(point),
                axis: direction(f, format!("{at}.cylinder.axis"), axis),
                radius,
            }
        }
        RawShape::Box(RawBox {
            centre,
            size,
            orientation,
        }) => {
            check_place(f, format!("{at}.box.centre"), &centre);
            for (k, &side) in size.iter().enumerate() {
                check_size(f, format!("{at}.box.size[{k}]"), side);
            }
            Shape::Cuboid {
                centre: DVec3::from(centre),
                half: DVec3::from(size) / 2.0,
                rotation: f.unit_quaternion(format!("{at}.box.orientation"), orientation),
            }
        }
        RawShape::Mesh(RawMesh {
            file,
            centre,
            orientation,
            scale,
            up,
            ..
        }) => {
            return mesh_faces(f, at, dir, meshes, (&file, centre, orientation, scale, up));
        }
    };
    vec![primitive]
}

/// How far a static scene's walls are drawn, metres; floors and bars twice as far.
const REACH: f64 = 0.3;

impl StaticSceneSpec {
    /// The scene's solids as pictures show them: fixed, of no body, each plane and bar
    /// drawn across the workspace.
    pub fn geometry(&self) -> Geometry {
        let mut geometry = Geometry::default();
        let placed =
            |at: DVec3, turn: DQuat| HapticdSolid::placed(at.to_array(), quat_to_wxyz(turn));
        let mut faces = Vec::new();
        let flush = |geometry: &mut Geometry, faces: &mut Vec<HapticdTriangle>| {
            if !faces.is_empty() {
                let solid = HapticdSolid {
                    flags: HAPTICD_SOLID_FIXED,
                    ..placed(DVec3::ZERO, DQuat::IDENTITY)
                };
                geometry.add_triangles(solid, faces.drain(..));
            }
        };
        for shape in &self.shapes {
            let (shape, size, frame) = match *shape {
                Shape::HalfSpace { point, normal } => {
                    let reach = if normal.y > 0.999 { 2.0 * REACH } else { REACH };
                    let turn = DQuat::from_rotation_arc(DVec3::Y, normal);
                    (HAPTICD_SHAPE_PLANE, [reach, 0.0, 0.0], placed(point, turn))
                }
                Shape::Sphere { centre, radius } => (
                    HAPTICD_SHAPE_SPHERE,
                    [radius, 0.0, 0.0],
                    placed(centre, DQuat::IDENTITY),
                ),
                Shape::Cylinder {
                    point,
                    axis,
                    radius,
                } => {
                    let turn = DQuat::from_rotation_arc(DVec3::Y, axis);
                    (
                        HAPTICD_SHAPE_CYLINDER,
                        [radius, 2.0 * REACH, 0.0],
                        placed(point, turn),
                    )
                }
                Shape::Cuboid {
                    centre,
                    half,
                    rotation,
                } => (HAPTICD_SHAPE_BOX, half.to_array(), placed(centre, rotation)),
                // A mesh's faces, drawn as they are: each run of them one solid, as its
                // mesh was one shape in the file.
                Shape::Triangle { corners, .. } => {
                    faces.push(HapticdTriangle {
                        corners: corners.map(|c| c.to_array()),
                    });
                    continue;
                }
            };
            flush(&mut geometry, &mut faces);
            geometry.add_solid(HapticdSolid {
                shape,
                flags: HAPTICD_SOLID_FIXED,
                size,
                ..frame
            });
        }
        flush(&mut geometry, &mut faces);
        geometry
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_scene_parses() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/scenes/static.yaml");
        let spec = StaticSceneSpec::load(&path).unwrap();
        assert_eq!(spec.name, "static");
        assert!(spec.shapes.len() >= 4);
    }

    #[test]
    fn bad_shapes_are_refused_each_at_its_place() {
        let parse = |text: &str| StaticSceneSpec::parse(text, Path::new("s.yaml"));
        assert!(parse("name: x\nshapes:\n  - cone: { height: 1 }\n").is_err());
        let e = parse("name: x\nshapes:\n  - floor: { hieght: 0 }\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "s.yaml:3:12: error: shapes[0].floor.height: required, but not given\n\
             s.yaml:3:14: error: shapes[0].floor.hieght: unknown key; the keys here are `height`"
        );
        // Schema and value mistakes together, each once.
        let e = parse("name: x\ncolour: red\nshapes:\n  - sphere: { centre: [0, 0], radius: -1 }\n  - floor: { height: .nan }\n")
            .unwrap_err()
            .to_string();
        let lines: Vec<_> = e.lines().collect();
        assert_eq!(lines.len(), 4, "{e}");
        assert!(lines[0].contains("colour: unknown key"), "{e}");
        assert!(
            lines[1].contains("shapes[0].sphere.centre: expected a list of 3"),
            "{e}"
        );
        assert!(lines[2].contains("shapes[0].sphere.radius: must be"), "{e}");
        assert!(
            lines[3].contains("shapes[1].floor.height: must be finite"),
            "{e}"
        );
        let e = parse(
            "name: x\nshapes:\n  - sphere: { centre: [0, 0, 0], radius: -1 }\n  - floor: { height: .nan }\n  - plane: { point: [0, 0, 0], normal: [0, 0, 0] }\n",
        )
        .unwrap_err()
        .to_string();
        let lines: Vec<_> = e.lines().collect();
        assert_eq!(
            lines,
            [
                "s.yaml:3:42: error: shapes[0].sphere.radius: must be a number from 0.0001 to 1000 m, not -1",
                "s.yaml:4:22: error: shapes[1].floor.height: must be finite, each within ±1000 m",
                "s.yaml:5:40: error: shapes[2].plane.normal: must not be zero",
            ]
        );
    }

    /// Each shape's material is its own; a shape without one has the scene's; an entry with
    /// no solid or two is refused.
    #[test]
    fn each_shape_has_its_material_or_the_scenes() {
        let text = "name: m\ntexture: { kind: grating, period: 0.002, amplitude: 0.1 }\nshapes:\n  \
                    - floor: { height: -0.03 }\n  - box: { centre: [0, 0, 0], size: [0.01, 0.01, 0.01] }\n    \
                    transient: { gain: 5, frequency: 200, decay: 0.01 }\n";
        let spec = StaticSceneSpec::parse(text, Path::new("s.yaml")).unwrap();
        assert_eq!(spec.surfaces[0].material, 0);
        assert!(spec.materials[0].as_ref().unwrap().texture.is_some());
        let own = spec.materials[usize::from(spec.surfaces[1].material)]
            .as_ref()
            .unwrap();
        assert_eq!(own.transient.unwrap().frequency, 200.0);
        assert!(own.texture.is_none());
        for (text, expected) in [
            (
                "name: m\nshapes:\n  - texture: { kind: grating, period: 0.002, amplitude: 0.1 }\n",
                "shapes[0]: must be one of",
            ),
            (
                "name: m\nshapes:\n  - floor: { height: 0 }\n    sphere: { centre: [0, 0, 0], radius: 0.01 }\n",
                "shapes[0]: must be one of",
            ),
            (
                "name: m\nshapes:\n  - floor: { height: 0 }\n    transient: { gain: 5, frequency: 5000, decay: 0.01 }\n",
                "shapes[0].transient.frequency: must be a number from 1 to 1000 Hz",
            ),
        ] {
            let said = StaticSceneSpec::parse(text, Path::new("s.yaml"))
                .unwrap_err()
                .to_string();
            assert!(said.contains(expected), "{said}");
        }
    }
}
