//! Pictures: CLiFF-maps as coloured arrows, predictions fanning out from the observed
//! track, and ADE/FDE error curves, as PNG or SVG.
//!
//! The pictures follow the CLiFF-LHMP paper's figures:
//!
//! * [`plot_map`]: one arrow per mixture component at its location, pointing along its
//!   mean direction, as long as its mean speed (times [`MapStyle::arrow_seconds`]),
//!   coloured by direction on a colour wheel ([`direction_colour`]) and as opaque as
//!   its weight, optionally over a floor plan ([`Floorplan`]).
//! * [`plot_predictions`]: floor plan, faint map arrows, the observed track
//!   ([`OBSERVED`], green), the ground truth ([`TRUTH`], red) and the predicted samples
//!   ([`SAMPLE`], blue, fading along the horizon).
//! * [`plot_curves`]: ADE and FDE against the prediction horizon per method and run,
//!   with one-standard-deviation bands, read from `summary.csv` files
//!   ([`read_summary`]).
//! * [`plot_occupancy`]: the probability that a place holds someone at a few times
//!   (one heat colour per time) over the map's faint arrows and the observed tracks.
//! * [`plot_lines`]: labelled lines over two numeric axes (linear or logarithmic x),
//!   for measured series such as `cliff-bench --compare`'s latency distributions.
//!
//! The output format follows the file extension ([`ImageFormat::from_path`]). Text is
//! drawn with an embedded font (DejaVu Sans), so nothing needs to be installed.
//!
//! Every map-like picture places the world on the pixels through a [`Frame`]: the
//! same transform the drawing code uses is public, so a caller (or a test) can find
//! the pixel where a world point was drawn.
//!
//! ```
//! use cliff::map::CliffMap;
//! use cliff::plot::{plot_map_to, MapStyle, ImageFormat};
//!
//! let map = CliffMap::demo();
//! let style = MapStyle { width: 400, ..MapStyle::default() };
//! let (bytes, frame) = plot_map_to(&map, None, &style, ImageFormat::Png).unwrap();
//! assert!(bytes.starts_with(b"\x89PNG"));
//! // where the location at the hall's centre was drawn
//! let (px, py) = frame.to_pixel(glam::DVec2::new(0.0, 0.0));
//! assert!(px > 0 && (px as u32) < frame.size.0 && py > 0 && (py as u32) < frame.size.1);
//! ```

mod curves;
mod diff;
mod frame;
mod lines;
mod map;
mod occupancy;
mod predict;
mod render;

use std::path::{Path, PathBuf};

pub use curves::{
    CurveRun, CurvesLayout, CurvesStyle, SummaryRow, curves_layout, parse_per_person_spread,
    parse_summary, plot_curves, plot_curves_to, read_per_person_spread, read_summary,
};
pub use diff::{ADDED, MOVED, plot_diff, plot_diff_to};
pub use frame::{Extent, Frame, PixelRect};
pub(crate) use frame::{clip_polyline, clip_segment};
pub use lines::{Line, LineChart, plot_lines, plot_lines_to};
pub use map::{MapStyle, plot_map, plot_map_to};
pub use occupancy::{OCCUPANCY_COLOURS, OccupancyStyle, plot_occupancy};
pub use predict::{PersonPrediction, PredictStyle, plot_predictions, plot_predictions_to};
pub use render::{Floorplan, ImageFormat};

/// Colour of the observed track (green).
pub const OBSERVED: (u8, u8, u8) = (0, 150, 0);
/// Colour of the ground-truth future track (red).
pub const TRUTH: (u8, u8, u8) = (220, 0, 0);
/// Colour of the predicted samples (blue).
pub const SAMPLE: (u8, u8, u8) = (0, 70, 230);

/// Errors from drawing and writing pictures.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The output file's extension names no picture format.
    #[error("{0}: unknown picture format (use .png or .svg)")]
    UnknownFormat(PathBuf),
    /// A floor plan image could not be read or decoded.
    #[error("floor plan {file}: {message}")]
    Floorplan {
        /// The image file.
        file: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// An extent is unusable (not four finite numbers `X0,X1,Y0,Y1` with `X0 < X1`,
    /// `Y0 < Y1`).
    #[error("extent '{text}': {message}")]
    Extent {
        /// The extent as given.
        text: String,
        /// What is wrong.
        message: String,
    },
    /// A summary file is unusable; names the file, line and column (1-based; column 0
    /// means the whole line).
    #[error("{file}:{line}: column {column}: {message}")]
    Summary {
        /// The file.
        file: String,
        /// Line (1-based).
        line: usize,
        /// Column (1-based, 0 for the whole line).
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// Nothing to draw, or a drawing parameter is unusable.
    #[error("{0}")]
    Invalid(String),
    /// The drawing library failed.
    #[error("drawing failed: {0}")]
    Draw(String),
    /// Reading or writing a file failed.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
}

impl PlotError {
    fn draw(e: impl std::fmt::Display) -> Self {
        PlotError::Draw(e.to_string())
    }
}

/// The colour of a direction on a circular colour map (a hue wheel): east (0) is red,
/// north (pi/2) yellow-green, west (pi) cyan, south (3pi/2) violet. Directions a full
/// turn apart get the same colour.
///
/// ```
/// use cliff::plot::direction_colour;
/// use std::f64::consts::{PI, TAU};
/// assert_eq!(direction_colour(0.0), direction_colour(TAU));
/// let (r, g, b) = direction_colour(0.0);
/// assert!(r > 200 && g < 60 && b < 60);
/// let (r, g, b) = direction_colour(PI);
/// assert!(r < 60 && g > 150 && b > 150);
/// ```
pub fn direction_colour(theta: f64) -> (u8, u8, u8) {
    let h = crate::math::wrap_2pi(theta) / std::f64::consts::TAU * 6.0;
    let (s, v) = (0.9, 0.9);
    let c = v * s;
    let x = c * (1.0 - ((h % 2.0) - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    let to = |u: f64| ((u + m) * 255.0).round().clamp(0.0, 255.0) as u8;
    (to(r), to(g), to(b))
}

/// The hue (degrees, `[0, 360)`) and saturation (`[0, 1]`) of an RGB colour, the
/// inverse of the colour wheel of [`direction_colour`] (for checking pictures).
///
/// ```
/// use cliff::plot::{direction_colour, hue_saturation};
/// let (h, s) = hue_saturation(direction_colour(std::f64::consts::FRAC_PI_2));
/// assert!((h - 90.0).abs() < 2.0 && s > 0.8);
/// ```
pub fn hue_saturation((r, g, b): (u8, u8, u8)) -> (f64, f64) {
    let (r, g, b) = (r as f64 / 255.0, g as f64 / 255.0, b as f64 / 255.0);
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let d = max - min;
    if max <= 0.0 || d <= 0.0 {
        return (0.0, 0.0);
    }
    let h = if max == r {
        60.0 * ((g - b) / d).rem_euclid(6.0)
    } else if max == g {
        60.0 * ((b - r) / d + 2.0)
    } else {
        60.0 * ((r - g) / d + 4.0)
    };
    (h.rem_euclid(360.0), d / max)
}

/// Write picture bytes to `path`, naming the file in the error.
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), PlotError> {
    std::fs::write(path, bytes).map_err(|source| PlotError::Io {
        file: path.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_wheel_is_circular_and_invertible() {
        for i in 0..72 {
            let theta = i as f64 * 5f64.to_radians();
            let (h, s) = hue_saturation(direction_colour(theta));
            let want = i as f64 * 5.0;
            let diff = ((h - want + 180.0).rem_euclid(360.0) - 180.0).abs();
            assert!(diff < 2.0, "theta {want} deg gave hue {h}");
            assert!(s > 0.85);
        }
        assert_eq!(
            direction_colour(-std::f64::consts::FRAC_PI_2),
            direction_colour(3.0 * std::f64::consts::FRAC_PI_2)
        );
    }
}
