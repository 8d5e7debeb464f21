//! Surface textures felt while the proxy slides on a surface: a force along the surface's
//! normal that follows where the proxy is on it. A sinusoidal grating of `period` metres
//! across `direction` (the grooves run across it) slid over at v m/s is felt at v/period Hz.

use std::f64::consts::TAU;

use glam::DVec3;
use serde::Deserialize;

use crate::diagnostics::Findings;

/// A texture of a scene's surfaces.
#[derive(Debug, Clone, Copy, PartialEq)]
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
}

impl Texture {
    /// [rt] The texture's force at `point` of a surface whose outward unit normal there is
    /// `normal`: zero where the direction has no part along the surface.
    #[inline]
    pub fn force(&self, point: DVec3, normal: DVec3) -> DVec3 {
        match *self {
            Texture::Grating {
                period,
                amplitude,
                direction,
            } => {
                let along = direction - normal * direction.dot(normal);
                let Some(along) = along.try_normalize() else {
                    return DVec3::ZERO;
                };
                normal * amplitude * (TAU * point.dot(along) / period).sin()
            }
        }
    }
}

/// A texture as a scene file writes it: `texture: { kind: grating, period: 0.002,
/// amplitude: 0.5, direction: [1, 0, 0] }`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextureSpec {
    /// `grating`.
    pub kind: String,
    /// Metres from one ridge to the next.
    pub period: f64,
    /// The force's amplitude, N.
    pub amplitude: f64,
    /// Across the ridges (default: along x).
    #[serde(default)]
    pub direction: Option<[f64; 3]>,
}

/// Finest grating, metres: finer than a fingertip's ridges is felt as nothing.
const FINEST: f64 = 1e-4;
/// Strongest texture, N.
const STRONGEST: f64 = 10.0;

impl TextureSpec {
    /// The texture, every mistake an error in `f` on the fields under `at`.
    pub fn check(&self, at: &str, f: &mut Findings) -> Option<Texture> {
        if self.kind != "grating" {
            f.error(
                format!("{at}.kind"),
                format!("{:?} is no texture: `grating`", self.kind),
            );
            return None;
        }
        let period = f.within(format!("{at}.period"), self.period, FINEST, 1.0, " m");
        let amplitude = f.within(
            format!("{at}.amplitude"),
            self.amplitude,
            0.0,
            STRONGEST,
            " N",
        );
        let direction = DVec3::from(self.direction.unwrap_or([1.0, 0.0, 0.0]));
        let unit = direction.try_normalize().filter(|_| direction.is_finite());
        if unit.is_none() {
            f.error(
                format!("{at}.direction"),
                "must be a finite direction, not zero",
            );
        }
        Some(Texture::Grating {
            period: period.then_some(self.period)?,
            amplitude: amplitude.then_some(self.amplitude)?,
            direction: unit?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
