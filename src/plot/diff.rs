//! What changed between two maps, as a picture ([`plot_diff`]): the new map's arrows,
//! under them every location in both as a red square as dark as it moved, added
//! locations as green circles and removed ones as black crosses.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::map::{draw_arrows, draw_axes, draw_title, map_extent, world_chart};
use super::render::{Background, Painter, render};
use super::{Floorplan, Frame, ImageFormat, MapStyle, PlotError, write_file};
use crate::map::CliffMap;
use crate::map::diff::MapDiff;

/// Colour of the squares of moved locations.
pub const MOVED: (u8, u8, u8) = (215, 25, 28);
/// Colour of added locations.
pub const ADDED: (u8, u8, u8) = (0, 150, 0);

/// Draw `diff` (from [`diff`](crate::map::diff::diff)`(old, new)`) as a picture and write
/// it to `out` (PNG or SVG, by extension); `style` as for [`plot_map`](super::plot_map)
/// (its opacity is the arrows'). A square is opaque for the largest move shown, or for
/// `full_move` when given. Returns the frame.
pub fn plot_diff(
    old: &CliffMap,
    new: &CliffMap,
    diff: &MapDiff,
    floorplan: Option<&Floorplan>,
    style: &MapStyle,
    full_move: Option<f64>,
    out: &Path,
) -> Result<Frame, PlotError> {
    let format = ImageFormat::from_path(out)?;
    let (bytes, frame) = plot_diff_to(old, new, diff, floorplan, style, full_move, format)?;
    write_file(out, &bytes)?;
    Ok(frame)
}

/// Draw `diff` into picture bytes of `format`; see [`plot_diff`].
pub fn plot_diff_to(
    old: &CliffMap,
    new: &CliffMap,
    diff: &MapDiff,
    floorplan: Option<&Floorplan>,
    style: &MapStyle,
    full_move: Option<f64>,
    format: ImageFormat,
) -> Result<(Vec<u8>, Frame), PlotError> {
    if let Some(f) = full_move
        && !(f > 0.0 && f <= 1.0)
    {
        return Err(PlotError::Invalid(format!(
            "full move {f} must be in (0, 1]"
        )));
    }
    let view = match (style.view, floorplan) {
        (Some(v), _) => v,
        (None, Some(fp)) => fp.extent(),
        (None, None) => {
            let (a, b) = (map_extent(old), map_extent(new));
            super::Extent {
                x0: a.x0.min(b.x0),
                x1: a.x1.max(b.x1),
                y0: a.y0.min(b.y0),
                y1: a.y1.max(b.y1),
            }
        }
    };
    let style = MapStyle {
        view: Some(view),
        ..style.clone()
    };
    style.check()?;
    let frame = Frame::for_map(view, style.width);
    let background = Background::new(&frame, floorplan, style.floorplan_strength);
    let full = full_move.unwrap_or_else(|| diff.largest_move()).max(1e-6);
    let painter = DiffPainter {
        old,
        new,
        diff,
        style: &style,
        full,
        frame,
    };
    let bytes = render(
        frame.size,
        background,
        floorplan.map(|_| frame.area),
        format,
        &painter,
    )?;
    Ok((bytes, frame))
}

struct DiffPainter<'a> {
    old: &'a CliffMap,
    new: &'a CliffMap,
    diff: &'a MapDiff,
    style: &'a MapStyle,
    full: f64,
    frame: Frame,
}

impl Painter for DiffPainter<'_> {
    fn paint<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let d = self.diff;
        let title = self.style.title.clone().unwrap_or_else(|| {
            format!(
                "map diff: {} added, {} removed, {} of {} moved > 0.01 (largest {:.3})",
                d.added.len(),
                d.removed.len(),
                d.moved_more_than(0.01),
                d.common.len(),
                d.largest_move()
            )
        });
        draw_title(root, &title)?;
        let mut chart = world_chart(root, &self.frame)?;
        draw_axes(&mut chart)?;
        let area = chart.plotting_area();
        let ext = self.frame.extent;
        let half = 0.4 * self.new.grid().step();
        let (r, g, b) = MOVED;
        for c in &d.common {
            let p = c.position;
            if !ext.contains(p) || c.moved <= 0.0 {
                continue;
            }
            let alpha = (c.moved / self.full).clamp(0.0, 1.0);
            area.draw(&Rectangle::new(
                [(p.x - half, p.y - half), (p.x + half, p.y + half)],
                RGBColor(r, g, b).mix(alpha).filled(),
            ))
            .map_err(PlotError::draw)?;
        }
        draw_arrows(
            &chart,
            self.new,
            self.style.arrow_seconds_for(self.new),
            self.style.min_weight,
            self.style.opacity * 0.6,
            &self.frame,
        )?;
        let (r, g, b) = ADDED;
        for &j in &d.added {
            let p = self.new.locations()[j].position;
            if ext.contains(p) {
                area.draw(&Circle::new(
                    (p.x, p.y),
                    4,
                    RGBColor(r, g, b).stroke_width(2),
                ))
                .map_err(PlotError::draw)?;
            }
        }
        for &i in &d.removed {
            let p = self.old.locations()[i].position;
            if ext.contains(p) {
                area.draw(&Cross::new((p.x, p.y), 4, BLACK.stroke_width(2)))
                    .map_err(PlotError::draw)?;
            }
        }
        let (_, h) = root.dim_in_pixel();
        let legend = format!(
            "red square: moved (opaque: {:.3}), green circle: added, black cross: removed",
            self.full
        );
        root.draw_text(
            &legend,
            &TextStyle::from(("sans-serif", 12).into_font()).color(&BLACK),
            (8, h as i32 - 16),
        )
        .map_err(PlotError::draw)?;
        Ok(())
    }
}
