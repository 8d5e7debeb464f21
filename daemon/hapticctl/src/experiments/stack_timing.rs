//! The cost of one physics step against the number of stacked blocks (thesis 5.4.2,
//! Fig. 5.10), for the contact-volume and the deepest-point penalty methods.

use std::time::Instant;

use glam::{DQuat, DVec3};
use hapticd_physics::body::Body;
use hapticd_physics::friction::FrictionParameters;
use hapticd_physics::polyhedron::Polyhedron;
use hapticd_physics::world::{ContactModel, Material, World};
use serde_json::{Value, json};

use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;

/// Edge of a block, metres.
pub const SIDE: f64 = 0.1;
/// Density of a block, kg/m³ (1 kg blocks).
pub const DENSITY: f64 = 1000.0;
/// Contact stiffness, N/m³: enough for 100 blocks to stand. On elastic contacts a stack is a
/// column whose bending stiffness is k·s⁵/12 (s: the edge), which buckles under its own
/// weight past q·L³ = 7.84·EI (q = ρ·g·s², L = n·s): k > 1.53·ρ·g·n³, 1.5·10¹⁰ for 100
/// blocks; at 10⁹ such a stack leaned over and fell within ten seconds.
pub const STIFFNESS: f64 = 3e10;
/// Physics step, seconds, short enough for that stiffness.
pub const DT: f64 = 2.5e-5;

/// A stack of `n` blocks on a floor, each contact pressed to the depth that carries the
/// blocks above it, settled for 40 ms on volume contacts so every contact is established.
pub fn stack(n: usize) -> World {
    let area = SIDE * SIDE;
    let mass = DENSITY * SIDE.powi(3);
    let critical = 2.0 * (STIFFNESS * area * mass).sqrt() / area;
    let floor = Polyhedron::cuboid(DVec3::new(1.0, 0.1, 1.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, -0.1, 0.0));
    let mut bodies = vec![Body::new(&floor, DENSITY, true)];
    let mut base = 0.0;
    for i in 0..n {
        base -= (n - i) as f64 * mass * 9.81 / (STIFFNESS * area);
        let block = Polyhedron::cuboid(DVec3::splat(SIDE / 2.0))
            .transformed(DQuat::IDENTITY, DVec3::new(0.0, base + SIDE / 2.0, 0.0));
        bodies.push(Body::new(&block, DENSITY, false));
        base += SIDE;
    }
    let mut world = World::new(
        bodies,
        DVec3::new(0.0, -9.81, 0.0),
        Material {
            stiffness: STIFFNESS,
            damping: critical,
            friction: FrictionParameters {
                static_coefficient: 0.6,
                dynamic_coefficient: 0.5,
                stiffness: STIFFNESS,
                damping: critical,
                slip_speed: 1e-3,
            },
            model: ContactModel::Volume,
            scaling: None,
        },
    );
    for _ in 0..(0.04 / DT) as usize {
        world.step(DT);
    }
    world
}

/// `settled` switched to the deepest-point model, with each face's stiffness and damping
/// gathered at that point. The deepest point cannot hold a stack (the thesis' 13 blocks fall
/// after 1.8 s; these, stiffer, topple at once), so its steps are taken from a stack settled
/// on volume contacts.
pub fn as_point_contacts(settled: &World) -> World {
    let mut world = settled.clone();
    world.material.stiffness *= SIDE * SIDE;
    world.material.damping *= SIDE * SIDE;
    world.material.model = ContactModel::Point;
    world
}

/// Median time of one step, seconds, for the volume and the point model on a stack of `n`,
/// over `samples` steps each (every point step starts again from the settled stack).
pub fn step_times(n: usize, samples: usize) -> (f64, f64) {
    let mut volume = stack(n);
    // The cost of computing every contact, as the thesis measures it: no body sleeps.
    volume.sleeping = false;
    let settled = volume.clone();
    let mut times = Vec::with_capacity(samples);
    for _ in 0..samples {
        let start = Instant::now();
        volume.step(DT);
        times.push(start.elapsed().as_secs_f64());
    }
    let volume_time = median(&mut times);
    times.clear();
    for _ in 0..samples {
        let mut world = as_point_contacts(&settled);
        let start = Instant::now();
        world.step(DT);
        times.push(start.elapsed().as_secs_f64());
    }
    (volume_time, median(&mut times))
}

/// Fig. 5.10: the median step time of both models on stacks of each of `heights`, timed
/// over `samples` steps each, in microseconds.
pub fn report(heights: &[usize], samples: usize) -> Report {
    let results: Vec<(usize, f64, f64)> = heights
        .iter()
        .map(|&n| {
            let (volume, point) = step_times(n, samples);
            (n, volume * 1e6, point * 1e6)
        })
        .collect();
    let curve = |pick: fn(&(usize, f64, f64)) -> f64| -> Vec<(f64, f64)> {
        results.iter().map(|r| (r.0 as f64, pick(r))).collect()
    };
    let chart = Chart {
        title: "time of one physics step against stacked blocks".into(),
        x_label: "blocks".into(),
        y_label: "time per step [us]".into(),
        series: vec![
            Series {
                label: "contact-volume penalty".into(),
                points: curve(|r| r.1),
                color: PALETTE[0],
            },
            Series {
                label: "deepest-point penalty".into(),
                points: curve(|r| r.2),
                color: PALETTE[1],
            },
        ],
        // Head room above the curves for the legend.
        y_range: Some((
            0.0,
            1.4 * results.iter().fold(0.0_f64, |m, r| m.max(r.1).max(r.2)),
        )),
        ..Chart::default()
    };
    let mut text = String::new();
    for (n, volume, point) in &results {
        text += &format!("  {n:>4} blocks: volume {volume:8.1} us, point {point:8.1} us\n");
    }
    let rows: Vec<Value> = results
        .iter()
        .map(|(n, v, p)| json!({"blocks": n, "volume_us": v, "point_us": p}))
        .collect();
    Report {
        text,
        json: json!({ "results": rows }),
        charts: vec![chart],
    }
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_unstable_by(f64::total_cmp);
    values[values.len() / 2]
}
