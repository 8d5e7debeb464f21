//! A soft block pinned at its base and pressed at its top by a hand's force, stepped one
//! device tick (1 ms) at a time: 504, 2 058 and 7 986 linear tetrahedra (Kuhn's cut of
//! 84, 343 and 1 331 cubes), and the same blocks of quadratic ones; the linear blocks again
//! under a finger dragged across them with friction; beside them, one tick of the penalty
//! engine's rigid block of the same size on a floor (the stack of one). Issue 48's goal:
//! 2 000 tetrahedra in 400 µs a tick.
//!
//! Run: `make bench`, or `cargo bench -p hapticd-e2e --bench soft`.

use divan::Bencher;
use glam::DVec3;
use hapticctl::experiments::stack_timing::{DT, stack};
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
