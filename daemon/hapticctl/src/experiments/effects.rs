//! The periodic effects through the daemon's own effect set at 1 kHz: each waveform's force
//! over time, rising over its attack and falling over its fade, a square's edges at the
//! force-rate limit; and a constant force cross-faded into its opposite. Then surface
//! materials as each effector feels them: each kind of texture's force against position
//! under a finger sliding across it, and the ringing of two taps on a surface.

use glam::DVec3;
use serde_json::json;

use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;
use hapticd_core::haptics::effects::{
    Effect, EffectCommand, EffectSet, Envelope, Grip, Kind, Wave,
};
use hapticd_core::haptics::surface::{Material, SurfaceFeel, Transient};
use hapticd_core::haptics::texture::{HeightImage, Texture, roughness_waves};
use hapticd_core::haptics::touch::Touch;
use hapticd_core::kinematics::Pose;

/// Tick, seconds.
const DT: f64 = 1e-3;
/// The force-rate limit, N/s, as the configuration's default.
const RATE: f64 = hapticd_core::haptic_loop::MAX_FORCE_RATE;

/// The force along x over `seconds` of `commands` given at their times to a set of 10 N.
fn run(commands: &[(f64, EffectCommand)], seconds: f64) -> Vec<(f64, f64)> {
    let mut set = EffectSet::new(10.0, RATE);
    let grip = Grip {
        pose: Pose::default(),
        velocity: DVec3::ZERO,
    };
    let mut pending = commands.iter().peekable();
    (0..(seconds / DT) as usize)
        .map(|k| {
            let t = k as f64 * DT;
            while let Some((_, command)) = pending.next_if(|(at, _)| *at <= t) {
                let _ = set.command(*command);
            }
            set.advance(DT);
            (t, set.wrenches(0, &grip, DT, DVec3::ZERO, &[]).1.force.x)
        })
        .collect()
}

/// A waveform of 2 N at 4 Hz along x, rising over 0.15 s, removed at 0.8 s.
fn periodic(wave: Wave) -> Vec<(f64, f64)> {
    let effect = Effect {
        kind: Kind::Periodic {
            wave,
            frequency: 4.0,
            amplitude: 2.0,
            direction: DVec3::X,
            phase: 0.0,
        },
        effector: None,
        body: None,
        envelope: Envelope {
            attack: 0.15,
            fade: 0.1,
            ..Envelope::default()
        },
    };
    run(
        &[
            (0.0, EffectCommand::Add(0, effect)),
            (0.8, EffectCommand::Remove(0)),
        ],
        1.0,
    )
}

/// A constant 3 N along x with 40 ms ramps, changed to −3 N at 0.3 s (the one fading as
/// the other rises) and removed at 0.6 s.
fn cross_fade() -> Vec<(f64, f64)> {
    let constant = |x: f64| Effect {
        kind: Kind::Constant {
            force: DVec3::X * x,
            torque: DVec3::ZERO,
        },
        effector: None,
        body: None,
        envelope: Envelope {
            attack: 0.04,
            fade: 0.04,
            ..Envelope::default()
        },
    };
    run(
        &[
            (0.05, EffectCommand::Add(0, constant(3.0))),
            (0.3, EffectCommand::Change(0, constant(-3.0))),
            (0.6, EffectCommand::Remove(0)),
        ],
        1.0,
    )
}

/// Sliding speed across the textures, m/s.
const SLIDE: f64 = 0.02;

/// The force along a floor's normal under a finger sliding along x at [`SLIDE`] over the
/// first 2 cm of `texture`, against position (mm).
fn slid(texture: Texture) -> Vec<(f64, f64)> {
    let material = Material {
        texture: Some(texture),
        transient: None,
    };
    let mut feel = SurfaceFeel::default();
    (0..=(0.02 / SLIDE / DT) as usize)
        .map(|k| {
            let x = k as f64 * DT * SLIDE;
            let touch = Touch {
                touching: true,
                point: DVec3::new(x, 0.0, 0.0),
                normal: DVec3::Y,
                ..Touch::NONE
            };
            let (force, _) = feel.update(Some(&material), &touch, None, DVec3::X * SLIDE, DT);
            (x * 1e3, force.y)
        })
        .collect()
}

/// The three kinds of texture, each of 0.4 N, slid across.
fn textures() -> Vec<(&'static str, Vec<(f64, f64)>)> {
    let amplitude = 0.4;
    vec![
        (
            "grating, 2 mm",
            slid(Texture::Grating {
                period: 0.002,
                amplitude,
                direction: DVec3::X,
            }),
        ),
        (
            "roughness, 0.5-8 mm",
            slid(Texture::Roughness {
                amplitude,
                waves: Box::new(roughness_waves(0.0005, 0.008, 2.0, 7)),
            }),
        ),
        (
            "height map, 8 px in 8 mm",
            slid(Texture::HeightMap {
                amplitude,
                size: [0.008, 0.008],
                image: std::sync::Arc::new(HeightImage {
                    width: 8,
                    height: 1,
                    heights: vec![0.0, 0.2, 1.0, 0.6, 0.1, 0.9, 0.3, 0.5],
                }),
            }),
        ),
    ]
}

/// The ringing of a tap at `speed` m/s on a surface of 12 N·s/m, 300 Hz and 15 ms, over
/// 60 ms at 10 kHz: time (ms) and force.
fn tap(speed: f64) -> Vec<(f64, f64)> {
    let dt = 1e-4;
    let material = Material {
        texture: None,
        transient: Some(Transient {
            gain: 12.0,
            frequency: 300.0,
            decay: 0.015,
        }),
    };
    let mut feel = SurfaceFeel::default();
    let touch = Touch {
        touching: true,
        normal: DVec3::Y,
        ..Touch::NONE
    };
    (0..600)
        .map(|k| {
            let velocity = if k == 0 {
                -DVec3::Y * speed
            } else {
                DVec3::ZERO
            };
            let (_, ring) = feel.update(Some(&material), &touch, None, velocity, dt);
            (k as f64 * dt * 1e3, ring.y)
        })
        .collect()
}

/// The fastest change of `forces`, N/s.
fn steepest(forces: &[(f64, f64)]) -> f64 {
    forces
        .windows(2)
        .map(|w| (w[1].1 - w[0].1).abs() / DT)
        .fold(0.0, f64::max)
}

/// Each periodic kind and the cross-fade: two charts, and the fastest change of each.
pub fn report() -> Report {
    let waves = [
        ("sine", Wave::Sine),
        ("square", Wave::Square),
        ("triangle", Wave::Triangle),
        ("saw up", Wave::SawUp),
        ("saw down", Wave::SawDown),
    ];
    let runs: Vec<(&str, Vec<(f64, f64)>)> = waves
        .iter()
        .map(|(name, wave)| (*name, periodic(*wave)))
        .collect();
    let faded = cross_fade();
    let mut text = String::new();
    let mut rows = Vec::new();
    for (name, forces) in runs.iter().chain([("cross-fade", faded.clone())].iter()) {
        let fastest = steepest(forces);
        text += &format!("  {name}: fastest change {fastest:.0} N/s (limit {RATE:.0})\n");
        rows.push(json!({"effect": name, "fastest": fastest}));
    }
    let waves_chart = Chart {
        title: "2 N at 4 Hz: 0.15 s attack, removed at 0.8 s".into(),
        x_label: "time [s]".into(),
        y_label: "force [N]".into(),
        series: runs
            .iter()
            .enumerate()
            .map(|(k, (name, forces))| Series {
                label: (*name).into(),
                points: forces.clone(),
                color: PALETTE[k % PALETTE.len()],
            })
            .collect(),
        y_range: Some((-2.5, 2.5)),
        ..Chart::default()
    };
    let fade_chart = Chart {
        title: "3 N, changed to -3 N, removed: 40 ms ramps".into(),
        x_label: "time [s]".into(),
        y_label: "force [N]".into(),
        series: vec![Series {
            label: "constant, cross-faded".into(),
            points: faded,
            color: PALETTE[0],
        }],
        y_range: Some((-3.5, 3.5)),
        ..Chart::default()
    };
    let texture_chart = Chart {
        title: format!("Textures of 0.4 N slid across at {SLIDE} m/s"),
        x_label: "position [mm]".into(),
        y_label: "force along the normal [N]".into(),
        series: textures()
            .into_iter()
            .enumerate()
            .map(|(k, (name, points))| Series {
                label: name.into(),
                points,
                color: PALETTE[k % PALETTE.len()],
            })
            .collect(),
        y_range: Some((-0.8, 0.8)),
        ..Chart::default()
    };
    let tap_chart = Chart {
        title: "Taps on a surface ringing at 300 Hz (12 N s/m, 15 ms)".into(),
        x_label: "time after the impact [ms]".into(),
        y_label: "force along the normal [N]".into(),
        series: [0.2, 0.1]
            .iter()
            .enumerate()
            .map(|(k, speed)| Series {
                label: format!("{speed} m/s"),
                points: tap(*speed),
                color: PALETTE[k % PALETTE.len()],
            })
            .collect(),
        y_range: Some((-2.5, 2.5)),
        ..Chart::default()
    };
    Report {
        text,
        json: json!({ "results": rows }),
        charts: vec![waves_chart, fade_chart, texture_chart, tap_chart],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_effect_changes_faster_than_the_limit_and_each_reaches_its_amplitude() {
        for wave in [
            Wave::Sine,
            Wave::Square,
            Wave::Triangle,
            Wave::SawUp,
            Wave::SawDown,
        ] {
            let forces = periodic(wave);
            assert!(steepest(&forces) <= RATE * (1.0 + 1e-9), "{wave:?}");
            let highest = forces.iter().map(|f| f.1.abs()).fold(0.0, f64::max);
            assert!((highest - 2.0).abs() < 0.02, "{wave:?}: {highest}");
            assert_eq!(forces.last().unwrap().1, 0.0, "{wave:?} faded out");
        }
        assert!(steepest(&cross_fade()) <= RATE * (1.0 + 1e-9));
    }

    /// Slid across, the grating is its formula at each position and the height map stays
    /// within its amplitude; a tap twice as fast rings twice as hard.
    #[test]
    fn the_textures_slid_across_are_their_profiles() {
        for (name, points) in textures() {
            if name.starts_with("height") {
                assert!(points.iter().all(|(_, f)| f.abs() <= 0.4 + 1e-12), "{name}");
            }
            if name.starts_with("grating") {
                for (x, f) in points {
                    let expected = 0.4 * (std::f64::consts::TAU * x / 2.0).sin();
                    assert!((f - expected).abs() < 1e-9, "{x} mm");
                }
            }
        }
        let (fast, slow) = (tap(0.2), tap(0.1));
        for (a, b) in fast.iter().zip(&slow) {
            assert!((a.1 - 2.0 * b.1).abs() < 1e-12);
        }
    }
}
