//! The rapier scene plugin (thesis Ch. 6): a scene file with `engine: rapier` stepped by
//! rapier3d's constraint solver at the file's `rate:` in hapticd's physics thread (the
//! multi-rate style of the scene ABI). Each step takes in what the hand did to the bodies
//! near it (local dynamics; the impulses it gave them under `feedback: impulse`; with
//! `feedback: position` a kinematic body moved to each pointer), and publishes the surfaces
//! near each pointer's proxy as planes and the bodies they belong to. Soft bodies are
//! stepped at the same rate, pressed by the impulses the hand gives them, their planes
//! giving under the finger between two steps. A body the pointer holds (`pointer.holds`) is
//! handed to the host with every body's surface through the held extension, and placed
//! where the host's god-object puts it.

use glam::{DQuat, DVec3};
use hapticd_core::kinematics::Pose;
use hapticd_core::scene::exact_shapes::Solid;
use hapticd_core::world_state::body_pose;
use hapticd_physics::joint::DrivenJoints;
use hapticd_physics::scene::{RapierScene, SceneFile};
use hapticd_plugin_api::export::{PhysicsInput, PhysicsOutput, answered};
use hapticd_plugin_api::*;
use hapticd_rapier::world::RapierWorld;

/// The plugin's instance: a world, its pictures, and what the held extension hands out.
struct Rapier(RapierWorld, Geometry, Surfaces);

/// The body the pointer holds, if it holds one, and every body's surface pieces.
struct Surfaces {
    held: Option<HapticdHeld>,
    /// Each body's pieces: what each is (its pose filled in when asked), and its triangles
    /// in the body's frame.
    pieces: Vec<Vec<(HapticdSurfacePiece, Vec<HapticdTriangle>)>>,
}

impl Surfaces {
    /// The surfaces of `spec`'s bodies, and its held body.
    fn of(spec: &RapierScene) -> Self {
        let held = spec.held.map(|h| {
            let p = &h.parameters;
            HapticdHeld {
                pointer: h.pointer as u32,
                body: h.body,
                grip: h.grip.to_array(),
                stiffness: p.stiffness,
                damping: p.damping,
                rotational_stiffness: p.rotational_stiffness,
                rotational_damping: p.rotational_damping,
                friction: p.friction,
            }
        });
        let mut pieces = vec![Vec::new(); spec.bodies.len()];
        for piece in spec.surface_pieces() {
            let triangles: Vec<HapticdTriangle> = (piece.triangles.iter())
                .map(|t| HapticdTriangle {
                    corners: t.map(|c| c.to_array()),
                })
                .collect();
            let (object, shape, size, offset) = match piece.exact {
                Some((object, Solid::Ball { centre, radius })) => (
                    object,
                    HAPTICD_SHAPE_SPHERE,
                    [radius, 0.0, 0.0],
                    (centre, DQuat::IDENTITY),
                ),
                Some((
                    object,
                    Solid::Box {
                        centre,
                        rotation,
                        half,
                    },
                )) => (
                    object,
                    HAPTICD_SHAPE_BOX,
                    half.to_array(),
                    (centre, rotation),
                ),
                None => (
                    HAPTICD_NO_OBJECT,
                    HAPTICD_SHAPE_TRIANGLES,
                    [0.0; 3],
                    (DVec3::ZERO, DQuat::IDENTITY),
                ),
            };
            let info = HapticdSurfacePiece {
                triangle_count: triangles.len() as u32,
                fixed: u32::from(piece.fixed),
                object,
                shape,
                size,
                offset: body_pose(&Pose {
                    position: offset.0,
                    orientation: offset.1,
                }),
                pose: HapticdBodyPose::default(),
            };
            pieces[piece.body as usize].push((info, triangles));
        }
        Surfaces { held, pieces }
    }
}

impl SceneInstance for Rapier {
    fn step_world(&mut self, input: &PhysicsInput<'_>, output: &mut PhysicsOutput<'_>) -> i32 {
        if !(input.dt > 0.0 && input.dt.is_finite()) {
            return HAPTICD_ERROR_ARGUMENT;
        }
        if self.0.step(input, output) {
            HAPTICD_OK
        } else {
            hapticd_plugin_api::log(HAPTICD_LOG_ERROR, "the world is no longer finite");
            HAPTICD_ERROR_FAILED
        }
    }

    fn step_physics(
        &mut self,
        dt: f64,
        pointers: &[HapticdPointer],
        impulses: &[HapticdImpulse],
        planes: &mut [HapticdPlanes],
    ) -> i32 {
        // A host before ABI 1.3: planes around the grips, no bodies moved there.
        let input = PhysicsInput {
            dt,
            pointers,
            proxies: pointers,
            impulses,
            locals: &[],
        };
        let mut count = 0;
        let mut output = PhysicsOutput {
            planes,
            bodies: &mut [],
            body_count: &mut count,
        };
        self.step_world(&input, &mut output)
    }

    fn poses(&self, poses: &mut [HapticdBodyPose]) -> usize {
        for (i, out) in poses.iter_mut().take(self.0.body_count()).enumerate() {
            *out = body_pose(&self.0.body(i).pose());
        }
        self.0.body_count()
    }

    fn geometry(&self) -> Option<&Geometry> {
        Some(&self.1)
    }

    fn body(&self, index: usize) -> Option<HapticdBodyInfo> {
        self.0.body_info(index)
    }

    fn object_body(&self, object: u32) -> Option<u32> {
        self.0.object_body(object).map(|b| b as u32)
    }

    fn mobility(&self, body: u32) -> Option<HapticdMobility> {
        self.0.mobility(body as usize)
    }

    fn joint(&self, index: usize) -> Option<HapticdJointInfo> {
        self.0.joint_info(index)
    }

    fn drive(&mut self, command: &HapticdJointCommand, state: &mut HapticdJointState) -> i32 {
        answered(state, self.0.drive_joint(command))
    }

    fn apply(&mut self, command: &HapticdSceneCommand, state: &mut HapticdBodyState) -> i32 {
        answered(state, self.0.control(command))
    }

    fn corners(&self, out: &mut [[f32; 3]]) -> usize {
        self.0.corners(out)
    }

    fn compliance(&self, pointer: u32, plane: u32) -> Option<HapticdPlaneCompliance> {
        self.0.compliance(pointer, plane)
    }

    fn held(&self) -> Option<HapticdHeld> {
        self.2.held
    }

    fn surface(
        &self,
        body: u32,
        piece: u32,
    ) -> Option<(HapticdSurfacePiece, Vec<HapticdTriangle>)> {
        let (info, triangles) = self.2.pieces.get(body as usize)?.get(piece as usize)?;
        let info = HapticdSurfacePiece {
            pose: body_pose(&self.0.body(body as usize).pose()),
            ..*info
        };
        Some((info, triangles.clone()))
    }
}

/// The rapier scene in the file at `path` for `pointers` pointers.
fn load(path: &str, pointers: usize) -> Result<Box<RapierScene>, SceneError> {
    match SceneFile::load(std::path::Path::new(path), pointers).map_err(|e| e.to_string())? {
        SceneFile::Rapier(spec) => Ok(spec),
        SceneFile::Penalty(_) => {
            Err(format!("{path}: a penalty scene (give engine: rapier)").into())
        }
    }
}

/// Check a rapier scene file without building its world (or cutting its meshes).
fn check(path: &str, pointers: usize) -> Result<(), SceneError> {
    match SceneFile::check(std::path::Path::new(path), pointers).map_err(|e| e.to_string())? {
        SceneFile::Rapier(_) => Ok(()),
        SceneFile::Penalty(_) => {
            Err(format!("{path}: a penalty scene (give engine: rapier)").into())
        }
    }
}

fn create(
    path: Option<&str>,
    pointers: usize,
) -> Result<(Box<dyn SceneInstance>, HapticdSceneInfo), SceneError> {
    let path = path.ok_or("the rapier scene needs a scene file")?;
    let spec = load(path, pointers)?;
    for warning in &spec.warnings {
        hapticd_plugin_api::log(HAPTICD_LOG_WARN, &warning.to_string());
    }
    hapticd_plugin_api::log(
        HAPTICD_LOG_INFO,
        &format!(
            "scene {}: {} bodies, {} pointers, {} Hz, {} feedback",
            spec.name,
            spec.bodies.len(),
            pointers,
            spec.rate,
            spec.feedback.name()
        ),
    );
    let info = HapticdSceneInfo {
        style: HAPTICD_SCENE_MULTIRATE,
        physics_rate: spec.rate,
    };
    let world = RapierWorld::new(&spec, pointers);
    let surfaces = Surfaces::of(&spec);
    Ok((Box::new(Rapier(world, spec.geometry(), surfaces)), info))
}

hapticd_plugin_api::export_scene!(
    name: "rapier",
    description: "Rigid bodies on rapier3d at a low rate, felt through interpolated planes (thesis Ch. 6)",
    create: create,
    engines: ["rapier"],
    check: check,
);
