//! `floor`: the smallest complete scene plugin in Rust, of the multi-rate style.
//!
//! Its physics thread runs at 50 Hz and publishes, for each pointer, the floor at
//! `y = FLOOR_Y` as one plane below it; the haptic thread interpolates the planes and renders
//! them through the proxy, and hands back the impulses the hand gave the floor, which a
//! floor bolted to the world ignores. A scene file may set the floor's height:
//!
//! ```yaml
//! floor_y: -0.03   # metres
//! ```
//!
//! Everything else (the C entry point, the vtable, panics kept from crossing into the
//! daemon) is `export_scene!`'s.

use hapticd_plugin_api::*;

/// Height of the floor when no scene file says otherwise, metres.
const FLOOR_Y: f64 = -0.03;

/// Object number of the floor in planes and impulses.
const FLOOR: u32 = 1;

struct Floor {
    y: f64,
    /// The floor, drawn 60 cm across.
    geometry: Geometry,
}

impl SceneInstance for Floor {
    fn step_physics(
        &mut self,
        _dt: f64,
        pointers: &[HapticdPointer],
        _impulses: &[HapticdImpulse],
        planes: &mut [HapticdPlanes],
    ) -> i32 {
        for (p, out) in pointers.iter().zip(planes) {
            out.count = 1;
            out.planes[0] = HapticdPlane {
                object: FLOOR,
                point: [p.position[0], self.y, p.position[2]],
                normal: [0.0, 1.0, 0.0],
                velocity: [0.0; 3],
            };
        }
        HAPTICD_OK
    }

    fn geometry(&self) -> Option<&Geometry> {
        Some(&self.geometry)
    }
}

/// What is wrong with a floor's scene file.
#[derive(Debug, Clone, PartialEq)]
enum FloorError {
    /// A line that is no `floor_y:` setting.
    UnknownKey(String),
    /// A height that is no number within ±1 m.
    Height(String),
}

impl std::fmt::Display for FloorError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FloorError::UnknownKey(line) => write!(f, "unknown key in `{line}` (only floor_y)"),
            FloorError::Height(value) => {
                write!(f, "floor_y must be a height within ±1 m, not `{value}`")
            }
        }
    }
}

/// The floor's height from a scene file holding `floor_y: METRES` (and nothing else).
fn floor_height(text: &str) -> Result<f64, FloorError> {
    let mut y = FLOOR_Y;
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let value = line
            .strip_prefix("floor_y:")
            .ok_or_else(|| FloorError::UnknownKey(line.to_string()))?;
        y = value
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|y| y.is_finite() && y.abs() <= 1.0)
            .ok_or_else(|| FloorError::Height(value.trim().to_string()))?;
    }
    Ok(y)
}

fn create(
    path: Option<&str>,
    _pointers: usize,
) -> Result<(Box<dyn SceneInstance>, HapticdSceneInfo), SceneError> {
    let y = match path {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
            floor_height(&text).map_err(|e| format!("{path}: {e}"))?
        }
        None => FLOOR_Y,
    };
    let info = HapticdSceneInfo {
        style: HAPTICD_SCENE_MULTIRATE,
        physics_rate: 50.0,
    };
    let mut geometry = Geometry::default();
    geometry.add_solid(HapticdSolid {
        shape: HAPTICD_SHAPE_PLANE,
        flags: HAPTICD_SOLID_FIXED,
        size: [0.6, 0.0, 0.0],
        ..HapticdSolid::placed([0.0, y, 0.0], [1.0, 0.0, 0.0, 0.0])
    });
    Ok((Box::new(Floor { y, geometry }), info))
}

hapticd_plugin_api::export_scene!(
    name: "floor",
    description: "A floor plane under each pointer, at 50 Hz",
    create: create,
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scene_file_sets_the_height_and_mistakes_are_named() {
        assert_eq!(floor_height("").unwrap(), FLOOR_Y);
        assert_eq!(
            floor_height("# a floor\nfloor_y: -0.1  # lower\n").unwrap(),
            -0.1
        );
        assert_eq!(
            floor_height("height: 1"),
            Err(FloorError::UnknownKey("height: 1".into()))
        );
        for (text, value) in [("floor_y: .nan", ".nan"), ("floor_y: 5", "5")] {
            assert_eq!(floor_height(text), Err(FloorError::Height(value.into())));
        }
        assert!(
            FloorError::Height("5".into())
                .to_string()
                .contains("within ±1 m")
        );
    }
}
