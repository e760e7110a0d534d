//! World rectangles and their placement on the picture's pixels.

use std::fmt;
use std::str::FromStr;

use glam::DVec2;

use super::PlotError;

/// A rectangle of the world (or of any two plotted quantities): `x0..x1` by `y0..y1`.
///
/// Parsed from the command line's `X0,X1,Y0,Y1`:
///
/// ```
/// use cliff::plot::Extent;
/// let e: Extent = "-11,12,-10,13.5".parse().unwrap();
/// assert_eq!((e.width(), e.height()), (23.0, 23.5));
/// assert!("1,0,0,1".parse::<Extent>().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extent {
    /// Left edge.
    pub x0: f64,
    /// Right edge.
    pub x1: f64,
    /// Bottom edge.
    pub y0: f64,
    /// Top edge.
    pub y1: f64,
}

impl Extent {
    /// An extent from its edges; fails unless all are finite, `x0 < x1` and `y0 < y1`.
    pub fn new(x0: f64, x1: f64, y0: f64, y1: f64) -> Result<Self, PlotError> {
        let e = Extent { x0, x1, y0, y1 };
        let bad = |message: &str| PlotError::Extent {
            text: e.to_string(),
            message: message.to_string(),
        };
        if ![x0, x1, y0, y1].iter().all(|v| v.is_finite()) {
            return Err(bad("all four numbers must be finite"));
        }
        if x0 >= x1 {
            return Err(bad("X0 must be less than X1"));
        }
        if y0 >= y1 {
            return Err(bad("Y0 must be less than Y1"));
        }
        Ok(e)
    }

    /// The smallest extent holding all `points`, grown by `pad` on every side; `None`
    /// when there are no finite points. A degenerate extent (all points on a line) is
    /// grown to at least one unit.
    pub fn around(points: impl IntoIterator<Item = DVec2>, pad: f64) -> Option<Self> {
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        for p in points.into_iter().filter(|p| p.is_finite()) {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        if !lo.is_finite() {
            return None;
        }
        let pad = pad.max(0.0);
        let grow = |a: f64, b: f64| {
            let extra = ((1.0 - (b - a)) * 0.5).max(0.0);
            (a - pad - extra, b + pad + extra)
        };
        let (x0, x1) = grow(lo.x, hi.x);
        let (y0, y1) = grow(lo.y, hi.y);
        Some(Extent { x0, x1, y0, y1 })
    }

    /// Width `x1 - x0`.
    pub fn width(&self) -> f64 {
        self.x1 - self.x0
    }

    /// Height `y1 - y0`.
    pub fn height(&self) -> f64 {
        self.y1 - self.y0
    }

    /// Whether `p` lies inside (edges included).
    pub fn contains(&self, p: DVec2) -> bool {
        (self.x0..=self.x1).contains(&p.x) && (self.y0..=self.y1).contains(&p.y)
    }
}

impl fmt::Display for Extent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.x1, self.y0, self.y1)
    }
}

impl FromStr for Extent {
    type Err = PlotError;
    fn from_str(s: &str) -> Result<Self, PlotError> {
        let bad = |message: String| PlotError::Extent {
            text: s.to_string(),
            message,
        };
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        if parts.len() != 4 {
            return Err(bad(format!(
                "expected four numbers X0,X1,Y0,Y1, found {}",
                parts.len()
            )));
        }
        let mut v = [0.0; 4];
        for (i, p) in parts.iter().enumerate() {
            v[i] = p
                .parse()
                .map_err(|_| bad(format!("'{p}' (number {}) is not a number", i + 1)))?;
        }
        Extent::new(v[0], v[1], v[2], v[3]).map_err(|e| match e {
            PlotError::Extent { message, .. } => bad(message),
            other => other,
        })
    }
}

/// The part of the segment `a`-`b` inside `e` (Liang-Barsky), or `None` when the
/// segment misses it.
pub(crate) fn clip_segment(a: DVec2, b: DVec2, e: &Extent) -> Option<(DVec2, DVec2)> {
    if !(a.is_finite() && b.is_finite()) {
        return None;
    }
    let d = b - a;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-d.x, a.x - e.x0),
        (d.x, e.x1 - a.x),
        (-d.y, a.y - e.y0),
        (d.y, e.y1 - a.y),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
            if t0 > t1 {
                return None;
            }
        }
    }
    Some((a + d * t0, a + d * t1))
}

/// A polyline cut to the parts inside `e`: each run of points continues while the
/// line stays inside, and a new run starts where it comes back in.
pub(crate) fn clip_polyline(points: &[DVec2], e: &Extent) -> Vec<Vec<DVec2>> {
    let mut runs: Vec<Vec<DVec2>> = Vec::new();
    let mut open = false;
    for w in points.windows(2) {
        match clip_segment(w[0], w[1], e) {
            Some((a, b)) => {
                if !open || a != w[0] {
                    runs.push(vec![a]);
                }
                runs.last_mut().expect("a run is open").push(b);
                open = b == w[1];
            }
            None => open = false,
        }
    }
    if points.len() == 1 && e.contains(points[0]) {
        runs.push(vec![points[0]]);
    }
    runs
}

/// A rectangle of pixels: columns `left..right`, rows `top..bottom` (ends exclusive).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelRect {
    /// First column.
    pub left: i32,
    /// First row.
    pub top: i32,
    /// One past the last column.
    pub right: i32,
    /// One past the last row.
    pub bottom: i32,
}

impl PixelRect {
    /// Width in pixels.
    pub fn width(&self) -> i32 {
        self.right - self.left
    }

    /// Height in pixels.
    pub fn height(&self) -> i32 {
        self.bottom - self.top
    }

    /// Whether the pixel `(x, y)` lies inside.
    pub fn contains(&self, (x, y): (i32, i32)) -> bool {
        (self.left..self.right).contains(&x) && (self.top..self.bottom).contains(&y)
    }
}

/// How a picture places a world rectangle on its pixels: the picture's size, the
/// plotting area inside it and the [`Extent`] shown there (x to the right, y up).
///
/// [`to_pixel`](Self::to_pixel) is exactly the transform the drawing code uses, so the
/// pixel it returns is where a point at that world position was drawn.
///
/// ```
/// use cliff::plot::{Extent, Frame};
/// use glam::DVec2;
/// let frame = Frame::for_map(Extent::new(-15.0, 15.0, -10.0, 10.0).unwrap(), 800);
/// assert_eq!(frame.size.0, 800);
/// // equal scale on both axes
/// let (a, b) = (frame.to_pixel(DVec2::new(0.0, 0.0)), frame.to_pixel(DVec2::new(1.0, 1.0)));
/// assert!(((b.0 - a.0) - (a.1 - b.1)).abs() <= 1);
/// // y grows upwards
/// assert!(b.1 < a.1);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Picture size in pixels (width, height).
    pub size: (u32, u32),
    /// The plotting area.
    pub area: PixelRect,
    /// The world rectangle shown in the plotting area.
    pub extent: Extent,
}

/// Margins of map pictures: title above, tick labels left and below.
pub(crate) const MAP_MARGIN_TOP: i32 = 34;
pub(crate) const MAP_MARGIN_RIGHT: i32 = 18;
pub(crate) const MAP_LABELS_LEFT: i32 = 58;
pub(crate) const MAP_LABELS_BOTTOM: i32 = 42;
/// Largest picture side we draw (pixels).
pub(crate) const MAX_SIDE: u32 = 8192;

impl Frame {
    /// The frame of a map picture `width` pixels wide showing `extent` at equal scale
    /// on both axes; the height follows from the extent's aspect ratio (the width is
    /// reduced when the height would exceed 8192 pixels, and at least 120 pixels are
    /// kept for the plotting area).
    pub fn for_map(extent: Extent, width: u32) -> Frame {
        let fixed_w = MAP_LABELS_LEFT + MAP_MARGIN_RIGHT;
        let fixed_h = MAP_MARGIN_TOP + MAP_LABELS_BOTTOM;
        let width = width.clamp(fixed_w as u32 + 120, MAX_SIDE);
        let mut area_w = width as i32 - fixed_w;
        let aspect = extent.height() / extent.width();
        let mut area_h = (area_w as f64 * aspect).round().max(1.0) as i32;
        let max_h = MAX_SIDE as i32 - fixed_h;
        if area_h > max_h {
            area_h = max_h;
            area_w = ((area_h as f64 / aspect).round() as i32).max(1);
        }
        let area = PixelRect {
            left: MAP_LABELS_LEFT,
            top: MAP_MARGIN_TOP,
            right: MAP_LABELS_LEFT + area_w,
            bottom: MAP_MARGIN_TOP + area_h,
        };
        Frame {
            size: ((area_w + fixed_w) as u32, (area_h + fixed_h) as u32),
            area,
            extent,
        }
    }

    /// The pixel where the world point `p` is drawn (it may lie outside the plotting
    /// area, or outside the picture, when `p` is outside the extent).
    pub fn to_pixel(&self, p: DVec2) -> (i32, i32) {
        // The same arithmetic as the drawing library's linear axes: x runs from the
        // area's first to its last column, y from its last row up to its first.
        let map = |v: f64, lo: f64, hi: f64, from: i32, to: i32| -> i32 {
            let t = (v - lo) / (hi - lo);
            let len = to - from;
            if len > 0 {
                from + (len as f64 * t + 1e-3).floor() as i32
            } else {
                from + (len as f64 * t - 1e-3).ceil() as i32
            }
        };
        (
            map(
                p.x,
                self.extent.x0,
                self.extent.x1,
                self.area.left,
                self.area.right - 1,
            ),
            map(
                p.y,
                self.extent.y0,
                self.extent.y1,
                self.area.bottom - 1,
                self.area.top,
            ),
        )
    }

    /// The world point at the centre of pixel `(x, y)` (the inverse of
    /// [`to_pixel`](Self::to_pixel) up to a pixel).
    pub fn to_world(&self, (x, y): (i32, i32)) -> DVec2 {
        let w = (self.area.right - 1 - self.area.left).max(1) as f64;
        let h = (self.area.bottom - 1 - self.area.top).max(1) as f64;
        DVec2::new(
            self.extent.x0 + (x - self.area.left) as f64 / w * self.extent.width(),
            self.extent.y0 + (self.area.bottom - 1 - y) as f64 / h * self.extent.height(),
        )
    }

    /// Pixels per world unit along x.
    pub fn scale_x(&self) -> f64 {
        (self.area.right - 1 - self.area.left) as f64 / self.extent.width()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extent_parse_errors_name_the_problem() {
        let e = |s: &str| s.parse::<Extent>().unwrap_err().to_string();
        assert!(
            e("1,2,3").contains("expected four numbers"),
            "{}",
            e("1,2,3")
        );
        assert!(e("1,x,3,4").contains("'x' (number 2) is not a number"));
        assert!(e("2,1,3,4").contains("X0 must be less than X1"));
        assert!(e("1,2,4,4").contains("Y0 must be less than Y1"));
        assert!(e("1,2,4,inf").contains("finite"));
        let ok: Extent = " -60, 80 ,-40,20".parse().unwrap();
        assert_eq!(ok, Extent::new(-60.0, 80.0, -40.0, 20.0).unwrap());
    }

    #[test]
    fn frame_keeps_aspect_and_maps_corners() {
        let e = Extent::new(-60.0, 80.0, -40.0, 20.0).unwrap();
        let f = Frame::for_map(e, 1000);
        assert_eq!(f.size.0, 1000);
        let ratio = f.area.height() as f64 / f.area.width() as f64;
        assert!((ratio - 60.0 / 140.0).abs() < 0.01);
        assert_eq!(
            f.to_pixel(DVec2::new(-60.0, 20.0)),
            (f.area.left, f.area.top)
        );
        assert_eq!(
            f.to_pixel(DVec2::new(80.0, -40.0)),
            (f.area.right - 1, f.area.bottom - 1)
        );
        let p = DVec2::new(3.3, -7.1);
        assert!(f.to_world(f.to_pixel(p)).distance(p) < 2.0 / f.scale_x());
        // a very tall extent is capped
        let tall = Frame::for_map(Extent::new(0.0, 1.0, 0.0, 1000.0).unwrap(), 2000);
        assert!(tall.size.1 <= MAX_SIDE);
    }

    #[test]
    fn clipping_keeps_the_inside_parts() {
        let e = Extent::new(0.0, 10.0, 0.0, 10.0).unwrap();
        let p = |x: f64, y: f64| DVec2::new(x, y);
        assert_eq!(
            clip_segment(p(1.0, 1.0), p(2.0, 2.0), &e),
            Some((p(1.0, 1.0), p(2.0, 2.0)))
        );
        assert_eq!(
            clip_segment(p(-5.0, 5.0), p(15.0, 5.0), &e),
            Some((p(0.0, 5.0), p(10.0, 5.0)))
        );
        assert_eq!(clip_segment(p(-5.0, 5.0), p(-1.0, 5.0), &e), None);
        let (a, b) = clip_segment(p(-1.0, 5.0), p(5.0, 11.0), &e).unwrap();
        assert!(a.distance(p(0.0, 6.0)) < 1e-12 && b.distance(p(4.0, 10.0)) < 1e-12);
        // out and back in: two runs
        let runs = clip_polyline(
            &[
                p(1.0, 1.0),
                p(5.0, 1.0),
                p(5.0, 20.0),
                p(6.0, 5.0),
                p(7.0, 5.0),
            ],
            &e,
        );
        assert_eq!(runs.len(), 2, "{runs:?}");
        assert_eq!(runs[0], vec![p(1.0, 1.0), p(5.0, 1.0), p(5.0, 10.0)]);
        assert_eq!(runs[1].last(), Some(&p(7.0, 5.0)));
        assert!((runs[1][0].y - 10.0).abs() < 1e-12);
    }

    #[test]
    fn around_pads_and_handles_degenerate_sets() {
        let e = Extent::around([DVec2::new(1.0, 2.0), DVec2::new(3.0, 2.0)], 0.5).unwrap();
        assert_eq!((e.x0, e.x1), (0.5, 3.5));
        assert_eq!((e.y0, e.y1), (1.0, 3.0));
        assert!(Extent::around([DVec2::NAN], 1.0).is_none());
    }
}
