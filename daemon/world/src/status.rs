//! What a world's status query answers: its step, hosts, energy and every body.

use glam::{DMat3, DVec3};
use hapticd_core::scene::shared_world::SharedWorld;
use hapticd_rapier::world::RapierWorld;

/// Kinetic energy of the world's moving bodies, joules.
pub fn kinetic_energy(world: &RapierWorld) -> f64 {
    (0..world.body_count())
        .map(|i| {
            let body = world.local_body(i);
            if body.inverse_mass <= 0.0 {
                return 0.0;
            }
            let (v, w) = (DVec3::from(body.velocity), DVec3::from(body.spin));
            let inertia = DMat3::from_cols_array(&body.inverse_inertia)
                .transpose()
                .inverse();
            let rotation = if inertia.is_finite() {
                0.5 * w.dot(inertia * w)
            } else {
                0.0
            };
            0.5 * v.length_squared() / body.inverse_mass + rotation
        })
        .sum()
}

/// The state of world `name` (its bodies called `names`, its largest kinetic energy so far
/// `peak_energy`) as its status query answers it (JSON).
pub fn status(
    shared: &SharedWorld<RapierWorld>,
    name: &str,
    names: &[String],
    peak_energy: f64,
) -> serde_json::Value {
    let world = shared.world();
    let bodies: Vec<_> = (0..world.body_count())
        .map(|i| {
            let b = world.body(i);
            let local = world.local_body(i);
            serde_json::json!({
                "name": names.get(i),
                "position": b.position.to_array(),
                "orientation": hapticd_core::kinematics::quat_to_wxyz(b.orientation),
                "velocity": b.velocity.to_array(),
                "spin": b.spin.to_array(),
                "mass": if local.inverse_mass > 0.0 { 1.0 / local.inverse_mass } else { 0.0 },
            })
        })
        .collect();
    let hosts: Vec<_> = shared.hosts().collect();
    serde_json::json!({
        "world": name,
        "step": shared.steps(),
        "rate": 1.0 / shared.period(),
        "hosts": hosts,
        "kinetic_energy": kinetic_energy(world),
        "peak_kinetic_energy": peak_energy,
        "bodies": bodies,
    })
}
