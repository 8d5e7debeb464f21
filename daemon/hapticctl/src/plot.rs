//! PNG line charts and region maps, drawn without a font or graphics stack so that every
//! experiment can write its figure on a bare server.

use std::io::Write;
use std::path::Path;

use hapticd_render::font;

/// An RGB colour.
pub type Rgb = [u8; 3];

/// Colours for successive series, distinguishable in print and for common colour blindness.
pub const PALETTE: [Rgb; 8] = [
    [0, 114, 178],
    [213, 94, 0],
    [0, 158, 115],
    [204, 121, 167],
    [230, 159, 0],
    [86, 180, 233],
    [0, 0, 0],
    [240, 228, 66],
];

const WHITE: Rgb = [255, 255, 255];
const INK: Rgb = [40, 40, 40];
const GRID: Rgb = [225, 225, 225];

/// An RGB raster.
#[derive(Debug, Clone, PartialEq)]
pub struct Canvas {
    width: usize,
    height: usize,
    pixels: Vec<u8>,
}

impl Canvas {
    /// A white canvas.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            pixels: vec![255; width * height * 3],
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The colour at (x, y).
    pub fn pixel(&self, x: usize, y: usize) -> Rgb {
        let i = (y * self.width + x) * 3;
        [self.pixels[i], self.pixels[i + 1], self.pixels[i + 2]]
    }

    fn set(&mut self, x: i64, y: i64, color: Rgb) {
        if x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height {
            let i = (y as usize * self.width + x as usize) * 3;
            self.pixels[i..i + 3].copy_from_slice(&color);
        }
    }

    /// Fill the rectangle [x0, x1) × [y0, y1).
    pub fn fill_rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, color: Rgb) {
        for y in y0..y1 {
            for x in x0..x1 {
                self.set(x, y, color);
            }
        }
    }

    /// A line `thickness` pixels wide from (x0, y0) to (x1, y1).
    pub fn line(&mut self, (x0, y0): (f64, f64), (x1, y1): (f64, f64), thickness: i64, color: Rgb) {
        let steps = (x1 - x0).abs().max((y1 - y0).abs()).ceil().max(1.0) as i64;
        let half = thickness / 2;
        for s in 0..=steps {
            let t = s as f64 / steps as f64;
            let x = (x0 + t * (x1 - x0)).round() as i64;
            let y = (y0 + t * (y1 - y0)).round() as i64;
            self.fill_rect(
                x - half,
                y - half,
                x - half + thickness,
                y - half + thickness,
                color,
            );
        }
    }

    /// Text with its top-left corner at (x, y), each font pixel drawn `scale`×`scale`.
    pub fn text(&mut self, x: i64, y: i64, text: &str, scale: i64, color: Rgb) {
        for (i, c) in text.chars().enumerate() {
            let left = x + i as i64 * (font::GLYPH_WIDTH as i64 + 1) * scale;
            for (row, bits) in font::glyph(c).iter().enumerate() {
                let row = row + font::drop(c);
                for col in 0..font::GLYPH_WIDTH {
                    if bits & (1 << (font::GLYPH_WIDTH - 1 - col)) != 0 {
                        let (px, py) = (left + col as i64 * scale, y + row as i64 * scale);
                        self.fill_rect(px, py, px + scale, py + scale, color);
                    }
                }
            }
        }
    }

    /// Width of `text` in pixels at `scale`.
    pub fn text_width(text: &str, scale: i64) -> i64 {
        text.chars().count() as i64 * (font::GLYPH_WIDTH as i64 + 1) * scale
    }

    /// Encode as PNG.
    pub fn to_png(&self) -> Vec<u8> {
        let mut out = Vec::new();
        let mut encoder = png::Encoder::new(&mut out, self.width as u32, self.height as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().expect("PNG header into memory");
        writer
            .write_image_data(&self.pixels)
            .expect("PNG data into memory");
        writer.finish().expect("PNG end into memory");
        out
    }

    /// `canvases` one below the other, as wide as the widest (figures of several charts).
    pub fn stacked(canvases: &[Canvas]) -> Canvas {
        let width = canvases.iter().map(|c| c.width).max().unwrap_or(0);
        let mut out = Canvas::new(width, canvases.iter().map(|c| c.height).sum());
        let mut top = 0;
        for c in canvases {
            for row in 0..c.height {
                let from = row * c.width * 3;
                let to = ((top + row) * width) * 3;
                out.pixels[to..to + c.width * 3]
                    .copy_from_slice(&c.pixels[from..from + c.width * 3]);
            }
            top += c.height;
        }
        out
    }

    /// Write as PNG to `path`, atomically (a reader never sees half a file).
    pub fn save_png(&self, path: &Path) -> std::io::Result<()> {
        let tmp = path.with_extension("png.tmp");
        let mut file = std::fs::File::create(&tmp)?;
        file.write_all(&self.to_png())?;
        file.sync_all()?;
        std::fs::rename(&tmp, path)
    }
}

/// A curve on a chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Points in data coordinates; a non-finite point breaks the line.
    pub points: Vec<(f64, f64)>,
    /// Line colour.
    pub color: Rgb,
}

/// A grid of coloured cells under the curves (e.g. a region map).
#[derive(Debug, Clone, PartialEq)]
pub struct Cells {
    /// Data x of the left edge of the first column and width of a column.
    pub x: (f64, f64),
    /// Data y of the bottom edge of the first row and height of a row.
    pub y: (f64, f64),
    /// Columns per row.
    pub columns: usize,
    /// Colours row by row, bottom row first.
    pub colors: Vec<Rgb>,
    /// Legend entries for the cell colours.
    pub legend: Vec<(String, Rgb)>,
}

/// A chart with axes, grid, title, legend and curves.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Chart {
    /// Title above the plot.
    pub title: String,
    /// Label of the horizontal axis.
    pub x_label: String,
    /// Label of the vertical axis.
    pub y_label: String,
    /// Curves, drawn in order.
    pub series: Vec<Series>,
    /// Optional cell layer drawn first.
    pub cells: Option<Cells>,
    /// Data range of x; by default that of the data.
    pub x_range: Option<(f64, f64)>,
    /// Data range of y; by default that of the data, with a margin.
    pub y_range: Option<(f64, f64)>,
    /// Equal scales on both axes (maps); the legend then sits beside the plot.
    pub equal_aspect: bool,
}

/// Round tick positions covering [lo, hi], about `target` of them.
pub fn ticks(lo: f64, hi: f64, target: usize) -> Vec<f64> {
    let raw = (hi - lo) / target.max(1) as f64;
    if !(raw > 0.0 && raw.is_finite()) {
        return vec![lo];
    }
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * magnitude)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * magnitude);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

fn tick_label(value: f64, step: f64) -> String {
    let decimals = (-step.abs().log10().floor()).max(0.0) as usize;
    let text = format!("{value:.decimals$}");
    if text.starts_with('-') && text[1..].chars().all(|c| c == '0' || c == '.') {
        text[1..].to_string()
    } else {
        text
    }
}

const PLOT_WIDTH: f64 = 830.0;
const PLOT_HEIGHT: f64 = 446.0;
const LEFT: i64 = 100;
const RIGHT: i64 = 30;
const TOP: i64 = 84;
const BOTTOM: i64 = 70;

impl Chart {
    fn data_range(&self) -> ((f64, f64), (f64, f64)) {
        let finite = self
            .series
            .iter()
            .flat_map(|s| &s.points)
            .filter(|(x, y)| x.is_finite() && y.is_finite());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in finite {
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
        if let Some(c) = &self.cells {
            let rows = c.colors.len() / c.columns.max(1);
            x0 = x0.min(c.x.0);
            x1 = x1.max(c.x.0 + c.x.1 * c.columns as f64);
            y0 = y0.min(c.y.0);
            y1 = y1.max(c.y.0 + c.y.1 * rows as f64);
        }
        if x0 > x1 {
            (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
        }
        let pad = |lo: f64, hi: f64| {
            let m = if hi > lo { (hi - lo) * 0.05 } else { 1.0 };
            (lo - m, hi + m)
        };
        let y = if self.cells.is_some() {
            (y0, y1)
        } else {
            pad(y0, y1)
        };
        (self.x_range.unwrap_or((x0, x1)), self.y_range.unwrap_or(y))
    }

    /// Draw the chart.
    pub fn render(&self) -> Canvas {
        let ((x0, x1), (y0, y1)) = self.data_range();
        let (pw, ph, beside) = if self.equal_aspect {
            let scale = PLOT_HEIGHT / (y1 - y0).max(x1 - x0);
            (
                (x1 - x0) * scale,
                (y1 - y0) * scale,
                self.legend_width() + 20,
            )
        } else {
            (PLOT_WIDTH, PLOT_HEIGHT, 0)
        };
        let width = (LEFT + RIGHT + beside) as usize + pw as usize;
        let height = (TOP + BOTTOM) as usize + ph as usize;
        let mut canvas = Canvas::new(width, height);
        let area = PlotArea {
            x: (x0, x1),
            y: (y0, y1),
            width: pw,
            height: ph,
        };

        if let Some(c) = &self.cells {
            area.draw_cells(&mut canvas, c);
        }
        self.draw_ticks(&mut canvas, &area);
        // The first series is drawn last, on top: it is usually the reference.
        for s in self.series.iter().rev() {
            let mut previous: Option<(f64, f64)> = None;
            for &(x, y) in &s.points {
                let here = (x.is_finite() && y.is_finite()).then(|| (area.sx(x), area.sy(y)));
                if let (Some(a), Some(b)) = (previous, here) {
                    canvas.line(a, b, 3, s.color);
                }
                previous = here;
            }
        }
        area.mask_and_frame(&mut canvas, width);
        let title_width = Canvas::text_width(&self.title, 3);
        canvas.text((width as i64 - title_width) / 2, 16, &self.title, 3, INK);
        let xw = Canvas::text_width(&self.x_label, 2);
        canvas.text(
            LEFT + (pw as i64 - xw) / 2,
            height as i64 - 28,
            &self.x_label,
            2,
            INK,
        );
        canvas.text(8, TOP - 28, &self.y_label, 2, INK);
        let legend_right = (LEFT as f64 + pw) as i64 + beside;
        self.draw_legend(&mut canvas, legend_right, TOP);
        canvas
    }

    /// Draw the ticks of both axes with their labels, and the grid unless cells fill the plot.
    fn draw_ticks(&self, canvas: &mut Canvas, area: &PlotArea) {
        let ((x0, x1), (y0, y1)) = (area.x, area.y);
        let (xt, yt) = (ticks(x0, x1, 8), ticks(y0, y1, 6));
        let xstep = xt.get(1).map_or(1.0, |b| b - xt[0]);
        let ystep = yt.get(1).map_or(1.0, |b| b - yt[0]);
        let (plot_left, plot_right) = (LEFT as f64, LEFT as f64 + area.width);
        let (plot_top, plot_bottom) = (TOP as f64, TOP as f64 + area.height);
        for &x in &xt {
            if self.cells.is_none() {
                canvas.line((area.sx(x), plot_top), (area.sx(x), plot_bottom), 1, GRID);
            }
            let label = tick_label(x, xstep);
            let w = Canvas::text_width(&label, 2);
            canvas.text(
                area.sx(x) as i64 - w / 2,
                plot_bottom as i64 + 10,
                &label,
                2,
                INK,
            );
        }
        for &y in &yt {
            if self.cells.is_none() {
                canvas.line((plot_left, area.sy(y)), (plot_right, area.sy(y)), 1, GRID);
            }
            let label = tick_label(y, ystep);
            let w = Canvas::text_width(&label, 2);
            canvas.text(LEFT - 8 - w, area.sy(y) as i64 - 7, &label, 2, INK);
        }
    }

    fn legend_entries(&self) -> Vec<(&str, Rgb)> {
        let mut entries: Vec<(&str, Rgb)> = self
            .series
            .iter()
            .filter(|s| !s.label.is_empty())
            .map(|s| (s.label.as_str(), s.color))
            .collect();
        if let Some(c) = &self.cells {
            entries.extend(c.legend.iter().map(|(l, c)| (l.as_str(), *c)));
        }
        entries
    }

    fn legend_width(&self) -> i64 {
        self.legend_entries()
            .iter()
            .map(|(l, _)| Canvas::text_width(l, 2))
            .max()
            .unwrap_or(0)
            + 50
    }

    fn draw_legend(&self, canvas: &mut Canvas, right: i64, top: i64) {
        let entries = self.legend_entries();
        if entries.is_empty() {
            return;
        }
        let width = self.legend_width();
        let height = entries.len() as i64 * 22 + 10;
        let (x, y) = (right - width - 10, top + 10);
        canvas.fill_rect(x, y, x + width, y + height, WHITE);
        canvas.line((x as f64, y as f64), ((x + width) as f64, y as f64), 1, INK);
        canvas.line(
            (x as f64, (y + height) as f64),
            ((x + width) as f64, (y + height) as f64),
            1,
            INK,
        );
        canvas.line(
            (x as f64, y as f64),
            (x as f64, (y + height) as f64),
            1,
            INK,
        );
        canvas.line(
            ((x + width) as f64, y as f64),
            ((x + width) as f64, (y + height) as f64),
            1,
            INK,
        );
        for (i, (label, color)) in entries.iter().enumerate() {
            let row = y + 8 + i as i64 * 22;
            canvas.fill_rect(x + 8, row + 3, x + 34, row + 11, *color);
            canvas.text(x + 42, row, label, 2, INK);
        }
    }
}

/// The plot's area on the canvas, `width` by `height` pixels, and the data ranges it shows.
struct PlotArea {
    x: (f64, f64),
    y: (f64, f64),
    width: f64,
    height: f64,
}

impl PlotArea {
    /// The canvas column of `x`.
    fn sx(&self, x: f64) -> f64 {
        LEFT as f64 + (x - self.x.0) / (self.x.1 - self.x.0) * self.width
    }

    /// The canvas row of `y`.
    fn sy(&self, y: f64) -> f64 {
        TOP as f64 + (self.y.1 - y) / (self.y.1 - self.y.0) * self.height
    }

    /// Fill each cell of `c` with its colour.
    fn draw_cells(&self, canvas: &mut Canvas, c: &Cells) {
        for (k, &color) in c.colors.iter().enumerate() {
            let (col, row) = (k % c.columns, k / c.columns);
            let left = c.x.0 + c.x.1 * col as f64;
            let bottom = c.y.0 + c.y.1 * row as f64;
            canvas.fill_rect(
                self.sx(left).floor() as i64,
                self.sy(bottom + c.y.1).floor() as i64,
                self.sx(left + c.x.1).ceil() as i64,
                self.sy(bottom).ceil() as i64,
                color,
            );
        }
    }

    /// Mask anything drawn outside the plot area of a canvas `width` wide, then frame it.
    fn mask_and_frame(&self, canvas: &mut Canvas, width: usize) {
        let (plot_left, plot_right) = (LEFT as f64, LEFT as f64 + self.width);
        let (plot_top, plot_bottom) = (TOP as f64, TOP as f64 + self.height);
        canvas.fill_rect(0, 0, width as i64, TOP - 1, WHITE);
        canvas.fill_rect(
            0,
            plot_bottom as i64 + 2,
            width as i64,
            plot_bottom as i64 + 9,
            WHITE,
        );
        canvas.fill_rect(
            plot_right as i64 + 2,
            TOP,
            width as i64,
            plot_bottom as i64 + 2,
            WHITE,
        );
        canvas.fill_rect(LEFT - 7, TOP, LEFT - 1, plot_bottom as i64 + 2, WHITE);
        for (a, b) in [
            ((plot_left, plot_top), (plot_right, plot_top)),
            ((plot_left, plot_bottom), (plot_right, plot_bottom)),
            ((plot_left, plot_top), (plot_left, plot_bottom)),
            ((plot_right, plot_top), (plot_right, plot_bottom)),
        ] {
            canvas.line(a, b, 2, INK);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        assert_eq!(ticks(0.0, 10.0, 5), vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        let t = ticks(-0.27, 0.27, 8);
        assert!(t.iter().all(|v| (v / 0.1 - (v / 0.1).round()).abs() < 1e-9));
        assert!(t.first().unwrap() >= &-0.27 && t.last().unwrap() <= &0.27);
    }

    #[test]
    fn a_series_is_drawn_in_its_colour_where_the_data_says() {
        let chart = Chart {
            series: vec![Series {
                label: String::new(),
                points: vec![(0.0, 0.0), (1.0, 1.0)],
                color: PALETTE[1],
            }],
            x_range: Some((0.0, 1.0)),
            y_range: Some((0.0, 1.0)),
            ..Chart::default()
        };
        let canvas = chart.render();
        // The midpoint of the diagonal in data space maps to the plot centre.
        let cx = LEFT as usize + PLOT_WIDTH as usize / 2;
        let cy = TOP as usize + PLOT_HEIGHT as usize / 2;
        assert_eq!(canvas.pixel(cx, cy), PALETTE[1]);
        // Stacked under a blank canvas, the same pixel moves down by its height.
        let stacked = Canvas::stacked(&[Canvas::new(10, 7), canvas.clone()]);
        assert_eq!(stacked.height(), canvas.height() + 7);
        assert_eq!(stacked.pixel(cx, cy + 7), PALETTE[1]);
        // The opposite corner region stays background.
        assert_eq!(canvas.pixel(cx + 100, cy + 100), WHITE);
        let png = canvas.to_png();
        assert_eq!(&png[1..4], b"PNG");
    }
}
