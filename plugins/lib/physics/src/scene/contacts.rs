//! What each pointer of a penalty world touches after a step, for contact events: the body
//! of its strongest contact, where, along which normal, and whether it slides.

use hapticd_plugin_api::{HAPTICD_NO_BODY, HAPTICD_TOUCH_SLIPPING, HapticdTouch};

use super::PenaltyScene;

impl PenaltyScene {
    /// What pointer `pointer` touches after the last step (None: nothing): a soft body it
    /// presses on first (the hardest pressed; no slip is told), else the rigid body it
    /// presses hardest. A pointer touching another pointer touches no body of the file.
    pub fn touch(&self, pointer: usize) -> Option<HapticdTouch> {
        let me = self.first_pointer + pointer;
        if me >= self.world.bodies.len() {
            return None;
        }
        // A soft body it presses on (the hardest), by its id after the rigid bodies.
        let soft = self
            .soft
            .iter()
            .enumerate()
            .filter_map(|(k, s)| Some((k, s.pressed_on(me, &self.world.bodies)?)))
            .max_by(|a, b| a.1.0.length().total_cmp(&b.1.0.length()));
        if let Some((k, (force, point))) = soft {
            // Out of the soft body's surface: toward the pointer's centre from where the
            // nodes press (the force leans with friction).
            let out = (self.world.bodies[me].position - point).try_normalize();
            return Some(HapticdTouch {
                body: (self.first_pointer + k) as u32,
                flags: 0,
                point: point.to_array(),
                normal: out.unwrap_or(force.normalize_or_zero()).to_array(),
            });
        }
        let touching = self.world.strongest_contact(me)?;
        Some(HapticdTouch {
            body: if touching.other < self.first_pointer {
                touching.other as u32
            } else {
                HAPTICD_NO_BODY
            },
            flags: if touching.sliding {
                HAPTICD_TOUCH_SLIPPING
            } else {
                0
            },
            point: touching.point.to_array(),
            normal: touching.normal.to_array(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, DVec3};
    use std::path::Path;

    fn blocks() -> PenaltyScene {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../config/scenes/blocks.yaml");
        PenaltyScene::load(&path, 1).unwrap()
    }

    #[test]
    fn a_pointer_on_the_table_touches_the_table_from_above_and_slides_when_dragged() {
        let mut scene = blocks();
        let k = scene.first_pointer;
        assert_eq!(scene.touch(0), None, "nothing touched before a step");
        // The 1 cm pointer cube 3 mm into the table top (y = −0.03), away from the blocks.
        let at = DVec3::new(0.0, -0.028, -0.1);
        scene.world.bodies[k].place(at, DQuat::IDENTITY, DVec3::ZERO, DVec3::ZERO);
        scene.world.step(1e-4);
        let touch = scene.touch(0).expect("it presses the table");
        assert_eq!(touch.body, 0, "the table: {:?}", scene.names[0]);
        assert!(
            (DVec3::from(touch.normal) - DVec3::Y).length() < 1e-9,
            "{touch:?}"
        );
        // The contact's centre: under the cube, in the table's top.
        let point = DVec3::from(touch.point);
        assert!(
            (point.x - at.x).abs() < 1e-9 && (point.z - at.z).abs() < 1e-9,
            "{touch:?}"
        );
        assert!((point.y - -0.03).abs() < 3e-3, "{touch:?}");
        assert_eq!(touch.flags & HAPTICD_TOUCH_SLIPPING, 0, "at rest it sticks");
        // Dragged sideways at 0.2 m/s, far faster than the friction's slip speed, it slides.
        let mut slid = false;
        for step in 1..=400 {
            let x = at + DVec3::new(0.2 * 1e-4 * step as f64, 0.0, 0.0);
            scene.world.bodies[k].place(x, DQuat::IDENTITY, DVec3::new(0.2, 0.0, 0.0), DVec3::ZERO);
            scene.world.step(1e-4);
            slid |= scene
                .touch(0)
                .is_some_and(|t| t.flags & HAPTICD_TOUCH_SLIPPING != 0);
        }
        assert!(slid, "{:?}", scene.touch(0));
        // Lifted off, it touches nothing.
        scene.world.bodies[k].place(
            at + DVec3::Y * 0.05,
            DQuat::IDENTITY,
            DVec3::ZERO,
            DVec3::ZERO,
        );
        scene.world.step(1e-4);
        assert_eq!(scene.touch(0), None);
    }
}
