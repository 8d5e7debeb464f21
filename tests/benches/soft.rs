//! A soft block pinned at its base and pressed at its top by a hand's force, stepped one
//! device tick (1 ms) at a time: 504, 2 058 and 7 986 linear tetrahedra (Kuhn's cut of
//! 84, 343 and 1 331 cubes), and the same blocks of quadratic ones; the linear blocks again
//! under a finger dragged across them with friction; beside them, one tick of the penalty
//! engine's rigid block of the same size on a floor (the stack of one). Issue 48's goal:
//! 2 000 tetrahedra in 400 µs a tick.
//!
//! The multi-rate regime: a rapier world's step at 60 Hz with a soft block of 20 250 and
//! 48 000 linear tetrahedra pressed at its top by the hand's impulse, its plane and
//! compliance published to a finger above it; beside them the same world's step with the
//! block rigid.
//!
//! Run: `make bench`, or `cargo bench -p hapticd-e2e --bench soft`.

use divan::Bencher;
use glam::DVec3;
use hapticctl::experiments::stack_timing::{DT, stack};
use hapticd_physics::scene::SceneFile;
use hapticd_plugin_api::export::{PhysicsInput, PhysicsOutput};
use hapticd_plugin_api::{HapticdImpulse, HapticdPlanes, HapticdPointer};
use hapticd_rapier::world::RapierWorld;
use hapticd_soft::body::SoftBody;
use hapticd_soft::contact::{Friction, Obstacle, Obstacles, Touch};
use hapticd_soft::element::Order;
use hapticd_soft::implicit::{Solve, Solver, Stepped};
use hapticd_soft::lattice::cut_box;
use hapticd_soft::material::Material;

fn main() {
    divan::main();
}

/// Cubes along x, y and z for each size.
const GRIDS: [[usize; 3]; 3] = [[4, 7, 3], [7, 7, 7], [11, 11, 11]];

/// A device tick's solve: at most 20 iterations, done with the velocities within 0.1 mm/s
/// (each position within 0.1 µm of the tick's solution).
const TICK: Solve = Solve {
    budget: 20,
    tolerance: 1e-4,
};

/// The block of `cells` 1 cm cubes, of rubber, its base pinned, pressed for 0.2 s at its
/// top's middle node with 1 N, as it stands then.
fn pressed(cells: [usize; 3], order: Order, factored: bool) -> (SoftBody, Solver) {
    let half = DVec3::new(cells[0] as f64, cells[1] as f64, cells[2] as f64) * 0.005;
    let mesh = cut_box(DVec3::new(0.0, half.y, 0.0), half, 0.01, order);
    let material = Material {
        young: 1e5,
        poisson: 0.45,
        density: 1100.0,
        damping: 0.002,
    };
    let mut body = SoftBody::new(mesh, material);
    body.pin_below(1, 0.0);
    let top = (0..body.positions.len())
        .min_by(|&a, &b| {
            let at = |i: usize| (body.mesh.nodes[i] - DVec3::new(0.0, 2.0 * half.y, 0.0)).length();
            at(a).total_cmp(&at(b))
        })
        .expect("nodes");
    let mut solver = match factored {
        true => Solver::factored(&body, 0.001).expect("a physical block"),
        false => Solver::new(body.positions.len()),
    };
    for _ in 0..200 {
        body.forces[top] = DVec3::new(0.0, -1.0, 0.0);
        step(&mut body, &mut solver);
    }
    (body, solver)
}

/// One device tick of `body` under gravity.
fn step(body: &mut SoftBody, solver: &mut Solver) -> Stepped {
    let gravity = DVec3::new(0.0, -9.81, 0.0);
    body.step(0.001, gravity, Obstacles::NONE, &mut [], TICK, solver)
}

/// One tick of the pressed block: its elements' turns, its forces and its solve,
/// preconditioned by its factored rest system or by its nodes' own diagonals.
fn tick(bencher: Bencher, cells: [usize; 3], order: Order, factored: bool) {
    let (mut body, mut solver) = pressed(cells, order, factored);
    let elements = body.mesh.element_count();
    let stepped = step(&mut body, &mut solver);
    println!("{elements} {order:?} elements, factored {factored}: {stepped:?} a tick");
    bencher.bench_local(|| step(&mut body, &mut solver));
}

#[divan::bench(args = GRIDS)]
fn linear_tick(bencher: Bencher, cells: [usize; 3]) {
    tick(bencher, cells, Order::Linear, true);
}

#[divan::bench(args = GRIDS)]
fn linear_tick_diagonal(bencher: Bencher, cells: [usize; 3]) {
    tick(bencher, cells, Order::Linear, false);
}

#[divan::bench(args = GRIDS)]
fn quadratic_tick(bencher: Bencher, cells: [usize; 3]) {
    tick(bencher, cells, Order::Quadratic, true);
}

/// A finger (a box 2 cm square) pressed 1 mm into the middle of the top of a block of
/// `cells`, dragged along it at 1 cm/s with friction (μs = 0.4, μk = 0.3): a tick of the
/// block under the finger, its contacts sticking, sliding and coming and going.
#[divan::bench(args = GRIDS)]
fn linear_tick_under_a_dragged_finger(bencher: Bencher, cells: [usize; 3]) {
    let (mut body, mut solver) = pressed(cells, Order::Linear, true);
    let elements = body.mesh.element_count();
    let top = body.mesh.nodes.iter().map(|p| p.y).fold(f64::MIN, f64::max);
    let mut x = 0.0;
    let mut planes = [(DVec3::ZERO, 0.0); 6];
    let mut touch = [Touch::default()];
    let mut tick = || {
        x += 1e-5;
        // The finger's faces, its bottom 1 mm below the block's top.
        let centre = DVec3::new(x, top + 0.01 - 0.001, 0.0);
        for (k, axis) in [DVec3::X, DVec3::Y, DVec3::Z].into_iter().enumerate() {
            for (j, side) in [1.0, -1.0].into_iter().enumerate() {
                let n = axis * side;
                planes[2 * k + j] = (n, n.dot(centre) + 0.01);
            }
        }
        let solids = [Obstacle {
            faces: (0, 6),
            centre,
            velocity: DVec3::new(0.01, 0.0, 0.0),
            spin: DVec3::ZERO,
        }];
        let finger = Obstacles {
            planes: &planes,
            solids: &solids,
            friction: Friction {
                stick: 0.4,
                slide: 0.3,
            },
        };
        let gravity = DVec3::new(0.0, -9.81, 0.0);
        body.step(0.001, gravity, finger, &mut touch, TICK, &mut solver)
    };
    // Pressed and sliding before it is timed.
    for _ in 0..200 {
        tick();
    }
    println!(
        "{elements} elements under a dragged finger: {:?} a tick",
        tick()
    );
    bencher.bench_local(tick);
}

/// The penalty engine's one block resting on its floor, a tick (its steps of [`DT`]).
#[divan::bench]
fn rigid_tick(bencher: Bencher) {
    let mut world = stack(1);
    world.sleeping = false;
    let steps = (0.001 / DT).round() as usize;
    bencher.bench_local(|| {
        for _ in 0..steps {
            world.step(DT);
        }
    });
}

/// Cubes along each side of the multi-rate blocks (of 0.4 cm): 20 250 and 48 000
/// tetrahedra.
const MULTIRATE_BLOCKS: [[usize; 3]; 2] = [[15, 15, 15], [20, 20, 20]];

/// A rapier world at 60 Hz of a block of `cells` 4 mm cubes on a floor, soft (pinned to the
/// floor) or rigid.
fn multirate_block(cells: [usize; 3], soft: bool) -> RapierWorld {
    let size = DVec3::new(cells[0] as f64, cells[1] as f64, cells[2] as f64) * 0.004;
    let kind = match soft {
        true => {
            ", soft: { young: 1.0e5, poisson: 0.45, damping: 0.002, resolution: 0.004 }, \
             pinned: { body: floor }"
        }
        false => "",
    };
    let text = format!(
        "name: block\nengine: rapier\nrate: 60\nmaterial: {{ static_friction: 0.4, \
         friction: 0.3 }}\nbodies:\n  - {{ name: floor, box: [0.3, 0.01, 0.3], position: \
         [0, -0.005, 0], fixed: true }}\n  - {{ name: block, box: [{}, {}, {}], position: [0, \
         {}, 0], density: 1100{kind} }}\n",
        size.x,
        size.y,
        size.z,
        size.y / 2.0
    );
    let SceneFile::Rapier(spec) =
        SceneFile::parse(&text, std::path::Path::new("block.yaml"), 1).expect("a valid scene")
    else {
        unreachable!("a rapier scene");
    };
    RapierWorld::new(&spec, 1)
}

/// One 60 Hz step of [`multirate_block`] pressed at its top's middle with 1 N (its object:
/// the floor's collider is 0) under a finger just above it.
fn multirate_step(bencher: Bencher, cells: [usize; 3], soft: bool) {
    let mut world = multirate_block(cells, soft);
    let top = cells[1] as f64 * 0.004;
    let dt = 1.0 / 60.0;
    let finger = [HapticdPointer {
        position: [0.0011, top + 0.0005, 0.0013],
        ..HapticdPointer::default()
    }];
    let pressed = [HapticdImpulse {
        object: 1,
        point: [0.0011, top, 0.0013],
        impulse: [0.0, -dt, 0.0],
    }];
    let mut planes = [HapticdPlanes::default()];
    let step = |world: &mut RapierWorld, planes: &mut [HapticdPlanes; 1]| {
        let input = PhysicsInput {
            dt,
            pointers: &finger,
            proxies: &finger,
            impulses: &pressed,
            locals: &[],
        };
        let mut output = PhysicsOutput {
            planes,
            bodies: &mut [],
            body_count: &mut 0,
        };
        assert!(world.step(&input, &mut output));
    };
    for _ in 0..30 {
        step(&mut world, &mut planes);
    }
    if let Some(part) = world.soft_bodies().first() {
        let elements = part.body.mesh.element_count();
        println!("{elements} elements at 60 Hz: {:?} a step", part.stepped);
    }
    bencher.bench_local(|| step(&mut world, &mut planes));
}

#[divan::bench(args = MULTIRATE_BLOCKS)]
fn multirate_soft_step(bencher: Bencher, cells: [usize; 3]) {
    multirate_step(bencher, cells, true);
}

#[divan::bench(args = MULTIRATE_BLOCKS)]
fn multirate_rigid_step(bencher: Bencher, cells: [usize; 3]) {
    multirate_step(bencher, cells, false);
}
