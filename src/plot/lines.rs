//! Line charts of measured series ([`plot_lines`]): latency distributions, throughput
//! against load, anything that is a few labelled polylines over two numeric axes.

use std::ops::Range;
use std::path::Path;

use image::{Rgb, RgbImage};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

use super::PlotError;
use super::curves::PALETTE;
use super::map::draw_title;
use super::render::{Background, ImageFormat, Painter, render};

/// One labelled series of a [`LineChart`].
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    /// The legend's text.
    pub label: String,
    /// The points, drawn in this order (non-finite points are left out).
    pub points: Vec<(f64, f64)>,
    /// Draw markers at the points (for series of a few measured points).
    pub markers: bool,
    /// Draw the line lighter (a reference series, such as a floor).
    pub faint: bool,
}

/// A chart of labelled lines over two numeric axes, drawn by [`plot_lines`].
///
/// ```
/// use cliff::plot::{plot_lines_to, ImageFormat, Line, LineChart};
/// let chart = LineChart {
///     title: "latency".into(),
///     x_label: "round trip (us)".into(),
///     y_label: "fraction of requests".into(),
///     log_x: true,
///     lines: vec![Line {
///         label: "iceoryx2".into(),
///         points: vec![(10.0, 0.0), (12.0, 0.5), (40.0, 1.0)],
///         markers: false,
///         faint: false,
///     }],
///     ..LineChart::default()
/// };
/// let png = plot_lines_to(&chart, ImageFormat::Png).unwrap();
/// assert!(png.starts_with(b"\x89PNG"));
/// // nothing to draw is an error, not an empty picture
/// let empty = LineChart { lines: vec![], ..chart };
/// assert!(plot_lines_to(&empty, ImageFormat::Png).is_err());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct LineChart {
    /// Title above the chart.
    pub title: String,
    /// Text along the x axis.
    pub x_label: String,
    /// Text along the y axis.
    pub y_label: String,
    /// A logarithmic x axis (every x must then be positive).
    pub log_x: bool,
    /// Start the y axis at zero (otherwise at the smallest y).
    pub y_from_zero: bool,
    /// Label only the whole numbers of the x axis (counts, such as clients).
    pub integer_x: bool,
    /// The legend in the upper left corner (otherwise the lower right).
    pub legend_upper_left: bool,
    /// Picture size in pixels.
    pub size: (u32, u32),
    /// The series, in legend order; colours follow the same palette as [`plot_curves`](super::plot_curves).
    pub lines: Vec<Line>,
}

impl Default for LineChart {
    fn default() -> Self {
        LineChart {
            title: String::new(),
            x_label: String::new(),
            y_label: String::new(),
            log_x: false,
            y_from_zero: true,
            integer_x: false,
            legend_upper_left: false,
            size: (900, 520),
            lines: Vec::new(),
        }
    }
}

impl LineChart {
    /// The axes' ranges: every finite point inside, with a margin; an error when no
    /// point can be drawn.
    fn ranges(&self) -> Result<(Range<f64>, Range<f64>), PlotError> {
        let (w, h) = self.size;
        if !(300..=8192).contains(&w) || !(200..=8192).contains(&h) {
            return Err(PlotError::Invalid(format!(
                "picture size {w}x{h} is outside 300x200 .. 8192x8192"
            )));
        }
        let pts: Vec<(f64, f64)> = self
            .lines
            .iter()
            .flat_map(|l| l.points.iter().copied())
            .filter(|&(x, y)| x.is_finite() && y.is_finite() && (!self.log_x || x > 0.0))
            .collect();
        if pts.is_empty() {
            return Err(PlotError::Invalid(
                "a line chart with no point to draw".into(),
            ));
        }
        let fold = |f: fn(f64, f64) -> f64, start: f64, of: fn(&(f64, f64)) -> f64| {
            pts.iter().map(of).fold(start, f)
        };
        let (x0, x1) = (
            fold(f64::min, f64::INFINITY, |p| p.0),
            fold(f64::max, f64::NEG_INFINITY, |p| p.0),
        );
        let (mut y0, y1) = (
            fold(f64::min, f64::INFINITY, |p| p.1),
            fold(f64::max, f64::NEG_INFINITY, |p| p.1),
        );
        if self.y_from_zero {
            y0 = y0.min(0.0);
        }
        let x = if self.log_x {
            // a little room on either side, in ratio
            let (a, b) = (x0 / 1.1, x1 * 1.1);
            if b > a * 1.5 { a..b } else { a / 1.5..b * 1.5 }
        } else {
            let pad = ((x1 - x0) * 0.04).max(x1.abs() * 0.02).max(1e-9);
            (x0 - pad)..(x1 + pad)
        };
        let span = (y1 - y0).max(y1.abs() * 0.05).max(1e-9);
        let y = if self.y_from_zero && y0 >= 0.0 {
            y0..y1 + span * 0.06
        } else {
            (y0 - span * 0.04)..(y1 + span * 0.06)
        };
        Ok((x, y))
    }
}

/// Draw `chart` and write it to `out` (PNG or SVG, by the extension).
pub fn plot_lines(chart: &LineChart, out: &Path) -> Result<(), PlotError> {
    let format = ImageFormat::from_path(out)?;
    let bytes = plot_lines_to(chart, format)?;
    super::write_file(out, &bytes)
}

/// Draw `chart` into picture bytes of `format`; see [`LineChart`].
pub fn plot_lines_to(chart: &LineChart, format: ImageFormat) -> Result<Vec<u8>, PlotError> {
    let ranges = chart.ranges()?;
    let background = Background {
        image: RgbImage::from_pixel(chart.size.0, chart.size.1, Rgb([255, 255, 255])),
    };
    render(
        chart.size,
        background,
        None,
        format,
        &LinesPainter { chart, ranges },
    )
}

struct LinesPainter<'a> {
    chart: &'a LineChart,
    ranges: (Range<f64>, Range<f64>),
}

impl Painter for LinesPainter<'_> {
    fn paint<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        draw_title(root, &self.chart.title)?;
        let (x, y) = self.ranges.clone();
        if self.chart.log_x {
            draw_lines(root, self.chart, x.log_scale(), y)
        } else {
            draw_lines(root, self.chart, x, y)
        }
    }
}

/// A tick label: whole numbers without decimals, small numbers with a few.
fn tick(v: f64) -> String {
    let a = v.abs();
    if a >= 100.0 || (a - a.round()).abs() < 1e-9 {
        format!("{v:.0}")
    } else if a >= 1.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

fn draw_lines<DB: DrawingBackend, X>(
    root: &DrawingArea<DB, Shift>,
    chart: &LineChart,
    x: X,
    y: Range<f64>,
) -> Result<(), PlotError>
where
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
{
    let mut c = ChartBuilder::on(root)
        .margin_top(36)
        .margin_right(20)
        .margin_left(10)
        .margin_bottom(10)
        .x_label_area_size(42)
        .y_label_area_size(64)
        .build_cartesian_2d(x, y)
        .map_err(PlotError::draw)?;
    c.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .x_label_formatter(&|v| {
            if chart.integer_x && (v - v.round()).abs() > 1e-9 {
                String::new()
            } else {
                tick(*v)
            }
        })
        .y_label_formatter(&|v| tick(*v))
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(215, 215, 215))
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .draw()
        .map_err(PlotError::draw)?;
    for (i, line) in chart.lines.iter().enumerate() {
        let (r, g, b) = PALETTE[i % PALETTE.len()];
        let colour = RGBColor(r, g, b);
        let (width, shade) = if line.faint { (2, 0.55) } else { (2, 1.0) };
        let style = colour.mix(shade).stroke_width(width);
        let legend = colour.mix(shade).stroke_width(width + 1);
        let pts: Vec<(f64, f64)> = line
            .points
            .iter()
            .copied()
            .filter(|&(x, y)| x.is_finite() && y.is_finite() && (!chart.log_x || x > 0.0))
            .collect();
        c.draw_series(LineSeries::new(pts.iter().copied(), style))
            .map_err(PlotError::draw)?
            .label(line.label.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], legend));
        if line.markers {
            c.draw_series(
                pts.iter()
                    .map(|&p| Circle::new(p, 3, colour.mix(shade).filled())),
            )
            .map_err(PlotError::draw)?;
        }
    }
    c.configure_series_labels()
        .position(if chart.legend_upper_left {
            SeriesLabelPosition::UpperLeft
        } else {
            SeriesLabelPosition::LowerRight
        })
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(190, 190, 190))
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(PlotError::draw)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart(log_x: bool, points: Vec<(f64, f64)>) -> LineChart {
        LineChart {
            log_x,
            lines: vec![Line {
                label: "a".into(),
                points,
                markers: true,
                faint: false,
            }],
            ..LineChart::default()
        }
    }

    #[test]
    fn ranges_hold_every_drawable_point() {
        let (x, y) = chart(false, vec![(1.0, 5.0), (3.0, 9.0), (f64::NAN, 100.0)])
            .ranges()
            .unwrap();
        assert!(x.start < 1.0 && x.end > 3.0, "{x:?}");
        assert!(y.start == 0.0 && y.end > 9.0 && y.end < 100.0, "{y:?}");
        // a log axis leaves out what it cannot draw
        let (x, _) = chart(true, vec![(0.0, 0.1), (10.0, 0.5), (1000.0, 1.0)])
            .ranges()
            .unwrap();
        assert!(x.start > 0.0 && x.start < 10.0 && x.end > 1000.0, "{x:?}");
        assert!(chart(true, vec![(0.0, 1.0), (-3.0, 2.0)]).ranges().is_err());
        let svg = plot_lines_to(
            &chart(true, vec![(2.0, 0.5), (20.0, 1.0)]),
            ImageFormat::Svg,
        )
        .unwrap();
        assert!(String::from_utf8(svg).unwrap().contains("<svg"));
    }
}
