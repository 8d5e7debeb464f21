//! The penalty scene plugin (thesis Ch. 5): a world of rigid boxes stepped inside every
//! haptic tick (direct style of the scene ABI) with forces integrated over each contact's
//! intersection volume. Each pointer is a solid placed at its grip's pose, whose contact
//! wrench the user feels (thesis 5.1), or a body tied to the grip by a virtual coupling
//! (4.1.2), whose stretch the user feels.

use glam::{DQuat, DVec3};
use hapticd_core::kinematics::{Wrench, quat_from_wxyz, quat_to_wxyz};
use hapticd_physics::coupling::Grip;
use hapticd_physics::joint::DrivenJoints;
use hapticd_physics::scene::{MAX_POINTERS, PenaltyScene, SceneFile};
use hapticd_plugin_api::export::answered;
use hapticd_plugin_api::*;

/// The plugin's instance: a loaded scene and what it looks like.
struct Penalty(PenaltyScene, Geometry);

impl SceneInstance for Penalty {
    fn step_direct(
        &mut self,
        dt: f64,
        pointers: &[HapticdPointer],
        wrenches: &mut [HapticdWrench],
    ) -> i32 {
        let mut grips = [Grip {
            position: DVec3::ZERO,
            orientation: DQuat::IDENTITY,
            velocity: DVec3::ZERO,
            spin: DVec3::ZERO,
        }; MAX_POINTERS];
        for (grip, p) in grips.iter_mut().zip(pointers) {
            *grip = Grip {
                position: DVec3::from(p.position),
                orientation: quat_from_wxyz(p.orientation).normalize(),
                velocity: DVec3::from(p.velocity),
                spin: DVec3::ZERO,
            };
        }
        let n = pointers.len();
        let mut felt = [Wrench::default(); MAX_POINTERS];
        let stepped = self.0.step_pointers(dt, &grips[..n], &mut felt[..n]);
        for (out, w) in wrenches.iter_mut().zip(felt) {
            *out = w.into();
        }
        // A tick too long for the step, or a world gone non-finite: the host fades out.
        if stepped {
            HAPTICD_OK
        } else {
            HAPTICD_ERROR_FAILED
        }
    }

    /// Every body by id: the scene file's rigid bodies, its soft ones, the pointers.
    fn poses(&self, poses: &mut [HapticdBodyPose]) -> usize {
        for (id, out) in poses.iter_mut().enumerate().take(self.0.body_count()) {
            let pose = self.0.pose_of(id);
            *out = HapticdBodyPose {
                position: pose.position.to_array(),
                orientation: quat_to_wxyz(pose.orientation),
            };
        }
        self.0.body_count()
    }

    fn geometry(&self) -> Option<&Geometry> {
        Some(&self.1)
    }

    fn body(&self, index: usize) -> Option<HapticdBodyInfo> {
        self.0.body_info(index)
    }

    fn touch(&self, pointer: usize) -> Option<HapticdTouch> {
        self.0.touch(pointer)
    }

    fn apply(&mut self, command: &HapticdSceneCommand, state: &mut HapticdBodyState) -> i32 {
        answered(state, self.0.apply(command))
    }

    fn joint(&self, index: usize) -> Option<HapticdJointInfo> {
        self.0.joint_info(index)
    }

    fn drive(&mut self, command: &HapticdJointCommand, state: &mut HapticdJointState) -> i32 {
        answered(state, self.0.drive_joint(command))
    }

    fn corners(&self, out: &mut [[f32; 3]]) -> usize {
        self.0.corners(out)
    }
}

/// Check a penalty scene file without building its world (or cutting its meshes).
fn check(path: &str, pointers: usize) -> Result<(), SceneError> {
    match SceneFile::check(std::path::Path::new(path), pointers).map_err(|e| e.to_string())? {
        SceneFile::Penalty(_) => Ok(()),
        SceneFile::Rapier(_) => {
            Err(format!("{path}: a rapier scene (give engine: penalty)").into())
        }
    }
}

fn create(
    path: Option<&str>,
    pointers: usize,
) -> Result<(Box<dyn SceneInstance>, HapticdSceneInfo), SceneError> {
    let path = path.ok_or("the penalty scene needs a scene file")?;
    let mut scene =
        PenaltyScene::load(std::path::Path::new(path), pointers).map_err(|e| e.to_string())?;
    // Stepped in the haptic thread: a held part's query keeps to its share of the tick.
    scene.keep_to_the_clock();
    for warning in &scene.warnings {
        hapticd_plugin_api::log(HAPTICD_LOG_WARN, &warning.to_string());
    }
    hapticd_plugin_api::log(
        HAPTICD_LOG_INFO,
        &format!(
            "scene {}: {} bodies, {} pointers",
            scene.name,
            scene.world.bodies.len() - pointers,
            pointers
        ),
    );
    let info = HapticdSceneInfo {
        style: HAPTICD_SCENE_DIRECT,
        physics_rate: 0.0,
    };
    let geometry = scene.geometry();
    Ok((Box::new(Penalty(scene, geometry)), info))
}

hapticd_plugin_api::export_scene!(
    name: "penalty",
    description: "Rigid boxes in the haptic tick, contact-volume penalty method (thesis Ch. 5)",
    create: create,
    engines: ["penalty"],
    check: check,
);
