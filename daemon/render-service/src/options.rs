//! The options of `Snapshot` and `OpenFrameStream` (`a{sv}`), checked: every key known,
//! every number finite and in range, or a named error saying which and why.

use std::collections::HashMap;

use glam::DVec3;
use hapticd_render::camera::Camera;
use hapticd_render::vulkan::MAX_EDGE;
use zbus::{OwnedVariant, Variant};

use crate::error::Error;

/// Highest frame rate a stream may ask for.
pub const MAX_RATE: f64 = 120.0;

/// What a picture request asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Request {
    /// Width and height, pixels.
    pub size: (u32, u32),
    /// Changes to the scene's camera.
    pub view: View,
    /// Frames per second (streams only).
    pub rate: f64,
}

/// A camera as asked for: each part the scene's own where not given.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct View {
    /// Turn about the vertical, radians (0: from +z).
    pub azimuth: Option<f64>,
    /// Angle down onto the target, radians.
    pub elevation: Option<f64>,
    /// Distance from the target, metres.
    pub distance: Option<f64>,
    /// The point looked at, metres.
    pub target: Option<DVec3>,
}

impl View {
    /// `scene`'s camera with this view's changes.
    pub fn apply(&self, scene: &Camera) -> Camera {
        let look = scene.eye - scene.target;
        let distance = look.length();
        let elevation = (look.y / distance).asin();
        let azimuth = look.x.atan2(look.z);
        let mut camera = Camera::orbit(
            self.target.unwrap_or(scene.target),
            self.distance.unwrap_or(distance),
            self.azimuth.unwrap_or(azimuth),
            self.elevation.unwrap_or(elevation),
        );
        camera.fov = scene.fov;
        camera
    }
}

/// The keys understood, for messages.
const KEYS: &str = "width, height, azimuth, elevation, distance, target, rate";

fn number(key: &str, value: &Variant) -> Result<f64, Error> {
    let x = match value {
        Variant::F64(x) => *x,
        Variant::U8(x) => f64::from(*x),
        Variant::I16(x) => f64::from(*x),
        Variant::U16(x) => f64::from(*x),
        Variant::I32(x) => f64::from(*x),
        Variant::U32(x) => f64::from(*x),
        Variant::I64(x) => *x as f64,
        Variant::U64(x) => *x as f64,
        Variant::Variant(inner) => return number(key, inner),
        other => {
            return Err(Error::InvalidOption(format!(
                "{key} is a number, not {}",
                other.value_signature()
            )));
        }
    };
    if x.is_finite() {
        Ok(x)
    } else {
        Err(Error::NotFinite(format!("{key} is {x}")))
    }
}

fn within(key: &str, x: f64, low: f64, high: f64) -> Result<f64, Error> {
    if (low..=high).contains(&x) {
        Ok(x)
    } else {
        Err(Error::OutOfRange(format!(
            "{key} is {x}, not within {low} to {high}"
        )))
    }
}

fn edge(key: &str, value: &Variant) -> Result<u32, Error> {
    let x = number(key, value)?;
    if x.fract() != 0.0 {
        return Err(Error::InvalidOption(format!(
            "{key} is {x}, not a whole number"
        )));
    }
    Ok(within(key, x, 1.0, f64::from(MAX_EDGE))? as u32)
}

/// Read `options`; sizes default to `default_size`, the rate to 30.
pub fn parse(
    options: &HashMap<String, OwnedVariant>,
    default_size: (u32, u32),
) -> Result<Request, Error> {
    let mut request = Request {
        size: default_size,
        view: View::default(),
        rate: 30.0,
    };
    let quarter = std::f64::consts::FRAC_PI_2 - 1e-3;
    for (key, value) in options {
        let value: &Variant = value;
        match key.as_str() {
            "width" => request.size.0 = edge(key, value)?,
            "height" => request.size.1 = edge(key, value)?,
            "azimuth" => request.view.azimuth = Some(number(key, value)?),
            "elevation" => {
                request.view.elevation = Some(within(key, number(key, value)?, -quarter, quarter)?)
            }
            "distance" => {
                request.view.distance = Some(within(key, number(key, value)?, 1e-3, 1e3)?)
            }
            "target" => {
                let parts: Vec<f64> = match value {
                    Variant::Array(a) => {
                        a.iter().map(|v| number(key, v)).collect::<Result<_, _>>()?
                    }
                    _ => {
                        return Err(Error::InvalidOption(format!(
                            "target is three numbers (ad), not {}",
                            value.value_signature()
                        )));
                    }
                };
                let [x, y, z] = parts[..] else {
                    return Err(Error::InvalidOption(format!(
                        "target is three numbers, not {}",
                        parts.len()
                    )));
                };
                for c in [x, y, z] {
                    within(key, c, -1e3, 1e3)?;
                }
                request.view.target = Some(DVec3::new(x, y, z));
            }
            "rate" => request.rate = within(key, number(key, value)?, 1.0, MAX_RATE)?,
            other => {
                return Err(Error::InvalidOption(format!(
                    "unknown option {other:?}; known: {KEYS}"
                )));
            }
        }
    }
    Ok(request)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options(pairs: &[(&str, Variant<'_>)]) -> HashMap<String, OwnedVariant> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.try_to_owned().unwrap()))
            .collect()
    }

    #[test]
    fn sizes_and_a_view_are_read() {
        let request = parse(
            &options(&[
                ("width", Variant::U32(320)),
                ("height", Variant::I32(240)),
                ("azimuth", Variant::F64(0.5)),
                ("target", Variant::from(vec![0.0, 0.1, 0.0])),
            ]),
            (640, 480),
        )
        .unwrap();
        assert_eq!(request.size, (320, 240));
        assert_eq!(request.view.azimuth, Some(0.5));
        assert_eq!(request.view.target, Some(DVec3::new(0.0, 0.1, 0.0)));
        assert_eq!(parse(&HashMap::new(), (640, 480)).unwrap().size, (640, 480));
    }

    #[test]
    fn bad_options_are_named() {
        let bad = |pairs: &[(&str, Variant<'_>)]| parse(&options(pairs), (640, 480)).unwrap_err();
        assert!(
            matches!(bad(&[("width", Variant::U32(0))]), Error::OutOfRange(m) if m.contains("width"))
        );
        assert!(matches!(
            bad(&[("height", Variant::U32(100_000))]),
            Error::OutOfRange(_)
        ));
        assert!(matches!(
            bad(&[("width", Variant::F64(1.5))]),
            Error::InvalidOption(_)
        ));
        assert!(matches!(
            bad(&[("distance", Variant::F64(f64::NAN))]),
            Error::NotFinite(_)
        ));
        assert!(matches!(
            bad(&[("azimuth", Variant::F64(f64::INFINITY))]),
            Error::NotFinite(_)
        ));
        assert!(matches!(
            bad(&[("elevation", Variant::F64(2.0))]),
            Error::OutOfRange(_)
        ));
        assert!(matches!(
            bad(&[("target", Variant::from(vec![0.0, 1.0]))]),
            Error::InvalidOption(_)
        ));
        assert!(
            matches!(bad(&[("zoom", Variant::F64(1.0))]), Error::InvalidOption(m) if m.contains("zoom"))
        );
        assert!(matches!(
            bad(&[("width", Variant::from("wide"))]),
            Error::InvalidOption(_)
        ));
        assert!(matches!(
            bad(&[("rate", Variant::F64(1000.0))]),
            Error::OutOfRange(_)
        ));
    }

    #[test]
    fn a_view_changes_only_what_it_gives() {
        let scene = Camera::orbit(DVec3::new(0.0, 0.1, 0.0), 0.8, 0.45, 0.75);
        let same = View::default().apply(&scene);
        assert!(
            (same.eye - scene.eye).length() < 1e-9,
            "{same:?} vs {scene:?}"
        );
        let closer = View {
            distance: Some(0.4),
            ..View::default()
        }
        .apply(&scene);
        assert!(((closer.eye - closer.target).length() - 0.4).abs() < 1e-9);
        assert!(
            ((closer.eye - scene.target).normalize() - (scene.eye - scene.target).normalize())
                .length()
                < 1e-9
        );
    }
}
