//! CLiFF-maps as coloured arrows.

use std::path::Path;

use glam::DVec2;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::render::{Background, Painter, render};
use super::{Extent, Floorplan, Frame, ImageFormat, PlotError, direction_colour, write_file};
use crate::map::CliffMap;

/// The chart type of map-like pictures: metres on both axes.
pub(crate) type WorldChart<'a, DB> =
    ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// How [`plot_map`] draws a map.
#[derive(Debug, Clone, PartialEq)]
pub struct MapStyle {
    /// Picture width in pixels; the height follows from the shown extent (equal scale
    /// on both axes).
    pub width: u32,
    /// The world rectangle shown; `None`: the floor plan's extent when there is one,
    /// else the map's locations with a border of one grid step.
    pub view: Option<Extent>,
    /// Arrow length per unit of speed (seconds: an arrow is as long as the distance
    /// walked in this time at the component's mean speed); `None`: the fastest
    /// component's arrow is 0.45 grid steps long, so arrows of neighbouring locations
    /// never touch.
    pub arrow_seconds: Option<f64>,
    /// Components whose weight (normalised per location) is below this are not drawn.
    pub min_weight: f64,
    /// Opacity of the whole arrow layer (`1`: a component of weight 1 is opaque).
    pub opacity: f64,
    /// How dark the floor plan is drawn, from 0 (invisible) to 1 (as in the file).
    pub floorplan_strength: f64,
    /// Title above the picture.
    pub title: Option<String>,
    /// Draw the direction colour wheel in the top-right corner.
    pub legend: bool,
}

impl Default for MapStyle {
    fn default() -> Self {
        MapStyle {
            width: 1000,
            view: None,
            arrow_seconds: None,
            min_weight: 0.0,
            opacity: 1.0,
            floorplan_strength: 0.35,
            title: None,
            legend: true,
        }
    }
}

impl MapStyle {
    /// The extent shown for `map` over an optional floor plan (see [`MapStyle::view`]).
    pub fn view_for(&self, map: &CliffMap, floorplan: Option<&Floorplan>) -> Extent {
        if let Some(v) = self.view {
            return v;
        }
        if let Some(fp) = floorplan {
            return fp.extent();
        }
        map_extent(map)
    }

    /// The arrow length per unit speed used for `map` (see [`MapStyle::arrow_seconds`]).
    pub fn arrow_seconds_for(&self, map: &CliffMap) -> f64 {
        if let Some(s) = self.arrow_seconds {
            return s;
        }
        let fastest = map
            .locations()
            .iter()
            .flat_map(|l| l.components.iter().map(|c| c.rho))
            .fold(0.0f64, f64::max);
        if fastest > 0.0 {
            0.45 * map.grid().step() / fastest
        } else {
            1.0
        }
    }

    pub(crate) fn check(&self) -> Result<(), PlotError> {
        let bad = |m: String| Err(PlotError::Invalid(m));
        if self.width < 200 {
            return bad(format!(
                "width {} is too small (at least 200 pixels)",
                self.width
            ));
        }
        if let Some(s) = self.arrow_seconds
            && !(s.is_finite() && s > 0.0)
        {
            return bad(format!("arrow length {s} s is not a positive number"));
        }
        if !(0.0..=1.0).contains(&self.opacity) || !(0.0..=1.0).contains(&self.floorplan_strength) {
            return bad("opacity and floor plan strength must be within 0..1".into());
        }
        if !self.min_weight.is_finite() {
            return bad("minimum weight must be a finite number".into());
        }
        Ok(())
    }
}

/// The map's locations with a border of one grid step.
pub(crate) fn map_extent(map: &CliffMap) -> Extent {
    let step = map.grid().step();
    Extent::around(map.locations().iter().map(|l| l.position), step).unwrap_or(Extent {
        x0: -1.0,
        x1: 1.0,
        y0: -1.0,
        y1: 1.0,
    })
}

/// Draw `map` as a picture and write it to `out` (PNG or SVG, by extension). Returns
/// the frame: where each world point was drawn.
///
/// ```
/// use cliff::map::CliffMap;
/// use cliff::plot::{plot_map, Floorplan, MapStyle};
/// // THÖR1's map over its floor plan (the data sit beside the repository)
/// let map = CliffMap::load("../shared/data/thor1/cliffmap.csv")?;
/// let plan = Floorplan::load("../shared/data/thor1/floorplan.png", "-11,12,-10,13.5".parse()?)?;
/// let out = std::env::temp_dir().join("cliff-doc-thor1-map.svg");
/// let frame = plot_map(&map, Some(&plan), &MapStyle::default(), &out)?;
/// assert_eq!(frame.size.0, 1000);
/// assert!(std::fs::read_to_string(&out)?.starts_with("<svg"));
/// # std::fs::remove_file(&out)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn plot_map(
    map: &CliffMap,
    floorplan: Option<&Floorplan>,
    style: &MapStyle,
    out: &Path,
) -> Result<Frame, PlotError> {
    let format = ImageFormat::from_path(out)?;
    let (bytes, frame) = plot_map_to(map, floorplan, style, format)?;
    write_file(out, &bytes)?;
    Ok(frame)
}

/// Draw `map` into picture bytes of `format`; see [`plot_map`].
pub fn plot_map_to(
    map: &CliffMap,
    floorplan: Option<&Floorplan>,
    style: &MapStyle,
    format: ImageFormat,
) -> Result<(Vec<u8>, Frame), PlotError> {
    style.check()?;
    let frame = Frame::for_map(style.view_for(map, floorplan), style.width);
    let background = Background::new(&frame, floorplan, style.floorplan_strength);
    let painter = MapPainter { map, style, frame };
    let bytes = render(
        frame.size,
        background,
        floorplan.map(|_| frame.area),
        format,
        &painter,
    )?;
    Ok((bytes, frame))
}

struct MapPainter<'a> {
    map: &'a CliffMap,
    style: &'a MapStyle,
    frame: Frame,
}

impl Painter for MapPainter<'_> {
    fn paint<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let info = self.map.info();
        let title = self.style.title.clone().unwrap_or_else(|| {
            format!(
                "CLiFF-map: {} locations, {} components",
                info.locations, info.components
            )
        });
        draw_title(root, &title)?;
        let mut chart = world_chart(root, &self.frame)?;
        draw_axes(&mut chart)?;
        draw_arrows(
            &chart,
            self.map,
            self.style.arrow_seconds_for(self.map),
            self.style.min_weight,
            self.style.opacity,
            &self.frame,
        )?;
        if self.style.legend {
            draw_colour_wheel(root, &self.frame)?;
        }
        Ok(())
    }
}

/// The title, centred in the top margin.
pub(crate) fn draw_title<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
) -> Result<(), PlotError> {
    let (w, _) = root.dim_in_pixel();
    // The largest size up to 18 px at which the title fits the width.
    let style = |size: u32| {
        TextStyle::from(("sans-serif", size).into_font())
            .color(&BLACK)
            .pos(plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Center,
                plotters::style::text_anchor::VPos::Center,
            ))
    };
    let mut size = 18;
    while size > 9 {
        let (tw, _) = root
            .estimate_text_size(title, &style(size))
            .map_err(PlotError::draw)?;
        if tw + 12 <= w {
            break;
        }
        size -= 1;
    }
    root.draw_text(title, &style(size), (w as i32 / 2, 16))
        .map_err(PlotError::draw)
}

/// A chart on `root` whose plotting area is exactly `frame.area` (in `root`'s
/// picture coordinates), showing `frame.extent`.
pub(crate) fn world_chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    frame: &Frame,
) -> Result<WorldChart<'a, DB>, PlotError> {
    let (bx, by) = root.get_base_pixel();
    let (w, h) = root.dim_in_pixel();
    let a = frame.area;
    let e = frame.extent;
    let chart = ChartBuilder::on(root)
        .margin_top(a.top - by)
        .margin_right(bx + w as i32 - a.right)
        .margin_left(0)
        .margin_bottom(0)
        .y_label_area_size(a.left - bx)
        .x_label_area_size(by + h as i32 - a.bottom)
        .build_cartesian_2d(e.x0..e.x1, e.y0..e.y1)
        .map_err(PlotError::draw)?;
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    if (xr.start, xr.end, yr.start, yr.end) != (a.left, a.right, a.top, a.bottom) {
        return Err(PlotError::Draw(format!(
            "plotting area {xr:?} x {yr:?} differs from the frame {a:?}"
        )));
    }
    Ok(chart)
}

/// Axes with ticks and metre labels, no grid lines.
pub(crate) fn draw_axes<DB: DrawingBackend>(
    chart: &mut WorldChart<'_, DB>,
) -> Result<(), PlotError> {
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x (m)")
        .y_desc("y (m)")
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .draw()
        .map_err(PlotError::draw)
}

/// The background of a picture over a map: its title, the world chart with its axes,
/// and the map's arrows at `opacity` (0: none), each as long as the map's default style
/// draws them.
pub(crate) fn map_background<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    title: &str,
    frame: &Frame,
    map: &CliffMap,
    opacity: f64,
) -> Result<WorldChart<'a, DB>, PlotError> {
    draw_title(root, title)?;
    let mut chart = world_chart(root, frame)?;
    draw_axes(&mut chart)?;
    if opacity > 0.0 {
        let seconds = super::MapStyle::default().arrow_seconds_for(map);
        draw_arrows(&chart, map, seconds, 0.0, opacity, frame)?;
    }
    Ok(chart)
}

/// One arrow per component: from the location along the mean direction, `rho *
/// seconds` long, coloured by direction, as opaque as `opacity * weight`.
pub(crate) fn draw_arrows<DB: DrawingBackend>(
    chart: &WorldChart<'_, DB>,
    map: &CliffMap,
    seconds: f64,
    min_weight: f64,
    opacity: f64,
    frame: &Frame,
) -> Result<(), PlotError> {
    let area = chart.plotting_area();
    let ext = frame.extent;
    let longest_px = map
        .locations()
        .iter()
        .flat_map(|l| l.components.iter().map(|c| c.rho))
        .fold(0.0f64, f64::max)
        * seconds
        * frame.scale_x();
    let stroke = if longest_px >= 14.0 { 2 } else { 1 };
    for loc in map.locations() {
        let p = loc.position;
        // Arrows are drawn whole or not at all: only those starting in the view.
        if !ext.contains(p) {
            continue;
        }
        let total: f64 = loc.components.iter().map(|c| c.weight).sum();
        for c in &loc.components {
            let w = if total > 0.0 { c.weight / total } else { 0.0 };
            if w < min_weight {
                continue;
            }
            let len = c.rho * seconds;
            if len <= 0.0 {
                continue;
            }
            let (r, g, b) = direction_colour(c.theta);
            let alpha = (opacity * (0.15 + 0.85 * w)).clamp(0.0, 1.0);
            let colour = RGBColor(r, g, b).mix(alpha);
            let u = DVec2::from_angle(c.theta);
            let tip = p + u * len;
            if !ext.contains(tip) {
                continue;
            }
            let head = (0.35 * len).min(len);
            let base = tip - u * head;
            let side = u.perp() * head * 0.45;
            area.draw(&PathElement::new(
                vec![(p.x, p.y), (base.x, base.y)],
                colour.stroke_width(stroke),
            ))
            .map_err(PlotError::draw)?;
            let (l, rr) = (base + side, base - side);
            area.draw(&Polygon::new(
                vec![(tip.x, tip.y), (l.x, l.y), (rr.x, rr.y)],
                colour.filled(),
            ))
            .map_err(PlotError::draw)?;
        }
    }
    Ok(())
}

/// A direction colour wheel in the top-right corner of the plotting area, with the
/// compass letters E, N, W, S.
pub(crate) fn draw_colour_wheel<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    frame: &Frame,
) -> Result<(), PlotError> {
    let r = 26.0;
    let (cx, cy) = (
        frame.area.right as f64 - r - 22.0,
        frame.area.top as f64 + r + 22.0,
    );
    let pt = |a: f64, rad: f64| {
        (
            (cx + rad * a.cos()).round() as i32,
            (cy - rad * a.sin()).round() as i32,
        )
    };
    root.draw(&Circle::new(
        (cx as i32, cy as i32),
        (r + 20.0) as i32,
        WHITE.mix(0.85).filled(),
    ))
    .map_err(PlotError::draw)?;
    let n = 72;
    for i in 0..n {
        let a0 = i as f64 / n as f64 * std::f64::consts::TAU;
        let a1 = (i + 1) as f64 / n as f64 * std::f64::consts::TAU;
        let (cr, cg, cb) = direction_colour(0.5 * (a0 + a1));
        root.draw(&Polygon::new(
            vec![pt(a0, r * 0.45), pt(a0, r), pt(a1, r), pt(a1, r * 0.45)],
            RGBColor(cr, cg, cb).filled(),
        ))
        .map_err(PlotError::draw)?;
    }
    let style = TextStyle::from(("sans-serif", 12).into_font())
        .color(&BLACK)
        .pos(plotters::style::text_anchor::Pos::new(
            plotters::style::text_anchor::HPos::Center,
            plotters::style::text_anchor::VPos::Center,
        ));
    for (a, label) in [(0.0, "E"), (90.0f64, "N"), (180.0, "W"), (270.0, "S")] {
        root.draw_text(label, &style, pt(a.to_radians(), r + 10.0))
            .map_err(PlotError::draw)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_arrows_fit_half_a_grid_step() {
        let map = CliffMap::demo();
        let s = MapStyle::default().arrow_seconds_for(&map);
        // the demo's fastest component walks 1.3 m/s; grid step 1 m
        assert!((s * 1.3 - 0.45).abs() < 1e-12);
        let v = MapStyle::default().view_for(&map, None);
        assert_eq!((v.x0, v.x1, v.y0, v.y1), (-16.0, 16.0, -11.0, 11.0));
    }

    #[test]
    fn frame_transform_is_the_charts_transform() {
        // The public Frame maps world points to exactly the pixels the chart uses.
        for (extent, width) in [
            (Extent::new(-16.0, 16.0, -11.0, 11.0).unwrap(), 900),
            (Extent::new(-60.0, 80.0, -40.0, 20.0).unwrap(), 1000),
            (Extent::new(0.3, 0.9, -2.0, 7.0).unwrap(), 333),
        ] {
            let frame = Frame::for_map(extent, width);
            let mut buf = vec![0u8; (frame.size.0 * frame.size.1 * 3) as usize];
            let root = BitMapBackend::with_buffer(&mut buf, frame.size).into_drawing_area();
            let chart = world_chart(&root, &frame).unwrap();
            for i in 0..=20 {
                for j in 0..=20 {
                    let p = DVec2::new(
                        extent.x0 + extent.width() * i as f64 / 20.0,
                        extent.y0 + extent.height() * j as f64 / 20.0,
                    );
                    assert_eq!(frame.to_pixel(p), chart.backend_coord(&(p.x, p.y)), "{p}");
                }
            }
        }
    }

    #[test]
    fn bad_styles_are_refused() {
        let map = CliffMap::demo();
        for style in [
            MapStyle {
                width: 10,
                ..MapStyle::default()
            },
            MapStyle {
                arrow_seconds: Some(-1.0),
                ..MapStyle::default()
            },
            MapStyle {
                opacity: 2.0,
                ..MapStyle::default()
            },
        ] {
            assert!(matches!(
                plot_map_to(&map, None, &style, ImageFormat::Png),
                Err(PlotError::Invalid(_))
            ));
        }
    }
}
