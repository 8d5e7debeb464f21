//! A peg put into its hole through a held part's 6-DOF god-object (thesis 7.2, assembly with
//! the hands): a hand script moves the grip (by default `config/hands/peg-in-hole.yaml`:
//! approach with the peg tilted, lean it on the rim, wobble it there, turn it upright over
//! the hole and push it in) and the god-object keeps the peg out of the block's triangles.
//! The peg and the block are those of the shipped `peg-in-hole` scene, the hole made as wide
//! as each run's clearance asks.
//!
//! For each clearance it reports how deep the peg's bottom went below the block's top, how
//! far either solid went into the other (by the exact formulas of both, not the meshes'
//! queries under test), the largest force and torque the hand felt, the ticks the
//! god-object kept its pose because it found too much, and what a tick cost on this machine.

use std::time::Instant;

use glam::{DQuat, DVec3};
use hapticd_core::diagnostics::Diagnostics;
use hapticd_core::haptics::god_object::{GodObject, GodObjectParameters, Obstacle};
use hapticd_device::sim::hand::{HandTrack, Script};
use serde_json::{Value, json};

use crate::parts::{Block, MM, Overlap, Section, peg};
use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;

/// The shipped hand script.
pub const HAND: &str = include_str!("../../../../config/hands/peg-in-hole.yaml");
/// The block's top, metres (the shipped scene's): the hole is about the y axis.
pub const TOP: f64 = -0.03;
/// The haptic tick, seconds.
const DT: f64 = 1e-3;
/// Every how many ticks the exact overlap is measured (it costs thousands of formulas).
const MEASURE_EVERY: usize = 5;

/// A peg and its hole.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// The sides of both sections (4: square; many: round).
    pub sides: usize,
    /// The peg's width across its sides, metres.
    pub width: f64,
    /// The peg's length, metres.
    pub length: f64,
    /// The hole's width less the peg's, metres (less than 0: interference).
    pub clearance: f64,
    /// The hole's depth, metres.
    pub depth: f64,
}

impl Fit {
    /// The shipped scene's peg, 10 mm wide and 20 mm long, of `sides` sides, in a hole 15 mm
    /// deep of `clearance`.
    pub fn shipped(sides: usize, clearance: f64) -> Fit {
        Fit {
            sides,
            width: 10.0 * MM,
            length: 20.0 * MM,
            clearance,
            depth: 15.0 * MM,
        }
    }

    fn section(&self) -> Section {
        Section {
            sides: self.sides,
            apothem: self.width / 2.0,
        }
    }

    /// The block: 30 mm across, 25 mm tall, its top at y = 0 in its own frame.
    fn block(&self) -> Block {
        Block {
            outer: Section {
                sides: self.sides,
                apothem: 15.0 * MM,
            },
            hole: Section {
                sides: self.sides,
                apothem: (self.width + self.clearance) / 2.0,
            },
            height: 25.0 * MM,
            depth: self.depth,
        }
    }
}

/// The hand of `script`'s first (or only) effector; one that holds still without one.
pub fn hand(script: &Script) -> HandTrack {
    let steps = script.hands.values().next().cloned().unwrap_or_default();
    HandTrack::new(DVec3::ZERO, steps)
}

/// The shipped hand script.
pub fn shipped_script() -> Result<Script, Diagnostics> {
    Script::parse(HAND, std::path::Path::new("config/hands/peg-in-hole.yaml"))
}

/// What one tick cost, microseconds.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Cost {
    /// The median.
    pub median: f64,
    /// The 99.9th percentile.
    pub p999: f64,
    /// The most.
    pub most: f64,
}

impl Cost {
    /// Of the ticks' `costs`, microseconds (none: zeros).
    fn of(mut costs: Vec<f64>) -> Cost {
        costs.sort_by(f64::total_cmp);
        let rank = |q: f64| {
            let at = ((q * costs.len() as f64) as usize).min(costs.len().saturating_sub(1));
            costs.get(at).copied().unwrap_or(0.0)
        };
        Cost {
            median: rank(0.5),
            p999: rank(0.999),
            most: rank(1.0),
        }
    }
}

/// One insertion.
#[derive(Debug, Clone, PartialEq)]
pub struct Insertion {
    /// The fit tried.
    pub fit: Fit,
    /// (time s, the peg's bottom below the block's top m, force felt N, torque felt N·m)
    /// every tick.
    pub samples: Vec<(f64, f64, f64, f64)>,
    /// The deepest the peg's bottom went below the block's top, metres.
    pub reached: f64,
    /// The deepest either solid went into the other, metres.
    pub deepest: f64,
    /// The largest force felt, newtons.
    pub peak_force: f64,
    /// The largest torque felt, N·m.
    pub peak_torque: f64,
    /// How much the torque felt changes from one tick to the next while the peg leans on
    /// the block (pressed, its bottom within [`ON_TOP`] of the top): the mean, N·m.
    pub rim_chatter: f64,
    /// Ticks the god-object kept its last pose, having found too much.
    pub held_back: usize,
    /// What a tick of the god-object cost.
    pub cost: Cost,
}

/// Put the peg of `fit` into its hole with `hand` for `seconds`, the god-object ticking at
/// 1 kHz with its default spring and contacts of Coulomb's `friction`.
pub fn insert(fit: &Fit, hand: &HandTrack, seconds: f64, friction: f64) -> Insertion {
    let (section, block) = (fit.section(), fit.block());
    let (part, solid) = (peg(section, fit.length), block.mesh());
    let overlap = Overlap::new((&part, section), (&solid, &block));
    let top = DVec3::new(0.0, TOP, 0.0);
    let obstacles = [Obstacle {
        mesh: &solid,
        position: top,
        orientation: DQuat::IDENTITY,
    }];
    let grip = |t: f64| {
        let c = hand.at(t);
        (c.target, c.turn)
    };
    let (at, turn) = grip(0.0);
    let parameters = GodObjectParameters {
        friction,
        ..GodObjectParameters::default()
    };
    let mut god = GodObject::new(part, at, turn, parameters);
    let ticks = (seconds / DT).round() as usize;
    let mut run = Insertion {
        fit: *fit,
        samples: Vec::with_capacity(ticks),
        reached: f64::NEG_INFINITY,
        deepest: 0.0,
        peak_force: 0.0,
        peak_torque: 0.0,
        rim_chatter: 0.0,
        held_back: 0,
        cost: Cost::default(),
    };
    let mut costs = Vec::with_capacity(ticks);
    for tick in 1..=ticks {
        let t = tick as f64 * DT;
        let started = Instant::now();
        let out = god.update(grip(t), DT, obstacles);
        costs.push(started.elapsed().as_secs_f64() * 1e6);
        let (at, turn) = god.pose();
        let bottom = (god.part().samples().iter())
            .map(|&p| (turn * p + at).y)
            .fold(f64::INFINITY, f64::min);
        let below = TOP - bottom;
        let (force, torque) = (out.felt.force.length(), out.felt.torque.length());
        run.samples.push((t, below, force, torque));
        run.reached = run.reached.max(below);
        run.peak_force = run.peak_force.max(force);
        run.peak_torque = run.peak_torque.max(torque);
        run.held_back += usize::from(out.held_back);
        if tick % MEASURE_EVERY == 0 || tick == ticks {
            let into = overlap.at(&block, (section, fit.length), (at - top, turn));
            run.deepest = run.deepest.max(into);
        }
    }
    run.cost = Cost::of(costs);
    run.rim_chatter = rim_chatter(&run.samples);
    run
}

/// How far below the block's top the peg's bottom may be and still lean on it, metres.
pub const ON_TOP: f64 = 2.0 * MM;

/// The mean change of the torque felt from one tick to the next over the ticks that lean
/// on the block (pressed, by more than half a newton, with the bottom within [`ON_TOP`] of
/// the top), N·m; 0 without any.
fn rim_chatter(samples: &[(f64, f64, f64, f64)]) -> f64 {
    let leaning = |s: &(f64, f64, f64, f64)| s.2 > 0.5 && s.1 < ON_TOP;
    let changes: Vec<f64> = samples
        .windows(2)
        .filter(|w| leaning(&w[0]) && leaning(&w[1]))
        .map(|w| (w[1].3 - w[0].3).abs())
        .collect();
    changes.iter().sum::<f64>() / changes.len().max(1) as f64
}

/// The peg of `sides` sides put in with `hand` for `seconds` at each of `clearances`
/// (metres), its contacts of Coulomb's `friction`: the table of figures, and the depth,
/// force and torque against time.
pub fn report(
    sides: usize,
    clearances: &[f64],
    (hand, seconds): (&HandTrack, f64),
    friction: f64,
) -> Report {
    let runs: Vec<Insertion> = clearances
        .iter()
        .map(|&c| insert(&Fit::shipped(sides, c), hand, seconds, friction))
        .collect();
    let label = |r: &Insertion| format!("clearance {:+.2} mm", r.fit.clearance / MM);
    let chart = |title: &str, y_label: &str, value: fn(&(f64, f64, f64, f64)) -> f64| Chart {
        title: title.into(),
        x_label: "time [s]".into(),
        y_label: y_label.into(),
        series: runs
            .iter()
            .enumerate()
            .map(|(k, r)| Series {
                label: label(r),
                points: r.samples.iter().map(|s| (s.0, value(s))).collect(),
                color: PALETTE[k % PALETTE.len()],
            })
            .collect(),
        ..Chart::default()
    };
    let shape = if sides == 4 { "square" } else { "round" };
    let mut text = format!(
        "a {shape} peg 10 mm wide and 20 mm long into a hole 15 mm deep, the god-object at 1 kHz, \
         friction {friction}\n"
    );
    text += "  clearance   reached    into the block   peak force   peak torque   rim chatter    tick p50 / p99.9 / most   poses kept\n";
    for r in &runs {
        text += &format!(
            "  {:+7.3} mm  {:7.3} mm  {:9.4} mm    {:8.2} N  {:8.4} N·m  {:8.5} N·m   {:5.0} / {:5.0} / {:5.0} µs   {:6}\n",
            r.fit.clearance / MM,
            r.reached / MM,
            r.deepest / MM,
            r.peak_force,
            r.peak_torque,
            r.rim_chatter,
            r.cost.median,
            r.cost.p999,
            r.cost.most,
            r.held_back
        );
    }
    let rows: Vec<Value> = runs
        .iter()
        .map(|r| {
            json!({
                "clearance": r.fit.clearance,
                "reached": r.reached,
                "deepest": r.deepest,
                "peak_force": r.peak_force,
                "peak_torque": r.peak_torque,
                "rim_chatter": r.rim_chatter,
                "held_back": r.held_back,
                "tick_us": { "median": r.cost.median, "p999": r.cost.p999, "most": r.cost.most },
            })
        })
        .collect();
    Report {
        text,
        json: json!({ "sides": sides, "seconds": seconds, "friction": friction, "results": rows }),
        charts: vec![
            chart(
                "the peg's bottom below the block's top",
                "depth [mm]",
                |s| s.1 / MM,
            ),
            chart("force felt", "force [N]", |s| s.2),
            chart("torque felt", "torque [N m]", |s| s.3),
        ],
    }
}
