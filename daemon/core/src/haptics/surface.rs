//! Surface materials: what a surface feels like besides its solidity, felt by whatever
//! touches it in any scene. A material has a texture, felt while sliding
//! ([`crate::haptics::texture`]), and a contact transient, felt on impact: a decaying
//! sinusoid along the normal whose amplitude follows the speed of the impact, as in
//! event-based haptics (a rigid tap rings at the surface's frequency).
//!
//! Each effector's [`SurfaceFeel`] turns what its pointer touches into two forces a tick:
//! the texture's, which joins the scene's before the passivity controller, and the
//! transient's, added with the active effects. A texture's force is passive by
//! construction: it gives the hand back only the energy it took from it (an energy tank),
//! so a hand beating on a texture gains nothing from it.

use std::f64::consts::TAU;
use std::path::Path;

use glam::DVec3;
use hapticd_plugin_api::Geometry;
use serde::{Deserialize, Serialize};

use super::shading::{Shading, SmoothMesh};
use super::texture::{ImageReader, Texture, TextureSpec};
use super::touch::Touch;
use crate::diagnostics::{self, Diagnostics, Findings, key_path};
use crate::kinematics::{Pose, pose_of};

/// A contact transient: on impact at v m/s into the surface, gain·v·e^(−t/decay)·sin(2π·
/// frequency·t) along the normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transient {
    /// N per m/s of impact speed.
    pub gain: f64,
    /// Hz.
    pub frequency: f64,
    /// Seconds for the ringing to fall by e.
    pub decay: f64,
}

/// A surface's material.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Material {
    /// Felt while sliding.
    pub texture: Option<Texture>,
    /// Felt on impact.
    pub transient: Option<Transient>,
}

/// A transient as a scene file writes it: `transient: { gain: 20, frequency: 300, decay:
/// 0.01 }`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TransientSpec {
    /// N per m/s.
    pub gain: f64,
    /// Hz.
    pub frequency: f64,
    /// s.
    pub decay: f64,
}

/// Highest transient gain, N per m/s: a 0.5 m/s tap rings at most at 25 N before the limits.
const STRONGEST_RING: f64 = 50.0;

impl TransientSpec {
    /// The transient, every mistake an error in `f` under `at`.
    pub fn check(&self, at: &str, f: &mut Findings) -> Option<Transient> {
        let mut ok = f.within(
            format!("{at}.gain"),
            self.gain,
            0.0,
            STRONGEST_RING,
            " N·s/m",
        );
        ok &= f.within(
            format!("{at}.frequency"),
            self.frequency,
            1.0,
            1000.0,
            " Hz",
        );
        ok &= f.within(format!("{at}.decay"), self.decay, 1e-3, 1.0, " s");
        ok.then_some(Transient {
            gain: self.gain,
            frequency: self.frequency,
            decay: self.decay,
        })
    }
}

/// A material's keys as a scene file writes them, on a shape, a body or a scene's
/// `material:`.
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
pub struct MaterialSpec {
    /// `texture:`.
    #[serde(default)]
    pub texture: Option<TextureSpec>,
    /// `transient:`.
    #[serde(default)]
    pub transient: Option<TransientSpec>,
}

impl MaterialSpec {
    /// The material (None when it has neither key), each mistake an error in `f` under
    /// `at`; a height map read by `images` from `dir`.
    pub fn check(
        &self,
        at: &str,
        f: &mut Findings,
        dir: &Path,
        images: ImageReader,
    ) -> Option<Material> {
        let texture = self
            .texture
            .as_ref()
            .and_then(|t| t.check(&key_path(at, "texture"), f, dir, images));
        let transient = self
            .transient
            .as_ref()
            .and_then(|t| t.check(&key_path(at, "transient"), f));
        (texture.is_some() || transient.is_some()).then_some(Material { texture, transient })
    }
}

/// The materials of a world's bodies: each body's own, or the scene's; and how each body's
/// mesh is shaded.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Surfaces {
    /// Every surface's without one of its own.
    pub default: Option<Material>,
    /// By body id.
    pub bodies: Vec<Option<Material>>,
    /// How each body's mesh is shaded, by body id (flat past the end).
    pub shading: Vec<Shading>,
    /// The smoothly shaded bodies' meshes by body id, once [`shade`](Self::shade) made them.
    smooth: Vec<Option<SmoothMesh>>,
}

impl Surfaces {
    /// [rt] The material of body `body` (the scene's for a solid of no body).
    #[inline]
    pub fn of(&self, body: u32) -> Option<&Material> {
        self.bodies
            .get(body as usize)
            .and_then(Option::as_ref)
            .or(self.default.as_ref())
    }

    /// The smooth shading of each body whose [`shading`](Self::shading) asks for it, from
    /// its triangles in `geometry` (the scene's, as drawn) in the body's own frame (built
    /// here, off the haptic thread).
    pub fn shade(&mut self, geometry: &Geometry) {
        let triangles = |body: u32| -> Vec<[DVec3; 3]> {
            let solids = geometry.solids.iter().filter(|s| s.body == body);
            solids
                .flat_map(|solid| {
                    let offset = pose_of(&solid.offset);
                    (geometry.triangles_of(solid).iter())
                        .map(move |t| t.corners.map(|c| offset.transform_point(c.into())))
                })
                .collect()
        };
        self.smooth = (self.shading.iter().enumerate())
            .map(|(body, shading)| {
                (*shading == Shading::Smooth)
                    .then(|| SmoothMesh::new(&triangles(body as u32)))
                    .flatten()
            })
            .collect();
    }

    /// [rt] The smoothly shaded mesh of body `body`, if it is one.
    #[inline]
    pub fn smooth(&self, body: u32) -> Option<&SmoothMesh> {
        self.smooth.get(body as usize).and_then(Option::as_ref)
    }
}

/// The surface materials of physics scene file `file`: its `material:`'s `texture:` and
/// `transient:` for every body, and a body's own (body *i* is the *i*-th of `bodies:`) with
/// its mesh's `shading:`, each checked with its place in the file; a height map read by
/// `images`. The engine reads the file's other keys.
pub fn listed_in(file: &Path, images: ImageReader) -> Result<Surfaces, Diagnostics> {
    /// A body's keys read here.
    #[derive(Deserialize)]
    struct Body {
        #[serde(flatten)]
        material: MaterialSpec,
        #[serde(default)]
        shading: Shading,
        mesh: Option<serde::de::IgnoredAny>,
    }
    /// The keys read here.
    #[derive(Deserialize, Default)]
    struct Listed {
        #[serde(default)]
        material: MaterialSpec,
        #[serde(default)]
        bodies: Vec<Body>,
    }
    let parsed = diagnostics::parse_yaml::<Listed>(&diagnostics::read_text(file)?, file)?;
    let map = parsed.map;
    let locate = |field: &str| map.find(field);
    let mut f = Findings::after_schema(file, &locate, parsed.schema);
    let dir = diagnostics::directory_of(file);
    let listed = parsed.value;
    for (k, body) in listed.bodies.iter().enumerate() {
        if body.shading == Shading::Smooth && body.mesh.is_none() {
            f.error(
                format!("bodies[{k}].shading"),
                "smooth shading is for a body of a mesh file (mesh:); a box, ball or hull has \
                 no faces to blend",
            );
        }
    }
    let surfaces = Surfaces {
        default: listed.material.check("material", &mut f, dir, images),
        bodies: (listed.bodies.iter().enumerate())
            .map(|(k, body)| (body.material).check(&format!("bodies[{k}]"), &mut f, dir, images))
            .collect(),
        shading: listed.bodies.iter().map(|b| b.shading).collect(),
        smooth: Vec::new(),
    };
    f.finish()?;
    Ok(surfaces)
}

/// Most energy a texture holds to give back, J: a few strokes' worth.
const TANK: f64 = 0.01;
/// Slowest impact that rings, m/s: a resting touch that flickers does not.
const SLOWEST_IMPACT: f64 = 0.005;
/// Decay times after which a ringing is over.
const RINGING: f64 = 10.0;

/// What one effector feels of the surfaces it touches.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SurfaceFeel {
    touching: bool,
    /// Energy the texture took from the hand and may give back, J.
    tank: f64,
    /// The ringing: its amplitude (N), normal, age (s) and law.
    ringing: Option<(f64, DVec3, f64, Transient)>,
}

impl SurfaceFeel {
    /// [rt] After a tick of `dt` seconds in which the pointer touched `touch` (of material
    /// `material`, on a body now at `body`, whose texture moves with it) moving at
    /// `velocity`: the texture's force (passive) and the transient's (active).
    #[inline]
    pub fn update(
        &mut self,
        material: Option<&Material>,
        touch: &Touch,
        body: Option<Pose>,
        velocity: DVec3,
        dt: f64,
    ) -> (DVec3, DVec3) {
        let onset = touch.touching && !self.touching;
        self.touching = touch.touching;
        let mut texture = DVec3::ZERO;
        if let (true, Some(m)) = (touch.touching, material) {
            if let Some(t) = &m.texture {
                let push = match body {
                    Some(pose) => {
                        let point = pose.inverse_transform_point(touch.point);
                        let normal = pose.orientation.inverse() * touch.normal;
                        pose.orientation * t.force(point, normal)
                    }
                    None => t.force(touch.point, touch.normal),
                };
                texture = self.passive(push, touch.normal, velocity, dt, t.amplitude());
            }
            let speed = -velocity.dot(touch.normal);
            if let (true, Some(ring)) = (onset && speed > SLOWEST_IMPACT, m.transient) {
                self.ringing = Some((ring.gain * speed, touch.normal, 0.0, ring));
            }
        } else if !touch.touching {
            self.tank = 0.0;
        }
        let mut transient = DVec3::ZERO;
        if let Some((amplitude, normal, age, ring)) = &mut self.ringing {
            transient = *normal
                * *amplitude
                * (-*age / ring.decay).exp()
                * (TAU * ring.frequency * *age).sin();
            *age += dt;
            if *age > RINGING * ring.decay {
                self.ringing = None;
            }
        }
        (texture, transient)
    }

    /// [rt] A texture's `push` along the surface's `normal`, made passive for a hand moving
    /// at `velocity` over a tick of `dt`: the energy it would give the hand comes first from
    /// what it took before, then from the hand's sliding, by a drag along the surface of at
    /// most `strongest` N (as a real bump takes from the finger crossing it what it gives
    /// back pushing it up); what neither covers, the push does without.
    #[inline]
    fn passive(
        &mut self,
        push: DVec3,
        normal: DVec3,
        velocity: DVec3,
        dt: f64,
        strongest: f64,
    ) -> DVec3 {
        let given = push.dot(velocity) * dt;
        if given <= self.tank {
            self.tank = (self.tank - given).min(TANK);
            return push;
        }
        let sliding = velocity - normal * velocity.dot(normal);
        let speed = sliding.length();
        // The drag that takes the rest from the slide, within its bound.
        let rest = given - self.tank;
        let drag = if speed > 0.0 {
            (rest / (speed * dt)).min(strongest)
        } else {
            0.0
        };
        let taken = self.tank + drag * speed * dt;
        self.tank = 0.0;
        let push = push * (taken / given).min(1.0);
        push - sliding * (drag / speed.max(f64::MIN_POSITIVE))
    }

    /// [rt] Forget the touch (after a fault or a scene change).
    pub fn reset(&mut self) {
        *self = Self::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 1e-4;

    fn floor(touching: bool, x: f64) -> Touch {
        Touch {
            touching,
            point: DVec3::new(x, 0.0, 0.0),
            normal: DVec3::Y,
            ..Touch::NONE
        }
    }

    /// A tap at v rings at gain·v·e^(−t/τ)·sin(2πft) exactly, and only once a touch.
    #[test]
    fn an_impact_rings_in_proportion_to_its_speed() {
        let ring = Transient {
            gain: 20.0,
            frequency: 300.0,
            decay: 0.01,
        };
        let material = Material {
            texture: None,
            transient: Some(ring),
        };
        for speed in [0.05, 0.2, 0.6] {
            let mut feel = SurfaceFeel::default();
            let down = DVec3::new(0.0, -speed, 0.0);
            feel.update(Some(&material), &floor(false, 0.0), None, down, DT);
            for k in 0..2_000 {
                // It arrives at `speed`, and rests.
                let v = if k == 0 { down } else { DVec3::ZERO };
                let (_, f) = feel.update(Some(&material), &floor(true, 0.0), None, v, DT);
                let t = k as f64 * DT;
                // Over after ten decay times.
                let expected = if t <= RINGING * 0.01 {
                    20.0 * speed * (-t / 0.01).exp() * (TAU * 300.0 * t).sin()
                } else {
                    0.0
                };
                assert!((f.y - expected).abs() < 1e-12, "{t}: {} {expected}", f.y);
            }
        }
        // The touch must begin toward the surface, faster than a flicker.
        let mut feel = SurfaceFeel::default();
        feel.update(Some(&material), &floor(true, 0.0), None, DVec3::Y * 0.3, DT);
        let (_, f) = feel.update(Some(&material), &floor(true, 0.0), None, DVec3::ZERO, DT);
        assert_eq!(f, DVec3::ZERO);
    }

    /// However a hand moves over a texture (beating, sliding, pressing, in any rhythm), the
    /// texture's force gives it no energy.
    #[test]
    fn a_texture_gives_no_energy_to_a_hand_beating_on_it() {
        let material = Material {
            texture: Some(Texture::Grating {
                period: 0.002,
                amplitude: 2.0,
                direction: DVec3::X,
            }),
            transient: None,
        };
        for (beat, slide) in [(7.0, 0.02), (31.0, 0.05), (3.0, 0.3), (113.0, 0.01)] {
            let mut feel = SurfaceFeel::default();
            let (mut energy, mut lowest, mut felt) = (0.0f64, 0.0f64, 0.0f64);
            for k in 0..50_000 {
                let t = k as f64 * DT;
                let x = slide * t;
                let y = -0.002 * (TAU * beat * t).sin();
                let v = DVec3::new(slide, -0.002 * TAU * beat * (TAU * beat * t).cos(), 0.0);
                let (f, _) = feel.update(Some(&material), &floor(y < 0.0, x), None, v, DT);
                energy -= f.dot(v) * DT;
                lowest = lowest.min(energy);
                felt = felt.max(f.length());
            }
            assert!(lowest >= -1e-12, "{beat} Hz: {lowest} J");
            assert!(felt > 1.0, "{beat} Hz: the texture was felt ({felt} N)");
        }
    }

    /// A body's texture moves with the body: slid on at the same place of the world, a
    /// grating on a body moved half a period along it pushes the other way, and one on a
    /// body turned a quarter about the normal has its ridges turned too.
    #[test]
    fn a_bodys_texture_moves_with_it() {
        let material = Material {
            texture: Some(Texture::Grating {
                period: 0.004,
                amplitude: 1.0,
                direction: DVec3::X,
            }),
            transient: None,
        };
        let felt = |body: Option<Pose>| {
            let mut feel = SurfaceFeel::default();
            let slide = DVec3::X * 0.01;
            feel.update(Some(&material), &floor(true, 0.001), body, slide, DT)
                .0
        };
        let still = felt(None);
        assert!((still - DVec3::Y).length() < 1e-12, "{still}");
        let moved = Pose {
            position: DVec3::new(0.002, 0.0, 0.0),
            ..Pose::default()
        };
        assert!((felt(Some(moved)) + DVec3::Y).length() < 1e-12);
        let turned = Pose {
            orientation: glam::DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2),
            ..Pose::default()
        };
        // Its ridges now run along x: sliding along x crosses none, at z = 0 the profile's
        // zero.
        assert!(felt(Some(turned)).length() < 1e-12);
    }
}
