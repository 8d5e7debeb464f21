//! A cantilever clamped at one end sags under its own weight (soft bodies, thesis 7.2):
//! its tip's sag against Euler–Bernoulli's q·L⁴/(8·E·I) for several Young's moduli, cut
//! into linear and into quadratic elements. Where the sag is small the quadratic elements
//! sag as the formula says; where it is a large part of the length the beam, turning as it
//! bends, sags less than the linear theory; linear elements lock, stiff in bending.

use glam::DVec3;
use hapticd_soft::body::SoftBody;
use hapticd_soft::element::Order;
use hapticd_soft::implicit::Solver;
use hapticd_soft::lattice::cut_box;
use hapticd_soft::material::Material;
use serde_json::{Value, json};

use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;

/// The beam: length and square section's side, m; cut at this resolution, m.
pub const LENGTH: f64 = 0.4;
/// Its section's side, m.
pub const DEPTH: f64 = 0.02;
/// Its elements' side, m: two through its depth.
pub const RESOLUTION: f64 = 0.01;
/// Its density, kg/m³, and Poisson's ratio.
const DENSITY: f64 = 1000.0;
const POISSON: f64 = 0.3;
/// Gravity, m/s².
const G: f64 = 9.81;
/// Static solves, each with the elements' turns brought up to date.
const ROUNDS: usize = 12;

/// Euler–Bernoulli's sag of the tip, m, at Young's modulus `young` (Pa).
pub fn formula(young: f64) -> f64 {
    let q = DENSITY * G * DEPTH * DEPTH;
    q * LENGTH.powi(4) / (8.0 * young * DEPTH.powi(4) / 12.0)
}

/// The tip's mean sag, m, of the beam of `order` elements at `young` (Pa), settled under
/// its weight.
pub fn sag(order: Order, young: f64) -> Result<f64, String> {
    let half = DVec3::new(LENGTH, DEPTH, DEPTH) / 2.0;
    let material = Material {
        young,
        poisson: POISSON,
        density: DENSITY,
        damping: 0.0,
    };
    let mut body = SoftBody::new(cut_box(half, half, RESOLUTION, order), material);
    body.pin_below(0, 0.0);
    let mut solver = Solver::settling(&body).map_err(|e| format!("{e:?}"))?;
    body.settle(DVec3::new(0.0, -G, 0.0), ROUNDS, &mut solver);
    let tip: Vec<usize> = (0..body.positions.len())
        .filter(|&i| body.mesh.nodes[i].x >= LENGTH - 1e-12)
        .collect();
    let fall: f64 = tip
        .iter()
        .map(|&i| body.mesh.nodes[i].y - body.positions[i].y)
        .sum();
    Ok(fall / tip.len() as f64)
}

/// The figure for Young's moduli `moduli` (Pa): each order's sag over the formula's, and
/// the sags themselves as a share of the length, against log₁₀ E.
pub fn report(moduli: &[f64]) -> Result<Report, String> {
    let (mut text, mut rows) = (String::new(), Vec::<Value>::new());
    let mut ratio = Vec::new();
    // The formula's curve, finely between the moduli asked.
    let logs = moduli.iter().map(|e| e.log10());
    let (low, high) = (
        logs.clone().fold(f64::INFINITY, f64::min),
        logs.fold(f64::NEG_INFINITY, f64::max),
    );
    let mut sags = vec![Series {
        label: "Euler-Bernoulli: q L^4 / (8 E I)".into(),
        points: (0..=80)
            .map(|k| {
                let log = low + (high - low) * k as f64 / 80.0;
                (log, 100.0 * formula(10f64.powf(log)) / LENGTH)
            })
            .collect(),
        color: PALETTE[0],
    }];
    for (k, order) in [Order::Quadratic, Order::Linear].into_iter().enumerate() {
        let color = PALETTE[(k + 1) % PALETTE.len()];
        let mut points = Vec::new();
        for &young in moduli {
            let (found, exact) = (sag(order, young)?, formula(young));
            text += &format!(
                "  {order:?} elements, E = {young:.2e} Pa: sag {found:.6e} m, Euler-Bernoulli \
                 {exact:.6e} m ({:+.2} %)\n",
                100.0 * (found / exact - 1.0)
            );
            rows.push(
                json!({"elements": format!("{order:?}").to_lowercase(), "young": young,
                             "sag": found, "euler_bernoulli": exact}),
            );
            points.push((young.log10(), found, exact));
        }
        let label = format!("{} elements", format!("{order:?}").to_lowercase());
        ratio.push(Series {
            label: label.clone(),
            points: points.iter().map(|p| (p.0, p.1 / p.2)).collect(),
            color,
        });
        sags.push(Series {
            label,
            points: points.iter().map(|p| (p.0, 100.0 * p.1 / LENGTH)).collect(),
            color,
        });
    }
    let charts = vec![
        Chart {
            title: "a cantilever's sag over Euler-Bernoulli's".into(),
            x_label: "log10 E [Pa]".into(),
            y_label: "sag / Euler-Bernoulli".into(),
            series: ratio,
            y_range: Some((0.0, 1.1)),
            ..Chart::default()
        },
        Chart {
            title: "the tip's sag".into(),
            x_label: "log10 E [Pa]".into(),
            y_label: "sag [% of the length]".into(),
            series: sags,
            ..Chart::default()
        },
    ];
    Ok(Report {
        text,
        json: json!({ "results": rows }),
        charts,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The formula at 10⁹ Pa: q = 3.924 N/m, I = 1.333·10⁻⁸ m⁴, so 9.4176·10⁻⁴ m; the
    /// quadratic beam within 1 % of it, the linear one locked at about half.
    #[test]
    fn a_stiff_beam_sags_as_the_formula_says() {
        assert!((formula(1e9) - 9.4176e-4).abs() < 1e-12);
        let quadratic = sag(Order::Quadratic, 1e9).unwrap() / formula(1e9);
        let linear = sag(Order::Linear, 1e9).unwrap() / formula(1e9);
        assert!((quadratic - 1.0).abs() < 0.01, "{quadratic}");
        assert!((0.4..0.6).contains(&linear), "{linear}");
    }
}
