//! A URDF robot placed in a scene (`urdf:`, thesis 7.2's "robots"): the ROS ecosystem's
//! robot description read into the scene's own bodies and joints, so both engines run it
//! and every check of a scene file applies to it.
//!
//! Each link with a `<collision>` becomes a body named `ROBOT.LINK`: its boxes, spheres
//! and cylinders (a 24-sided prism) become its pieces, or its one mesh (read by the mesh
//! readers, its path from the URDF file) its mesh; its `<inertial>` gives its mass, centre of
//! mass and inertia (a link without one weighs its collision solids at water's density).
//! Each `revolute`, `continuous`, `prismatic` and `fixed` joint becomes a joint at its frame
//! as the robot stands at load (every coordinate 0), with the URDF's `<limit>` (revolute
//! and prismatic) and `<dynamics damping>`. The root link is held by the world (`base:
//! fixed`, the default, as ROS places a robot) or free (`base: free`); a root without a
//! collision is the world itself (ROS's `world` link). Elements hapticd does not use
//! (`<visual>`, `<material>`, `<transmission>`, `<gazebo>`, a joint's `<safety_controller>`)
//! are skipped, as the URDF specification asks of readers. The URDF file and its meshes
//! are read from the scene file's directory and below it, never from elsewhere: a scene sent
//! to the daemon over the bus names no file outside the daemon's copy of it.
//!
//! ```yaml
//! name: arm
//! engine: rapier
//! rate: 60
//! material: { static_friction: 0.4, friction: 0.3 }
//! bodies: []
//! urdf:                          # robots in the scene, each of a URDF file
//!   - file: robots/arm.urdf      # from the scene file's directory
//!     position: [0.05, 0.07, 0]  # where its root link's frame goes (m)
//!     orientation: [0.7071067811865476, -0.7071067811865476, 0, 0]  # its z up is y
//!     name: arm                  # bodies arm.upper, arm.fore…; default: the robot's name
//!     base: fixed                # the world holds its root link (the default), or free
//! ```

// Read with `roxmltree`, our own reading of what the URDF specification says: `urdf-rs`
// brings three XML parsers and a regex engine for what this needs of one.
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{DMat3, DQuat, DVec3};

use hapticd_core::diagnostics::Findings;
use hapticd_core::kinematics::WORLD_EXTENT;

use super::joints::RawJoint;
use super::schema::{RawBase, RawBody, RawInertial, RawPiece, RawRobot, RawScene};
use crate::joint::JointKind;
use crate::mass::moved_inertia;

/// Largest URDF file read, bytes.
const MAX_URDF_BYTES: u64 = 16 << 20;
/// Sides of the prism a cylinder is read as.
const CYLINDER_SIDES: usize = 24;
/// Most links a robot may have.
const MAX_LINKS: usize = 64;

/// What is wrong with a URDF file, and where.
#[derive(Debug, Clone, PartialEq)]
pub struct UrdfError {
    /// The line (1-based; 0 for the whole file).
    pub line: u32,
    /// What is wrong.
    pub message: String,
}

impl std::fmt::Display for UrdfError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line > 0 {
            write!(f, "line {}: {}", self.line, self.message)
        } else {
            f.write_str(&self.message)
        }
    }
}

/// A placement in a link's or joint's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Frame {
    at: DVec3,
    turn: DQuat,
}

impl Frame {
    const IDENTITY: Frame = Frame {
        at: DVec3::ZERO,
        turn: DQuat::IDENTITY,
    };

    /// The parent's placement in this frame.
    fn inverse(&self) -> Frame {
        let turn = self.turn.inverse();
        Frame {
            at: -(turn * self.at),
            turn,
        }
    }

    /// `inner` (given in this frame) in this frame's parent.
    fn then(&self, inner: &Frame) -> Frame {
        Frame {
            at: self.at + self.turn * inner.at,
            turn: (self.turn * inner.turn).normalize(),
        }
    }
}

/// A collision solid of a link.
#[derive(Debug, Clone, PartialEq)]
enum Shape {
    Box([f64; 3]),
    Sphere(f64),
    Cylinder { radius: f64, length: f64 },
    Mesh { file: PathBuf, scale: f64 },
}

/// A link as the URDF gives it.
#[derive(Debug, Clone, PartialEq)]
struct Link {
    name: String,
    /// Mass, centre of mass and inertia about it, in the link's frame.
    inertial: Option<(f64, DVec3, DMat3)>,
    collisions: Vec<(Frame, Shape)>,
}

/// A joint as the URDF gives it.
#[derive(Debug, Clone, PartialEq)]
struct UrdfJoint {
    name: String,
    kind: JointKind,
    parent: String,
    child: String,
    /// The child link's frame in the parent's, at coordinate 0.
    origin: Frame,
    /// Unit, in the joint's frame.
    axis: DVec3,
    limits: Option<[f64; 2]>,
    damping: f64,
}

/// A robot as the URDF gives it.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Robot {
    name: String,
    links: Vec<Link>,
    joints: Vec<UrdfJoint>,
    tree: Tree,
}

/// How a robot's links hang together.
#[derive(Debug, Clone, PartialEq)]
struct Tree {
    /// Each link's frame at load, in the root's.
    frames: Vec<Frame>,
    /// The root link.
    base: usize,
    /// The joint whose child each link is (none for the root).
    parents: Vec<Option<usize>>,
}

/// Read each of `raw`'s URDF robots (files relative to the scene file at `scene`) into its
/// bodies and joints; what is wrong with one is reported at its `file`.
pub(super) fn expand(f: &mut Findings, raw: &mut RawScene, scene: &Path) {
    let dir = hapticd_core::diagnostics::directory_of(scene).to_path_buf();
    let robots = std::mem::take(&mut raw.urdf);
    for (k, robot) in robots.iter().enumerate() {
        let at = format!("urdf[{k}]");
        let ok = f.coordinates(format!("{at}.position"), &robot.position, WORLD_EXTENT, "m");
        f.unit_quaternion(format!("{at}.orientation"), robot.orientation);
        // Only below the scene's directory: a scene sent over the bus is read in a
        // directory of the daemon's own, and no path in it may reach further.
        let Some(relative) = below(Path::new(""), &robot.file) else {
            f.error(
                format!("{at}.file"),
                "must be a path from the scene file's directory that stays inside it",
            );
            continue;
        };
        let file = dir.join(&relative);
        let read = read(&file).and_then(|text| {
            let from = relative.parent().unwrap_or(Path::new(""));
            Robot::parse(&text, from)?.entries(robot)
        });
        match read {
            Ok((bodies, joints)) if ok && !f.has_errors() => {
                raw.bodies.extend(bodies);
                raw.joints.extend(joints);
            }
            Ok(_) => {}
            Err(e) => f.error(format!("{at}.file"), format!("{}: {e}", file.display())),
        }
    }
    raw.urdf = robots;
}

/// `path` from `from` (both relative to the scene file's directory), lexically: None when
/// it is absolute or climbs out of that directory.
fn below(from: &Path, path: &str) -> Option<PathBuf> {
    let mut out = PathBuf::new();
    for part in from.join(path).components() {
        match part {
            std::path::Component::Normal(name) => out.push(name),
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir if out.pop() => {}
            _ => return None,
        }
    }
    Some(out)
}

/// The text of URDF file `path`.
fn read(path: &Path) -> Result<String, UrdfError> {
    let whole = |message: String| UrdfError { line: 0, message };
    let size = std::fs::metadata(path)
        .map_err(|e| whole(e.to_string()))?
        .len();
    if size > MAX_URDF_BYTES {
        return Err(whole(format!(
            "{size} bytes; a URDF file may hold at most {MAX_URDF_BYTES}"
        )));
    }
    std::fs::read_to_string(path).map_err(|e| whole(e.to_string()))
}

/// An element's line.
fn line(node: roxmltree::Node<'_, '_>) -> u32 {
    node.document().text_pos_at(node.range().start).row
}

fn error(node: roxmltree::Node<'_, '_>, message: impl Into<String>) -> UrdfError {
    UrdfError {
        line: line(node),
        message: message.into(),
    }
}

/// The element children of `node` named `tag`.
fn children<'a, 'i>(
    node: roxmltree::Node<'a, 'i>,
    tag: &'static str,
) -> impl Iterator<Item = roxmltree::Node<'a, 'i>> {
    node.children()
        .filter(move |n| n.is_element() && n.tag_name().name() == tag)
}

/// The one child of `node` named `tag`, if any (two are a mistake).
fn child<'a, 'i>(
    node: roxmltree::Node<'a, 'i>,
    tag: &'static str,
) -> Result<Option<roxmltree::Node<'a, 'i>>, UrdfError> {
    let mut found = children(node, tag);
    let first = found.next();
    match found.next() {
        Some(second) => Err(error(second, format!("a second <{tag}>"))),
        None => Ok(first),
    }
}

/// Attribute `name` of `node`, which must be there.
fn attribute<'a>(node: roxmltree::Node<'a, '_>, name: &str) -> Result<&'a str, UrdfError> {
    node.attribute(name)
        .ok_or_else(|| error(node, format!("<{}> lacks `{name}`", node.tag_name().name())))
}

/// The `N` finite numbers of attribute `name` of `node`, or `default` when it is absent
/// and one is given.
fn numbers<const N: usize>(
    node: roxmltree::Node<'_, '_>,
    name: &str,
    default: Option<[f64; N]>,
) -> Result<[f64; N], UrdfError> {
    let Some(text) = node.attribute(name) else {
        return default
            .ok_or_else(|| error(node, format!("<{}> lacks `{name}`", node.tag_name().name())));
    };
    let values: Vec<f64> = text
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()
        .map_err(|_| error(node, format!("`{name}` must be numbers, not `{text}`")))?;
    let values: [f64; N] = values
        .try_into()
        .map_err(|_| error(node, format!("`{name}` must be {N} numbers, not `{text}`")))?;
    if values.iter().all(|v| v.is_finite()) {
        Ok(values)
    } else {
        Err(error(
            node,
            format!("`{name}` must be finite, not `{text}`"),
        ))
    }
}

/// One number of attribute `name`.
fn number(
    node: roxmltree::Node<'_, '_>,
    name: &str,
    default: Option<f64>,
) -> Result<f64, UrdfError> {
    numbers::<1>(node, name, default.map(|d| [d])).map(|[v]| v)
}

/// The `<origin>` child of `node` (none: the identity).
fn origin(node: roxmltree::Node<'_, '_>) -> Result<Frame, UrdfError> {
    let Some(o) = child(node, "origin")? else {
        return Ok(Frame::IDENTITY);
    };
    let at = numbers::<3>(o, "xyz", Some([0.0; 3]))?;
    let [roll, pitch, yaw] = numbers::<3>(o, "rpy", Some([0.0; 3]))?;
    // Fixed axes x, then y, then z: R = Rz(yaw)·Ry(pitch)·Rx(roll).
    let turn =
        DQuat::from_rotation_z(yaw) * DQuat::from_rotation_y(pitch) * DQuat::from_rotation_x(roll);
    Ok(Frame {
        at: DVec3::from(at),
        turn,
    })
}

impl Robot {
    /// The robot of URDF `text`, in directory `dir` (relative to the scene file's), where
    /// its meshes' paths start.
    pub(super) fn parse(text: &str, dir: &Path) -> Result<Robot, UrdfError> {
        let doc = roxmltree::Document::parse(text).map_err(|e| UrdfError {
            line: e.pos().row,
            message: e.to_string(),
        })?;
        let root = doc.root_element();
        if root.tag_name().name() != "robot" {
            return Err(error(root, "a URDF's root element is <robot>"));
        }
        let name = attribute(root, "name")?.to_string();
        let links = children(root, "link")
            .map(|l| link(l, dir))
            .collect::<Result<Vec<_>, _>>()?;
        if links.is_empty() || links.len() > MAX_LINKS {
            return Err(error(
                root,
                format!("1 to {MAX_LINKS} links, not {}", links.len()),
            ));
        }
        let joints = children(root, "joint")
            .map(joint)
            .collect::<Result<Vec<_>, _>>()?;
        let tree = tree(&links, &joints).map_err(|m| error(root, m))?;
        Ok(Robot {
            name,
            links,
            joints,
            tree,
        })
    }

    /// The robot's bodies and joints as scene entries, placed by `robot` (the `urdf:` entry).
    /// Links welded by `fixed` joints are one body, named after the link nearest the root
    /// (as MuJoCo and Pinocchio read them): a weld between two bodies would only stiffen
    /// the step, and a URDF's welded sensor weighs grams (RRBot's camera 10 mg).
    pub(super) fn entries(
        &self,
        robot: &RawRobot,
    ) -> Result<(Vec<RawBody>, Vec<RawJoint>), UrdfError> {
        let prefix = robot.name.clone().unwrap_or_else(|| self.name.clone());
        let [w, x, y, z] = robot.orientation;
        let placed = Frame {
            at: DVec3::from(robot.position),
            turn: DQuat::from_xyzw(x, y, z, w).normalize(),
        };
        let fixed = robot.base == RawBase::Fixed;
        // Each link's body: the nearest link up its welds.
        let owners: Vec<usize> = (0..self.links.len())
            .map(|mut at| {
                while let Some(k) =
                    self.tree.parents[at].filter(|&k| self.joints[k].kind == JointKind::Fixed)
                {
                    at = self.index(&self.joints[k].parent);
                }
                at
            })
            .collect();
        let owner = &owners[..];
        let members = |o: usize| (0..self.links.len()).filter(move |&i| owner[i] == o);
        let is_world = |o: usize| {
            o == self.tree.base && fixed && members(o).all(|i| self.links[i].collisions.is_empty())
        };
        let name_of = &|i: usize| {
            if is_world(owner[i]) {
                super::joints::WORLD.to_string()
            } else {
                format!("{prefix}.{}", self.links[owner[i]].name)
            }
        };
        let mut bodies = Vec::new();
        for o in (0..self.links.len()).filter(|&o| owner[o] == o && !is_world(o)) {
            let inside = |i: usize| self.tree.frames[o].inverse().then(&self.tree.frames[i]);
            let collisions: Vec<(Frame, Shape)> = members(o)
                .flat_map(|i| {
                    let frame = inside(i);
                    self.links[i]
                        .collisions
                        .iter()
                        .map(move |(at, shape)| (frame.then(at), shape.clone()))
                })
                .collect();
            let inertials: Vec<(f64, DVec3, DMat3)> = members(o)
                .filter_map(|i| {
                    let (mass, centre, inertia) = self.links[i].inertial?;
                    let frame = inside(i);
                    let turn = DMat3::from_quat(frame.turn);
                    Some((
                        mass,
                        frame.at + frame.turn * centre,
                        turn * inertia * turn.transpose(),
                    ))
                })
                .collect();
            let frame = placed.then(&self.tree.frames[o]);
            bodies.push(body(
                &self.links[o].name,
                (name_of(o), frame, fixed && o == self.tree.base),
                &collisions,
                combined(&inertials),
            )?);
        }
        let joints = self
            .joints
            .iter()
            .filter(|j| j.kind != JointKind::Fixed)
            .map(|j| {
                let (parent, child) = (self.index(&j.parent), self.index(&j.child));
                let frame = placed.then(&self.tree.frames[child]);
                RawJoint {
                    name: Some(format!("{prefix}.{}", j.name)),
                    kind: j.kind,
                    bodies: [name_of(parent), name_of(child)],
                    anchor: frame.at.to_array(),
                    axis: Some((frame.turn * j.axis).to_array()),
                    limits: j.limits,
                    restitution: 0.0,
                    stiffness: 0.0,
                    damping: j.damping,
                    motor: None,
                }
            })
            .collect();
        Ok((bodies, joints))
    }

    /// The index of the link called `name` (checked to be there when read).
    fn index(&self, name: &str) -> usize {
        self.links
            .iter()
            .position(|l| l.name == name)
            .expect("a joint's links are checked when read")
    }
}

/// Masses, centres and inertias (in one frame) as one body's: their sum, the centre of
/// them all, and each inertia moved there (parallel axes). None for none.
fn combined(parts: &[(f64, DVec3, DMat3)]) -> Option<(f64, DVec3, DMat3)> {
    let mass: f64 = parts.iter().map(|p| p.0).sum();
    if parts.is_empty() || mass <= 0.0 {
        return None;
    }
    let centre = parts.iter().map(|p| p.1 * p.0).sum::<DVec3>() / mass;
    let inertia = parts.iter().fold(DMat3::ZERO, |sum, &(m, c, i)| {
        sum + moved_inertia(i, m, c - centre)
    });
    Some((mass, centre, inertia))
}

/// Each link's frame at load in the root's, the root's index and the joint whose child each
/// link is: every link named once,
/// every joint between two of them, each link but the root the child of one joint, and no
/// loop.
fn tree(links: &[Link], joints: &[UrdfJoint]) -> Result<Tree, String> {
    let mut index = HashMap::new();
    for (i, l) in links.iter().enumerate() {
        if index.insert(l.name.as_str(), i).is_some() {
            return Err(format!("two links are called `{}`", l.name));
        }
    }
    let mut parent_of: Vec<Option<usize>> = vec![None; links.len()];
    let mut names = HashMap::new();
    for (k, j) in joints.iter().enumerate() {
        let find = |name: &str| {
            index
                .get(name)
                .copied()
                .ok_or_else(|| format!("joint `{}` names no link `{name}`", j.name))
        };
        let child = find(&j.child)?;
        find(&j.parent)?;
        if names.insert(j.name.as_str(), k).is_some() {
            return Err(format!("two joints are called `{}`", j.name));
        }
        if parent_of[child].replace(k).is_some() {
            return Err(format!("link `{}` is the child of two joints", j.child));
        }
    }
    let roots: Vec<usize> = (0..links.len())
        .filter(|&i| parent_of[i].is_none())
        .collect();
    let [base] = roots[..] else {
        return Err(format!(
            "one link must be no joint's child, not {}",
            roots.len()
        ));
    };
    // From each link up toward the root: a loop never reaches it.
    let mut frames = vec![None; links.len()];
    frames[base] = Some(Frame::IDENTITY);
    for start in 0..links.len() {
        let mut path = Vec::new();
        let mut at = start;
        while frames[at].is_none() {
            let Some(k) = parent_of[at] else { break };
            if path.len() > links.len() {
                return Err("its joints make a loop".into());
            }
            path.push(k);
            at = index[joints[k].parent.as_str()];
        }
        let mut frame = frames[at].unwrap_or(Frame::IDENTITY);
        for &k in path.iter().rev() {
            frame = frame.then(&joints[k].origin);
            frames[index[joints[k].child.as_str()]] = Some(frame);
        }
    }
    Ok(Tree {
        frames: frames
            .into_iter()
            .map(|f| f.unwrap_or(Frame::IDENTITY))
            .collect(),
        base,
        parents: parent_of,
    })
}

/// A `<link>`.
fn link(node: roxmltree::Node<'_, '_>, dir: &Path) -> Result<Link, UrdfError> {
    let name = attribute(node, "name")?.to_string();
    let inertial = match child(node, "inertial")? {
        None => None,
        Some(i) => {
            let frame = origin(i)?;
            let mass_node = child(i, "mass")?.ok_or_else(|| error(i, "<inertial> lacks <mass>"))?;
            let mass = number(mass_node, "value", None)?;
            let t = child(i, "inertia")?.ok_or_else(|| error(i, "<inertial> lacks <inertia>"))?;
            let get = |key| number(t, key, Some(0.0));
            let (xx, yy, zz) = (get("ixx")?, get("iyy")?, get("izz")?);
            let (xy, xz, yz) = (get("ixy")?, get("ixz")?, get("iyz")?);
            let tensor = DMat3::from_cols(
                DVec3::new(xx, xy, xz),
                DVec3::new(xy, yy, yz),
                DVec3::new(xz, yz, zz),
            );
            let turn = DMat3::from_quat(frame.turn);
            Some((mass, frame.at, turn * tensor * turn.transpose()))
        }
    };
    let collisions = children(node, "collision")
        .map(|c| {
            let frame = origin(c)?;
            let g =
                child(c, "geometry")?.ok_or_else(|| error(c, "<collision> lacks <geometry>"))?;
            Ok((frame, shape(g, dir)?))
        })
        .collect::<Result<Vec<_>, UrdfError>>()?;
    Ok(Link {
        name,
        inertial,
        collisions,
    })
}

/// A `<geometry>`'s one shape.
fn shape(g: roxmltree::Node<'_, '_>, dir: &Path) -> Result<Shape, UrdfError> {
    let mut shapes = g.children().filter(|n| n.is_element());
    let (Some(s), None) = (shapes.next(), shapes.next()) else {
        return Err(error(g, "<geometry> holds exactly one shape"));
    };
    match s.tag_name().name() {
        "box" => Ok(Shape::Box(numbers::<3>(s, "size", None)?)),
        "sphere" => Ok(Shape::Sphere(number(s, "radius", None)?)),
        "cylinder" => Ok(Shape::Cylinder {
            radius: number(s, "radius", None)?,
            length: number(s, "length", None)?,
        }),
        "mesh" => {
            let file = attribute(s, "filename")?;
            let [sx, sy, sz] = numbers::<3>(s, "scale", Some([1.0; 3]))?;
            if sx != sy || sy != sz {
                return Err(error(s, "a mesh's scale must be the same along each axis"));
            }
            let path = below(dir, file).filter(|_| !file.contains("://"));
            let Some(path) = path else {
                return Err(error(
                    s,
                    format!(
                        "`{file}`: give the mesh's path from the URDF file, inside the scene \
                         file's directory"
                    ),
                ));
            };
            Ok(Shape::Mesh {
                file: path,
                scale: sx,
            })
        }
        other => Err(error(
            s,
            format!("<{other}> is no shape (box, sphere, cylinder, mesh)"),
        )),
    }
}

/// A `<joint>`.
fn joint(node: roxmltree::Node<'_, '_>) -> Result<UrdfJoint, UrdfError> {
    let name = attribute(node, "name")?.to_string();
    let kind_text = attribute(node, "type")?;
    let kind = match kind_text {
        "revolute" | "continuous" => JointKind::Revolute,
        "prismatic" => JointKind::Prismatic,
        "fixed" => JointKind::Fixed,
        other => {
            return Err(error(
                node,
                format!(
                    "joint `{name}`: `{other}` joints are not taken (revolute, continuous, prismatic, fixed)"
                ),
            ));
        }
    };
    let link_of = |tag: &'static str| -> Result<String, UrdfError> {
        let n = child(node, tag)?
            .ok_or_else(|| error(node, format!("joint `{name}` lacks <{tag}>")))?;
        Ok(attribute(n, "link")?.to_string())
    };
    let axis = match child(node, "axis")? {
        Some(a) => {
            let v = DVec3::from(numbers::<3>(a, "xyz", None)?);
            v.try_normalize()
                .ok_or_else(|| error(a, format!("joint `{name}`: a zero axis")))?
        }
        None => DVec3::X,
    };
    let limits = match (kind_text, child(node, "limit")?) {
        ("revolute" | "prismatic", Some(l)) => Some([
            number(l, "lower", Some(0.0))?,
            number(l, "upper", Some(0.0))?,
        ]),
        ("revolute" | "prismatic", None) => {
            return Err(error(
                node,
                format!("joint `{name}`: a {kind_text} joint needs <limit>"),
            ));
        }
        _ => None,
    };
    let damping = match child(node, "dynamics")? {
        Some(d) => number(d, "damping", Some(0.0))?,
        None => 0.0,
    };
    let (parent, child_link) = (link_of("parent")?, link_of("child")?);
    Ok(UrdfJoint {
        name,
        kind,
        parent,
        child: child_link,
        origin: origin(node)?,
        axis,
        limits,
        damping,
    })
}

/// The body of link `link` and those welded to it, called `name`, its frame at `frame`,
/// with their `collisions` and combined `inertial` in its frame.
fn body(
    link: &str,
    (name, frame, fixed): (String, Frame, bool),
    collisions: &[(Frame, Shape)],
    inertial: Option<(f64, DVec3, DMat3)>,
) -> Result<RawBody, UrdfError> {
    let whole = |message: String| UrdfError { line: 0, message };
    let orientation = [frame.turn.w, frame.turn.x, frame.turn.y, frame.turn.z];
    let mut b = RawBody::placed(name, frame.at.to_array(), orientation, fixed);
    match collisions {
        [] => {
            return Err(whole(format!(
                "link `{link}` has no <collision>: every moving link needs a solid"
            )));
        }
        [(at, Shape::Mesh { file, scale })] => {
            if at.at.length() > 1e-12 || at.turn.angle_between(DQuat::IDENTITY) > 1e-12 {
                return Err(whole(format!(
                    "link `{link}`: a mesh's <origin> must be the link's own"
                )));
            }
            b.mesh = Some(file.to_string_lossy().into_owned());
            b.scale = Some(*scale);
        }
        _ => {
            let pieces = collisions
                .iter()
                .map(|(at, s)| piece(link, at, s))
                .collect::<Result<Vec<_>, _>>()
                .map_err(whole)?;
            b.pieces = Some(pieces);
        }
    }
    b.inertial = inertial.map(|(mass, centre, inertia)| RawInertial {
        mass,
        centre: centre.to_array(),
        inertia: [
            inertia.x_axis.x,
            inertia.y_axis.y,
            inertia.z_axis.z,
            inertia.y_axis.x,
            inertia.z_axis.x,
            inertia.z_axis.y,
        ],
    });
    Ok(b)
}

/// A collision solid of link `link` at `at` in its frame, as a scene piece.
fn piece(link: &str, at: &Frame, s: &Shape) -> Result<RawPiece, String> {
    let mut p = RawPiece {
        size: None,
        hull: None,
        sphere: None,
        position: at.at.to_array(),
        orientation: [at.turn.w, at.turn.x, at.turn.y, at.turn.z],
    };
    match *s {
        Shape::Box(size) => p.size = Some(size),
        Shape::Sphere(radius) => p.sphere = Some(radius),
        Shape::Cylinder { radius, length } => {
            // Along the frame's z, as URDF's cylinders stand.
            p.hull = Some(
                (0..CYLINDER_SIDES)
                    .flat_map(|k| {
                        let a = std::f64::consts::TAU * k as f64 / CYLINDER_SIDES as f64;
                        let (x, y) = (radius * a.cos(), radius * a.sin());
                        [[x, y, -length / 2.0], [x, y, length / 2.0]]
                    })
                    .collect(),
            );
        }
        Shape::Mesh { .. } => {
            return Err(format!(
                "link `{link}`: a mesh is taken as a link's only <collision>"
            ));
        }
    }
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    const RRBOT: &str = include_str!("../../../../../tests/corpus/rrbot.urdf");

    /// A robot of one box link and `rest` (XML inside `<robot>`).
    fn robot(rest: &str) -> String {
        format!(
            "<robot name=\"r\">\n<link name=\"a\"><collision><geometry><box size=\"0.1 0.1 \
             0.1\"/></geometry></collision></link>\n{rest}\n</robot>\n"
        )
    }

    /// A second link `b` and a joint `j` of `kind` from `a` to it, with `inside`.
    fn jointed(kind: &str, inside: &str) -> String {
        robot(&format!(
            "<link name=\"b\"><collision><geometry><sphere radius=\"0.05\"/></geometry>\
             </collision></link>\n<joint name=\"j\" type=\"{kind}\"><parent link=\"a\"/>\
             <child link=\"b\"/>{inside}</joint>"
        ))
    }

    fn refused(text: &str) -> UrdfError {
        Robot::parse(text, Path::new("robots")).expect_err(text)
    }

    /// RRBot as ROS publishes it: its post welded to the world is one fixed body, its
    /// camera welded to its top link weighs with it, its two continuous joints are
    /// hinges about y at their frames, damped as the file says.
    #[test]
    fn rrbot_reads_as_its_file_says() {
        let robot = Robot::parse(RRBOT, Path::new("robots")).unwrap();
        let placed = RawRobot {
            file: "rrbot.urdf".into(),
            position: [0.0; 3],
            orientation: [1.0, 0.0, 0.0, 0.0],
            name: None,
            base: RawBase::Fixed,
        };
        let (bodies, joints) = robot.entries(&placed).unwrap();
        let names: Vec<&str> = bodies.iter().map(|b| b.name.as_str()).collect();
        assert_eq!(names, ["rrbot.world", "rrbot.link2", "rrbot.link3"]);
        assert!(bodies[0].fixed && !bodies[1].fixed && !bodies[2].fixed);
        assert!(bodies[0].inertial.as_ref().is_some_and(|i| i.mass == 1.0));
        let top = bodies[2].inertial.as_ref().unwrap();
        let mass = 1.0 + 1e-5;
        assert_eq!(top.mass, mass);
        let centre = (DVec3::new(0.0, 0.0, 0.45) + DVec3::new(0.05, 0.0, 0.9) * 1e-5) / mass;
        assert!(DVec3::from(top.centre).distance(centre) < 1e-15);
        assert_eq!(bodies[2].pieces.as_ref().map(Vec::len), Some(2));
        assert_eq!(bodies[2].position, [0.0, 0.2, 2.85]);
        let anchors: Vec<[f64; 3]> = joints.iter().map(|j| j.anchor).collect();
        assert_eq!(anchors, [[0.0, 0.1, 1.95], [0.0, 0.2, 2.85]]);
        for j in &joints {
            assert_eq!(j.kind, JointKind::Revolute);
            assert_eq!(j.axis, Some([0.0, 1.0, 0.0]));
            assert_eq!((j.limits, j.damping), (None, 0.7));
        }
        assert_eq!(joints[1].bodies, ["rrbot.link2", "rrbot.link3"]);
    }

    /// Each mistake of a URDF file is refused with its line and what is wrong.
    #[test]
    fn hostile_urdf_files_are_refused_each_with_its_line() {
        let cases = [
            ("<robot name=\"r\">", "", 1),
            ("<machine name=\"r\"/>", "root element is <robot>", 1),
            ("<robot/>", "lacks `name`", 1),
            (
                &jointed("floating", ""),
                "`floating` joints are not taken",
                4,
            ),
            (&jointed("revolute", ""), "needs <limit>", 4),
            (
                &jointed("prismatic", "<axis xyz=\"0 0 0\"/><limit upper=\"1\"/>"),
                "a zero axis",
                4,
            ),
            (
                &jointed("continuous", "<axis xyz=\"0 nan 1\"/>"),
                "must be finite",
                4,
            ),
            (
                &jointed("continuous", "<axis xyz=\"0 1\"/>"),
                "must be 3 numbers",
                4,
            ),
            (
                &jointed("continuous", "<origin xyz=\"a b c\"/>"),
                "must be numbers",
                4,
            ),
            (
                &robot(
                    "<joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"z\"/></joint>",
                ),
                "names no link `z`",
                1,
            ),
            (&robot("<link name=\"a\"/>"), "two links are called `a`", 1),
            (
                &robot("<link name=\"b\"/>"),
                "one link must be no joint's child, not 2",
                1,
            ),
            (
                &robot(
                    "<link name=\"b\"/><link name=\"c\"/>\
                     <joint name=\"j\" type=\"fixed\"><parent link=\"b\"/><child link=\"c\"/></joint>\
                     <joint name=\"k\" type=\"fixed\"><parent link=\"c\"/><child link=\"b\"/></joint>",
                ),
                "its joints make a loop",
                1,
            ),
            (
                &robot(
                    "<link name=\"b\"><collision><geometry><box size=\"1 1 1\"/><sphere radius=\"1\"/></geometry></collision></link>",
                ),
                "exactly one shape",
                3,
            ),
            (
                &robot(
                    "<link name=\"b\"><collision><geometry><cone radius=\"1\"/></geometry></collision></link>",
                ),
                "<cone> is no shape",
                3,
            ),
            (
                &robot(
                    "<link name=\"b\"><collision><geometry><mesh filename=\"m.stl\" scale=\"1 2 1\"/></geometry></collision></link>",
                ),
                "same along each axis",
                3,
            ),
            (
                &robot(
                    "<link name=\"b\"><collision><geometry><mesh filename=\"package://arm/m.stl\"/></geometry></collision></link>",
                ),
                "give the mesh's path",
                3,
            ),
            (
                &robot(
                    "<link name=\"b\"><collision><geometry><mesh filename=\"/etc/m.stl\"/></geometry></collision></link>",
                ),
                "inside the scene file's directory",
                3,
            ),
            (
                &robot(
                    "<link name=\"b\"><collision><geometry><mesh filename=\"../../m.stl\"/></geometry></collision></link>",
                ),
                "inside the scene file's directory",
                3,
            ),
            (
                &robot("<link name=\"b\"><inertial><mass value=\"1\"/></inertial></link>"),
                "lacks <inertia>",
                3,
            ),
        ];
        for (text, message, line) in cases {
            let e = refused(text);
            println!("{e}");
            assert!(e.message.contains(message), "{text}: {e}");
            if line > 0 {
                assert_eq!(e.line, line, "{text}: {e}");
            }
        }
    }
}
