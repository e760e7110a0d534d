//! ADE and FDE against the prediction horizon, from `summary.csv` files.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::map::draw_title;
use super::render::{Background, Painter, render};
use super::{Extent, Frame, ImageFormat, PixelRect, PlotError, write_file};

/// One row of an evaluation summary: a method's errors at one horizon.
#[derive(Debug, Clone, PartialEq)]
pub struct SummaryRow {
    /// Method name (`cliff`, `cvm`, ...).
    pub method: String,
    /// Prediction horizon (s).
    pub horizon: f64,
    /// Mean average displacement error over people (m).
    pub ade: f64,
    /// Mean final displacement error over people (m).
    pub fde: f64,
    /// Standard deviation of the ADE over people (m).
    pub ade_sd: f64,
    /// Standard deviation of the FDE over people (m).
    pub fde_sd: f64,
    /// People evaluated at this horizon (a mean over seeds), when the file has the
    /// column.
    pub people: Option<f64>,
}

/// The summary of one evaluation run, with the label it gets in the legend.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveRun {
    /// Label of the run (with several runs, legend entries read `label: method`).
    pub label: String,
    /// Its rows.
    pub rows: Vec<SummaryRow>,
}

/// Columns a summary must have.
const NEEDED: [&str; 6] = ["method", "horizon", "ade", "fde", "ade_sd", "fde_sd"];

/// Read a `summary.csv` written by `cliff eval`: a header row, then one row per method
/// and horizon. Columns are found by name (`method, horizon, ade, fde, ade_sd, fde_sd`
/// are needed, `people` is used when present, others are ignored).
pub fn read_summary(path: &Path) -> Result<Vec<SummaryRow>, PlotError> {
    let text = std::fs::read_to_string(path).map_err(|source| PlotError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    parse_summary(&text, &path.display().to_string())
}

/// Parse summary text (see [`read_summary`]); `file` names the source in errors.
///
/// ```
/// use cliff::plot::parse_summary;
/// let text = "method,horizon,people,ade,fde,min_ade,min_fde,ade_sd,fde_sd\n\
///             cliff,1.0,10,0.3,0.5,0.1,0.2,0.1,0.2\n";
/// let rows = parse_summary(text, "summary.csv").unwrap();
/// assert_eq!((rows[0].method.as_str(), rows[0].horizon, rows[0].people), ("cliff", 1.0, Some(10.0)));
/// let err = parse_summary("method,ade\ncliff,1\n", "s.csv").unwrap_err().to_string();
/// assert!(err.contains("s.csv:1") && err.contains("horizon"), "{err}");
/// ```
pub fn parse_summary(text: &str, file: &str) -> Result<Vec<SummaryRow>, PlotError> {
    let table = Table::parse(text, file, &NEEDED)?;
    let people_col = table.col("people");
    let mut rows = Vec::with_capacity(table.rows.len());
    for r in 0..table.rows.len() {
        rows.push(SummaryRow {
            method: table.method(r)?,
            horizon: table.horizon(r)?,
            ade: table.num(r, "ade")?,
            fde: table.num(r, "fde")?,
            ade_sd: table.num(r, "ade_sd")?,
            fde_sd: table.num(r, "fde_sd")?,
            people: match people_col {
                Some(_) => Some(table.num(r, "people")?),
                None => None,
            },
        });
    }
    Ok(rows)
}

/// Read a `per_person.csv` written by `cliff eval` and summarise it per method and
/// horizon with the mean and the standard deviation over people (the spread the
/// paper's figures show), rather than over seeds as in `summary.csv`.
pub fn read_per_person_spread(path: &Path) -> Result<Vec<SummaryRow>, PlotError> {
    let text = std::fs::read_to_string(path).map_err(|source| PlotError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    parse_per_person_spread(&text, &path.display().to_string())
}

/// Parse per-person text (columns `method, horizon, ade, fde` by name, one row per
/// person, method and horizon) into one row per method and horizon: the mean over
/// people and the population standard deviation over people; see
/// [`read_per_person_spread`].
///
/// ```
/// use cliff::plot::parse_per_person_spread;
/// let text = "person_id,method,horizon,ade,fde\n1,cliff,1.0,1.0,2.0\n2,cliff,1.0,3.0,2.0\n";
/// let rows = parse_per_person_spread(text, "per_person.csv").unwrap();
/// assert_eq!(rows.len(), 1);
/// assert_eq!((rows[0].ade, rows[0].ade_sd, rows[0].fde_sd, rows[0].people), (2.0, 1.0, 0.0, Some(2.0)));
/// ```
pub fn parse_per_person_spread(text: &str, file: &str) -> Result<Vec<SummaryRow>, PlotError> {
    let table = Table::parse(text, file, &["method", "horizon", "ade", "fde"])?;
    // (method, horizon in micro-seconds) -> (n, sum, sum of squares) of ade and fde
    let mut groups: Vec<((String, i64), [f64; 5])> = Vec::new();
    for r in 0..table.rows.len() {
        let key = (table.method(r)?, (table.horizon(r)? * 1e6).round() as i64);
        let (ade, fde) = (table.num(r, "ade")?, table.num(r, "fde")?);
        if !(ade.is_finite() && fde.is_finite()) {
            continue;
        }
        let acc = match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, acc)) => acc,
            None => {
                groups.push((key, [0.0; 5]));
                &mut groups.last_mut().expect("just pushed").1
            }
        };
        acc[0] += 1.0;
        acc[1] += ade;
        acc[2] += ade * ade;
        acc[3] += fde;
        acc[4] += fde * fde;
    }
    let mut rows: Vec<SummaryRow> = groups
        .into_iter()
        .map(|((method, h), a)| {
            let n = a[0];
            let (ade, fde) = (a[1] / n, a[3] / n);
            SummaryRow {
                method,
                horizon: h as f64 / 1e6,
                ade,
                fde,
                ade_sd: (a[2] / n - ade * ade).max(0.0).sqrt(),
                fde_sd: (a[4] / n - fde * fde).max(0.0).sqrt(),
                people: Some(n),
            }
        })
        .collect();
    // methods in order of first appearance (stable), horizons ascending
    rows.sort_by(|a, b| a.horizon.total_cmp(&b.horizon));
    if rows.is_empty() {
        return Err(PlotError::Summary {
            file: file.to_string(),
            line: 1,
            column: 0,
            message: "no row with finite errors".into(),
        });
    }
    Ok(rows)
}

/// A CSV table with a header row, read by column name; errors name file, line, column.
struct Table {
    file: String,
    names: Vec<String>,
    /// (1-based line, fields)
    rows: Vec<(usize, Vec<String>)>,
}

impl Table {
    fn parse(text: &str, file: &str, needed: &[&str]) -> Result<Self, PlotError> {
        let err = |line: usize, message: String| PlotError::Summary {
            file: file.to_string(),
            line,
            column: 0,
            message,
        };
        let split = |l: &str| -> Vec<String> {
            l.split(',')
                .map(|f| f.trim().trim_matches('"').to_string())
                .collect()
        };
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let Some((hl, header)) = lines.next() else {
            return Err(err(1, "the file is empty (expected a header row)".into()));
        };
        let names: Vec<String> = split(header)
            .iter()
            .map(|n| n.to_ascii_lowercase())
            .collect();
        let missing: Vec<&str> = needed
            .iter()
            .copied()
            .filter(|n| !names.iter().any(|m| m == n))
            .collect();
        if !missing.is_empty() {
            return Err(err(
                hl + 1,
                format!(
                    "header lacks column(s) {} (found: {})",
                    missing.join(", "),
                    names.join(", ")
                ),
            ));
        }
        let mut rows = Vec::new();
        for (ln, line) in lines {
            let f = split(line);
            if f.len() != names.len() {
                return Err(err(
                    ln + 1,
                    format!("{} fields, the header has {}", f.len(), names.len()),
                ));
            }
            rows.push((ln + 1, f));
        }
        if rows.is_empty() {
            return Err(err(hl + 1, "no rows after the header".into()));
        }
        Ok(Table {
            file: file.to_string(),
            names,
            rows,
        })
    }

    fn col(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    fn err(&self, r: usize, c: usize, message: String) -> PlotError {
        PlotError::Summary {
            file: self.file.clone(),
            line: self.rows[r].0,
            column: c + 1,
            message,
        }
    }

    /// A number (NaN allowed: a horizon nobody reached; infinities refused).
    fn num(&self, r: usize, name: &str) -> Result<f64, PlotError> {
        let c = self.col(name).expect("checked at parse");
        let f = &self.rows[r].1[c];
        let v: f64 = f
            .parse()
            .map_err(|_| self.err(r, c, format!("'{f}' is not a number")))?;
        if v.is_infinite() {
            return Err(self.err(r, c, format!("'{f}' is not finite")));
        }
        Ok(v)
    }

    fn horizon(&self, r: usize) -> Result<f64, PlotError> {
        let h = self.num(r, "horizon")?;
        if h.is_nan() || h < 0.0 {
            let c = self.col("horizon").expect("checked at parse");
            return Err(self.err(
                r,
                c,
                format!(
                    "horizon '{}' is not a non-negative number",
                    self.rows[r].1[c]
                ),
            ));
        }
        Ok(h)
    }

    fn method(&self, r: usize) -> Result<String, PlotError> {
        let c = self.col("method").expect("checked at parse");
        let m = &self.rows[r].1[c];
        if m.is_empty() {
            return Err(self.err(r, c, "empty method name".into()));
        }
        Ok(m.clone())
    }
}

/// How [`plot_curves`] draws.
#[derive(Debug, Clone, PartialEq)]
pub struct CurvesStyle {
    /// Picture size in pixels (the ADE panel left, the FDE panel right).
    pub size: (u32, u32),
    /// Draw the one-standard-deviation bands.
    pub bands: bool,
    /// Title above the picture.
    pub title: Option<String>,
}

impl Default for CurvesStyle {
    fn default() -> Self {
        CurvesStyle {
            size: (1100, 460),
            bands: true,
            title: None,
        }
    }
}

/// Where [`plot_curves`] puts its two panels.
#[derive(Debug, Clone, PartialEq)]
pub struct CurvesLayout {
    /// Picture size.
    pub size: (u32, u32),
    /// The ADE panel: horizon (s) along x, metres along y.
    pub ade: Frame,
    /// The FDE panel.
    pub fde: Frame,
    /// The curves in drawing order: legend label and colour; run by run, and within
    /// a run the methods in order of first appearance.
    pub series: Vec<(String, (u8, u8, u8))>,
}

/// Series colours, in order (a ten-colour qualitative palette; repeats after ten).
pub(crate) const PALETTE: [(u8, u8, u8); 10] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

const TOP: i32 = 40;
const RIGHT: i32 = 18;
const LEFT: i32 = 64;
const BOTTOM: i32 = 48;

/// The series of a set of runs: `(run index, method)` in drawing order.
fn series_of(runs: &[CurveRun]) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, run) in runs.iter().enumerate() {
        let mut seen: Vec<&str> = Vec::new();
        for r in &run.rows {
            if !seen.contains(&r.method.as_str()) {
                seen.push(&r.method);
                out.push((i, r.method.clone()));
            }
        }
    }
    out
}

/// The layout [`plot_curves`] uses for `runs`: panel frames and series colours.
/// The horizon axis runs from 0 to the largest horizon; the metre axes from 0 to the
/// largest mean plus one standard deviation (or mean, without bands), plus 5 %.
///
/// ```
/// use cliff::plot::{curves_layout, parse_summary, CurveRun, CurvesStyle};
/// let rows = parse_summary(
///     "method,horizon,ade,fde,ade_sd,fde_sd\ncvm,4,1.0,2.0,0.5,1.0\ncliff,4,0.8,1.5,0.2,0.5\n",
///     "inline",
/// ).unwrap();
/// let layout = curves_layout(&[CurveRun { label: "run".into(), rows }], &CurvesStyle::default()).unwrap();
/// // one run: the legend names the methods, in order of first appearance
/// assert_eq!(layout.series[0].0, "cvm");
/// assert!((layout.ade.extent.y1 - 1.5 * 1.05).abs() < 1e-12);
/// // the pixel where cvm's ADE at 4 s is drawn
/// let (x, y) = layout.ade.to_pixel(glam::DVec2::new(4.0, 1.0));
/// assert!(layout.ade.area.contains((x, y)));
/// ```
pub fn curves_layout(runs: &[CurveRun], style: &CurvesStyle) -> Result<CurvesLayout, PlotError> {
    let (w, h) = style.size;
    if !(400..=8192).contains(&w) || !(200..=8192).contains(&h) {
        return Err(PlotError::Invalid(format!(
            "picture size {w}x{h} is outside 400x200 .. 8192x8192"
        )));
    }
    let rows = || runs.iter().flat_map(|r| r.rows.iter());
    if rows().next().is_none() {
        return Err(PlotError::Invalid("no summary rows to draw".into()));
    }
    let hmax = rows().map(|r| r.horizon).fold(0.0f64, f64::max);
    let top = |m: fn(&SummaryRow) -> (f64, f64)| {
        rows()
            .map(|r| {
                let (v, sd) = m(r);
                if style.bands && sd.is_finite() {
                    v + sd.abs()
                } else {
                    v
                }
            })
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max)
    };
    let ymax = |v: f64| if v > 0.0 { v * 1.05 } else { 1.0 };
    let xmax = if hmax > 0.0 { hmax } else { 1.0 };
    let half = w as i32 / 2;
    let panel = |x0: i32, x1: i32, ytop: f64| Frame {
        size: (w, h),
        area: PixelRect {
            left: x0 + LEFT,
            top: TOP,
            right: x1 - RIGHT,
            bottom: h as i32 - BOTTOM,
        },
        extent: Extent {
            x0: 0.0,
            x1: xmax,
            y0: 0.0,
            y1: ymax(ytop),
        },
    };
    let several = runs.len() > 1;
    let series = series_of(runs)
        .into_iter()
        .enumerate()
        .map(|(i, (run, method))| {
            let label = if several {
                format!("{}: {method}", runs[run].label)
            } else {
                method
            };
            (label, PALETTE[i % PALETTE.len()])
        })
        .collect();
    Ok(CurvesLayout {
        size: (w, h),
        ade: panel(0, half, top(|r| (r.ade, r.ade_sd))),
        fde: panel(half, w as i32, top(|r| (r.fde, r.fde_sd))),
        series,
    })
}

/// Draw ADE (left) and FDE (right) against the horizon for every method of every run,
/// with one-standard-deviation bands, and write the picture to `out` (PNG or SVG).
/// Returns the layout (panel frames and series colours).
///
/// ```
/// use cliff::plot::{parse_summary, plot_curves_to, CurveRun, CurvesStyle, ImageFormat};
/// let rows = parse_summary(
///     "method,horizon,ade,fde,ade_sd,fde_sd\ncliff,1,0.2,0.4,0.1,0.2\ncliff,2,0.5,1.0,0.2,0.4\n",
///     "inline",
/// ).unwrap();
/// let runs = [CurveRun { label: "demo".into(), rows }];
/// let (png, layout) = plot_curves_to(&runs, &CurvesStyle::default(), ImageFormat::Png).unwrap();
/// assert!(png.starts_with(b"\x89PNG"));
/// assert_eq!(layout.series[0].0, "cliff");
/// ```
pub fn plot_curves(
    runs: &[CurveRun],
    style: &CurvesStyle,
    out: &Path,
) -> Result<CurvesLayout, PlotError> {
    let format = ImageFormat::from_path(out)?;
    let (bytes, layout) = plot_curves_to(runs, style, format)?;
    write_file(out, &bytes)?;
    Ok(layout)
}

/// Draw error curves into picture bytes of `format`; see [`plot_curves`].
pub fn plot_curves_to(
    runs: &[CurveRun],
    style: &CurvesStyle,
    format: ImageFormat,
) -> Result<(Vec<u8>, CurvesLayout), PlotError> {
    let layout = curves_layout(runs, style)?;
    let background = Background::new(&layout.ade, None, 0.0);
    let painter = CurvesPainter {
        runs,
        style,
        layout: &layout,
    };
    let bytes = render(layout.size, background, None, format, &painter)?;
    Ok((bytes, layout))
}

struct CurvesPainter<'a> {
    runs: &'a [CurveRun],
    style: &'a CurvesStyle,
    layout: &'a CurvesLayout,
}

impl Painter for CurvesPainter<'_> {
    fn paint<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let title = self.style.title.clone().unwrap_or_else(|| {
            "Displacement error against prediction horizon (mean ± 1 sd)".to_string()
        });
        draw_title(root, &title)?;
        let half = self.layout.size.0 / 2;
        let (left, right) = root.split_horizontally(half);
        let series = series_of(self.runs);
        for (panel, frame, name, pick) in [
            (&left, &self.layout.ade, "ADE (m)", Metric::Ade),
            (&right, &self.layout.fde, "FDE (m)", Metric::Fde),
        ] {
            let mut chart = super::map::world_chart(panel, frame)?;
            chart
                .configure_mesh()
                .x_desc("prediction horizon (s)")
                .y_desc(name)
                .light_line_style(RGBColor(235, 235, 235))
                .bold_line_style(RGBColor(215, 215, 215))
                .label_style(("sans-serif", 13))
                .axis_desc_style(("sans-serif", 14))
                .draw()
                .map_err(PlotError::draw)?;
            let points: Vec<Vec<(f64, f64, f64)>> = series
                .iter()
                .map(|(run, method)| {
                    let mut pts: Vec<(f64, f64, f64)> = self.runs[*run]
                        .rows
                        .iter()
                        .filter(|row| &row.method == method)
                        .map(|row| {
                            let (v, sd) = pick.of(row);
                            (row.horizon, v, sd)
                        })
                        .filter(|(_, v, _)| v.is_finite())
                        .collect();
                    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                    pts
                })
                .collect();
            let colour = |i: usize| {
                let (r, g, b) = self.layout.series[i].1;
                RGBColor(r, g, b)
            };
            // All bands first, then all lines, so that no band veils a line.
            if self.style.bands {
                for (i, pts) in points.iter().enumerate().filter(|(_, p)| p.len() > 1) {
                    let mut band: Vec<(f64, f64)> =
                        pts.iter().map(|&(x, v, sd)| (x, v + sd.abs())).collect();
                    band.extend(
                        pts.iter()
                            .rev()
                            .map(|&(x, v, sd)| (x, (v - sd.abs()).max(0.0))),
                    );
                    chart
                        .draw_series(std::iter::once(Polygon::new(
                            band,
                            colour(i).mix(0.18).filled(),
                        )))
                        .map_err(PlotError::draw)?;
                }
            }
            for (i, pts) in points.iter().enumerate() {
                let c = colour(i);
                chart
                    .draw_series(LineSeries::new(
                        pts.iter().map(|&(x, v, _)| (x, v)),
                        c.stroke_width(2),
                    ))
                    .map_err(PlotError::draw)?
                    .label(self.layout.series[i].0.clone())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(3))
                    });
                chart
                    .draw_series(
                        pts.iter()
                            .map(|&(x, v, _)| Circle::new((x, v), 3, c.filled())),
                    )
                    .map_err(PlotError::draw)?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(190, 190, 190))
                .label_font(("sans-serif", 13))
                .draw()
                .map_err(PlotError::draw)?;
        }
        Ok(())
    }
}

#[derive(Clone, Copy)]
enum Metric {
    Ade,
    Fde,
}

impl Metric {
    fn of(self, r: &SummaryRow) -> (f64, f64) {
        match self {
            Metric::Ade => (r.ade, r.ade_sd),
            Metric::Fde => (r.fde, r.fde_sd),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_errors_name_line_and_column() {
        let e = |t: &str| parse_summary(t, "s.csv").unwrap_err().to_string();
        let h = "method,horizon,ade,fde,ade_sd,fde_sd\n";
        assert!(e("").contains("empty"));
        assert!(e(h).contains("no rows"));
        assert!(
            e(&format!("{h}cliff,1,x,1,1,1\n")).contains("s.csv:2: column 3: 'x' is not a number")
        );
        assert!(e(&format!("{h}cliff,-1,1,1,1,1\n")).contains("column 2: horizon"));
        assert!(e(&format!("{h}cliff,1,1,1,1\n")).contains("s.csv:2: column 0: 5 fields"));
        // extra columns, other order, NaN for a horizon nobody reached
        let rows = parse_summary(
            "fde_sd,extra,ade_sd,fde,ade,horizon,method\n0.2,zz,0.1,NaN,nan,3.0,cvm\n",
            "s",
        )
        .unwrap();
        assert_eq!(rows[0].method, "cvm");
        assert_eq!(rows[0].horizon, 3.0);
        assert!(rows[0].ade.is_nan() && rows[0].people.is_none());
    }

    #[test]
    fn layout_covers_the_bands_and_labels_runs() {
        let row = |m: &str, h: f64, ade: f64, sd: f64| SummaryRow {
            method: m.into(),
            horizon: h,
            ade,
            fde: 2.0 * ade,
            ade_sd: sd,
            fde_sd: sd,
            people: None,
        };
        let runs = vec![
            CurveRun {
                label: "a".into(),
                rows: vec![row("cliff", 1.0, 1.0, 0.5), row("cvm", 2.0, 2.0, 1.0)],
            },
            CurveRun {
                label: "b".into(),
                rows: vec![row("cliff", 4.0, 0.5, 0.0)],
            },
        ];
        let l = curves_layout(&runs, &CurvesStyle::default()).unwrap();
        assert_eq!(l.ade.extent.x1, 4.0);
        assert!((l.ade.extent.y1 - 3.0 * 1.05).abs() < 1e-12);
        assert!((l.fde.extent.y1 - 5.0 * 1.05).abs() < 1e-12);
        let labels: Vec<&str> = l.series.iter().map(|s| s.0.as_str()).collect();
        assert_eq!(labels, ["a: cliff", "a: cvm", "b: cliff"]);
        assert!(l.fde.area.left > l.ade.area.right);
    }
}
