//! The running world's bodies as `hapticctl body …` shows them, each look a [`Report`]: the
//! bodies of the world, and where one is and how it moves.

use hapticd_ipc::client::{Body, BodyState};
use serde_json::json;

use crate::report::Report;

/// The bodies of the world: id, name, and whether forces move them.
pub fn list(bodies: &[Body]) -> Report {
    let mut text = String::new();
    for (id, b) in bodies.iter().enumerate() {
        let kind = if b.fixed { "fixed" } else { "free" };
        text += &format!("{id:>3}  {:<20} {kind}\n", b.name);
    }
    if bodies.is_empty() {
        text = "the running scene has no bodies to change from outside\n".into();
    }
    let rows: Vec<_> = bodies
        .iter()
        .enumerate()
        .map(|(id, b)| json!({"id": id, "name": b.name, "fixed": b.fixed}))
        .collect();
    Report {
        text,
        json: json!(rows),
        charts: Vec::new(),
    }
}

/// The state of the body called (or numbered) `body`.
pub fn state(body: &str, state: &BodyState) -> Report {
    let text = format!(
        "{body}: position {:?} m, orientation {:?}, velocity {:?} m/s, spin {:?} rad/s, mass {} \
         kg, friction {}, held force {:?} N\n",
        state.position,
        state.orientation,
        state.velocity,
        state.spin,
        state.mass,
        state.friction,
        state.force
    );
    let json = json!({
        "body": body,
        "position": state.position,
        "orientation": state.orientation,
        "velocity": state.velocity,
        "spin": state.spin,
        // A fixed body's mass is infinite, which JSON cannot say.
        "mass": state.mass.is_finite().then_some(state.mass),
        "friction": state.friction,
        "force": state.force,
    });
    Report {
        text,
        json,
        charts: Vec::new(),
    }
}
