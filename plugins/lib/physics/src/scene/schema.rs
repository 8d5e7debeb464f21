//! The scene file's schema: every key of both engines as YAML gives it, unknown keys
//! refused, nothing checked yet.

use hapticd_core::kinematics::Up;
use serde::Deserialize;

/// A scene file as YAML gives it, before any check.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScene {
    pub(super) name: String,
    #[serde(default)]
    pub(super) engine: RawEngine,
    #[serde(default = "earth")]
    pub(super) gravity: [f64; 3],
    pub(super) dt: Option<f64>,
    pub(super) rate: Option<f64>,
    pub(super) feedback: Option<RawFeedback>,
    pub(super) material: RawMaterial,
    pub(super) bodies: Vec<RawBody>,
    pub(super) pointer: Option<RawPointer>,
    /// Haptic effects: rendered by the daemon, not the engine (read here so that a file
    /// of them is a scene file; checked by the daemon against each device).
    #[serde(default)]
    #[allow(dead_code)]
    pub(super) effects: Vec<hapticd_core::haptics::effects::spec::EffectSpec>,
    pub(super) grasp: Option<RawGrasp>,
    #[serde(default)]
    pub(super) joints: Vec<super::joints::RawJoint>,
    /// URDF robots, read into `bodies` and `joints` before any check.
    #[serde(default)]
    pub(super) urdf: Vec<RawRobot>,
}

/// `grasp:`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawGrasp {
    #[serde(default)]
    pub(super) method: RawGraspMethod,
    pub(super) grip_stiffness: f64,
    pub(super) inertia_stiffness: f64,
    pub(super) inertia_damping: Option<f64>,
}

/// `grasp.method:`.
#[derive(Deserialize, Default, Clone, Copy)]
#[serde(rename_all = "lowercase")]
pub(super) enum RawGraspMethod {
    #[default]
    Distributed,
    Conventional,
}

/// `engine:`.
#[derive(Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
pub(super) enum RawEngine {
    #[default]
    Penalty,
    Rapier,
}

/// `feedback:`.
#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
pub(super) enum RawFeedback {
    Local,
    Impulse,
    Position,
}

/// A `gravity:` not given: the earth's.
fn earth() -> [f64; 3] {
    [0.0, -9.81, 0.0]
}

/// `material:`, both engines' keys.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMaterial {
    pub(super) stiffness: Option<f64>,
    pub(super) damping: Option<f64>,
    pub(super) static_friction: f64,
    pub(super) friction: f64,
    pub(super) friction_stiffness: Option<f64>,
    pub(super) friction_damping: Option<f64>,
    pub(super) slip_speed: Option<f64>,
    pub(super) model: Option<RawModel>,
    pub(super) point_stiffness: Option<f64>,
    pub(super) point_damping: Option<f64>,
    pub(super) scaling: Option<RawScaling>,
    /// A surface texture and transient: rendered by the daemon (read here so that a file of
    /// them is a scene file; checked by the daemon).
    #[allow(dead_code)]
    pub(super) texture: Option<hapticd_core::haptics::texture::TextureSpec>,
    #[allow(dead_code)]
    pub(super) transient: Option<hapticd_core::haptics::surface::TransientSpec>,
}

/// `material.scaling:`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScaling {
    pub(super) spring: f64,
    pub(super) damper: f64,
}

/// `material.model:`.
#[derive(Deserialize, Default, Clone, Copy)]
#[serde(rename_all = "lowercase")]
pub(super) enum RawModel {
    #[default]
    Volume,
    Point,
}

/// One of `bodies:`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBody {
    #[serde(default)]
    pub(super) name: String,
    #[serde(rename = "box")]
    pub(super) size: Option<[f64; 3]>,
    pub(super) hull: Option<Vec<[f64; 3]>>,
    pub(super) sphere: Option<f64>,
    pub(super) pieces: Option<Vec<RawPiece>>,
    pub(super) mesh: Option<String>,
    pub(super) scale: Option<f64>,
    /// The mesh file's up axis.
    pub(super) up: Option<Up>,
    pub(super) position: [f64; 3],
    #[serde(default = "identity")]
    pub(super) orientation: [f64; 4],
    #[serde(default)]
    pub(super) fixed: bool,
    #[serde(default = "water")]
    pub(super) density: f64,
    #[serde(default)]
    pub(super) velocity: [f64; 3],
    #[serde(default)]
    pub(super) spin: [f64; 3],
    /// The body's own surface texture and transient (rendered by the daemon).
    #[allow(dead_code)]
    pub(super) texture: Option<hapticd_core::haptics::texture::TextureSpec>,
    #[allow(dead_code)]
    pub(super) transient: Option<hapticd_core::haptics::surface::TransientSpec>,
    /// How its mesh is felt across faces (shaded by the daemon).
    #[allow(dead_code)]
    pub(super) shading: Option<hapticd_core::haptics::shading::Shading>,
    /// Its mass and inertia as given, instead of its solid's at `density`.
    pub(super) inertial: Option<RawInertial>,
    /// A soft body's material and cut: the body is then soft (a box or a ball).
    pub(super) soft: Option<RawSoft>,
    /// A soft body's nodes held still.
    pub(super) pinned: Option<RawPinned>,
    /// Whether the pointer holds it (set from `pointer.holds`, not read from the file).
    #[serde(skip)]
    pub(super) held: bool,
}

/// A body's `soft:`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSoft {
    /// Young's modulus, Pa.
    pub(super) young: f64,
    /// Poisson's ratio.
    pub(super) poisson: f64,
    /// Stiffness-proportional damping, s.
    #[serde(default)]
    pub(super) damping: f64,
    /// The largest element's edge along the cut's lattice, m.
    pub(super) resolution: f64,
    /// The elements' degree.
    #[serde(default)]
    pub(super) elements: RawElements,
}

/// `soft.elements:`.
#[derive(Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
pub(super) enum RawElements {
    #[default]
    Linear,
    Quadratic,
}

/// A soft body's `pinned:`: its nodes inside a fixed body, or at or below a height along an
/// axis.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPinned {
    pub(super) body: Option<String>,
    pub(super) below: Option<(RawAxis, f64)>,
}

/// An axis of the scene's frame.
#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
pub(super) enum RawAxis {
    X,
    Y,
    Z,
}

impl RawBody {
    /// A body called `name` at `position` and `orientation`, its solid yet to be given.
    pub(super) fn placed(
        name: String,
        position: [f64; 3],
        orientation: [f64; 4],
        fixed: bool,
    ) -> Self {
        RawBody {
            name,
            size: None,
            hull: None,
            sphere: None,
            pieces: None,
            mesh: None,
            scale: None,
            up: None,
            position,
            orientation,
            fixed,
            density: water(),
            velocity: [0.0; 3],
            spin: [0.0; 3],
            texture: None,
            transient: None,
            shading: None,
            inertial: None,
            soft: None,
            pinned: None,
            held: false,
        }
    }

    /// Whether it is a rigid body of the world: not soft, not the pointer's.
    pub(super) fn rigid(&self) -> bool {
        self.soft.is_none() && !self.held
    }
}

/// One of `urdf:` as YAML gives it.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRobot {
    /// The URDF file, relative to the scene file.
    pub(super) file: String,
    /// Where the root link's frame is, metres.
    #[serde(default)]
    pub(super) position: [f64; 3],
    /// How the robot is turned (w, x, y, z): a URDF's z is up, a scene's y.
    #[serde(default = "identity")]
    pub(super) orientation: [f64; 4],
    /// What its bodies' and joints' names start with (default: the URDF's robot name).
    pub(super) name: Option<String>,
    /// Whether the world holds its root link.
    #[serde(default)]
    pub(super) base: RawBase,
}

/// `base:`.
#[derive(Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
pub(super) enum RawBase {
    #[default]
    Fixed,
    Free,
}

/// A body's `inertial:`: its mass, centre of mass and inertia about it, as a robot's
/// description gives them (the solid then only touches).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawInertial {
    /// kg.
    pub(super) mass: f64,
    /// The centre of mass in the body's frame (from its `position`, along its axes), m.
    #[serde(default)]
    pub(super) centre: [f64; 3],
    /// About the centre of mass, the body's axes: [ixx, iyy, izz, ixy, ixz, iyz], kg·m².
    pub(super) inertia: [f64; 6],
}

/// One of a body's `pieces:`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPiece {
    #[serde(rename = "box")]
    pub(super) size: Option<[f64; 3]>,
    pub(super) hull: Option<Vec<[f64; 3]>>,
    pub(super) sphere: Option<f64>,
    #[serde(default)]
    pub(super) position: [f64; 3],
    #[serde(default = "identity")]
    pub(super) orientation: [f64; 4],
}

/// A `orientation:` not given: no turn.
pub(super) fn identity() -> [f64; 4] {
    [1.0, 0.0, 0.0, 0.0]
}

/// A `density:` not given: water's.
fn water() -> f64 {
    1000.0
}

/// `pointer:`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPointer {
    #[serde(rename = "box")]
    pub(super) size: Option<[f64; 3]>,
    pub(super) hull: Option<Vec<[f64; 3]>>,
    pub(super) sphere: Option<f64>,
    pub(super) coupling: Option<RawCoupling>,
    #[serde(default = "water")]
    pub(super) density: f64,
    /// A body of `bodies:` the pointer holds: the part the hand puts to others.
    pub(super) holds: Option<String>,
    /// How a held body is rendered.
    #[serde(default)]
    pub(super) rendering: RawRendering,
}

/// `pointer.rendering:`.
#[derive(Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub(super) enum RawRendering {
    /// A 6-DOF god-object kept out of the fixed bodies' exact surfaces.
    #[default]
    GodObject,
    /// The held body coupled to the grip by `coupling:` (a body of the world).
    Coupling,
}

impl RawPointer {
    /// The pointer of a scene that names none: a ball of 1 cm radius, water's density,
    /// rendered through its proxy.
    pub(super) fn fingertip() -> Self {
        Self {
            size: None,
            hull: None,
            sphere: Some(0.01),
            coupling: None,
            density: water(),
            holds: None,
            rendering: RawRendering::default(),
        }
    }
}

/// `pointer.coupling:`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCoupling {
    pub(super) stiffness: f64,
    pub(super) damping: f64,
    #[serde(default)]
    pub(super) rotational_stiffness: f64,
    #[serde(default)]
    pub(super) rotational_damping: f64,
}
