//! Studies of a mechanism over its workspace: the thesis' tension sweep (Fig. 3.15) and the
//! complete-presentation region (Fig. 3.13, 3.19).

use glam::{DQuat, DVec3};

use super::Mechanism;
use crate::kinematics::{Pose, Wrench};
use crate::solver::closure::is_force_closed;
use crate::solver::geometry::StringGeometry;
use crate::solver::tension::TensionSettings;

/// Tensions along a straight path for several λ.
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    /// Sample positions along the path.
    pub positions: Vec<DVec3>,
    /// The λ values swept.
    pub lambdas: Vec<f64>,
    /// `tensions[l][s][i]`: tension of string i at sample s for λ index l.
    pub tensions: Vec<Vec<Vec<f64>>>,
    /// Whether the grip is in the complete region at each sample.
    pub closed: Vec<bool>,
}

impl Sweep {
    /// Largest change of any string's tension between neighbouring samples, per λ.
    pub fn largest_jumps(&self) -> Vec<f64> {
        self.tensions
            .iter()
            .map(|per_sample| {
                per_sample
                    .windows(2)
                    .flat_map(|w| w[0].iter().zip(&w[1]).map(|(a, b)| (a - b).abs()))
                    .fold(0.0, f64::max)
            })
            .collect()
    }
}

/// Tensions of effector `effector` for a constant `wrench` while its grip moves from `from`
/// to `to` (orientation `orientation`) in `samples` steps, for each of `lambdas`, every
/// wrench component weighted 1 as in eq. 3.16. Solvers are warm-started along the path, as
/// in the haptic loop.
pub fn tension_sweep(
    mechanism: &Mechanism,
    effector: usize,
    (from, to): (DVec3, DVec3),
    orientation: DQuat,
    wrench: &Wrench,
    lambdas: &[f64],
    samples: usize,
) -> Sweep {
    let kinematics = mechanism.kinematics(effector);
    let positions: Vec<DVec3> = (0..samples)
        .map(|s| from.lerp(to, s as f64 / (samples.max(2) - 1) as f64))
        .collect();
    let geometries: Vec<StringGeometry> = positions
        .iter()
        .map(|&position| {
            StringGeometry::at(
                &kinematics,
                &Pose {
                    position,
                    orientation,
                },
            )
        })
        .collect();
    let tensions = lambdas
        .iter()
        .map(|&lambda| {
            let mut solver = mechanism.tension_solver(effector);
            solver.set_settings(TensionSettings {
                lambda,
                torque_weight: 1.0,
            });
            geometries
                .iter()
                .map(|g| solver.solve(g, wrench).tensions().to_vec())
                .collect()
        })
        .collect();
    Sweep {
        closed: geometries.iter().map(is_force_closed).collect(),
        positions,
        lambdas: lambdas.to_vec(),
        tensions,
    }
}

/// Which points of a planar slice lie in the complete-presentation region.
#[derive(Debug, Clone, PartialEq)]
pub struct RegionSlice {
    /// Axes spanned by the slice (0 = x, 1 = y, 2 = z), horizontal then vertical.
    pub axes: (usize, usize),
    /// Lower corner of the slice in its two coordinates, and the cell size.
    pub origin: (f64, f64),
    /// Cell edge, metres.
    pub cell: f64,
    /// Cells per row.
    pub columns: usize,
    /// Force closure at each cell centre, row by row from the bottom.
    pub closed: Vec<bool>,
}

impl RegionSlice {
    /// Fraction of the slice inside the complete region.
    pub fn closed_fraction(&self) -> f64 {
        self.closed.iter().filter(|c| **c).count() as f64 / self.closed.len().max(1) as f64
    }
}

/// Force closure of effector `effector` over the plane through `centre` spanned by `axes`,
/// `resolution` cells a side, covering the motors' extent along those axes.
pub fn region_slice(
    mechanism: &Mechanism,
    effector: usize,
    centre: Pose,
    axes: (usize, usize),
    resolution: usize,
) -> RegionSlice {
    let kinematics = mechanism.kinematics(effector);
    let extent = kinematics
        .motors()
        .iter()
        .map(|m| m[axes.0].abs().max(m[axes.1].abs()))
        .fold(0.0, f64::max)
        * 1.1;
    let cell = 2.0 * extent / resolution as f64;
    let mut closed = Vec::with_capacity(resolution * resolution);
    for row in 0..resolution {
        for col in 0..resolution {
            let mut position = centre.position;
            position[axes.0] = -extent + (col as f64 + 0.5) * cell;
            position[axes.1] = -extent + (row as f64 + 0.5) * cell;
            let geometry = StringGeometry::at(
                &kinematics,
                &Pose {
                    position,
                    orientation: centre.orientation,
                },
            );
            closed.push(is_force_closed(&geometry));
        }
    }
    RegionSlice {
        axes,
        origin: (-extent, -extent),
        cell,
        columns: resolution,
        closed,
    }
}
