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
//! texture: { kind: grating, period: 0.002, amplitude: 0.4, direction: [1, 0, 0] }  # optional
//! effects: []               # optional: haptic effects (`crate::haptics::effects::spec`)
//! ```
//!
//! Surfaces have materials: a texture felt while sliding (`texture: { kind: grating, period,
//! amplitude, direction }`, `{ kind: roughness, amplitude, shortest, longest, exponent, seed
//! }` or `{ kind: height_map, file: bumps.png, size: [0.02, 0.02], amplitude }`) and a
//! transient felt on impact (`transient: { gain, frequency, decay }`). A shape's own are
//! written beside its solid (`- box: {...}` and, on the next line, `texture: {...}`); the
//! scene's, at the top, are every other surface's. A mesh may be shaded smooth (`shading:
//! smooth` in its `mesh:`): its push turns across faces along the corners' blended normals.
//!
//! A shape may also be a triangle mesh, `mesh: { file: bracket.obj, centre: [0, -0.02, 0],
//! orientation: [1, 0, 0, 0], scale: 0.001, up: z }` (orientation, scale and up optional):
//! an OBJ, STL, glTF or GLB file in the scene file's own directory (never outside it), its
//! coordinates times `scale` in metres, turned so that its `up` axis (y, or z for a file
//! written z up) is hapticd's y. Its triangles are kept as they are, holes included, and the proxy
//! walks on them: faces hold it, a seam between two faces holds it, an edge or corner pushes
//! along its bisector. A closed mesh bounds a solid, entered only from outside; an open one
//! (most scans) is a sheet, felt from either side. A scene's meshes may have 500 000 triangles together; the proxy finds
//! the few near it through a hierarchy of boxes.

mod spec;

pub use spec::{
    MAX_MESH_TRIANGLES, MeshFaces, MeshReader, NO_FILES, SceneFiles, ShapeSurface, StaticSceneSpec,
};

use glam::DVec3;
use hapticd_plugin_api::Geometry;

use super::{Pointer, Scene, Touch};
use crate::haptics::proxy::{Proxy, ProxyParameters};
use crate::haptics::scenery::Scenery;
use crate::haptics::surface::Material;
use crate::kinematics::Wrench;

/// A static scene with one proxy per pointer.
pub struct StaticScene {
    spec: StaticSceneSpec,
    scenery: Scenery,
    proxies: Vec<Proxy>,
    /// The shape each proxy rests on and the normal it pushes along, if it touches one.
    touched: Vec<Option<(usize, DVec3)>>,
    geometry: Geometry,
}

impl StaticScene {
    /// The scene for `pointers` pointers, each proxy starting at its pointer.
    pub fn new(spec: StaticSceneSpec, pointers: &[Pointer]) -> Self {
        Self {
            proxies: pointers
                .iter()
                .map(|p| Proxy::new(p.pose.position))
                .collect(),
            touched: vec![None; pointers.len()],
            geometry: spec.geometry(),
            scenery: Scenery::new(&spec.shapes),
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

    fn render(&mut self, pointers: &[Pointer], dt: f64, wrenches: &mut [Wrench]) -> bool {
        let rendered = self.proxies.iter_mut().zip(pointers).zip(wrenches);
        for (((proxy, pointer), wrench), touched) in rendered.zip(&mut self.touched) {
            let out = proxy.update(
                pointer.pose.position,
                pointer.velocity,
                &self.scenery,
                &self.spec.proxy,
                dt,
            );
            let mut force = out.force;
            *touched = None;
            if let Some((k, face)) = self.scenery.nearest(out.proxy).filter(|_| out.in_contact) {
                let surface = self.spec.surfaces.get(k).copied().unwrap_or_default();
                let corners = surface
                    .normals
                    .and_then(|n| self.spec.corner_normals.get(n as usize));
                let normal = match corners {
                    // Force shading: the push along the face turned to the blended normal.
                    Some(corners) => {
                        let blended = self.spec.shapes[k]
                            .blend(out.proxy, corners, face)
                            .unwrap_or(face);
                        force += (blended - face) * force.dot(face);
                        blended
                    }
                    None => face,
                };
                *touched = Some((k, normal));
            }
            *wrench = Wrench::force(force);
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

    fn write_touches(&self, touches: &mut [Touch]) {
        for ((out, proxy), touched) in touches.iter_mut().zip(&self.proxies).zip(&self.touched) {
            *out = Touch {
                normal: touched.map_or(DVec3::ZERO, |(_, normal)| normal),
                ..proxy.touch()
            };
        }
    }

    fn material(&self, pointer: usize, _touch: &Touch) -> Option<&Material> {
        let (k, _) = self.touched.get(pointer).copied().flatten()?;
        let surface = self.spec.surfaces.get(k).copied().unwrap_or_default();
        self.spec
            .materials
            .get(usize::from(surface.material))?
            .as_ref()
    }

    fn write_proxies(&self, proxies: &mut [DVec3]) -> bool {
        for (out, p) in proxies.iter_mut().zip(self.proxies()) {
            *out = p;
        }
        true
    }

    fn geometry(&self) -> &Geometry {
        &self.geometry
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::kinematics::Pose;

    /// A prism of `sides` faces about y (radius 1 cm, 4 cm tall, closed), as a mesh reader
    /// gives it.
    fn prism(sides: usize) -> MeshFaces {
        let corner = |k: usize, y: f64| {
            let a = std::f64::consts::TAU * k as f64 / sides as f64;
            DVec3::new(0.01 * a.cos(), y, 0.01 * a.sin())
        };
        let mut triangles = Vec::new();
        for k in 0..sides {
            let (a0, a1) = (corner(k, -0.02), corner(k + 1, -0.02));
            let (b0, b1) = (corner(k, 0.02), corner(k + 1, 0.02));
            triangles.push([a0, b1, a1]);
            triangles.push([a0, b0, b1]);
            triangles.push([DVec3::new(0.0, 0.02, 0.0), b1, b0]);
            triangles.push([DVec3::new(0.0, -0.02, 0.0), a0, a1]);
        }
        MeshFaces {
            triangles,
            closed: true,
        }
    }

    /// Pressed into a faceted prism beside a face's middle, the flat push is the face's
    /// normal and the smooth one the corners' normals blended where the proxy rests: nearer
    /// the round bar's radius, and as strong.
    #[test]
    fn a_smoothly_shaded_mesh_pushes_along_its_blended_normals() {
        let files = SceneFiles {
            meshes: &|_, _, _| Ok(prism(8)),
            images: &|_, _| Err("none".into()),
        };
        let push = |shading: &str, angle: f64| {
            let text = format!(
                "name: bar\nproxy: {{ stiffness: 2000, damping: 0, static_friction: 0, \
                 dynamic_friction: 0 }}\nshapes:\n  - mesh: {{ file: bar.obj, shading: {shading} }}\n"
            );
            let spec =
                StaticSceneSpec::parse_with_files(&text, Path::new("s.yaml"), files).unwrap();
            let outside = DVec3::new(0.02 * angle.cos(), 0.0, 0.02 * angle.sin());
            let inside = DVec3::new(0.0085 * angle.cos(), 0.0, 0.0085 * angle.sin());
            let at = |p: DVec3| Pointer {
                pose: Pose {
                    position: p,
                    ..Pose::default()
                },
                velocity: DVec3::ZERO,
            };
            let mut scene = StaticScene::new(spec, &[at(outside)]);
            let mut wrench = [Wrench::ZERO];
            scene.render(&[at(outside)], 1e-3, &mut wrench);
            for _ in 0..3 {
                scene.render(&[at(inside)], 1e-3, &mut wrench);
            }
            let mut touch = [Touch::NONE];
            scene.write_touches(&mut touch);
            (wrench[0].force, touch[0])
        };
        let radial = |a: f64| DVec3::new(a.cos(), 0.0, a.sin());
        // A quarter of the way across face 0 (from 0 to 45°).
        let angle = 0.25 * std::f64::consts::FRAC_PI_4;
        let (flat, flat_touch) = push("flat", angle);
        let (smooth, smooth_touch) = push("smooth", angle);
        let face = radial(std::f64::consts::FRAC_PI_8);
        assert!(flat.normalize().dot(face) > 1.0 - 1e-9, "{flat}");
        assert!((flat_touch.normal - flat.normalize()).length() < 1e-6);
        // The corners' normals lean along the bar's radius (two side faces meet at each with
        // equal angles; the cap's tilts them alike, and cancels half way up): blended at the
        // proxy's place across the face, between 0° and 45°.
        let (c0, c1) = (
            radial(0.0) * 0.01,
            radial(std::f64::consts::FRAC_PI_4) * 0.01,
        );
        let u = (smooth_touch.point - c0).dot(c1 - c0) / (c1 - c0).length_squared();
        assert!(u > 0.2 && u < 0.4, "{u}");
        let expected =
            (radial(0.0) * (1.0 - u) + radial(std::f64::consts::FRAC_PI_4) * u).normalize();
        assert!(
            smooth.normalize().dot(expected) > 1.0 - 1e-6,
            "{smooth} against {expected}"
        );
        assert!((smooth.length() - flat.length()).abs() < 1e-9);
        assert!((smooth_touch.normal - expected).length() < 1e-6);
    }
}
