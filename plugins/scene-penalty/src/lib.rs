//! The penalty scene plugin (thesis Ch. 5): a world of rigid boxes stepped inside every
//! haptic tick (direct style of the scene ABI) with forces integrated over each contact's
//! intersection volume. Each pointer is a solid placed at its grip's pose; the contact
//! wrench on it is what the user feels (thesis 5.1).

use glam::{DQuat, DVec3};
use hapticd_physics::scene::PenaltyScene;
use hapticd_plugin_api::*;

/// The plugin's instance: a loaded scene.
struct Penalty(PenaltyScene);

impl SceneInstance for Penalty {
    fn step_direct(
        &mut self,
        dt: f64,
        pointers: &[HapticdPointer],
        wrenches: &mut [HapticdWrench],
    ) -> i32 {
        let scene = &mut self.0;
        for (k, p) in pointers.iter().enumerate() {
            let [w, x, y, z] = p.orientation;
            let body = &mut scene.world.bodies[scene.first_pointer + k];
            body.place(
                DVec3::from(p.position),
                DQuat::from_xyzw(x, y, z, w).normalize(),
                DVec3::from(p.velocity),
                DVec3::ZERO,
            );
        }
        // Split the tick into steps no longer than the scene's physics step.
        let steps = (dt / scene.dt).ceil().max(1.0) as usize;
        let mut sum = [(DVec3::ZERO, DVec3::ZERO); 8];
        for _ in 0..steps {
            scene.world.step(dt / steps as f64);
            for (k, s) in sum.iter_mut().enumerate().take(pointers.len()) {
                let w = scene.world.contact_wrench(scene.first_pointer + k);
                s.0 += w.force;
                s.1 += w.torque;
            }
        }
        // The user feels the contact force on the pointer, averaged over the tick.
        for (out, (force, torque)) in wrenches.iter_mut().zip(sum) {
            *out = HapticdWrench {
                force: (force / steps as f64).to_array(),
                torque: (torque / steps as f64).to_array(),
            };
        }
        HAPTICD_OK
    }
}

fn create(
    path: Option<&str>,
    pointers: usize,
) -> Result<(Box<dyn SceneInstance>, HapticdSceneInfo), String> {
    if pointers > 8 {
        return Err("at most 8 pointers".into());
    }
    let path = path.ok_or("the penalty scene needs a scene file")?;
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: cannot read: {e}"))?;
    let scene = PenaltyScene::parse(&text, pointers).map_err(|e| format!("{path}: {e}"))?;
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
    Ok((Box::new(Penalty(scene)), info))
}

hapticd_plugin_api::export_scene!(
    name: "penalty",
    description: "Rigid boxes in the haptic tick, contact-volume penalty method (thesis Ch. 5)",
    create: create,
);
