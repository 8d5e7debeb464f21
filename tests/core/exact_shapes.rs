//! A fingertip on a box or ball of rapier's world moved by local dynamics touches that solid
//! where the body is each tick, not the plane the last physics step found: slid off the top
//! of a block in a 10 Hz world, the finger drops off its edge as it passes it instead of
//! riding on the top's plane until the next step; and the pieces the world describes as
//! exact are the objects its planes name.

use std::path::Path;

use glam::DVec3;
use hapticctl::multirate::Lockstep;
use hapticd_core::kinematics::Wrench;
use hapticd_physics::scene::{RapierScene, SceneFile};

use crate::support;

/// The haptic rate, Hz.
const HAPTIC_RATE: f64 = 1000.0;

fn parse(text: &str) -> RapierScene {
    match SceneFile::parse(text, Path::new("edge.yaml"), 1) {
        Ok(SceneFile::Rapier(scene)) => *scene,
        Ok(SceneFile::Penalty(_)) => panic!("a penalty scene"),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn a_finger_slid_off_a_blocks_top_drops_off_its_edge_as_it_passes_it() {
    // Down onto the top's middle, pressed 1 mm in, then along x past the edge at x = 0.05
    // to x = 0.08 at 0.13 m/s, and held there.
    let way = |tick: usize| match tick {
        0..200 => DVec3::new(0.0, 0.07, 0.0),
        200..500 => DVec3::new(0.0, 0.07 - 0.021 * (tick - 200) as f64 / 300.0, 0.0),
        _ => DVec3::new(0.08 * ((tick - 500) as f64 / 600.0).min(1.0), 0.049, 0.0),
    };
    let scene = parse(support::BLOCK_AT_10_HZ);
    let start = Lockstep::pointers(&[(way(0), DVec3::ZERO)]);
    let mut run = Lockstep::new(&scene, &start, HAPTIC_RATE, 0.0);
    let mut felt = [Wrench::ZERO];
    let (mut beyond, mut beyond_pressed, mut pressed_on_top) = (0, 0, 0);
    // Where the world's first step settles the block (rapier's first 0.1 s step shifts it by
    // a millimetre or so, before the finger comes).
    let mut settled = None;
    for tick in 0..1300 {
        let velocity = (way(tick + 1) - way(tick)) * HAPTIC_RATE;
        run.tick(&Lockstep::pointers(&[(way(tick), velocity)]), &mut felt)
            .unwrap();
        let block = run.body(1).position;
        let settled = *settled.get_or_insert(block);
        let (grip, edge) = (way(tick), block.x + 0.05);
        let force = felt[0].force.length();
        if tick > 500 && grip.x < edge - 0.005 {
            pressed_on_top += usize::from(force > 1.0);
        }
        // A millimetre past the edge the grip is outside the block: nothing to press on.
        if grip.x > edge + 1e-3 {
            beyond += 1;
            beyond_pressed += usize::from(force > 0.1);
        }
        // The finger's light press moves the block no more than a hair.
        assert!(
            block.distance(settled) < 1e-4,
            "tick {tick}: {block} from {settled}"
        );
    }
    eprintln!(
        "pressed on the top in {pressed_on_top} ticks; {beyond_pressed} of {beyond} past the edge"
    );
    assert!(pressed_on_top > 300, "{pressed_on_top}");
    assert!(beyond > 300, "{beyond}");
    assert_eq!(beyond_pressed, 0, "of {beyond} ticks past the edge");
}

#[test]
fn the_exact_pieces_a_world_describes_are_the_objects_its_planes_name() {
    let balls = support::repo_dir().join("config/scenes/balls.yaml");
    let scene = parse(&std::fs::read_to_string(balls).unwrap());
    let world = hapticd_rapier::world::RapierWorld::new(&scene, 1);
    let pieces = scene.surface_pieces();
    let exact: Vec<_> = pieces
        .iter()
        .filter_map(|p| Some((p.body, p.exact?)))
        .collect();
    // Five boxes (the floor and four walls) and twelve balls, each one object of its own.
    assert_eq!(exact.len(), 17, "{exact:?}");
    for (body, (object, _)) in exact {
        assert_eq!(
            world.object_body(object),
            Some(body as usize),
            "object {object}"
        );
    }
}
