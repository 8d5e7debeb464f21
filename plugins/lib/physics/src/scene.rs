//! Physics scene files: bodies of boxes, spheres or convex hulls, one material, gravity, the
//! shape of each pointer, and the engine that steps them (`engine:`):
//!
//! - `penalty` (the default): the contact-volume penalty method inside every haptic tick
//!   (thesis Ch. 5), in steps of `dt`, with the material's stiffness, damping and friction
//!   springs;
//! - `rapier`: rapier3d's constraint solver at `rate:` steps per second in hapticd's physics
//!   thread (thesis Ch. 6); the hand feels the surfaces near each pointer as planes moved
//!   between physics steps. The bodies near a pointer move with the hand in the haptic
//!   thread and the physics takes back what the hand did to them (`feedback: local`, thesis
//!   6.5.4, the default: of the three it alone pushes light bodies as far as physics at the
//!   haptic rate and throws none, `hapticctl experiment push-mass`); each body gets back the
//!   impulse of the force felt (`feedback: impulse`), or is pushed by a solid placed where
//!   the hand was when the physics sampled it (`feedback: position`, the conventional
//!   method).
//!
//! Bodies, gravity, `static_friction` and `friction` mean the same under both; a key only
//! one engine reads is an error, at its place, under the other. A penalty scene:
//!
//! ```yaml
//! name: blocks
//! gravity: [0, -9.81, 0]
//! dt: 0.00025                  # longest physics step; a haptic tick is split into steps
//! material:
//!   stiffness: 2.0e7           # N/m³: normal force per unit depth per unit area
//!   damping: 2.0e4             # N·s/m³
//!   static_friction: 0.5       # μ0
//!   friction: 0.4              # μ
//!   friction_stiffness: 2.0e7  # N/m³
//!   friction_damping: 2.0e4    # N·s/m³
//!   slip_speed: 0.001          # m/s
//!   model: volume              # or point: the deepest point only, for comparison
//!   point_stiffness: 1000      # N/m and N·s/m of the point model (default: the numbers of
//!   point_damping: 50          #   stiffness and damping, which the point model reads per point)
//!   scaling: { spring: 0.05, damper: 0.4 }   # optional: instead of the numbers above, each
//!                              #   contact a spring 2·spring·m/dt² and damper damper·m/dt for
//!                              #   its pair's reduced mass m (stable for any masses)
//! bodies:
//!   - name: floor
//!     box: [0.3, 0.02, 0.3]    # edge lengths, metres
//!     position: [0, -0.04, 0]
//!     fixed: true
//!   - name: block
//!     box: [0.03, 0.03, 0.03]
//!     position: [0.03, -0.015, 0]
//!     orientation: [1, 0, 0, 0]
//!     density: 500             # kg/m³
//!     velocity: [0, 0, 0]      # m/s, optional
//!     spin: [0, 0, 0]          # rad/s, optional
//!   - name: wedge
//!     hull: [[0, 0, 0], [0.02, 0, 0], [0, 0.02, 0], [0, 0, 0.02]]   # instead of box: the convex
//!     position: [-0.05, 0, 0]  #   hull of these points, relative to position
//!   - name: marble
//!     sphere: 0.008            # radius; the penalty engine uses a 42-vertex hull of the
//!     position: [0, 0.05, 0]   #   ball's volume (within 4 % of its surface)
//!   - name: arch               # a body that is not convex: convex pieces, each a box or a
//!     pieces:                  #   hull, placed relative to the body's position
//!       - { box: [0.01, 0.03, 0.03], position: [-0.02, 0, 0] }
//!       - { box: [0.01, 0.03, 0.03], position: [0.02, 0, 0] }
//!       - { box: [0.05, 0.01, 0.03], position: [0, 0.02, 0] }
//!     position: [0.1, 0.015, 0]
//! pointer:                     # optional: scenes without one take no pointers
//!   box: [0.01, 0.01, 0.01]    # each pointer: this solid (or a hull), centred at the grip
//!   coupling:                  # optional (thesis 4.1.2): the solid is a body of the world,
//!     stiffness: 400           #   tied to the grip by a spring (N/m) and damper (N·s/m),
//!     damping: 5               #   and the user feels their stretch; without it the solid
//!     rotational_stiffness: 0.5  # sits at the grip and the user feels its contacts
//!     rotational_damping: 0.01   # (N·m/rad, N·m·s/rad; both optional, default 0)
//!   density: 1000              # kg/m³ of a coupled pointer (its weight is felt too)
//! ```
//!
//! Scenes for two or more pointers may let them hold bodies (thesis 4.2–4.7): a body that is
//! one `box:` is held while two pointers press it from opposite sides, and let go when they
//! open (see `config/scenes/grasp.yaml`):
//!
//! ```yaml
//! name: grasp
//! gravity: [0, -2.0, 0]
//! dt: 0.0005
//! material: { stiffness: 2.0e7, damping: 2.0e4, static_friction: 1.0, friction: 1.0,
//!             friction_stiffness: 2.0e7, friction_damping: 2.0e4, slip_speed: 0.02 }
//! bodies:
//!   - { name: table, box: [0.3, 0.04, 0.3], position: [0, -0.17, 0], fixed: true }
//!   - { name: box, box: [0.06, 0.1, 0.06], position: [0, -0.1, 0], density: 2777.8 }
//! pointer:
//!   box: [0.01, 0.01, 0.01]
//! grasp:
//!   method: distributed        # the shape shell and the resultant shared among the fingers;
//!                              #   or conventional: one spring per finger (for comparison)
//!   grip_stiffness: 800        # N/m from each pointer to the surface it holds
//!   inertia_stiffness: 800     # N/m from the shell to the body (moments scale with size²)
//!   inertia_damping: 10        # N·s/m; optional, default 0.35·√(kr·m) for each body
//! ```
//!
//! In such a scene the pointers touch box bodies through the grasp springs (grasped or not),
//! and held bodies stick to them up to the material's `static_friction`.
//!
//! A rapier scene (see `config/scenes/balls.yaml`):
//!
//! ```yaml
//! name: tray
//! engine: rapier
//! rate: 20                     # physics steps per second (10–1000)
//! feedback: local              # or impulse, or position
//! gravity: [0, -9.81, 0]
//! material:
//!   static_friction: 0.3       # rapier's contacts stick and slide at μ; the proxy the
//!   friction: 0.3              #   hand feels sticks at μ0
//! bodies:
//!   - { name: floor, box: [0.3, 0.02, 0.3], position: [0, -0.04, 0], fixed: true }
//!   - { name: ball, sphere: 0.015, position: [0, -0.015, 0], density: 7800 }
//! pointer:
//!   sphere: 0.005              # the solid that pushes under feedback: position
//! ```

use crate::body::Body;
use crate::coupling::{Coupling, Grip};
use crate::friction::FrictionParameters;
use crate::grasping::Grasping;
use crate::polyhedron::Polyhedron;
use crate::world::{ContactModel, Material, Scaling, World};
use hapticd_core::kinematics::Wrench;
use std::path::Path;

use glam::{DQuat, DVec3};
use hapticd_core::diagnostics::{self, Diagnostic, Diagnostics, Findings, YamlMap};
use hapticd_core::haptics::grasp::{GraspSettings, Method};
use hapticd_core::kinematics::{SOLID_SIZES, WORLD_EXTENT};
use serde::Deserialize;
use serde::de::IgnoredAny;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    name: String,
    #[serde(default)]
    engine: RawEngine,
    #[serde(default = "earth")]
    gravity: [f64; 3],
    dt: Option<f64>,
    rate: Option<f64>,
    feedback: Option<RawFeedback>,
    material: RawMaterial,
    bodies: Vec<RawBody>,
    pointer: Option<RawPointer>,
    grasp: Option<RawGrasp>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGrasp {
    #[serde(default)]
    method: RawGraspMethod,
    grip_stiffness: f64,
    inertia_stiffness: f64,
    inertia_damping: Option<f64>,
}

#[derive(Deserialize, Default, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum RawGraspMethod {
    #[default]
    Distributed,
    Conventional,
}

#[derive(Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
enum RawEngine {
    #[default]
    Penalty,
    Rapier,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum RawFeedback {
    Local,
    Impulse,
    Position,
}

fn earth() -> [f64; 3] {
    [0.0, -9.81, 0.0]
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    stiffness: Option<f64>,
    damping: Option<f64>,
    static_friction: f64,
    friction: f64,
    friction_stiffness: Option<f64>,
    friction_damping: Option<f64>,
    slip_speed: Option<f64>,
    model: Option<RawModel>,
    point_stiffness: Option<f64>,
    point_damping: Option<f64>,
    scaling: Option<RawScaling>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScaling {
    spring: f64,
    damper: f64,
}

#[derive(Deserialize, Default, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum RawModel {
    #[default]
    Volume,
    Point,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBody {
    #[serde(default)]
    name: String,
    #[serde(rename = "box")]
    size: Option<[f64; 3]>,
    hull: Option<Vec<[f64; 3]>>,
    sphere: Option<f64>,
    pieces: Option<Vec<RawPiece>>,
    position: [f64; 3],
    #[serde(default = "identity")]
    orientation: [f64; 4],
    #[serde(default)]
    fixed: bool,
    #[serde(default = "water")]
    density: f64,
    #[serde(default)]
    velocity: [f64; 3],
    #[serde(default)]
    spin: [f64; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPiece {
    #[serde(rename = "box")]
    size: Option<[f64; 3]>,
    hull: Option<Vec<[f64; 3]>>,
    sphere: Option<f64>,
    #[serde(default)]
    position: [f64; 3],
    #[serde(default = "identity")]
    orientation: [f64; 4],
}

fn identity() -> [f64; 4] {
    [1.0, 0.0, 0.0, 0.0]
}

fn water() -> f64 {
    1000.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPointer {
    #[serde(rename = "box")]
    size: Option<[f64; 3]>,
    hull: Option<Vec<[f64; 3]>>,
    sphere: Option<f64>,
    coupling: Option<RawCoupling>,
    #[serde(default = "water")]
    density: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCoupling {
    stiffness: f64,
    damping: f64,
    #[serde(default)]
    rotational_stiffness: f64,
    #[serde(default)]
    rotational_damping: f64,
}

/// A loaded scene: the world with one fixed body per pointer at its end.
pub struct PenaltyScene {
    /// The scene's name.
    pub name: String,
    /// The world.
    pub world: World,
    /// Longest physics step, seconds.
    pub dt: f64,
    /// Index of the first pointer body in the world.
    pub first_pointer: usize,
    /// Names of the bodies in world order; pointers are `pointer 1`, `pointer 2`, …
    pub names: Vec<String>,
    /// The material as the file gives it for each contact model.
    materials: [Material; 2],
    /// The coupling of each pointer; none for one placed at its grip.
    couplings: Vec<Option<Coupling>>,
    /// Whether the pointers have been put at their grips once.
    pointers_placed: bool,
    /// Bodies held between pointers, when the file asks for grasping.
    pub grasping: Option<Grasping>,
    /// What the file asks for that works, but worth knowing (a step near its stability
    /// limit).
    pub warnings: Vec<Diagnostic>,
}

/// Most pointers a scene steps.
pub const MAX_POINTERS: usize = 8;

/// Softest and stiffest grasp springs, N/m.
pub const GRASP_STIFFNESS: (f64, f64) = (1.0, 1e5);
/// The inertia damper a grasp gets when its file gives none: this times √(kr·m), about a
/// 0.18 damping ratio (10 N·s/m for the thesis' 1 kg box on 800 N/m).
pub const INERTIA_DAMPING_FACTOR: f64 = 0.35;
/// Heaviest damper on the inertia spring, N·s/m.
pub const MAX_GRASP_DAMPING: f64 = 1e4;

// What a scene file may describe: the world of a desk and a room, in SI units, with room to
// spare on every side, and none of the extremes where the numbers stop meaning anything
// (a 1e-300 m box has no inertia to integrate; a position of 1e17 m has no millimetres).

/// Shortest physics step, seconds; also what keeps one haptic tick to a bounded number of
/// steps.
pub const MIN_DT: f64 = 1e-6;
/// Longest physics step, seconds.
pub const MAX_DT: f64 = 0.1;
/// Lightest and densest material, kg/m³ (the thesis' 1 kg cube of 2 m is 0.125).
pub const DENSITY_RANGE: (f64, f64) = (1e-3, 1e5);
/// Strongest gravity, m/s² (a hundred times the earth's).
pub const MAX_GRAVITY: f64 = 1e3;
/// Fastest initial speed, m/s, and spin, rad/s.
pub const MAX_SPEED: (f64, f64) = (1e3, 1e4);
/// Most points of a hull (its construction is cubic in them).
pub const MAX_HULL_POINTS: usize = 64;
/// Most convex pieces in a world, pointers included: the world keeps state for every pair.
pub const MAX_PIECES: usize = 256;
/// Most physics steps in one call of [`PenaltyScene::step_pointers`]; a tick that would
/// need more fails instead of holding the haptic thread.
pub const MAX_STEPS_PER_CALL: usize = 1000;

/// A convex piece as the file gives it, for engines with primitives of their own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Primitive {
    /// A box of these half edges, turned by `rotation` from the world's axes.
    Cuboid {
        /// Half the edge lengths, metres.
        half: DVec3,
        /// The box's orientation.
        rotation: DQuat,
    },
    /// A ball of this radius, metres (the penalty engine uses [`Polyhedron::ball`]).
    Ball {
        /// Radius, metres.
        radius: f64,
    },
    /// The convex hull of the piece's vertices.
    Hull,
}

/// The shape keys of one solid: exactly one of `box:`, `hull:` or `sphere:`.
#[derive(Clone, Copy)]
struct Given<'a> {
    size: Option<[f64; 3]>,
    hull: Option<&'a [[f64; 3]]>,
    sphere: Option<f64>,
}

impl Given<'_> {
    fn any(&self) -> bool {
        self.size.is_some() || self.hull.is_some() || self.sphere.is_some()
    }
}

macro_rules! given {
    ($raw:expr) => {
        Given {
            size: $raw.size,
            hull: $raw.hull.as_deref(),
            sphere: $raw.sphere,
        }
    };
}

/// The solid of a `box:`, `hull:` or `sphere:` (exactly one) of the item at field path `at`,
/// turned by its `orientation` and moved to its `position`, with the primitive it is;
/// `None` after reporting what is wrong.
fn solid(
    f: &mut Findings,
    at: &str,
    given: Given,
    position: [f64; 3],
    orientation: [f64; 4],
) -> Option<(Polyhedron, Primitive)> {
    let turn = f.unit_quaternion(format!("{at}.orientation"), orientation);
    let placed = f.coordinates(format!("{at}.position"), &position, WORLD_EXTENT, "m");
    let (smallest, largest) = SOLID_SIZES;
    let local = match (given.size, given.hull, given.sphere) {
        (Some(size), None, None) => {
            let mut ok = true;
            for (k, side) in size.iter().enumerate() {
                ok &= f.within(format!("{at}.box[{k}]"), *side, smallest, largest, " m");
            }
            let half = DVec3::from(size) / 2.0;
            ok.then(|| {
                let rotation = turn;
                (
                    Polyhedron::cuboid(half),
                    Primitive::Cuboid { half, rotation },
                )
            })
        }
        (None, None, Some(radius)) => f
            .within(
                format!("{at}.sphere"),
                radius,
                smallest / 2.0,
                largest / 2.0,
                " m",
            )
            .then(|| (Polyhedron::ball(radius), Primitive::Ball { radius })),
        (None, Some(points), None) => {
            if points.len() > MAX_HULL_POINTS {
                f.error(
                    format!("{at}.hull"),
                    format!(
                        "{} points; a hull takes at most {MAX_HULL_POINTS}",
                        points.len()
                    ),
                );
                return None;
            }
            let mut ok = true;
            for (k, p) in points.iter().enumerate() {
                ok &= f.coordinates(format!("{at}.hull[{k}]"), p, largest, "m");
            }
            if !ok {
                return None;
            }
            let points: Vec<DVec3> = points.iter().map(|p| DVec3::from(*p)).collect();
            match Polyhedron::hull(&points) {
                Err(e) => {
                    f.error(format!("{at}.hull"), e);
                    None
                }
                Ok(hull) if hull.thickness() < smallest => {
                    f.error(
                        format!("{at}.hull"),
                        format!(
                            "the hull is {:.3e} m thin; solids must be at least {smallest} m thick",
                            hull.thickness()
                        ),
                    );
                    None
                }
                Ok(hull) => Some((hull, Primitive::Hull)),
            }
        }
        _ => {
            f.error(at, "give exactly one of box:, hull: or sphere:");
            None
        }
    };
    let (local, primitive) = local?;
    placed.then_some((local.transformed(turn, DVec3::from(position)), primitive))
}

/// The convex pieces of body `b` (at field path `at`) where the file puts them, each with
/// its primitive: its `box:`, `hull:` or `sphere:`, or each of its `pieces:` placed on the
/// body's pose.
fn body_pieces(f: &mut Findings, at: &str, b: &RawBody) -> Option<Vec<(Polyhedron, Primitive)>> {
    let Some(pieces) = &b.pieces else {
        return Some(vec![solid(f, at, given!(b), b.position, b.orientation)?]);
    };
    if given!(b).any() || pieces.is_empty() {
        f.error(at, "give either box:, hull:, sphere: or a list of pieces:");
        return None;
    }
    let turn = f.unit_quaternion(format!("{at}.orientation"), b.orientation);
    let placed = f.coordinates(format!("{at}.position"), &b.position, WORLD_EXTENT, "m");
    let pieces: Vec<Option<(Polyhedron, Primitive)>> = pieces
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let (piece, primitive) = solid(
                f,
                &format!("{at}.pieces[{k}]"),
                given!(p),
                p.position,
                p.orientation,
            )?;
            let primitive = match primitive {
                Primitive::Cuboid { half, rotation } => Primitive::Cuboid {
                    half,
                    rotation: turn * rotation,
                },
                other => other,
            };
            Some((piece.transformed(turn, DVec3::from(b.position)), primitive))
        })
        .collect();
    placed.then_some(())?;
    pieces.into_iter().collect()
}

/// ω·dt of the stiffest contact spring a body can meet above which an explicit step gains
/// energy (and, past 2, diverges).
const STABLE_OMEGA_DT: f64 = 1.0;

/// Refuse a material too stiff for the step and the scene's movable bodies: the volume
/// spring on a body's largest face (the largest patch it can rest on) is a spring of
/// k = stiffness × area, and the step integrates m·ẍ = −k·x stably only while √(k/m)·dt < 2.
/// Between 1 and 2 it still gains energy on every bounce: a warning.
fn check_stability(f: &mut Findings, m: &RawMaterial, dt: f64, bodies: &[Body]) {
    if m.scaling.is_some() {
        return; // Per-contact springs scaled by mass and step: stable by construction.
    }
    for (i, body) in bodies.iter().enumerate().filter(|(_, b)| !b.fixed) {
        let area = body
            .pieces
            .iter()
            .map(Polyhedron::largest_face_area)
            .fold(0.0, f64::max);
        for (key, k) in [
            ("stiffness", m.stiffness.unwrap_or(0.0) * area),
            ("point_stiffness", m.point_stiffness.unwrap_or(0.0)),
        ] {
            let omega_dt = (k / body.mass).sqrt() * dt;
            if omega_dt <= STABLE_OMEGA_DT {
                continue;
            }
            let message = format!(
                "with bodies[{i}] ({:.3} kg on a {area:.2e} m² face) the contact spring has \
                 ω·dt = {omega_dt:.2} at dt = {dt} s; a step of at most {:.2e} s keeps it at 1",
                body.mass,
                dt / omega_dt
            );
            if omega_dt >= 2.0 {
                f.error(format!("material.{key}"), format!("too stiff: {message}"));
            } else {
                f.warning(
                    format!("material.{key}"),
                    format!("gains energy: {message}"),
                );
            }
        }
    }
}

/// Which simulator steps a scene file's world (`engine:`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Engine {
    /// The contact-volume penalty method inside every haptic tick (thesis Ch. 5).
    Penalty,
    /// rapier3d's constraint solver at `rate:` in a physics thread (thesis Ch. 6).
    Rapier,
}

/// What a multi-rate world takes back from the haptic side (`feedback:`, thesis 6.2–6.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feedback {
    /// Local dynamics (thesis 6.5.4): the bodies near a pointer move in the haptic thread
    /// under the hand between physics steps, and what the hand did to them goes back.
    Local,
    /// The impulse the hand gave each body over a physics period, at its point.
    Impulse,
    /// The conventional method: each pointer is a kinematic body moved to the hand's
    /// position as the physics samples it.
    Position,
}

impl Feedback {
    /// The name a scene file gives it.
    pub fn name(self) -> &'static str {
        match self {
            Feedback::Local => "local",
            Feedback::Impulse => "impulse",
            Feedback::Position => "position",
        }
    }
}

/// A world for a multi-rate engine, as its scene file describes it.
#[derive(Debug, Clone)]
pub struct MultiRateWorld {
    /// The scene's name.
    pub name: String,
    /// Gravity, m/s².
    pub gravity: DVec3,
    /// Physics steps per second.
    pub rate: f64,
    /// What the haptic side gives back.
    pub feedback: Feedback,
    /// μ0 of every contact.
    pub static_friction: f64,
    /// μ of every contact.
    pub friction: f64,
    /// The bodies (centroid, mass and inertia as the penalty engine has them).
    pub bodies: Vec<Body>,
    /// What each piece of each body is, in the order of [`Body::pieces`].
    pub primitives: Vec<Vec<Primitive>>,
    /// Names of the bodies.
    pub names: Vec<String>,
    /// The pointers' solid, centred at the origin, if the file gives one.
    pub pointer: Option<(Body, Primitive)>,
    /// What works but is worth knowing.
    pub warnings: Vec<Diagnostic>,
}

/// A physics scene file, read for the engine it names.
pub enum SceneFile {
    /// `engine: penalty` (the default).
    Penalty(Box<PenaltyScene>),
    /// `engine: rapier`.
    Rapier(Box<MultiRateWorld>),
}

/// Fastest and slowest physics of a multi-rate world, steps per second (the thesis runs
/// 10 to 100).
pub const RATE_RANGE: (f64, f64) = (10.0, 1000.0);

/// Keys that only the penalty engine reads, with whether the file gives each.
fn penalty_keys(raw: &RawScene) -> [(&'static str, bool); 12] {
    let m = &raw.material;
    [
        ("dt", raw.dt.is_some()),
        ("material.stiffness", m.stiffness.is_some()),
        ("material.damping", m.damping.is_some()),
        (
            "material.friction_stiffness",
            m.friction_stiffness.is_some(),
        ),
        ("material.friction_damping", m.friction_damping.is_some()),
        ("material.slip_speed", m.slip_speed.is_some()),
        ("material.model", m.model.is_some()),
        ("material.point_stiffness", m.point_stiffness.is_some()),
        ("material.point_damping", m.point_damping.is_some()),
        ("material.scaling", m.scaling.is_some()),
        (
            "pointer.coupling",
            raw.pointer.as_ref().is_some_and(|p| p.coupling.is_some()),
        ),
        ("grasp", raw.grasp.is_some()),
    ]
}

impl SceneFile {
    /// Whether the file at `path` describes a physics world (`bodies:`) rather than static
    /// solids (`shapes:`, which `hapticd_core::scene::static_scene` reads); false when it
    /// cannot be read as YAML at all.
    pub fn is_physics(path: &Path) -> bool {
        let Ok(text) = diagnostics::read_text(path) else {
            return false;
        };
        let keys: Result<std::collections::BTreeMap<String, IgnoredAny>, _> =
            serde_saphyr::from_str(&text);
        keys.is_ok_and(|k| k.contains_key("bodies"))
    }

    /// Load the scene file at `path` for `pointers` pointers.
    pub fn load(path: &Path, pointers: usize) -> Result<Self, Diagnostics> {
        Self::parse(&diagnostics::read_text(path)?, path, pointers)
    }

    /// Parse scene `text` for `pointers` pointers; `path` names it in diagnostics, which
    /// come all at once, each at its line and column.
    pub fn parse(text: &str, path: &Path, pointers: usize) -> Result<Self, Diagnostics> {
        let (raw, map): (RawScene, YamlMap) = diagnostics::parse_yaml(text, path)?;
        let locate = |field: &str| map.find(field);
        let mut f = Findings::new(path, &locate);
        f.name("name", &raw.name);
        if f.finite("gravity", &raw.gravity) && DVec3::from(raw.gravity).length() > MAX_GRAVITY {
            f.error("gravity", format!("must be at most {MAX_GRAVITY} m/s²"));
        }
        let m = &raw.material;
        let penalty = match raw.engine {
            RawEngine::Rapier => None,
            RawEngine::Penalty => {
                let dt = raw.dt.unwrap_or(MAX_DT);
                f.within("dt", dt, MIN_DT, MAX_DT, " s");
                Some((dt, Penalty::read(&mut f, m)))
            }
        };
        for (key, value) in [
            ("static_friction", m.static_friction),
            ("friction", m.friction),
        ] {
            f.non_negative(format!("material.{key}"), value);
        }
        if m.friction > m.static_friction {
            f.error("material.friction", "must not exceed static_friction");
        }
        let engine = match raw.engine {
            RawEngine::Penalty => Engine::Penalty,
            RawEngine::Rapier => Engine::Rapier,
        };
        match engine {
            Engine::Penalty => {
                for (key, given) in [
                    ("rate", raw.rate.is_some()),
                    ("feedback", raw.feedback.is_some()),
                ] {
                    if given {
                        f.error(key, "only for engine: rapier (the penalty engine steps in every haptic tick)");
                    }
                }
                for (key, given) in &penalty_keys(&raw)[..6] {
                    if !given {
                        f.error(*key, "missing: the penalty engine needs it");
                    }
                }
            }
            Engine::Rapier => {
                for (key, given) in penalty_keys(&raw) {
                    if given {
                        f.error(
                            key,
                            "only for engine: penalty (rapier's solver has no such setting)",
                        );
                    }
                }
                let (slow, fast) = RATE_RANGE;
                match raw.rate {
                    Some(rate) => {
                        f.within("rate", rate, slow, fast, " Hz");
                    }
                    None => f.error("rate", "missing: the rapier engine steps at this many Hz"),
                }
            }
        }
        let pieces: usize = raw
            .bodies
            .iter()
            .map(|b| b.pieces.as_ref().map_or(1, Vec::len))
            .sum::<usize>()
            + pointers;
        if engine == Engine::Penalty && pieces > MAX_PIECES {
            f.error(
                "bodies",
                format!("{pieces} convex pieces; a world holds at most {MAX_PIECES}"),
            );
            return Err(f.into_error());
        }
        let mut bodies = Vec::with_capacity(raw.bodies.len() + pointers);
        let mut primitives = Vec::with_capacity(raw.bodies.len());
        // Each body that is one box: its half edges and orientation (the body's frame starts
        // as the world's), for grasping.
        let mut boxes = Vec::with_capacity(raw.bodies.len());
        for (i, b) in raw.bodies.iter().enumerate() {
            let at = format!("bodies[{i}]");
            f.text(format!("{at}.name"), &b.name);
            let pieces = body_pieces(&mut f, &at, b);
            let (light, dense) = DENSITY_RANGE;
            f.within(format!("{at}.density"), b.density, light, dense, " kg/m³");
            let (speed, spin) = MAX_SPEED;
            f.coordinates(format!("{at}.velocity"), &b.velocity, speed, "m/s");
            f.coordinates(format!("{at}.spin"), &b.spin, spin, "rad/s");
            if let Some(pieces) = pieces
                && !f.has_errors()
            {
                let (solids, kinds): (Vec<Polyhedron>, Vec<Primitive>) = pieces.into_iter().unzip();
                let mut body = Body::compound(&solids, b.density, b.fixed);
                (body.velocity, body.spin) = (DVec3::from(b.velocity), DVec3::from(b.spin));
                bodies.push(body);
                boxes.push(match (kinds.as_slice(), &b.pieces) {
                    ([Primitive::Cuboid { half, rotation }], None) => Some((*half, *rotation)),
                    _ => None,
                });
                primitives.push(kinds);
            }
        }
        let first_pointer = bodies.len();
        if pointers > 0 && raw.pointer.is_none() {
            f.error(
                "",
                format!("{pointers} pointers, but the scene has no pointer: shape"),
            );
        }
        if pointers > MAX_POINTERS {
            f.error("pointer", format!("at most {MAX_POINTERS} pointers"));
        }
        let pointer_solid = raw.pointer.as_ref().and_then(|pointer| {
            if let Some(c) = &pointer.coupling {
                for (key, value) in [
                    ("stiffness", c.stiffness),
                    ("damping", c.damping),
                    ("rotational_stiffness", c.rotational_stiffness),
                    ("rotational_damping", c.rotational_damping),
                ] {
                    f.non_negative(format!("pointer.coupling.{key}"), value);
                }
                let (light, dense) = DENSITY_RANGE;
                f.within("pointer.density", pointer.density, light, dense, " kg/m³");
            }
            solid(&mut f, "pointer", given!(pointer), [0.0; 3], identity())
        });
        if let Some(g) = &raw.grasp {
            let (soft, stiff) = GRASP_STIFFNESS;
            f.within(
                "grasp.grip_stiffness",
                g.grip_stiffness,
                soft,
                stiff,
                " N/m",
            );
            f.within(
                "grasp.inertia_stiffness",
                g.inertia_stiffness,
                soft,
                stiff,
                " N/m",
            );
            if let Some(d) = g.inertia_damping {
                f.within("grasp.inertia_damping", d, 0.0, MAX_GRASP_DAMPING, " N·s/m");
            }
            if pointers > 0 && raw.pointer.as_ref().is_some_and(|p| p.coupling.is_some()) {
                f.error(
                    "grasp",
                    "grasping needs pointers at their grips, not coupled ones",
                );
            }
        }
        if let Some((dt, _)) = penalty
            && !f.has_errors()
        {
            check_stability(&mut f, m, dt, &bodies);
        }
        let warnings = f.finish()?;
        let Some((dt, penalty)) = penalty else {
            let feedback = match raw.feedback {
                Some(RawFeedback::Position) => Feedback::Position,
                Some(RawFeedback::Local) | None => Feedback::Local,
                Some(RawFeedback::Impulse) => Feedback::Impulse,
            };
            return Ok(SceneFile::Rapier(Box::new(MultiRateWorld {
                name: raw.name,
                gravity: DVec3::from(raw.gravity),
                rate: raw.rate.unwrap_or(RATE_RANGE.0),
                feedback,
                static_friction: m.static_friction,
                friction: m.friction,
                bodies,
                primitives,
                names: raw.bodies.into_iter().map(|b| b.name).collect(),
                pointer: pointer_solid.map(|(shape, primitive)| {
                    let density = raw.pointer.as_ref().map_or(1000.0, |p| p.density);
                    (Body::new(&shape, density, false), primitive)
                }),
                warnings,
            })));
        };
        let mut couplings = Vec::with_capacity(pointers);
        if let (Some(pointer), Some((shape, _))) = (&raw.pointer, &pointer_solid) {
            for _ in 0..pointers {
                let coupling = pointer.coupling.as_ref().map(|c| Coupling {
                    stiffness: c.stiffness,
                    damping: c.damping,
                    rotational_stiffness: c.rotational_stiffness,
                    rotational_damping: c.rotational_damping,
                });
                bodies.push(Body::new(shape, pointer.density, coupling.is_none()));
                couplings.push(coupling);
            }
        }
        let grasping = raw.grasp.as_ref().filter(|_| pointers >= 2).map(|g| {
            // The pointer's half size: where its solid meets a face its centre is that far out.
            let pointer = bodies[first_pointer].pieces[0]
                .vertices
                .iter()
                .fold(DVec3::ZERO, |m, v| m.max(v.abs()))
                .min_element();
            Grasping::new(&bodies[..first_pointer], &boxes, pointer, |mass| {
                GraspSettings {
                    method: match g.method {
                        RawGraspMethod::Distributed => Method::Distributed,
                        RawGraspMethod::Conventional => Method::Conventional,
                    },
                    grip_stiffness: g.grip_stiffness,
                    inertia_stiffness: g.inertia_stiffness,
                    // Unless the file says, a damping ratio of about 0.18 for the body on the
                    // inertia spring: through the shares the damper acts on the fingers' own
                    // motion, and with the device's tick of delay a heavier one shakes them.
                    inertia_damping: g
                        .inertia_damping
                        .unwrap_or(INERTIA_DAMPING_FACTOR * (g.inertia_stiffness * mass).sqrt()),
                    // Holding is sticking: the static coefficient.
                    friction: m.static_friction,
                }
            })
        });
        let material = Material {
            stiffness: penalty.stiffness,
            damping: penalty.damping,
            friction: FrictionParameters {
                static_coefficient: m.static_friction,
                dynamic_coefficient: m.friction,
                stiffness: penalty.friction_stiffness,
                damping: penalty.friction_damping,
                slip_speed: penalty.slip_speed,
            },
            model: ContactModel::Volume,
            scaling: penalty.scaling,
        };
        let materials = [
            material,
            Material {
                stiffness: penalty.point[0],
                damping: penalty.point[1],
                model: ContactModel::Point,
                ..material
            },
        ];
        let mut scene = PenaltyScene {
            name: raw.name,
            world: World::new(bodies, DVec3::from(raw.gravity), material),
            dt,
            first_pointer,
            names: raw
                .bodies
                .into_iter()
                .map(|b| b.name)
                .chain((1..=pointers).map(|k| format!("pointer {k}")))
                .collect(),
            materials,
            couplings,
            pointers_placed: false,
            grasping,
            warnings,
        };
        scene.set_model(penalty.model);
        Ok(SceneFile::Penalty(Box::new(scene)))
    }

    /// The engine that runs the scene.
    pub fn engine(&self) -> Engine {
        match self {
            SceneFile::Penalty(_) => Engine::Penalty,
            SceneFile::Rapier(_) => Engine::Rapier,
        }
    }
}

/// The penalty engine's own material keys, checked (absent ones were reported and read 0).
struct Penalty {
    stiffness: f64,
    damping: f64,
    friction_stiffness: f64,
    friction_damping: f64,
    slip_speed: f64,
    point: [f64; 2],
    scaling: Option<Scaling>,
    model: ContactModel,
}

impl Penalty {
    fn read(f: &mut Findings, m: &RawMaterial) -> Self {
        let mut value = |key: &str, v: Option<f64>| {
            let v = v.unwrap_or(0.0);
            f.non_negative(format!("material.{key}"), v);
            v
        };
        let stiffness = value("stiffness", m.stiffness);
        let damping = value("damping", m.damping);
        let penalty = Penalty {
            stiffness,
            damping,
            friction_stiffness: value("friction_stiffness", m.friction_stiffness),
            friction_damping: value("friction_damping", m.friction_damping),
            slip_speed: value("slip_speed", m.slip_speed),
            point: [
                m.point_stiffness
                    .map_or(stiffness, |v| value("point_stiffness", Some(v))),
                m.point_damping
                    .map_or(damping, |v| value("point_damping", Some(v))),
            ],
            scaling: m.scaling.as_ref().map(|s| Scaling {
                spring: s.spring,
                damper: s.damper,
            }),
            model: match m.model.unwrap_or_default() {
                RawModel::Volume => ContactModel::Volume,
                RawModel::Point => ContactModel::Point,
            },
        };
        if let Some(s) = &penalty.scaling {
            // A contact spring of 2·spring·m/dt² turns ω·dt into √(2·spring): stable below 2.
            if f.positive("material.scaling.spring", s.spring) && s.spring >= 2.0 {
                f.error(
                    "material.scaling.spring",
                    "must be below 2: larger springs cannot be stable at any step",
                );
            }
            f.non_negative("material.scaling.damper", s.damper);
        }
        penalty
    }
}

impl PenaltyScene {
    /// Load the penalty scene file at `path` for `pointers` pointers.
    pub fn load(path: &Path, pointers: usize) -> Result<Self, Diagnostics> {
        Self::parse(&diagnostics::read_text(path)?, path, pointers)
    }

    /// Parse penalty scene `text` for `pointers` pointers (see [`SceneFile::parse`]); a
    /// file for another engine is an error at its `engine:`.
    pub fn parse(text: &str, path: &Path, pointers: usize) -> Result<Self, Diagnostics> {
        match SceneFile::parse(text, path, pointers)? {
            SceneFile::Penalty(scene) => Ok(*scene),
            SceneFile::Rapier(_) => {
                let (_, map): (IgnoredAny, YamlMap) = diagnostics::parse_yaml(text, path)?;
                let locate = |field: &str| map.find(field);
                let mut f = Findings::new(path, &locate);
                f.error("engine", "a rapier scene; this runs penalty scenes only");
                Err(f.into_error())
            }
        }
    }

    /// [rt] Step the world through `dt` (in steps no longer than the scene's) with pointer k
    /// following `grips[k]`; `felt[k]` gets the wrench the user feels there (force, then
    /// torque about the pointer), averaged over `dt`. Allocates nothing: the world sized its
    /// clipping buffers for its largest pieces when it was made.
    ///
    /// Returns false, and steps nothing, when `dt` is not a positive time or would take more
    /// than [`MAX_STEPS_PER_CALL`] steps; and false when a wrench came out non-finite.
    pub fn step_pointers(&mut self, dt: f64, grips: &[Grip], felt: &mut [Wrench]) -> bool {
        felt.fill(Wrench::default());
        let steps = (dt / self.dt).ceil().max(1.0);
        if !(dt > 0.0 && steps <= MAX_STEPS_PER_CALL as f64) {
            return false;
        }
        let steps = steps as usize;
        let first = self.first_pointer;
        for (k, grip) in grips.iter().enumerate() {
            let body = &mut self.world.bodies[first + k];
            let coupled = self.couplings[k].is_some();
            // A coupled pointer starts at its grip, then moves on its own.
            if !coupled || !self.pointers_placed {
                body.place(grip.position, grip.orientation, grip.velocity, grip.spin);
                body.kinematic = !coupled;
            }
        }
        self.pointers_placed = true;
        let step = dt / steps as f64;
        for _ in 0..steps {
            for (k, grip) in grips.iter().enumerate() {
                if let Some(c) = &self.couplings[k] {
                    self.world.loads[first + k] = c.load(grip, &self.world.bodies[first + k], step);
                }
            }
            if let Some(g) = &mut self.grasping {
                g.before_step(&mut self.world, first, grips.len(), step);
            }
            self.world.step(step);
            for (k, out) in felt.iter_mut().enumerate().take(grips.len()) {
                *out = *out
                    + match self.couplings[k] {
                        None => self.world.contact_wrench(first + k),
                        Some(_) => self.world.loads[first + k] * -1.0,
                    };
                if let Some(g) = &self.grasping {
                    *out = *out + g.felt(k);
                }
            }
        }
        for out in felt.iter_mut() {
            *out = *out * (1.0 / steps as f64);
        }
        felt.iter().all(Wrench::is_finite) && self.world.is_finite()
    }

    /// Use `model` for contacts, with the material the file gives for it.
    pub fn set_model(&mut self, model: ContactModel) {
        self.world.material = self.materials[match model {
            ContactModel::Volume => 0,
            ContactModel::Point => 1,
        }];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped(name: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../config/scenes")
            .join(name)
    }

    fn parse(text: &str, pointers: usize) -> Result<PenaltyScene, Diagnostics> {
        PenaltyScene::parse(text, Path::new("s.yaml"), pointers)
    }

    #[test]
    fn grasp_settings_are_checked_each_at_its_place() {
        let text = std::fs::read_to_string(shipped("grasp.yaml")).unwrap();
        let scene = parse(&text, 2).unwrap();
        assert!(scene.grasping.is_some());
        // One pointer holds nothing: no grasping, and no error either.
        assert!(parse(&text, 1).unwrap().grasping.is_none());
        for (from, to, expected) in [
            (
                "grip_stiffness: 800",
                "grip_stiffness: .nan",
                "grasp.grip_stiffness",
            ),
            (
                "inertia_stiffness: 800",
                "inertia_stiffness: 1.0e9",
                "grasp.inertia_stiffness",
            ),
            (
                "method: distributed",
                "method: telepathic",
                "unknown variant `telepathic`",
            ),
            (
                "grip_stiffness: 800",
                "grip_stiffnes: 800",
                "unknown field `grip_stiffnes`",
            ),
            (
                "box: [0.01, 0.01, 0.01]      # each finger",
                "box: [0.01, 0.01, 0.01]\n  coupling: { stiffness: 400, damping: 5 }\n  #",
                "not coupled ones",
            ),
        ] {
            assert!(text.contains(from), "{from}");
            let e = parse(&text.replace(from, to), 2).err().unwrap().to_string();
            assert!(e.contains(expected), "{to}: {e}");
        }
    }

    #[test]
    fn the_shipped_scenes_parse() {
        let scene = PenaltyScene::load(&shipped("blocks.yaml"), 2).unwrap();
        assert_eq!(scene.world.bodies.len(), scene.first_pointer + 2);
        assert!(scene.world.bodies[scene.first_pointer].fixed);
        for (name, bodies) in [("cube-drop.yaml", 2), ("stack.yaml", 14), ("top.yaml", 2)] {
            let scene = PenaltyScene::load(&shipped(name), 0).unwrap();
            assert_eq!(scene.world.bodies.len(), bodies, "{name}");
            assert!(
                PenaltyScene::load(&shipped(name), 1).is_err(),
                "{name} has no pointer"
            );
        }
    }

    #[test]
    fn bad_scenes_are_refused() {
        let good = std::fs::read_to_string(shipped("blocks.yaml")).unwrap();
        assert!(parse(&good.replacen("dt: ", "dt: -", 1), 1).is_err());
        assert!(parse(&format!("{good}\nspeed: 3\n"), 1).is_err());
        assert!(parse(&good.replacen("density: 500", "density: 0", 1), 1).is_err());
        let scaled = "material:\n  scaling: { spring: 0.05, damper: 0.4 }\n";
        assert!(parse(&good.replacen("material:\n", scaled, 1), 1).is_ok());
        let unstable = "material:\n  scaling: { spring: 0, damper: 0.4 }\n";
        assert!(parse(&good.replacen("material:\n", unstable, 1), 1).is_err());
    }

    #[test]
    fn one_format_serves_both_engines_and_engine_specific_keys_are_located() {
        let push = std::fs::read_to_string(shipped("push.yaml")).unwrap();
        let SceneFile::Rapier(world) = SceneFile::parse(&push, Path::new("push.yaml"), 1).unwrap()
        else {
            panic!("push.yaml is a rapier scene");
        };
        assert_eq!((world.rate, world.feedback), (20.0, Feedback::Local));
        assert_eq!(world.names, ["floor", "block"]);
        assert!((world.bodies[1].mass - 8.0).abs() < 1e-9);
        assert!(matches!(world.pointer, Some((_, Primitive::Ball { radius })) if radius == 0.005));
        // The penalty engine reads the same bodies (and runs nothing else).
        let as_penalty = push.replace("engine: rapier", "engine: penalty");
        let e = SceneFile::parse(&as_penalty, Path::new("s.yaml"), 1)
            .err()
            .unwrap()
            .to_string();
        for expected in [
            "s.yaml:6:7: error: rate: only for engine: rapier",
            "material.stiffness: missing",
        ] {
            assert!(e.contains(expected), "{e}");
        }
        let blocks = std::fs::read_to_string(shipped("blocks.yaml")).unwrap();
        let as_rapier = blocks.replace("name: blocks", "name: blocks\nengine: rapier\nrate: 50");
        let e = parse(&as_rapier, 1).err().unwrap().to_string();
        assert!(
            e.contains("s.yaml:8:5: error: dt: only for engine: penalty"),
            "{e}"
        );
        assert!(
            e.contains("s.yaml:10:14: error: material.stiffness: only for engine: penalty"),
            "{e}"
        );
        for (from, to, expected) in [
            (
                "rate: 20 ",
                "rate: 5000 ",
                "rate: must be a number from 10 to 1000 Hz",
            ),
            (
                "feedback: local",
                "feedback: telepathy",
                "unknown variant `telepathy`",
            ),
            (
                "engine: rapier",
                "engine: bullet",
                "unknown variant `bullet`",
            ),
            (
                "sphere: 0.005",
                "sphere: .nan",
                "pointer.sphere: must be a number",
            ),
            (
                "box: [0.1, 0.1, 0.1]",
                "box: [0.1, 0.1, 0.1]\n    sphere: 0.1",
                "exactly one of",
            ),
        ] {
            assert!(push.contains(from), "{from}");
            let e = SceneFile::parse(&push.replace(from, to), Path::new("s.yaml"), 1)
                .err()
                .unwrap()
                .to_string();
            assert!(e.contains(expected), "{to}: {e}");
        }
        // A rapier file is no penalty scene.
        let e = PenaltyScene::parse(&push, Path::new("s.yaml"), 1)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("s.yaml:5:9: error: engine: a rapier scene"),
            "{e}"
        );
    }

    #[test]
    fn a_sphere_under_the_penalty_engine_has_the_balls_mass_and_rests_at_its_radius() {
        let text = "name: ball
dt: 0.0005
gravity: [0, -9.81, 0]
material: { stiffness: 1.0e7, damping: 3.0e4, static_friction: 0.5, friction: 0.4,
            friction_stiffness: 1.0e7, friction_damping: 2.0e4, slip_speed: 0.001 }
bodies:
  - { name: floor, box: [0.4, 0.1, 0.4], position: [0, -0.05, 0], fixed: true }
  - { name: ball, sphere: 0.02, position: [0, 0.02, 0], density: 1000 }
";
        let mut scene = parse(text, 0).unwrap();
        let ball = &scene.world.bodies[1];
        let exact = 1000.0 * 4.0 / 3.0 * std::f64::consts::PI * 0.02f64.powi(3);
        assert!((ball.mass / exact - 1.0).abs() < 1e-12, "{} kg", ball.mass);
        // Within 1 % of a solid ball's 2/5·m·r² about every axis.
        let moment = 0.4 * exact * 0.02f64.powi(2);
        for k in 0..3 {
            assert!((ball.inertia.col(k)[k] / moment - 1.0).abs() < 0.01);
        }
        for _ in 0..4000 {
            assert!(scene.step_pointers(5e-4, &[], &mut []));
        }
        // At rest on the floor within the hull's 4 % and the spring's millimetre fraction.
        let y = scene.world.bodies[1].position.y;
        assert!((y - 0.02).abs() < 0.04 * 0.02, "{y}");
    }

    #[test]
    fn every_mistake_is_reported_at_its_line() {
        let text = "\
name: three-mistakes
gravity: [0, .nan, 0]
dt: 0.001
material: { stiffness: 1.0e7, damping: -5, static_friction: 0.5, friction: 0.4,
            friction_stiffness: 1.0e7, friction_damping: 2.0e4, slip_speed: 0.001 }
bodies:
  - { name: floor, box: [1, 0.1, 1], position: [0, -0.05, 0], fixed: true }
  - name: block
    box: [0.03, 0, 0.03]
    position: [0, 0.1, 0]
";
        let e = parse(text, 0).err().expect("three mistakes").to_string();
        let lines: Vec<_> = e.lines().collect();
        assert_eq!(
            lines,
            [
                "s.yaml:2:10: error: gravity: must be a finite number",
                "s.yaml:4:40: error: material.damping: must be a finite number ≥ 0",
                "s.yaml:9:17: error: bodies[1].box[1]: must be a number from 0.0001 to 1000 m, not 0",
            ]
        );
    }
}

#[cfg(test)]
mod pointer_tests {
    use super::*;
    use glam::DQuat;

    #[test]
    fn a_pointer_pressed_into_the_table_is_pushed_out_by_its_depth() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../config/scenes/blocks.yaml");
        let mut scene = PenaltyScene::load(&path, 1).unwrap();
        let k = scene.first_pointer;
        // The 1 cm pointer cube 3 mm into the table top (y = −0.03), away from the blocks.
        scene.world.bodies[k].place(
            DVec3::new(0.0, -0.028, -0.1),
            DQuat::IDENTITY,
            DVec3::ZERO,
            DVec3::ZERO,
        );
        scene.world.step(1e-4);
        let w = scene.world.contact_wrench(k);
        // 2·10⁷ N/m³ × 1 cm² × 3 mm = 6 N, straight up through the contact.
        assert!(
            (w.force - DVec3::new(0.0, 6.0, 0.0)).length() < 1e-6,
            "{w:?}"
        );
        assert!(w.torque.length() < 1e-9, "{w:?}");
    }
}

#[cfg(test)]
mod coupling_tests {
    use super::*;
    use glam::DQuat;

    const SCENE: &str = "name: coupled
dt: 0.0001
material: { stiffness: 1.0e7, damping: 2.0e4, static_friction: 0.5, friction: 0.4,
            friction_stiffness: 1.0e7, friction_damping: 2.0e4, slip_speed: 0.001 }
bodies:
  - { name: floor, box: [1, 0.1, 1], position: [0, -0.05, 0], fixed: true }
pointer:
  box: [0.02, 0.02, 0.02]
  density: 1000
  coupling: { stiffness: 400, damping: 5, rotational_stiffness: 0.5, rotational_damping: 0.01 }
";

    #[test]
    fn a_coupled_pointer_stays_on_the_floor_and_the_user_feels_the_stretch() {
        let mut scene = PenaltyScene::parse(SCENE, Path::new("coupled.yaml"), 1).unwrap();
        // The grip pushes 1 cm below where the 2 cm cube would rest on the floor (y = 0).
        let grip = Grip {
            position: DVec3::new(0.0, 0.0, 0.0),
            orientation: DQuat::IDENTITY,
            velocity: DVec3::ZERO,
            spin: DVec3::ZERO,
        };
        let mut felt = [Wrench::default()];
        for _ in 0..3000 {
            scene.step_pointers(1e-3, &[grip], &mut felt);
        }
        let body = &scene.world.bodies[scene.first_pointer];
        let (k, m, g) = (400.0, body.mass, 9.81);
        // The user feels the spring's stretch, and nothing else (to the friction springs'
        // micro-motion within the tick).
        let stretch = body.position - grip.position;
        let error = (felt[0].force - k * stretch).length();
        assert!(
            error < 1e-3 * felt[0].force.length(),
            "{felt:?}, {}",
            k * stretch
        );
        // The floor carries the weight and the spring's pull: depth = (m·g + k·s)/(k_N·A).
        let depth = 0.01 - body.position.y;
        let expected = (m * g + k * stretch.y) / (1.0e7 * 0.02 * 0.02);
        assert!(
            (depth / expected - 1.0).abs() < 5e-3,
            "{depth} m, {expected} m"
        );
        assert!(
            stretch.y > 0.009,
            "the pointer went into the floor: {stretch}"
        );
    }

    #[test]
    fn a_coupling_damped_far_past_the_step_still_settles() {
        // Explicitly, 1000 N·s/m on 8 g and 1 N·m·s on 5·10⁻⁷ kg·m² would reverse the pointer's
        // motion 12 and 190 times over in each 0.1 ms step.
        let scene = SCENE.replace(
            "damping: 5, rotational_stiffness: 0.5, rotational_damping: 0.01",
            "damping: 1000, rotational_stiffness: 0.5, rotational_damping: 1.0",
        );
        let mut scene = PenaltyScene::parse(&scene, Path::new("coupled.yaml"), 1).unwrap();
        let grip = Grip {
            position: DVec3::new(0.0, 0.02, 0.0),
            orientation: DQuat::from_rotation_z(0.5),
            velocity: DVec3::ZERO,
            spin: DVec3::ZERO,
        };
        let mut felt = [Wrench::default()];
        for _ in 0..1000 {
            assert!(scene.step_pointers(1e-3, &[grip], &mut felt));
        }
        let body = &scene.world.bodies[scene.first_pointer];
        assert!(body.spin.length() < 1e-3 && body.velocity.length() < 1e-3);
        assert!(body.orientation.angle_between(grip.orientation) < 0.02);
    }
}
