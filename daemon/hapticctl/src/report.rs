//! What a command shows: text for people, a JSON value for programs and the charts of its
//! figure. The library computes it; the binary writes the figure where it was asked to and
//! prints one of the other two.

use serde_json::Value;

use crate::plot::{Canvas, Chart};

/// The result of an experiment or a mechanism study, ready to print and draw.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// The text printed without `--json`, every line ended by a newline.
    pub text: String,
    /// The value printed with `--json` (without the figure's path: the caller knows it).
    pub json: Value,
    /// The figure's charts, top to bottom; none for a report without a figure.
    pub charts: Vec<Chart>,
}

impl Report {
    /// The charts drawn one below the other.
    pub fn figure(&self) -> Canvas {
        let rendered: Vec<Canvas> = self.charts.iter().map(Chart::render).collect();
        Canvas::stacked(&rendered)
    }
}
