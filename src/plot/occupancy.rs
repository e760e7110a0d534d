//! Occupancy over the map: the probability that a place holds someone at a few times,
//! as heat in one colour per time, over the map's faint arrows and the people's
//! observed tracks.

use std::path::Path;

use glam::DVec2;
use image::Rgb;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::map::map_background;
use super::render::{Background, Painter, render};
use super::{
    Extent, Floorplan, Frame, ImageFormat, OBSERVED, PlotError, clip_polyline, write_file,
};
use crate::map::CliffMap;
use crate::occupancy::Occupancy;

/// The heat colours of the layers, in order (orange, red, violet, blue, then again).
pub const OCCUPANCY_COLOURS: [(u8, u8, u8); 4] =
    [(245, 140, 0), (215, 25, 28), (150, 40, 190), (30, 90, 220)];

/// How an occupancy picture looks.
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyStyle {
    /// Picture width in pixels (the height follows the view's aspect).
    pub width: u32,
    /// The part of the world drawn (default: the occupancy's grid).
    pub view: Option<Extent>,
    /// Opacity of the map arrows, 0 to 1.
    pub arrow_opacity: f64,
    /// The probability drawn at full colour (cells above it are as strong); `None`:
    /// per layer, two thirds of its largest cell's.
    pub full: Option<f64>,
    /// Title (default: the times).
    pub title: Option<String>,
}

impl Default for OccupancyStyle {
    fn default() -> Self {
        Self {
            width: 900,
            view: None,
            arrow_opacity: 0.25,
            full: None,
            title: None,
        }
    }
}

/// Draw the layers of `occupancy` (each time in its colour, [`OCCUPANCY_COLOURS`],
/// as opaque as its probability over [`OccupancyStyle::full`]) over `map`'s arrows and an optional
/// floor plan, with the people's observed tracks (green) and where they stand (black
/// rings), into `out` (PNG or SVG, by extension). Returns the frame.
pub fn plot_occupancy(
    map: &CliffMap,
    floorplan: Option<&Floorplan>,
    occupancy: &Occupancy,
    observed: &[Vec<DVec2>],
    style: &OccupancyStyle,
    out: &Path,
) -> Result<Frame, PlotError> {
    let format = ImageFormat::from_path(out)?;
    let grid = *occupancy
        .grid()
        .ok_or_else(|| PlotError::Invalid("no occupancy computed".into()))?;
    if style.width < 200 {
        return Err(PlotError::Invalid(format!(
            "width {} is too small (at least 200 pixels)",
            style.width
        )));
    }
    if let Some(f) = style
        .full
        .filter(|f| !(f.is_finite() && *f > 0.0 && *f <= 1.0))
    {
        return Err(PlotError::Invalid(format!(
            "full colour at {f} is not a probability above 0"
        )));
    }
    let full: Vec<f64> = (0..occupancy.layers())
        .map(|i| {
            style.full.unwrap_or_else(|| {
                let top = occupancy.layer(i).iter().fold(0.0f32, |m, &v| m.max(v)) as f64;
                (top * 2.0 / 3.0).max(1e-6)
            })
        })
        .collect();
    let view = match style.view {
        Some(v) => v,
        None => Extent::new(
            grid.origin[0],
            grid.origin[0] + grid.width as f64 * grid.resolution,
            grid.origin[1],
            grid.origin[1] + grid.height as f64 * grid.resolution,
        )?,
    };
    let frame = Frame::for_map(view, style.width);
    let mut background = Background::new(&frame, floorplan, 0.6);
    // the heat, pixel by pixel in the plotting area: each layer blends its colour in
    let a = frame.area;
    for py in a.top.max(0)..a.bottom.min(frame.size.1 as i32) {
        for px in a.left.max(0)..a.right.min(frame.size.0 as i32) {
            let w = frame.to_world((px, py));
            let Some((r, c)) = grid.cell_of(w.x, w.y) else {
                continue;
            };
            let pixel = background.image.get_pixel_mut(px as u32, py as u32);
            for i in 0..occupancy.layers() {
                let p = occupancy.at(i, r, c) as f64;
                let alpha = (p / full[i]).min(1.0) * 0.85;
                if alpha <= 0.004 {
                    continue;
                }
                let (cr, cg, cb) = OCCUPANCY_COLOURS[i % OCCUPANCY_COLOURS.len()];
                let mix = |under: u8, over: u8| {
                    (under as f64 * (1.0 - alpha) + over as f64 * alpha).round() as u8
                };
                *pixel = Rgb([mix(pixel[0], cr), mix(pixel[1], cg), mix(pixel[2], cb)]);
            }
        }
    }
    let times = occupancy
        .times()
        .iter()
        .map(|t| format!("{t:.1}"))
        .collect::<Vec<_>>()
        .join(", ");
    let title = style.title.clone().unwrap_or_else(|| {
        if occupancy.is_window() {
            format!("occupancy between {times} s")
        } else {
            format!("occupancy at {times} s")
        }
    });
    let painter = OccupancyPainter {
        map,
        observed,
        style,
        frame,
        title,
        layers: if occupancy.is_window() {
            Vec::new()
        } else {
            occupancy.times().to_vec()
        },
    };
    let bytes = render(frame.size, background, Some(frame.area), format, &painter)?;
    write_file(out, &bytes)?;
    Ok(frame)
}

struct OccupancyPainter<'a> {
    map: &'a CliffMap,
    observed: &'a [Vec<DVec2>],
    style: &'a OccupancyStyle,
    frame: Frame,
    title: String,
    layers: Vec<f64>,
}

impl Painter for OccupancyPainter<'_> {
    fn paint<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let chart = map_background(
            root,
            &self.title,
            &self.frame,
            self.map,
            self.style.arrow_opacity,
        )?;
        let area = chart.plotting_area();
        let view = self.frame.extent;
        let err = PlotError::draw;
        let green = RGBColor(OBSERVED.0, OBSERVED.1, OBSERVED.2);
        for track in self.observed {
            for run in clip_polyline(track, &view) {
                area.draw(&PathElement::new(
                    run.iter().map(|p| (p.x, p.y)).collect::<Vec<_>>(),
                    green.stroke_width(3),
                ))
                .map_err(err)?;
            }
            if let Some(&last) = track.last().filter(|p| view.contains(**p)) {
                area.draw(&Circle::new((last.x, last.y), 5, BLACK.stroke_width(2)))
                    .map_err(err)?;
            }
        }
        // the key: one swatch per time
        let (x0, y0) = (self.frame.area.left + 12, self.frame.area.top + 12);
        for (i, t) in self.layers.iter().enumerate() {
            let (r, g, b) = OCCUPANCY_COLOURS[i % OCCUPANCY_COLOURS.len()];
            let y = y0 + 22 * i as i32;
            root.draw(&Rectangle::new(
                [(x0, y), (x0 + 16, y + 16)],
                RGBColor(r, g, b).filled(),
            ))
            .map_err(err)?;
            root.draw(&Text::new(
                format!("{t:.1} s"),
                (x0 + 22, y),
                ("sans-serif", 15).into_font(),
            ))
            .map_err(err)?;
        }
        Ok(())
    }
}
