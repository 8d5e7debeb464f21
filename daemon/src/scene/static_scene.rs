//! A static scene: fixed solids touched through the god-object proxy, with friction.
//!
//! ```yaml
//! name: static
//! proxy: { stiffness: 2000, damping: 5, static_friction: 0.3, dynamic_friction: 0.2 }
//! shapes:
//!   - floor: { height: -0.03 }                               # the plane y = height, solid below
//!   - plane: { point: [0.06, 0, 0], normal: [-1, 0, 0] }     # solid on the far side of normal
//!   - sphere: { centre: [-0.03, -0.01, 0], radius: 0.015 }
//!   - cylinder: { point: [0, 0, 0], axis: [0, 1, 0], radius: 0.2 }      # endless round bar
//!   - box: { centre: [0.03, -0.02, 0], size: [0.02, 0.02, 0.02], orientation: [1, 0, 0, 0] }
//! ```

use std::path::Path;

use glam::{DQuat, DVec3};
use serde::Deserialize;

use super::{Pointer, Scene};
use crate::haptics::obstacle::Shape;
use crate::haptics::proxy::{Proxy, ProxyParameters};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    name: String,
    #[serde(default)]
    proxy: Option<RawProxy>,
    shapes: Vec<RawShape>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProxy {
    stiffness: f64,
    damping: f64,
    static_friction: f64,
    dynamic_friction: f64,
}

#[derive(Deserialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
enum RawShape {
    Floor {
        height: f64,
    },
    Plane {
        point: [f64; 3],
        normal: [f64; 3],
    },
    Sphere {
        centre: [f64; 3],
        radius: f64,
    },
    Cylinder {
        point: [f64; 3],
        axis: [f64; 3],
        radius: f64,
    },
    Box {
        centre: [f64; 3],
        size: [f64; 3],
        #[serde(default = "identity")]
        orientation: [f64; 4],
    },
}

fn identity() -> [f64; 4] {
    [1.0, 0.0, 0.0, 0.0]
}

/// The description of a static scene.
#[derive(Debug, Clone, PartialEq)]
pub struct StaticSceneSpec {
    /// Scene name.
    pub name: String,
    /// Proxy coupling and friction.
    pub proxy: ProxyParameters,
    /// The solids.
    pub shapes: Vec<Shape>,
}

impl StaticSceneSpec {
    /// Load a scene file.
    pub fn load(path: &Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        Self::parse(&text).map_err(|e| format!("{}{e}", path.display()))
    }

    /// Parse and check scene text; errors start with `:line:column: ` when located.
    pub fn parse(text: &str) -> Result<Self, String> {
        let raw: RawScene =
            serde_saphyr::from_str(text).map_err(|e| crate::config::located_yaml_error(&e))?;
        Self::check(raw).map_err(|e| format!(": error: {e}"))
    }

    fn check(raw: RawScene) -> Result<Self, String> {
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        let proxy = match raw.proxy {
            None => ProxyParameters::default(),
            Some(p) => {
                let values = [
                    p.stiffness,
                    p.damping,
                    p.static_friction,
                    p.dynamic_friction,
                ];
                if !finite(&values)
                    || values.iter().any(|v| *v < 0.0)
                    || p.dynamic_friction > p.static_friction
                {
                    return Err("proxy: parameters must be finite and ≥ 0, with dynamic_friction ≤ static_friction".into());
                }
                ProxyParameters {
                    stiffness: p.stiffness,
                    damping: p.damping,
                    static_friction: p.static_friction,
                    dynamic_friction: p.dynamic_friction,
                }
            }
        };
        let mut shapes = Vec::with_capacity(raw.shapes.len());
        for (i, s) in raw.shapes.into_iter().enumerate() {
            let bad = |what: &str| format!("shapes[{i}]: {what}");
            shapes.push(match s {
                RawShape::Floor { height } if height.is_finite() => Shape::HalfSpace {
                    point: DVec3::new(0.0, height, 0.0),
                    normal: DVec3::Y,
                },
                RawShape::Plane { point, normal }
                    if finite(&point) && finite(&normal) && DVec3::from(normal).length() > 1e-9 =>
                {
                    Shape::HalfSpace {
                        point: DVec3::from(point),
                        normal: DVec3::from(normal).normalize(),
                    }
                }
                RawShape::Sphere { centre, radius }
                    if finite(&centre) && radius.is_finite() && radius > 0.0 =>
                {
                    Shape::Sphere {
                        centre: DVec3::from(centre),
                        radius,
                    }
                }
                RawShape::Cylinder {
                    point,
                    axis,
                    radius,
                } if finite(&point)
                    && finite(&axis)
                    && DVec3::from(axis).length() > 1e-9
                    && radius.is_finite()
                    && radius > 0.0 =>
                {
                    Shape::Cylinder {
                        point: DVec3::from(point),
                        axis: DVec3::from(axis).normalize(),
                        radius,
                    }
                }
                RawShape::Box {
                    centre,
                    size,
                    orientation,
                } if finite(&centre) && finite(&size) && size.iter().all(|s| *s > 0.0) => {
                    let [w, x, y, z] = orientation;
                    let q = DQuat::from_xyzw(x, y, z, w);
                    if !q.is_finite() || (q.length() - 1.0).abs() > 1e-6 {
                        return Err(bad("orientation must be a unit quaternion (w, x, y, z)"));
                    }
                    Shape::Cuboid {
                        centre: DVec3::from(centre),
                        half: DVec3::from(size) / 2.0,
                        rotation: q.normalize(),
                    }
                }
                _ => {
                    return Err(bad(
                        "values must be finite, sizes and radii > 0, normals non-zero",
                    ));
                }
            });
        }
        Ok(Self {
            name: raw.name,
            proxy,
            shapes,
        })
    }
}

/// A static scene with one proxy per pointer.
pub struct StaticScene {
    spec: StaticSceneSpec,
    proxies: Vec<Proxy>,
}

impl StaticScene {
    /// The scene for `pointers` pointers, each proxy starting at its pointer.
    pub fn new(spec: StaticSceneSpec, pointers: &[Pointer]) -> Self {
        Self {
            proxies: pointers
                .iter()
                .map(|p| Proxy::new(p.pose.position))
                .collect(),
            spec,
        }
    }

    /// Proxy positions.
    pub fn proxies(&self) -> impl Iterator<Item = DVec3> + '_ {
        self.proxies.iter().map(Proxy::position)
    }

    /// The scene description.
    pub fn spec(&self) -> &StaticSceneSpec {
        &self.spec
    }
}

impl Scene for StaticScene {
    fn name(&self) -> &str {
        &self.spec.name
    }

    fn render(&mut self, pointers: &[Pointer], dt: f64, wrenches: &mut [[f64; 6]]) -> bool {
        for ((proxy, pointer), wrench) in self.proxies.iter_mut().zip(pointers).zip(wrenches) {
            let out = proxy.update(
                pointer.pose.position,
                pointer.velocity,
                &self.spec.shapes,
                &self.spec.proxy,
                dt,
            );
            *wrench = [out.force.x, out.force.y, out.force.z, 0.0, 0.0, 0.0];
        }
        true
    }

    fn reset(&mut self, pointers: &[Pointer]) {
        for (proxy, pointer) in self.proxies.iter_mut().zip(pointers) {
            // Start outside every solid: a grip that is inside keeps its proxy where it was.
            if !self
                .spec
                .shapes
                .iter()
                .any(|s| s.contains(pointer.pose.position, 0.0))
            {
                proxy.reset(pointer.pose.position);
            }
        }
    }

    fn set_proxy(&mut self, parameters: &ProxyParameters) {
        self.spec.proxy = *parameters;
    }

    fn proxy(&self) -> Option<ProxyParameters> {
        Some(self.spec.proxy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_scene_parses() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/static.yaml");
        let spec = StaticSceneSpec::load(&path).unwrap();
        assert_eq!(spec.name, "static");
        assert!(spec.shapes.len() >= 4);
    }

    #[test]
    fn bad_shapes_are_refused() {
        assert!(
            StaticSceneSpec::parse(
                "name: x\nshapes:\n  - sphere: { centre: [0, 0, 0], radius: -1 }\n"
            )
            .is_err()
        );
        assert!(StaticSceneSpec::parse("name: x\nshapes:\n  - cone: { height: 1 }\n").is_err());
        assert!(StaticSceneSpec::parse("name: x\nshapes:\n  - floor: { height: .nan }\n").is_err());
        let e = StaticSceneSpec::parse("name: x\nshapes:\n  - floor: { hieght: 0 }\n").unwrap_err();
        assert!(e.starts_with(":3:14: error: unknown field `hieght`"), "{e}");
    }
}
