//! A held part's 6-DOF god-object putting pegs into holes, all as triangle meshes: with
//! clearance the hand inserts the peg to the bottom, with interference it stops at the rim,
//! and it never enters the block deeper than 0.1 mm by an exact formula for the solids
//! (not the meshes' own queries); the torque felt against the rim is the rim contact's
//! moment, a hand beating the part on the block gets no energy back, and a part dragged
//! round the inside of the shipped mug stays inside it, touching its wall.

use std::path::Path;

use glam::{DQuat, DVec3};
use hapticd_core::haptics::god_object::{GodObject, GodObjectParameters, Obstacle};
use hapticd_core::haptics::passivity::{PassivityController, PassivityLimits};
use hapticd_core::haptics::signed_mesh::SignedMesh;
use hapticd_core::kinematics::rotation_vector;
use hapticd_mesh::{Limits, read};
use rapier3d::parry::query::PointQuery;
use rapier3d::parry::shape::{TriMesh, TriMeshFlags};
use rapier3d::prelude::Vector;

use hapticctl::parts::{
    Block, MM, Overlap, SPACING, Section, edge_points, peg, square_peg_and_block,
};

/// The haptic tick.
const DT: f64 = 1e-3;
/// `mesh` as the one obstacle, its frame the world's.
fn unmoved(mesh: &SignedMesh) -> [Obstacle<'_>; 1] {
    [Obstacle {
        mesh,
        position: DVec3::ZERO,
        orientation: DQuat::IDENTITY,
    }]
}

/// A peg of `sides` sides and 10 mm across, 20 mm long, put by a hand into a hole 15 mm
/// deep of `clearance` (the hole's width less the peg's), the hand 0.03 mm off and turned
/// 1° about z (so that the peg, 20 mm long, does not fit unless it turns): the peg's lowest point in the end, and the deepest it went into the block.
fn insert(sides: usize, clearance: f64) -> (f64, f64) {
    let (length, width) = (20.0 * MM, 10.0 * MM);
    let section = Section {
        sides,
        apothem: width / 2.0,
    };
    let block = Block {
        outer: Section {
            sides,
            apothem: 15.0 * MM,
        },
        hole: Section {
            sides,
            apothem: (width + clearance) / 2.0,
        },
        height: 25.0 * MM,
        depth: 15.0 * MM,
    };
    let (part, solid) = (peg(section, length), block.mesh());
    let overlap = Overlap::new((&part, section), (&solid, &block));
    let turn = DQuat::from_rotation_z(1f64.to_radians());
    // The peg's tip centred over the hole to within the hand's 0.03 mm.
    let start = DVec3::new(0.03 * MM, 5.0 * MM, 0.0) + turn * DVec3::Y * (length / 2.0);
    let mut god = GodObject::new(part, start, turn, GodObjectParameters::default());
    let obstacles = unmoved(&solid);
    let mut deepest = 0.0f64;
    // Down at 40 mm/s for 0.6 s (to 4 mm below the hole's floor), then held there.
    for tick in 0..800 {
        let down = 40.0 * (tick.min(600) as f64 * DT);
        let grip = (start - DVec3::Y * down * MM, turn);
        let out = god.update(grip, DT, obstacles);
        assert!(!out.held_back, "tick {tick}");
        assert!(out.felt.is_finite());
        // The god-object's own account every tick, the exact one every 25th.
        assert!(
            out.penetration <= 0.1 * MM,
            "tick {tick}: {}",
            out.penetration
        );
        if tick % 25 == 0 || tick >= 790 {
            deepest = deepest.max(overlap.at(&block, (section, length), god.pose()));
        }
    }
    let (at, turn) = god.pose();
    let lowest = (god.part().samples().iter())
        .map(|&p| (turn * p + at).y)
        .fold(f64::INFINITY, f64::min);
    (lowest, deepest)
}

#[test]
fn a_peg_with_clearance_goes_to_the_bottom_and_one_with_interference_stops_at_the_rim() {
    for sides in [4, 48] {
        let name = if sides == 4 { "square" } else { "round" };
        let (bottom, deepest) = insert(sides, 0.2 * MM);
        eprintln!(
            "{name} peg, 0.2 mm clearance: its bottom at {:.4} mm, at most {:.4} mm into the block",
            bottom / MM,
            deepest / MM
        );
        assert!((bottom + 15.0 * MM).abs() < 0.01 * MM, "{name}: {bottom}");
        assert!(deepest <= 0.1 * MM, "{name}: {deepest}");
        let (bottom, deepest) = insert(sides, -0.2 * MM);
        eprintln!(
            "{name} peg, 0.2 mm interference: its bottom at {:.4} mm, at most {:.4} mm into the block",
            bottom / MM,
            deepest / MM
        );
        assert!(bottom.abs() < 0.1 * MM, "{name}: {bottom}");
        assert!(deepest <= 0.1 * MM, "{name}: {deepest}");
    }
}

#[test]
fn the_torque_felt_against_the_rim_is_the_rim_contacts_moment() {
    let (part, _, block) = square_peg_and_block();
    let solid = block.mesh();
    let obstacles = unmoved(&solid);
    let (half, rim) = (10.0 * MM, block.hole.apothem);
    for degrees in [5.0f64, 10.0, 20.0] {
        // Tilted so, the peg's bottom face spans the rim's edge along z at x = 5.1 mm: the
        // edge is the one contact. The hand goes 3 mm past where the face meets it.
        let tilt = degrees.to_radians();
        let turn = DQuat::from_rotation_z(tilt);
        let touching = (half - rim * tilt.sin()) / tilt.cos();
        let start = DVec3::new(0.0, touching + 2.0 * MM, 0.0);
        let mut god = GodObject::new(part.clone(), start, turn, GodObjectParameters::default());
        let mut felt = None;
        for tick in 0..800 {
            // At 20 mm/s, to 3 mm past the touch.
            let down = (20.0 * MM * tick as f64 * DT).min(5.0 * MM);
            felt = Some(
                god.update((start - DVec3::Y * down, turn), DT, obstacles)
                    .felt,
            );
        }
        let felt = felt.expect("ticked");
        let (at, proxy_turn) = god.pose();
        // Statics of the rim contact: the rim's edge, the line x = 5.1 mm, y = 0 along z,
        // bears the felt force. Its moment about the tilt's axis (z) does not depend on
        // where along the edge it bears; about x and y it would, and how a line contact
        // shares its load along the line is not settled by statics, so those are not held
        // to it.
        let contact = DVec3::new(rim, 0.0, at.z);
        let moment = (contact - at).cross(felt.force);
        eprintln!(
            "tilted {degrees}°: felt {:.4} N, {:.5} N·m; the rim contact's moment {:.5} N·m",
            felt.force, felt.torque, moment
        );
        assert!(felt.force.length() > 1.0, "{felt:?}");
        // The rim pushes the face up and off itself, away from the rim.
        let normal = proxy_turn * DVec3::Y;
        assert!(
            felt.force.y > 0.0 && felt.force.x * normal.x > 0.0,
            "{felt:?}"
        );
        assert!(
            (felt.torque.z - moment.z).abs() <= 0.1 * moment.z.abs(),
            "{degrees}°: {felt:?} against {moment}"
        );
    }
}

#[test]
fn a_hand_beating_the_part_on_the_block_gets_no_energy_back() {
    let (part, _, block) = square_peg_and_block();
    let solid = block.mesh();
    let obstacles = unmoved(&solid);
    // Over the block's top beside the hole: from 2 mm above it to 2 mm into it twice a
    // second, sliding to and fro along x and rocking about it meanwhile.
    let grip = |tick: usize| {
        let t = tick as f64 * DT;
        let tau = std::f64::consts::TAU;
        let position = DVec3::new(
            10.0 * MM + 1.5 * MM * (tau * t).sin(),
            12.0 * MM - 4.0 * MM * (1.0 - (tau * 2.0 * t).cos()) / 2.0,
            0.0,
        );
        (
            position,
            DQuat::from_rotation_x(3f64.to_radians() * (tau * 1.5 * t).sin()),
        )
    };
    let mut god = GodObject::new(part, grip(0).0, grip(0).1, GodObjectParameters::default());
    let mut passivity = [PassivityController::new(PassivityLimits::default()); 2];
    let (mut given, mut raw) = (0.0, 0.0);
    let mut cycles = Vec::new();
    let mut velocity = (DVec3::ZERO, DVec3::ZERO);
    for tick in 0..4000 {
        let (now, next) = (grip(tick), grip(tick + 1));
        let felt = god.update(now, DT, obstacles).felt;
        let force = passivity[0].filter(felt.force, velocity.0, DT);
        let torque = passivity[1].filter(felt.torque, velocity.1, DT);
        // The hand moves on while the wrench is displayed through the tick: the work done
        // on it is the wrench times that motion.
        let moved = (next.0 - now.0, rotation_vector(next.1 * now.1.inverse()));
        given += force.dot(moved.0) + torque.dot(moved.1);
        raw += felt.force.dot(moved.0) + felt.torque.dot(moved.1);
        // What the loop knows at the next tick: the motion it just saw.
        velocity = (moved.0 / DT, moved.1 / DT);
        if (tick + 1) % 500 == 0 {
            cycles.push((given, raw));
            (given, raw) = (0.0, 0.0);
        }
    }
    for (k, (given, raw)) in cycles.iter().enumerate() {
        eprintln!("cycle {k}: {given:.3e} J to the hand ({raw:.3e} J before the controller)");
        assert!(*raw <= 0.0, "cycle {k}: {raw} J");
        assert!(*given <= 0.0, "cycle {k}: {given} J");
    }
}

#[test]
fn a_part_dragged_round_the_mugs_inside_stays_inside_touching_the_wall() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/meshes/mug.obj");
    let mug = read(&file, 1.0, Limits::DEFAULT, None).expect("the shipped mug");
    let solid = SignedMesh::new(&mug.vertices, &mug.triangles, SPACING).expect("closed");
    // parry's own account of inside and outside (its pseudo-normals, single precision).
    let reference = TriMesh::with_flags(
        mug.vertices
            .iter()
            .map(|v| v.as_vec3())
            .map(|v| Vector::new(v.x, v.y, v.z))
            .collect(),
        mug.triangles.clone(),
        TriMeshFlags::ORIENTED,
    )
    .expect("a mesh");
    let depth = |p: DVec3| {
        let p = p.as_vec3();
        let projected = reference.project_local_point(Vector::new(p.x, p.y, p.z), true);
        let gap = (Vector::new(p.x, p.y, p.z) - projected.point).length() as f64;
        if projected.is_inside { gap } else { -gap }
    };
    // An 8 mm cube in the cup (36 mm inside radius, 4 mm walls, its floor at 6 mm): the
    // hand takes it from the middle at 45 mm up out to 2 mm past the wall, then once round.
    let part = peg(
        Section {
            sides: 4,
            apothem: 4.0 * MM,
        },
        8.0 * MM,
    );
    let points = edge_points(&part, 0.2 * MM);
    let centre = DVec3::new(0.0, 45.0 * MM, 0.0);
    let reach = (36.0 - 4.0 + 2.0) * MM;
    let grip = |tick: usize| {
        let t = tick as f64 * DT;
        let out = (t / 0.3).min(1.0);
        let angle = std::f64::consts::TAU * ((t - 0.3).max(0.0) / 2.0);
        centre + reach * out * DVec3::new(angle.cos(), 0.0, angle.sin())
    };
    let obstacles = unmoved(&solid);
    let mut god = GodObject::new(
        part,
        centre,
        DQuat::IDENTITY,
        GodObjectParameters::default(),
    );
    let (mut deepest, mut farthest_apart) = (0.0f64, 0.0f64);
    for tick in 0..2300 {
        let out = god.update((grip(tick), DQuat::IDENTITY), DT, obstacles);
        let (at, turn) = god.pose();
        let radial = DVec3::new(at.x, 0.0, at.z).length();
        assert!(
            radial < 36.0 * MM && at.y > 10.0 * MM,
            "tick {tick}: out at {at}"
        );
        if tick % 10 == 0 {
            let depths: Vec<f64> = points.iter().map(|&p| depth(turn * p + at)).collect();
            deepest = deepest.max(depths.iter().copied().fold(f64::MIN, f64::max));
            if tick >= 400 {
                // Going round, it leans on the wall: felt, and some corner touching it.
                let nearest = -depths.iter().copied().fold(f64::MIN, f64::max);
                farthest_apart = farthest_apart.max(nearest);
                assert!(out.felt.force.length() > 1.0, "tick {tick}: {:?}", out.felt);
            }
        }
    }
    eprintln!(
        "round the mug's inside: at most {:.4} mm into its wall, at most {:.4} mm from it",
        deepest / MM,
        farthest_apart / MM
    );
    assert!(deepest <= 0.1 * MM, "{deepest}");
    assert!(farthest_apart <= 0.05 * MM, "{farthest_apart}");
}

#[test]
fn a_tick_that_finds_too_much_keeps_the_last_pose_and_the_hand_feels_it() {
    // A plate 200 mm square lying on a block's top: its bottom edges' samples every 0.1 mm,
    // 8 000 of them all touching, more than a tick's table holds.
    let (half, thickness) = (100.0 * MM, 2.0 * MM);
    let plate = peg(
        Section {
            sides: 4,
            apothem: half,
        },
        thickness,
    );
    let block = Block {
        outer: Section {
            sides: 4,
            apothem: 150.0 * MM,
        },
        hole: Section {
            sides: 4,
            apothem: 1.0 * MM,
        },
        height: 25.0 * MM,
        depth: 15.0 * MM,
    }
    .mesh();
    let obstacles = unmoved(&block);
    let resting = DVec3::new(20.0 * MM, thickness / 2.0, 0.0);
    let mut god = GodObject::new(
        plate,
        resting,
        DQuat::IDENTITY,
        GodObjectParameters::default(),
    );
    for tick in 0..10 {
        // The hand pulls it along and down.
        let grip = resting + DVec3::new(1.0, -1.0, 0.0) * MM * (tick + 1) as f64;
        let out = god.update((grip, DQuat::IDENTITY), DT, obstacles);
        assert!(out.held_back, "tick {tick}");
        assert_eq!(god.pose(), (resting, DQuat::IDENTITY), "tick {tick}");
        // The spring to the pose kept, and the damper against the hand's motion since the
        // last tick (none the first tick).
        let p = GodObjectParameters::default();
        let moved = if tick > 0 {
            DVec3::new(1.0, -1.0, 0.0) * MM
        } else {
            DVec3::ZERO
        };
        let expected = p.stiffness * (resting - grip) - p.damping / DT * moved;
        assert!(
            (out.felt.force - expected).length() < 1e-9 * expected.length(),
            "{out:?}"
        );
    }
}

/// A 4 mm cube held on the block's top, pressed 4 mm into it (8 N through the 2 000 N/m
/// spring), then dragged 4 mm across it. With Coulomb friction μ = 0.5 it sticks while the
/// hand's pull is under μ times its press (2 mm of the spring's stretch) and then slides with
/// the hand feeling μ times the press across, as Coulomb says; without friction it follows
/// the hand across from the start and the hand feels nothing across.
#[test]
fn a_query_out_of_time_goes_on_at_the_next_tick_and_ends_where_a_whole_one_does() {
    // The square peg standing on the block's top beside the hole, the hand 1 mm below and
    // 0.5 mm aside: its bottom edges' 400 samples touch, a query of thousands of pairs.
    let (part, _, block) = square_peg_and_block();
    let solid = block.mesh();
    let obstacles = unmoved(&solid);
    let resting = DVec3::new(10.0 * MM, 10.0 * MM, 0.0);
    let grip = (resting + DVec3::new(0.5, -1.0, 0.0) * MM, DQuat::IDENTITY);
    // A tick of 10 ns gives the query 4 ns: each tick's walk stops at its first look at
    // the clock, a few dozen pairs of nodes on.
    let tick = 1e-8;
    let mut timed = GodObject::new(part, resting, DQuat::IDENTITY, Default::default());
    let mut whole = timed.clone();
    timed.keep_to_the_clock();
    let mut ticks = 0;
    while timed.update(grip, tick, obstacles).held_back {
        // Held where it was, touching nothing it has not finished looking at.
        assert_eq!(timed.pose(), (resting, DQuat::IDENTITY));
        assert!(timed.contacts().is_empty());
        ticks += 1;
        assert!(ticks < 100_000, "the query never ended");
    }
    assert!(ticks > 10, "done after {ticks} ticks");
    // Off the clock (a run in simulated time), one tick looks at everything: the same
    // contacts and the same step.
    assert!(!whole.update(grip, tick, obstacles).held_back);
    assert!(whole.contacts().len() >= 4, "{:?}", whole.contacts());
    assert_eq!(timed.contacts(), whole.contacts());
    assert_eq!(timed.pose(), whole.pose());
    assert_ne!(timed.pose().0, resting);
}

#[test]
fn a_query_out_of_time_whose_obstacle_moved_looks_again_from_the_start() {
    let (part, _, block) = square_peg_and_block();
    let solid = block.mesh();
    let resting = DVec3::new(10.0 * MM, 10.0 * MM, 0.0);
    let grip = (resting + DVec3::new(0.5, -1.0, 0.0) * MM, DQuat::IDENTITY);
    let mut god = GodObject::new(part, resting, DQuat::IDENTITY, Default::default());
    god.keep_to_the_clock();
    // The block lowered by 1 µm every tick: no query is ever finished, the part held.
    for k in 0..2000 {
        let obstacles = [Obstacle {
            mesh: &solid,
            position: DVec3::new(0.0, -1e-6 * k as f64, 0.0),
            orientation: DQuat::IDENTITY,
        }];
        assert!(god.update(grip, 1e-8, obstacles).held_back, "tick {k}");
        assert_eq!(god.pose(), (resting, DQuat::IDENTITY));
    }
    // Standing still, it finishes, where the block is now.
    let obstacles = [Obstacle {
        mesh: &solid,
        position: DVec3::new(0.0, -2e-3, 0.0),
        orientation: DQuat::IDENTITY,
    }];
    let mut whole = GodObject::new(
        god.part().clone(),
        resting,
        DQuat::IDENTITY,
        Default::default(),
    );
    while god.update(grip, 1e-8, obstacles).held_back {}
    whole.update(grip, 1e-8, obstacles);
    assert_eq!(god.contacts(), whole.contacts());
    assert_eq!(god.pose(), whole.pose());
}

#[test]
fn a_part_dragged_on_a_face_sticks_then_slides_by_coulombs_law() {
    let (_, _, block) = square_peg_and_block();
    let solid = block.mesh();
    let obstacles = unmoved(&solid);
    let cube = peg(
        Section {
            sides: 4,
            apothem: 2.0 * MM,
        },
        4.0 * MM,
    );
    let resting = DVec3::new(10.0 * MM, 2.0 * MM, 0.0);
    // A coefficient that is not a finite positive number (from a caller that did not check)
    // holds nothing, and panics nowhere.
    for mu in [0.5, 0.0, f64::NAN, f64::INFINITY, -1.0] {
        let sticks = mu > 0.0 && mu.is_finite();
        let parameters = GodObjectParameters {
            friction: mu,
            ..GodObjectParameters::default()
        };
        let mut god = GodObject::new(cube.clone(), resting, DQuat::IDENTITY, parameters);
        let mut stuck = 0.0f64;
        // Down 4 mm in 0.2 s, held 0.1 s, then 4 mm along z in 2 s.
        let hand = |tick: usize| {
            let t = tick as f64 * DT;
            let down = 4.0 * MM * (t / 0.2).min(1.0);
            let across = 4.0 * MM * ((t - 0.3) / 2.0).clamp(0.0, 1.0);
            resting + DVec3::new(0.0, -down, across)
        };
        for tick in 0..2600 {
            let grip = hand(tick);
            let felt = god.update((grip, DQuat::IDENTITY), DT, obstacles).felt;
            let (at, _) = god.pose();
            let pulled = grip.z - resting.z;
            let press = felt.force.y;
            if tick > 250 {
                // Pressed on the face by the spring's 8 N, with the damper's share of a
                // slide at 2 mm/s (0.01 N).
                assert!((press - 8.0).abs() < 0.02, "μ {mu}, tick {tick}: {felt:?}");
            }
            if sticks && pulled < 1.9 * MM {
                stuck = stuck.max((at.z - resting.z).abs());
            }
            if sticks && pulled > 2.2 * MM {
                let across = -felt.force.z;
                assert!(
                    (across - mu * press).abs() < 0.01 * mu * press,
                    "tick {tick}: {across} N across, {press} N pressed"
                );
            }
            if !sticks && tick > 250 {
                // Nothing but the solve's rounding (its tolerance, 1e-8 m, is 2e-5 N).
                assert!(felt.force.z.abs() < 1e-4, "tick {tick}: {felt:?}");
            }
        }
        let (at, _) = god.pose();
        let slid = at.z - resting.z;
        let expected = if sticks { 2.0 * MM } else { 4.0 * MM };
        eprintln!(
            "μ {mu}: slid {:.4} mm, at most {:.2e} mm while stuck",
            slid / MM,
            stuck / MM
        );
        assert!((slid - expected).abs() < 0.02 * MM, "μ {mu}: slid {slid}");
        // Stuck, it creeps by no more than the solve's tolerance a tick (1e-8 m; measured:
        // 0.74 µm over the 0.95 s it stuck).
        assert!(stuck < 1e-8 * 1000.0, "μ {mu}: crept {stuck} m while stuck");
    }
}
