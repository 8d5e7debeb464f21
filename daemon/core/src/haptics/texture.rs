//! Surface textures felt while a pointer slides on a surface: a force along the surface's
//! normal that follows where the pointer is on it, from a profile between -1 and 1 times
//! the texture's amplitude.
//!
//! - A sinusoidal grating of `period` metres across `direction` (the grooves run across it),
//!   slid over at v m/s, is felt at v/period Hz.
//! - Random roughness: a sum of plane waves with wavelengths spread evenly in octaves from
//!   `shortest` to `longest`, random directions and phases (from `seed`), their amplitudes
//!   following a power spectrum ∝ f^-`exponent` of the spatial frequency f.
//! - A height map: a grey PNG laid over the surface in tiles of `size` metres, seen along
//!   the axis nearest the surface's normal; black is -1, white 1.
//!
//! Whether a texture's force may do work on the hand is the caller's concern (the surface
//! materials give it back only what it took).

use std::error::Error;
use std::f64::consts::TAU;
use std::path::Path;
use std::sync::Arc;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::diagnostics::Findings;

/// Plane waves of a random roughness.
pub const ROUGHNESS_WAVES: usize = 32;

/// One plane wave of a roughness.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneWave {
    /// Its wave vector, radians per metre.
    pub wave: DVec3,
    /// Its amplitude (the waves' squares add up to 1).
    pub amplitude: f64,
    /// Its phase, radians.
    pub phase: f64,
}

/// A grey image's heights, from 0 (black) to 1 (white), row after row from the top.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightImage {
    /// Pixels across.
    pub width: usize,
    /// Pixels down.
    pub height: usize,
    /// `width × height` heights.
    pub heights: Vec<f32>,
}

impl HeightImage {
    /// The height at (`u`, `v`), in pixels, the image repeated in tiles; between pixels
    /// bilinear.
    #[inline]
    fn at(&self, u: f64, v: f64) -> f64 {
        let (w, h) = (self.width as f64, self.height as f64);
        let (u, v) = ((u - 0.5).rem_euclid(w), (v - 0.5).rem_euclid(h));
        let (x0, y0) = (u.floor(), v.floor());
        let (fx, fy) = (u - x0, v - y0);
        let (x0, y0) = (x0 as usize % self.width, y0 as usize % self.height);
        let (x1, y1) = ((x0 + 1) % self.width, (y0 + 1) % self.height);
        let p = |x: usize, y: usize| f64::from(self.heights[y * self.width + x]);
        let top = p(x0, y0) * (1.0 - fx) + p(x1, y0) * fx;
        let bottom = p(x0, y1) * (1.0 - fx) + p(x1, y1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// Reads the grey PNG `file` a scene names (in the scene's directory `dir`, which it must
/// not leave). hapticd and hapticctl read them with hapticd-mesh; the core reads no image.
pub type ImageReader<'a> =
    &'a dyn Fn(&Path, &Path) -> Result<HeightImage, Box<dyn Error + Send + Sync>>;

/// A texture of a surface.
#[derive(Debug, Clone, PartialEq)]
pub enum Texture {
    /// A sinusoidal grating.
    Grating {
        /// Metres from one ridge to the next.
        period: f64,
        /// The force's amplitude, N.
        amplitude: f64,
        /// The unit direction across the ridges (on each surface, its part along the
        /// surface).
        direction: DVec3,
    },
    /// Random roughness.
    Roughness {
        /// The amplitude of a sine of its power, N (its force's mean square is half its
        /// square).
        amplitude: f64,
        /// Its plane waves.
        waves: Box<[PlaneWave; ROUGHNESS_WAVES]>,
    },
    /// A height map.
    HeightMap {
        /// The force at white, N (at black its opposite).
        amplitude: f64,
        /// Metres a tile spans across and down.
        size: [f64; 2],
        /// The image.
        image: Arc<HeightImage>,
    },
}

impl Texture {
    /// [rt] The texture's force at `point` of a surface whose outward unit normal there is
    /// `normal`.
    #[inline]
    pub fn force(&self, point: DVec3, normal: DVec3) -> DVec3 {
        normal * self.profile(point, normal)
    }

    /// [rt] Its strongest force, N.
    #[inline]
    pub fn amplitude(&self) -> f64 {
        match self {
            Texture::Grating { amplitude, .. } | Texture::HeightMap { amplitude, .. } => *amplitude,
            Texture::Roughness { amplitude, waves } => {
                amplitude * waves.iter().map(|w| w.amplitude).sum::<f64>()
            }
        }
    }

    /// [rt] The force along the normal, N.
    #[inline]
    fn profile(&self, point: DVec3, normal: DVec3) -> f64 {
        match self {
            Texture::Grating {
                period,
                amplitude,
                direction,
            } => {
                // Zero where the direction has no part along the surface.
                let along = *direction - normal * direction.dot(normal);
                let Some(along) = along.try_normalize() else {
                    return 0.0;
                };
                amplitude * (TAU * point.dot(along) / period).sin()
            }
            Texture::Roughness { amplitude, waves } => {
                amplitude
                    * waves
                        .iter()
                        .map(|w| w.amplitude * (w.wave.dot(point) + w.phase).sin())
                        .sum::<f64>()
            }
            Texture::HeightMap {
                amplitude,
                size,
                image,
            } => {
                // Laid along the two axes farthest from the normal.
                let n = normal.abs();
                let (across, down) = if n.x >= n.y && n.x >= n.z {
                    (point.z, point.y)
                } else if n.y >= n.z {
                    (point.x, point.z)
                } else {
                    (point.x, point.y)
                };
                let u = across / size[0] * image.width as f64;
                let v = down / size[1] * image.height as f64;
                amplitude * (2.0 * image.at(u, v) - 1.0)
            }
        }
    }
}

/// A texture as a scene file writes it: `{ kind: grating, period: 0.002, amplitude: 0.5,
/// direction: [1, 0, 0] }`, `{ kind: roughness, amplitude: 0.3, shortest: 0.0005, longest:
/// 0.01, exponent: 2, seed: 7 }` or `{ kind: height_map, file: bumps.png, size: [0.02, 0.02],
/// amplitude: 0.4 }`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TextureSpec {
    /// `grating`, `roughness` or `height_map`.
    pub kind: String,
    /// The force's amplitude, N.
    pub amplitude: f64,
    /// A grating's metres from one ridge to the next.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period: Option<f64>,
    /// A grating's direction across the ridges (default: along x).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction: Option<[f64; 3]>,
    /// A roughness' shortest wavelength, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shortest: Option<f64>,
    /// A roughness' longest wavelength, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub longest: Option<f64>,
    /// A roughness' spectral exponent: power ∝ f^-exponent (default 2, as many natural
    /// surfaces).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exponent: Option<f64>,
    /// A roughness' seed: the same seed, the same surface.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// A height map's PNG, in the scene file's directory.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// A height map's tile, metres across and down.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<[f64; 2]>,
}

/// Finest feature, metres: finer than a fingertip's ridges is felt as nothing.
const FINEST: f64 = 1e-4;
/// Strongest texture, N.
const STRONGEST: f64 = 10.0;

impl TextureSpec {
    /// The texture, every mistake an error in `f` on the fields under `at`; a height map's
    /// image read by `images` from `dir`.
    pub fn check(
        &self,
        at: &str,
        f: &mut Findings,
        dir: &Path,
        images: ImageReader,
    ) -> Option<Texture> {
        let amplitude = f.within(
            format!("{at}.amplitude"),
            self.amplitude,
            0.0,
            STRONGEST,
            " N",
        );
        let keys: &[&str] = match self.kind.as_str() {
            "grating" => &["period", "direction"],
            "roughness" => &["shortest", "longest", "exponent", "seed"],
            "height_map" => &["file", "size"],
            other => {
                f.error(
                    format!("{at}.kind"),
                    format!("{other:?} is no texture: `grating`, `roughness` or `height_map`"),
                );
                return None;
            }
        };
        let given = [
            ("period", self.period.is_some()),
            ("direction", self.direction.is_some()),
            ("shortest", self.shortest.is_some()),
            ("longest", self.longest.is_some()),
            ("exponent", self.exponent.is_some()),
            ("seed", self.seed.is_some()),
            ("file", self.file.is_some()),
            ("size", self.size.is_some()),
        ];
        let mut fits = true;
        for (key, _) in given.iter().filter(|(k, g)| *g && !keys.contains(k)) {
            f.error(
                format!("{at}.{key}"),
                format!("a {} texture has no {key}", self.kind),
            );
            fits = false;
        }
        let texture = match self.kind.as_str() {
            "grating" => self.grating(at, f),
            "roughness" => self.roughness(at, f),
            _ => self.height_map(at, f, dir, images),
        };
        texture.filter(|_| amplitude && fits)
    }

    /// A required key's value, or an error saying it is missing.
    fn required<T: Copy>(
        &self,
        at: &str,
        key: &str,
        value: Option<T>,
        f: &mut Findings,
    ) -> Option<T> {
        if value.is_none() {
            f.error(
                format!("{at}.{key}"),
                format!("a {} texture needs {key}", self.kind),
            );
        }
        value
    }

    fn grating(&self, at: &str, f: &mut Findings) -> Option<Texture> {
        let period = self.required(at, "period", self.period, f)?;
        let period = f
            .within(format!("{at}.period"), period, FINEST, 1.0, " m")
            .then_some(period);
        let direction = DVec3::from(self.direction.unwrap_or([1.0, 0.0, 0.0]));
        let unit = direction.try_normalize().filter(|_| direction.is_finite());
        if unit.is_none() {
            f.error(
                format!("{at}.direction"),
                "must be a finite direction, not zero",
            );
        }
        Some(Texture::Grating {
            period: period?,
            amplitude: self.amplitude,
            direction: unit?,
        })
    }

    fn roughness(&self, at: &str, f: &mut Findings) -> Option<Texture> {
        let shortest = self.required(at, "shortest", self.shortest, f);
        let longest = self.required(at, "longest", self.longest, f);
        let (shortest, longest) = (shortest?, longest?);
        let mut ok = f.within(format!("{at}.shortest"), shortest, FINEST, 1.0, " m");
        ok &= f.within(format!("{at}.longest"), longest, FINEST, 1.0, " m");
        if ok && longest < shortest {
            f.error(format!("{at}.longest"), "must not be shorter than shortest");
            ok = false;
        }
        let exponent = self.exponent.unwrap_or(2.0);
        ok &= f.within(format!("{at}.exponent"), exponent, -4.0, 6.0, "");
        ok.then(|| Texture::Roughness {
            amplitude: self.amplitude,
            waves: Box::new(roughness_waves(
                shortest,
                longest,
                exponent,
                self.seed.unwrap_or(0),
            )),
        })
    }

    fn height_map(
        &self,
        at: &str,
        f: &mut Findings,
        dir: &Path,
        images: ImageReader,
    ) -> Option<Texture> {
        let file = self.required(at, "file", self.file.as_deref(), f);
        let size = self.required(at, "size", self.size, f);
        let (file, size) = (file?, size?);
        let mut ok = true;
        for (k, side) in size.iter().enumerate() {
            ok &= f.within(format!("{at}.size[{k}]"), *side, FINEST, 1.0, " m");
        }
        let image = match images(&dir.join(file), dir) {
            Ok(image) => image,
            Err(e) => {
                f.error(format!("{at}.file"), e.to_string());
                return None;
            }
        };
        ok.then(|| Texture::HeightMap {
            amplitude: self.amplitude,
            size,
            image: Arc::new(image),
        })
    }
}

/// The plane waves of a roughness from `shortest` to `longest` metres with power ∝
/// f^-`exponent`, their directions and phases drawn from `seed`; their powers add up to a
/// unit sine's (their amplitudes' squares to 1).
pub fn roughness_waves(
    shortest: f64,
    longest: f64,
    exponent: f64,
    seed: u64,
) -> [PlaneWave; ROUGHNESS_WAVES] {
    let mut state = seed ^ 0x9e37_79b9_7f4a_7c15;
    // splitmix64: a few lines, the same numbers everywhere.
    let mut uniform = || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        (z ^ (z >> 31)) as f64 / u64::MAX as f64
    };
    let mut waves = [PlaneWave {
        wave: DVec3::ZERO,
        amplitude: 0.0,
        phase: 0.0,
    }; ROUGHNESS_WAVES];
    let ratio = longest / shortest;
    for (k, w) in waves.iter_mut().enumerate() {
        let s = if ROUGHNESS_WAVES > 1 {
            k as f64 / (ROUGHNESS_WAVES - 1) as f64
        } else {
            0.0
        };
        let frequency = 1.0 / (longest / ratio.powf(s));
        // Uniform on the sphere.
        let z = 2.0 * uniform() - 1.0;
        let azimuth = TAU * uniform();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let direction = DVec3::new(r * azimuth.cos(), z, r * azimuth.sin());
        // Evenly spread in octaves, each wave stands for a band ∝ f wide: its power is
        // f^-exponent × f, its amplitude the square root.
        *w = PlaneWave {
            wave: direction * TAU * frequency,
            amplitude: frequency.powf((1.0 - exponent) / 2.0),
            phase: TAU * uniform(),
        };
    }
    let total = waves
        .iter()
        .map(|w| w.amplitude.powi(2))
        .sum::<f64>()
        .sqrt();
    for w in &mut waves {
        w.amplitude /= total;
    }
    waves
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_images(_: &Path, _: &Path) -> Result<HeightImage, Box<dyn Error + Send + Sync>> {
        Err("no images here".into())
    }

    #[test]
    fn a_grating_rises_and_falls_across_its_ridges_along_the_normal() {
        let grating = Texture::Grating {
            period: 0.004,
            amplitude: 0.5,
            direction: DVec3::X,
        };
        let at = |x: f64| grating.force(DVec3::new(x, 0.0, 0.3), DVec3::Y);
        assert!(at(0.0).length() < 1e-12);
        assert!((at(0.001) - DVec3::Y * 0.5).length() < 1e-12);
        assert!((at(0.003) + DVec3::Y * 0.5).length() < 1e-12);
        // Along the ridges nothing changes; on a wall facing x the ridges have no run.
        assert_eq!(
            at(0.001),
            grating.force(DVec3::new(0.001, 0.0, -0.7), DVec3::Y)
        );
        assert_eq!(
            grating.force(DVec3::new(0.001, 0.0, 0.0), DVec3::X),
            DVec3::ZERO
        );
    }

    /// The amplitudes follow the spectrum's law (their log-log slope is (1 − exponent)/2),
    /// their power is a unit sine's, the force never passes the strongest the texture
    /// says, and a seed makes the same surface.
    #[test]
    fn roughness_follows_its_spectrum_and_its_bound() {
        for exponent in [0.0, 1.0, 2.0, 3.5] {
            let waves = roughness_waves(0.0005, 0.02, exponent, 3);
            let points: Vec<(f64, f64)> = waves
                .iter()
                .map(|w| (w.wave.length().ln(), w.amplitude.ln()))
                .collect();
            let n = points.len() as f64;
            let (mx, my) = points
                .iter()
                .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
            let slope = points.iter().map(|(x, y)| (x - mx) * (y - my)).sum::<f64>()
                / points.iter().map(|(x, _)| (x - mx).powi(2)).sum::<f64>();
            assert!((slope - (1.0 - exponent) / 2.0).abs() < 1e-9, "{slope}");
            assert!((waves.iter().map(|w| w.amplitude.powi(2)).sum::<f64>() - 1.0).abs() < 1e-12);
            let lengths: Vec<f64> = waves.iter().map(|w| TAU / w.wave.length()).collect();
            assert!((lengths[0] - 0.02).abs() < 1e-12 && (lengths[31] - 0.0005).abs() < 1e-12);
        }
        let rough = Texture::Roughness {
            amplitude: 0.7,
            waves: Box::new(roughness_waves(0.0005, 0.02, 2.0, 3)),
        };
        let mut largest = 0.0f64;
        for k in 0..20_000 {
            let p = DVec3::new(k as f64 * 1.3e-5, 0.002, -(k as f64) * 0.7e-5);
            largest = largest.max(rough.force(p, DVec3::Y).length());
        }
        assert!(largest <= rough.amplitude() && largest > 0.7, "{largest}");
        assert_eq!(
            roughness_waves(0.001, 0.01, 2.0, 9),
            roughness_waves(0.001, 0.01, 2.0, 9)
        );
        assert_ne!(
            roughness_waves(0.001, 0.01, 2.0, 9),
            roughness_waves(0.001, 0.01, 2.0, 10)
        );
    }

    /// A 2 × 1 image of black and white, tiled 2 cm across: black at one pixel's centre,
    /// white at the other's, halfway between, and again a tile on.
    #[test]
    fn a_height_map_is_tiled_and_interpolated() {
        let map = Texture::HeightMap {
            amplitude: 0.4,
            size: [0.02, 0.01],
            image: Arc::new(HeightImage {
                width: 2,
                height: 1,
                heights: vec![0.0, 1.0],
            }),
        };
        let on_floor = |x: f64| map.force(DVec3::new(x, 0.0, 0.003), DVec3::Y).y;
        assert!((on_floor(0.005) + 0.4).abs() < 1e-9);
        assert!((on_floor(0.015) - 0.4).abs() < 1e-9);
        assert!(on_floor(0.010).abs() < 1e-9);
        assert!((on_floor(0.025) + 0.4).abs() < 1e-9);
        assert!((on_floor(-0.005) - 0.4).abs() < 1e-9);
        // On a wall facing x it is laid along z.
        let on_wall = map.force(DVec3::new(0.5, 0.0, 0.015), DVec3::X);
        assert!((on_wall.x - 0.4).abs() < 1e-9);
    }

    #[test]
    fn a_texture_names_its_mistakes() {
        let path = Path::new("t");
        let check = |text: &str| {
            let spec: TextureSpec = crate::diagnostics::parse_yaml(text, path).unwrap().value;
            let mut f = Findings::new(path, &|_| None);
            let texture = spec.check("texture", &mut f, Path::new("."), &no_images);
            (texture, f.finish().err().map(|e| e.to_string()))
        };
        let (good, said) = check("{kind: roughness, amplitude: 1, shortest: 0.001, longest: 0.01}");
        assert!(good.is_some() && said.is_none(), "{said:?}");
        for (text, expected) in [
            (
                "{kind: grating, amplitude: 1}",
                "texture.period: a grating texture needs period",
            ),
            (
                "{kind: grating, amplitude: 1, period: 0.002, seed: 3}",
                "texture.seed: a grating texture has no seed",
            ),
            (
                "{kind: roughness, amplitude: 1, shortest: 0.01, longest: 0.001}",
                "texture.longest: must not be shorter than shortest",
            ),
            (
                "{kind: height_map, amplitude: 1, file: x.png, size: [0.01, 0.01]}",
                "texture.file: no images here",
            ),
            (
                "{kind: velvet, amplitude: 1}",
                "texture.kind: \"velvet\" is no texture",
            ),
        ] {
            let (texture, said) = check(text);
            assert!(texture.is_none(), "{text}");
            assert!(
                said.as_deref().unwrap_or("").contains(expected),
                "{text}: {said:?}"
            );
        }
    }
}
