//! Output formats, floor plans and the shared rendering path (PNG and SVG).

use std::io::Cursor;
use std::path::Path;
use std::sync::Once;

use base64::Engine as _;
use glam::DVec2;
use image::codecs::png::{CompressionType, FilterType as PngFilter, PngEncoder};
use image::imageops::FilterType;
use image::{ImageEncoder, Rgb, RgbImage};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{Extent, Frame, PlotError};
use crate::map::CliffMap;

/// Picture formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFormat {
    /// PNG bitmap.
    Png,
    /// SVG drawing (a floor plan is embedded as a PNG image).
    Svg,
}

impl ImageFormat {
    /// The format named by a path's extension (`.png` or `.svg`, any case).
    ///
    /// ```
    /// use cliff::plot::ImageFormat;
    /// assert_eq!(ImageFormat::from_path("a/map.SVG".as_ref()).unwrap(), ImageFormat::Svg);
    /// assert!(ImageFormat::from_path("map.jpg".as_ref()).is_err());
    /// ```
    pub fn from_path(path: &Path) -> Result<Self, PlotError> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("png") => Ok(ImageFormat::Png),
            Some("svg") => Ok(ImageFormat::Svg),
            _ => Err(PlotError::UnknownFormat(path.to_path_buf())),
        }
    }
}

/// A floor plan: an image of the environment and the world rectangle it covers
/// (its left column at `x0`, its top row at `y1`).
///
/// Pictures draw it faded (see [`MapStyle::floorplan_strength`](super::MapStyle)) so
/// that the arrows and tracks over it stay readable.
#[derive(Debug, Clone)]
pub struct Floorplan {
    image: RgbImage,
    extent: Extent,
}

impl Floorplan {
    /// Read a PNG or JPEG floor plan covering `extent`.
    ///
    /// ```
    /// use cliff::plot::Floorplan;
    /// let plan = Floorplan::load("../shared/data/atc/floorplan.jpg", "-60,80,-40,20".parse()?)?;
    /// assert_eq!(plan.image().dimensions(), (2800, 1200));
    /// let missing = Floorplan::load("no-such-plan.png", "0,1,0,1".parse()?).unwrap_err();
    /// assert!(missing.to_string().contains("no-such-plan.png"));
    /// # Ok::<(), cliff::plot::PlotError>(())
    /// ```
    pub fn load(path: impl AsRef<Path>, extent: Extent) -> Result<Self, PlotError> {
        let path = path.as_ref();
        let bad = |message: String| PlotError::Floorplan {
            file: path.to_path_buf(),
            message,
        };
        let reader = image::ImageReader::open(path)
            .map_err(|e| bad(e.to_string()))?
            .with_guessed_format()
            .map_err(|e| bad(e.to_string()))?;
        let img = reader
            .decode()
            .map_err(|e| bad(format!("cannot decode the image: {e}")))?;
        if img.width() == 0 || img.height() == 0 {
            return Err(bad("the image is empty".into()));
        }
        Ok(Floorplan {
            image: img.to_rgb8(),
            extent,
        })
    }

    /// A floor plan from an image in memory covering `extent`.
    pub fn from_image(image: RgbImage, extent: Extent) -> Self {
        Floorplan { image, extent }
    }

    /// The floor a map covers: white where a map location lies within half a grid
    /// step (in x and in y), dark grey elsewhere, drawn at `pixels_per_metre` over
    /// `extent`. For maps of a closed space, such as the built-in demo hall, this is
    /// its walkable floor.
    ///
    /// ```
    /// use cliff::{map::CliffMap, plot::{Extent, Floorplan}};
    /// let plan = Floorplan::from_map(&CliffMap::demo(), Extent::new(-16.0, 16.0, -11.0, 11.0)?, 10.0);
    /// assert_eq!(plan.image().dimensions(), (320, 220));
    /// // the crossing is floor, the corner of the hall is not
    /// assert_eq!(plan.image().get_pixel(160, 110).0, [255, 255, 255]);
    /// assert_eq!(plan.image().get_pixel(5, 5).0, [60, 60, 60]);
    /// # Ok::<(), cliff::plot::PlotError>(())
    /// ```
    pub fn from_map(map: &CliffMap, extent: Extent, pixels_per_metre: f64) -> Self {
        let w = (extent.width() * pixels_per_metre)
            .round()
            .clamp(1.0, 4096.0) as u32;
        let h = (extent.height() * pixels_per_metre)
            .round()
            .clamp(1.0, 4096.0) as u32;
        let step = map.grid().step();
        let half = 0.5 * step;
        let image = RgbImage::from_fn(w, h, |x, y| {
            let p = DVec2::new(
                extent.x0 + (x as f64 + 0.5) / w as f64 * extent.width(),
                extent.y1 - (y as f64 + 0.5) / h as f64 * extent.height(),
            );
            let mut free = false;
            map.for_each_near(p, step, |i| {
                let d = (map.locations()[i].position - p).abs();
                free |= d.x <= half && d.y <= half;
            });
            if free {
                Rgb([255, 255, 255])
            } else {
                Rgb([60, 60, 60])
            }
        });
        Floorplan { image, extent }
    }

    /// The floor plan of the built-in demo hall ([`CliffMap::demo`]): its two
    /// corridors, over x in [-16, 16], y in [-11, 11].
    pub fn demo() -> Self {
        Self::from_map(&CliffMap::demo(), Self::demo_extent(), 20.0)
    }

    /// The extent of [`Floorplan::demo`]: the demo hall with a 1 m border.
    pub fn demo_extent() -> Extent {
        Extent {
            x0: -16.0,
            x1: 16.0,
            y0: -11.0,
            y1: 11.0,
        }
    }

    /// The world rectangle the image covers.
    pub fn extent(&self) -> Extent {
        self.extent
    }

    /// The image.
    pub fn image(&self) -> &RgbImage {
        &self.image
    }
}

/// A picture being made: its frame's size and an optional background (the floor
/// plan, already scaled and faded) covering the plotting area.
pub(crate) struct Background {
    /// Picture-sized image, white outside the floor plan.
    pub image: RgbImage,
}

impl Background {
    /// White picture with the floor plan drawn into `frame`'s plotting area, faded
    /// towards white by `1 - strength`.
    pub fn new(frame: &Frame, floorplan: Option<&Floorplan>, strength: f64) -> Self {
        let mut image = RgbImage::from_pixel(frame.size.0, frame.size.1, Rgb([255, 255, 255]));
        if let Some(fp) = floorplan {
            paste_floorplan(&mut image, frame, fp, strength);
        }
        Background { image }
    }
}

/// Draw the part of `fp` inside `frame`'s view into its plotting area, faded. Only
/// the visible part of the image is cropped and scaled, so the work is bounded by the
/// plotting area whatever the zoom.
fn paste_floorplan(image: &mut RgbImage, frame: &Frame, fp: &Floorplan, strength: f64) {
    let (e, v) = (fp.extent, frame.extent);
    let (w, h) = (fp.image.width() as f64, fp.image.height() as f64);
    // the visible world rectangle, in source pixels, widened to whole pixels
    let (vx0, vx1) = (e.x0.max(v.x0), e.x1.min(v.x1));
    let (vy0, vy1) = (e.y0.max(v.y0), e.y1.min(v.y1));
    if vx0 >= vx1 || vy0 >= vy1 {
        return;
    }
    let col = |x: f64| ((x - e.x0) / e.width() * w).clamp(0.0, w);
    let row = |y: f64| ((e.y1 - y) / e.height() * h).clamp(0.0, h);
    let (c0, c1) = (
        col(vx0).floor(),
        col(vx1).ceil().max(col(vx0).floor() + 1.0),
    );
    let (r0, r1) = (
        row(vy1).floor(),
        row(vy0).ceil().max(row(vy1).floor() + 1.0),
    );
    let (c1, r1) = (c1.min(w), r1.min(h));
    if c1 <= c0 || r1 <= r0 {
        return;
    }
    // where that whole-pixel crop lands in the picture
    let wx = |c: f64| e.x0 + c / w * e.width();
    let wy = |r: f64| e.y1 - r / h * e.height();
    let (ax, ay) = frame.to_pixel(DVec2::new(wx(c0), wy(r0)));
    let (bx, by) = frame.to_pixel(DVec2::new(wx(c1), wy(r1)));
    let (dw, dh) = (
        i64::from(bx) - i64::from(ax) + 1,
        i64::from(by) - i64::from(ay) + 1,
    );
    let (fw, fh) = (frame.size.0 as i64, frame.size.1 as i64);
    // at most a few pixels beyond the picture: anything else is a degenerate frame
    if dw < 1 || dh < 1 || dw > 4 * fw + 8 || dh > 4 * fh + 8 {
        return;
    }
    let crop = image::imageops::crop_imm(
        &fp.image,
        c0 as u32,
        r0 as u32,
        (c1 - c0) as u32,
        (r1 - r0) as u32,
    )
    .to_image();
    let scaled = image::imageops::resize(&crop, dw as u32, dh as u32, FilterType::Triangle);
    let s = strength.clamp(0.0, 1.0);
    let fade = |u: u8| (255.0 - (255.0 - u as f64) * s).round() as u8;
    let area = frame.area;
    let (ax, ay) = (i64::from(ax), i64::from(ay));
    for y in i64::from(area.top).max(ay)..i64::from(area.bottom).min(ay + dh) {
        for x in i64::from(area.left).max(ax)..i64::from(area.right).min(ax + dw) {
            let src = scaled.get_pixel((x - ax) as u32, (y - ay) as u32);
            image.put_pixel(
                x as u32,
                y as u32,
                Rgb([fade(src[0]), fade(src[1]), fade(src[2])]),
            );
        }
    }
}

/// Something that draws itself on a drawing area of any backend.
pub(crate) trait Painter {
    /// Draw on `root`, whose background is already laid.
    fn paint<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError>;
}

/// Register the embedded font once (plotters looks fonts up by family name).
pub(crate) fn ensure_fonts() {
    static FONTS: Once = Once::new();
    FONTS.call_once(|| {
        // The bytes are a valid TrueType font shipped by the `dejavu` crate; a failure
        // here would leave text undrawn, which the drawing calls then report.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
        let _ = plotters::style::register_font("sans-serif", FontStyle::Bold, dejavu::sans::bold());
    });
}

/// Render a picture of `frame.size` in `format` over `background`.
pub(crate) fn render(
    size: (u32, u32),
    background: Background,
    area: Option<super::PixelRect>,
    format: ImageFormat,
    painter: &impl Painter,
) -> Result<Vec<u8>, PlotError> {
    ensure_fonts();
    match format {
        ImageFormat::Png => {
            let mut buf = background.image.into_raw();
            {
                let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
                painter.paint(&root)?;
                root.present().map_err(PlotError::draw)?;
            }
            encode_png(&buf, size)
        }
        ImageFormat::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
                painter.paint(&root)?;
                root.present().map_err(PlotError::draw)?;
            }
            // Lay the background under everything: a white page and, when the
            // plotting area holds a floor plan, that part of it as an embedded PNG.
            let mut under = format!(
                r##"<rect x="0" y="0" width="{}" height="{}" fill="#FFFFFF"/>"##,
                size.0, size.1
            );
            if let Some(a) = area {
                let crop = image::imageops::crop_imm(
                    &background.image,
                    a.left.max(0) as u32,
                    a.top.max(0) as u32,
                    a.width().max(1) as u32,
                    a.height().max(1) as u32,
                )
                .to_image();
                let png = encode_png(crop.as_raw(), crop.dimensions())?;
                under.push_str(&format!(
                    r#"<image x="{}" y="{}" width="{}" height="{}" preserveAspectRatio="none" href="data:image/png;base64,{}"/>"#,
                    a.left,
                    a.top,
                    crop.width(),
                    crop.height(),
                    base64::engine::general_purpose::STANDARD.encode(png)
                ));
            }
            let open = svg
                .find("<svg")
                .and_then(|i| svg[i..].find('>').map(|j| i + j + 1))
                .ok_or_else(|| PlotError::Draw("the SVG backend wrote no <svg> element".into()))?;
            svg.insert_str(open, &under);
            Ok(svg.into_bytes())
        }
    }
}

/// Encode RGB bytes as a compressed PNG.
pub(crate) fn encode_png(rgb: &[u8], (w, h): (u32, u32)) -> Result<Vec<u8>, PlotError> {
    let mut out = Vec::new();
    PngEncoder::new_with_quality(
        Cursor::new(&mut out),
        CompressionType::Best,
        PngFilter::Adaptive,
    )
    .write_image(rgb, w, h, image::ExtendedColorType::Rgb8)
    .map_err(PlotError::draw)?;
    Ok(out)
}
