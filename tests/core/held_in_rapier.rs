//! A held part in rapier's world (thesis 7.2 with Ch. 6), through the lockstep hapticctl
//! runs the daemon's haptic side in: the god-object puts a held peg into a hole it fits and
//! stops it on the rim of one it does not, the hand feeling the spring's exact force, and
//! its contacts push a box on the floor by local dynamics to where the peg's face ends,
//! the world taking the push in.

use std::path::Path;

use glam::DVec3;
use hapticctl::multirate::Lockstep;
use hapticd_core::kinematics::Wrench;
use hapticd_physics::scene::{RapierScene, SceneFile};

/// The haptic rate, Hz.
const HAPTIC_RATE: f64 = 1000.0;
/// The god-object's spring, N/m (its default, which the scene keeps).
const STIFFNESS: f64 = 2000.0;
/// Coulomb's coefficient of the scene's material.
const FRICTION: f64 = 0.4;
/// Bodies of the scene, in its order (the held peg after the others).
const BOX: usize = 2;
const FAR_BOX: usize = 3;
const PEG: usize = 4;

/// A floor whose top is at y = −0.025, on it a block whose top is at y = 0 with a square hole
/// 10.2 mm wide and 15 mm deep (five box pieces), two 10 mm steel boxes on the floor at
/// x = 0.05 (one of them 5 cm further along z), and a square peg of `width`, 20 mm long,
/// held with its middle at y = 0.02 over the hole, in rapier's world at 100 Hz.
fn scene(width: f64) -> RapierScene {
    let text = format!(
        "name: peg
engine: rapier
rate: 100
gravity: [0, -9.81, 0]
material: {{ static_friction: {FRICTION}, friction: {FRICTION} }}
bodies:
  - {{ name: floor, box: [0.2, 0.01, 0.2], position: [0, -0.03, 0], fixed: true }}
  - name: block
    fixed: true
    position: [0, 0, 0]
    pieces:
      - {{ box: [0.0099, 0.015, 0.030], position: [-0.01005, -0.0075, 0] }}
      - {{ box: [0.0099, 0.015, 0.030], position: [0.01005, -0.0075, 0] }}
      - {{ box: [0.0102, 0.015, 0.0099], position: [0, -0.0075, -0.01005] }}
      - {{ box: [0.0102, 0.015, 0.0099], position: [0, -0.0075, 0.01005] }}
      - {{ box: [0.030, 0.010, 0.030], position: [0, -0.020, 0] }}
  - {{ name: box, box: [0.01, 0.01, 0.01], position: [0.05, -0.02, 0], density: 7800 }}
  - {{ name: far box, box: [0.01, 0.01, 0.01], position: [0.05, -0.02, 0.05], density: 7800 }}
  - {{ name: peg, box: [{width}, 0.020, {width}], position: [0, 0.02, 0], density: 7800 }}
pointer:
  holds: peg
"
    );
    match SceneFile::parse(&text, Path::new("peg.yaml"), 1) {
        Ok(SceneFile::Rapier(scene)) => *scene,
        Ok(SceneFile::Penalty(_)) => panic!("a penalty scene"),
        Err(e) => panic!("{e}"),
    }
}

/// Run `scene` with the grip along `way` (its position at each tick), still-handed
/// (the grip's velocity from one tick to the next); `each` sees every tick's run and wrench.
fn run(
    scene: &RapierScene,
    ticks: usize,
    way: impl Fn(usize) -> DVec3,
    mut each: impl FnMut(usize, &Lockstep, &Wrench),
) -> Lockstep {
    let mut run = Lockstep::new(
        scene,
        &Lockstep::pointers(&[(way(0), DVec3::ZERO)]),
        HAPTIC_RATE,
        0.0,
    );
    let mut felt = [Wrench::ZERO];
    for tick in 0..ticks {
        let velocity = (way(tick + 1) - way(tick)) * HAPTIC_RATE;
        let pointers = Lockstep::pointers(&[(way(tick), velocity)]);
        run.tick(&pointers, &mut felt).unwrap();
        assert!(felt[0].is_finite(), "tick {tick}");
        each(tick, &run, &felt[0]);
    }
    run
}

#[test]
fn a_held_peg_goes_into_a_hole_it_fits_and_stops_on_the_rim_of_one_it_does_not() {
    // Lowered from 20 mm over the block's top to 10 mm under it (5 mm under the hole's
    // floor for the peg's bottom), then held there.
    let way = |tick: usize| DVec3::new(0.0, 0.02 - 0.03 * (tick as f64 / 700.0).min(1.0), 0.0);
    for (width, stop) in [(0.010, -0.005), (0.0104, 0.010)] {
        let mut felt = Wrench::ZERO;
        let run = run(&scene(width), 1000, way, |_, _, w| felt = *w);
        let at = run.body(PEG).position;
        eprintln!("peg {width} m wide: its middle at {at}, the hand feels {felt:?}");
        // Its middle 10 mm over the floor it stands on (the hole's, or the rim), and never
        // through it by more than 10 µm.
        assert!((at.y - stop).abs() < 1e-5, "{width}: {at}");
        assert!(at.x.abs() < 1e-4 && at.z.abs() < 1e-4, "{width}: {at}");
        // At rest, the spring alone: its stiffness times how far the grip is past the peg.
        let pressed = STIFFNESS * (stop - way(1000).y);
        assert!((felt.force.y - pressed).abs() < 0.05, "{width}: {felt:?}");
        // The world has the peg where the god-object put it, as of its last step: a proxy
        // pressed on the rim still creeps by nanometres a period (measured: 1e-8 m).
        let world = run.world.body(PEG).position;
        assert!(world.distance(at) < 1e-6, "{width}: {world} against {at}");
    }
}

#[test]
fn a_held_peg_pushes_a_box_along_the_floor_to_where_its_face_ends() {
    // Beside the block, down to 3 mm over the floor, then along x at 0.1 m/s into the box
    // (the peg's face meets it with the grip at x = 0.04) to x = 0.065, and held.
    let speed = 0.1;
    let way = |tick: usize| match tick {
        0..300 => DVec3::new(0.025 * tick as f64 / 300.0, 0.02, 0.0),
        300..600 => DVec3::new(0.025, 0.02 - 0.032 * (tick - 300) as f64 / 300.0, 0.0),
        _ => DVec3::new(
            0.025 + speed * ((tick - 600) as f64 / HAPTIC_RATE).min(0.4),
            -0.012,
            0.0,
        ),
    };
    let (mut resisted, mut pushing) = (0.0, 0);
    let run = run(&scene(0.010), 1600, way, |tick, _, w| {
        // While the peg's face drives the box on at the hand's speed.
        if (800..1000).contains(&tick) {
            resisted -= w.force.x;
            pushing += 1;
        }
    });
    let (pushed, far) = (run.body(BOX).position, run.body(FAR_BOX).position);
    let resisted = resisted / pushing as f64;
    eprintln!("the box at {pushed}, the far one at {far}; the hand felt {resisted} N pushing");
    // The peg's face ends at x = 0.065 + 0.005: the box's near face there, plus how far it
    // slid on once the hand stopped, v²/(2μg).
    let slid = speed * speed / (2.0 * FRICTION * 9.81);
    let near_face = pushed.x - 0.005;
    assert!(
        (0.07 - 1e-4..0.07 + slid + 1e-4).contains(&near_face),
        "its near face at {near_face}"
    );
    // It stays on the floor, and the box out of the peg's way does not move.
    assert!((pushed.y + 0.02).abs() < 2e-4, "{pushed}");
    assert!(far.distance(DVec3::new(0.05, -0.02, 0.05)) < 1e-4, "{far}");
    // The hand feels the box's sliding friction, μ·m·g.
    let friction = FRICTION * 7800.0 * 1e-6 * 9.81;
    assert!(
        (resisted - friction).abs() < 0.2 * friction,
        "{resisted} N against {friction} N"
    );
    // The world took in what the hand did.
    let world = run.world.body(BOX).position;
    assert!(world.distance(pushed) < 5e-4, "{world} against {pushed}");
}
