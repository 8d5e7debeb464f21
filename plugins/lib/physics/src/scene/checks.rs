//! What a scene file must be, checked section by section: the scene's own keys and which
//! engine reads them, the solids of bodies and pointers, grasping, and a penalty material's
//! stability on the file's step. Every check reports at its key and goes on, so that a file
//! gets all its mistakes at once.

use glam::{DMat3, DQuat, DVec3};
use hapticd_core::diagnostics::Findings;
use hapticd_core::kinematics::{SOLID_SIZES, WORLD_EXTENT, quat_from_wxyz};

use super::Engine;
use super::meshes::{MeshBody, MeshFiles, mesh_body};
use super::schema::{
    RawBody, RawEngine, RawInertial, RawMaterial, RawModel, RawPointer, RawScene, identity,
};
use crate::body::Body;
use crate::joint::Joint;
use crate::polyhedron::Polyhedron;
use crate::world::{ContactModel, Scaling, coordinate_bounds};

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
/// Fastest and slowest physics of a multi-rate world, steps per second (the thesis runs
/// 10 to 100).
pub const RATE_RANGE: (f64, f64) = (10.0, 1000.0);

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
                    f.error(format!("{at}.hull"), e.to_string());
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
        f.error(
            at,
            "give either box:, hull:, sphere:, mesh: or a list of pieces:",
        );
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
/// energy (and, past [`DIVERGENT_OMEGA_DT`], diverges).
const STABLE_OMEGA_DT: f64 = 1.0;
/// ω·dt past which the step diverges: what a scene file, or a mass set on a running body,
/// may not reach.
pub(crate) const DIVERGENT_OMEGA_DT: f64 = 2.0;

/// The contact springs `body` can meet, by the material key that sets each: the volume
/// spring on its largest face (the largest patch it can rest on), k = `stiffness` × area,
/// and the point model's `point_stiffness`; N/m.
pub(crate) fn contact_springs(
    stiffness: f64,
    point_stiffness: f64,
    body: &Body,
) -> [(&'static str, f64); 2] {
    let area = body
        .pieces
        .iter()
        .map(Polyhedron::largest_face_area)
        .fold(0.0, f64::max);
    [
        ("stiffness", stiffness * area),
        ("point_stiffness", point_stiffness),
    ]
}

/// ω·dt of the spring `k` (N/m) on a body of `mass` kg at step `dt`: the step integrates
/// m·ẍ = −k·x stably only while it is below [`DIVERGENT_OMEGA_DT`].
pub(crate) fn omega_dt(k: f64, mass: f64, dt: f64) -> f64 {
    (k / mass).sqrt() * dt
}

/// Refuse a material too stiff for the step and the scene's movable bodies; between
/// [`STABLE_OMEGA_DT`] and [`DIVERGENT_OMEGA_DT`] the step still gains energy on every
/// bounce: a warning.
pub(super) fn stability(f: &mut Findings, m: &RawMaterial, dt: f64, bodies: &[Body]) {
    if m.scaling.is_some() {
        return; // Per-contact springs scaled by mass and step: stable by construction.
    }
    let (stiffness, point) = (m.stiffness.unwrap_or(0.0), m.point_stiffness.unwrap_or(0.0));
    for (i, body) in bodies.iter().enumerate().filter(|(_, b)| !b.fixed) {
        for (key, k) in contact_springs(stiffness, point, body) {
            let omega_dt = omega_dt(k, body.mass, dt);
            if omega_dt <= STABLE_OMEGA_DT {
                continue;
            }
            let message = format!(
                "with bodies[{i}] ({:.3} kg) the contact spring of {k:.3e} N/m has ω·dt = \
                 {omega_dt:.2} at dt = {dt} s; a step of at most {:.2e} s keeps it at 1",
                body.mass,
                dt / omega_dt
            );
            if omega_dt >= DIVERGENT_OMEGA_DT {
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

/// Warn of each of `joints` whose spring or damper is stiffer than the penalty step of `dt`
/// integrates with `bodies` where they are: the world holds it at what the step takes.
pub(super) fn joint_springs(f: &mut Findings, joints: &[Joint], dt: f64, bodies: &[Body]) {
    for (k, j) in joints.iter().enumerate() {
        let (stiffest, firmest) = coordinate_bounds(bodies, j, dt);
        for (key, asked, most) in [
            ("stiffness", j.stiffness, stiffest),
            ("damping", j.damping, firmest),
        ] {
            if asked > most {
                f.warning(
                    format!("joints[{k}].{key}"),
                    format!(
                        "{asked} is more than a step of {dt} s takes with these bodies: it is \
                         held at {most:.3e}"
                    ),
                );
            }
        }
    }
}

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

/// The scene's own keys: its name, gravity, a penalty scene's step and material, friction,
/// and the keys only the other engine reads, in the order a reader meets them. The engine,
/// and a penalty scene's material.
pub(super) fn scene_keys(f: &mut Findings, raw: &RawScene) -> (Engine, Option<Penalty>) {
    f.name("name", &raw.name);
    if f.finite("gravity", &raw.gravity) && DVec3::from(raw.gravity).length() > MAX_GRAVITY {
        f.error("gravity", format!("must be at most {MAX_GRAVITY} m/s²"));
    }
    let m = &raw.material;
    let penalty = match raw.engine {
        RawEngine::Rapier => None,
        RawEngine::Penalty => Some(Penalty::read(f, raw.dt.unwrap_or(MAX_DT), m)),
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
    engine_keys(f, raw, engine);
    (engine, penalty)
}

/// The keys only one engine reads, where the file names the other; `rate:` for rapier.
fn engine_keys(f: &mut Findings, raw: &RawScene, engine: Engine) {
    match engine {
        Engine::Penalty => {
            for (key, given) in [
                ("rate", raw.rate.is_some()),
                ("feedback", raw.feedback.is_some()),
            ] {
                if given {
                    f.error(
                        key,
                        "only for engine: rapier (the penalty engine steps in every haptic tick)",
                    );
                }
            }
            for (key, given) in &penalty_keys(raw)[..6] {
                if !given {
                    f.error(*key, "missing: the penalty engine needs it");
                }
            }
        }
        Engine::Rapier => {
            for (key, given) in penalty_keys(raw) {
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
}

/// A mesh body's triangles, in its frame.
pub(super) type Surface = Vec<[DVec3; 3]>;

/// A scene's bodies as the file checks out, in its order.
pub(super) struct Bodies {
    /// Each body (centroid, mass and inertia as the penalty engine has them).
    pub(super) bodies: Vec<Body>,
    /// What each piece of each body is.
    pub(super) primitives: Vec<Vec<Primitive>>,
    /// The triangles of each body that is a mesh, in its frame.
    pub(super) surfaces: Vec<Option<Surface>>,
    /// Each body that is one box: its half edges and orientation, for grasping.
    pub(super) boxes: Vec<Option<(DVec3, DQuat)>>,
    /// Whether each body's mass and inertia are given (`inertial:`), not its solid's.
    pub(super) weighed: Vec<bool>,
}

/// The `bodies:` of a scene for `engine` with `pointers` pointers; those with a mistake are
/// left out after it is reported. None when the world would be too large to check further.
pub(super) fn bodies(
    f: &mut Findings,
    raw: &RawScene,
    engine: Engine,
    pointers: usize,
    files: &MeshFiles<'_>,
) -> Option<Bodies> {
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
        return None;
    }
    let mut bodies = Vec::with_capacity(raw.bodies.len() + pointers);
    let mut primitives = Vec::with_capacity(raw.bodies.len());
    // Each body that is one box: its half edges and orientation (the body's frame starts
    // as the world's), for grasping.
    let mut boxes = Vec::with_capacity(raw.bodies.len());
    let mut weighed = Vec::with_capacity(raw.bodies.len());
    let mut surfaces = Vec::with_capacity(raw.bodies.len());
    for (i, b) in raw.bodies.iter().enumerate() {
        let at = format!("bodies[{i}]");
        f.text(format!("{at}.name"), &b.name);
        // A soft body is no rigid body of the world, nor is the body the pointer holds:
        // their own checks make them.
        if !b.rigid() {
            continue;
        }
        if let Some((body, kinds, surface)) = rigid_body(f, &at, b, engine, files) {
            surfaces.push(surface);
            bodies.push(body);
            weighed.push(b.inertial.is_some());
            boxes.push(match (kinds.as_slice(), &b.pieces) {
                ([Primitive::Cuboid { half, rotation }], None) => Some((*half, *rotation)),
                _ => None,
            });
            primitives.push(kinds);
        }
    }
    let pieces: usize = bodies.iter().map(|b| b.pieces.len()).sum::<usize>() + pointers;
    if engine == Engine::Penalty && pieces > MAX_PIECES {
        f.error(
            "bodies",
            format!(
                "{pieces} convex pieces with the meshes' own; a world holds at most {MAX_PIECES}"
            ),
        );
    }
    Some(Bodies {
        bodies,
        primitives,
        surfaces,
        boxes,
        weighed,
    })
}

/// The rigid body `b` (at `at`) of a scene for `engine`: the body, what each of its pieces
/// is, and its triangles in its frame when it is a mesh; None after reporting what is wrong.
pub(super) fn rigid_body(
    f: &mut Findings,
    at: &str,
    b: &RawBody,
    engine: Engine,
    files: &MeshFiles<'_>,
) -> Option<(Body, Vec<Primitive>, Option<Surface>)> {
    // A fixed mesh under rapier is its triangles; every other body touches through convex
    // pieces.
    let mesh = b.mesh.as_ref().and_then(|file| {
        let pieces = engine == Engine::Penalty || !b.fixed;
        mesh_body(f, at, b, file, files, pieces)
    });
    let pieces = pieces_of(f, at, b, mesh.as_ref());
    let (light, dense) = DENSITY_RANGE;
    f.within(format!("{at}.density"), b.density, light, dense, " kg/m³");
    let (speed, spin) = MAX_SPEED;
    f.coordinates(format!("{at}.velocity"), &b.velocity, speed, "m/s");
    f.coordinates(format!("{at}.spin"), &b.spin, spin, "rad/s");
    let pieces = pieces.filter(|_| !f.has_errors())?;
    let (solids, kinds): (Vec<Polyhedron>, Vec<Primitive>) = pieces.into_iter().unzip();
    let mut body = match &mesh {
        Some(m) => Body::from_parts(
            &solids,
            (m.volume, m.volume * b.density),
            m.centre,
            m.inertia * b.density,
            b.fixed,
        ),
        None => Body::compound(&solids, b.density, b.fixed),
    };
    if let Some(given) = &b.inertial {
        body = inertial(f, at, b, given, &solids, body.volume)?;
    }
    (body.velocity, body.spin) = (DVec3::from(b.velocity), DVec3::from(b.spin));
    let surface = mesh.map(|m| {
        let centre = body.position;
        m.surface.iter().map(|t| t.map(|c| c - centre)).collect()
    });
    Some((body, kinds, surface))
}

/// Heaviest and lightest body an `inertial:` may give, kg.
const INERTIAL_MASS: (f64, f64) = (1e-5, 1e5);

/// Body `b` (at `at`) touching through `solids` of `volume`, weighing as `given` says; None
/// after reporting what is wrong: a mass out of range, an inertia that is not a solid's
/// (not positive definite, or one moment larger than the other two together).
fn inertial(
    f: &mut Findings,
    at: &str,
    b: &RawBody,
    given: &RawInertial,
    solids: &[Polyhedron],
    volume: f64,
) -> Option<Body> {
    let (light, heavy) = INERTIAL_MASS;
    let mut ok = f.within(
        format!("{at}.inertial.mass"),
        given.mass,
        light,
        heavy,
        " kg",
    );
    ok &= f.coordinates(
        format!("{at}.inertial.centre"),
        &given.centre,
        WORLD_EXTENT,
        "m",
    );
    let [xx, yy, zz, xy, xz, yz] = given.inertia;
    let tensor = DMat3::from_cols(
        DVec3::new(xx, xy, xz),
        DVec3::new(xy, yy, yz),
        DVec3::new(xz, yz, zz),
    );
    let field = format!("{at}.inertial.inertia");
    if f.finite(field.clone(), &given.inertia) {
        // Leading minors positive: positive definite; each moment at most the other two's
        // sum, as any solid's are.
        let minors = [xx, xx * yy - xy * xy, tensor.determinant()];
        let triangle = xx <= yy + zz && yy <= xx + zz && zz <= xx + yy;
        if !(minors.iter().all(|&m| m > 0.0) && triangle) {
            f.error(
                field,
                "is no solid's inertia: it must be positive definite, each moment at most \
                 the sum of the other two",
            );
            ok = false;
        }
    } else {
        ok = false;
    }
    ok.then(|| {
        let turn = quat_from_wxyz(b.orientation).normalize();
        let axes = DMat3::from_quat(turn);
        Body::from_parts(
            solids,
            (volume, given.mass),
            DVec3::from(b.position) + turn * DVec3::from(given.centre),
            axes * tensor * axes.transpose(),
            b.fixed,
        )
    })
}

/// The convex pieces of body `b` with their primitives: its `mesh`'s hulls, or its solids.
fn pieces_of(
    f: &mut Findings,
    at: &str,
    b: &RawBody,
    mesh: Option<&MeshBody>,
) -> Option<Vec<(Polyhedron, Primitive)>> {
    match (&b.mesh, mesh) {
        (Some(_), Some(mesh)) => Some(
            mesh.pieces
                .iter()
                .map(|p| (p.clone(), Primitive::Hull))
                .collect(),
        ),
        (Some(_), None) => None,
        (None, _) => {
            if b.scale.is_some() {
                f.error(format!("{at}.scale"), "only with mesh:");
            }
            if b.up.is_some() {
                f.error(format!("{at}.up"), "only with mesh:");
            }
            body_pieces(f, at, b)
        }
    }
}

/// The `pointer:` solid, centred at the origin, of a scene for `pointers` pointers, with
/// its primitive; None when there is none or it is wrong.
pub(super) fn pointer(
    f: &mut Findings,
    raw: &RawScene,
    pointers: usize,
) -> Option<(Polyhedron, Primitive)> {
    if pointers > MAX_POINTERS {
        f.error("pointer", format!("at most {MAX_POINTERS} pointers"));
    }
    raw.pointer.as_ref().and_then(|pointer| {
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
        // The first pointer has the body it holds for its solid (see `held`); a device's
        // other pointers are fingertips.
        if pointer.holds.is_some() {
            let fingertip = RawPointer::fingertip();
            return solid(f, "pointer", given!(fingertip), [0.0; 3], identity());
        }
        solid(f, "pointer", given!(pointer), [0.0; 3], identity())
    })
}

/// The `grasp:` settings of a scene for `pointers` pointers.
pub(super) fn grasp(f: &mut Findings, raw: &RawScene, pointers: usize) {
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
}

/// The penalty engine's own material keys, checked (absent ones were reported and read 0).
pub(super) struct Penalty {
    /// Longest physics step, seconds.
    pub(super) dt: f64,
    pub(super) stiffness: f64,
    pub(super) damping: f64,
    pub(super) friction_stiffness: f64,
    pub(super) friction_damping: f64,
    pub(super) slip_speed: f64,
    pub(super) point: [f64; 2],
    pub(super) scaling: Option<Scaling>,
    pub(super) model: ContactModel,
}

impl Penalty {
    /// The step `dt` (checked) and the material keys of `m`.
    pub(super) fn read(f: &mut Findings, dt: f64, m: &RawMaterial) -> Self {
        f.within("dt", dt, MIN_DT, MAX_DT, " s");
        let mut value = |key: &str, v: Option<f64>| {
            let v = v.unwrap_or(0.0);
            f.non_negative(format!("material.{key}"), v);
            v
        };
        let stiffness = value("stiffness", m.stiffness);
        let damping = value("damping", m.damping);
        let penalty = Penalty {
            dt,
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
