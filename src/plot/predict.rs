//! Predictions: observed track, ground truth and sampled futures over the map.

use std::path::Path;

use glam::DVec2;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::map::{map_background, map_extent};
use super::render::{Background, Painter, render};
use super::{
    Extent, Floorplan, Frame, ImageFormat, OBSERVED, PlotError, SAMPLE, TRUTH, clip_polyline,
    clip_segment, write_file,
};
use crate::eval::protocol::Case;
use crate::map::CliffMap;
use crate::predict::TrajectoryBatch;

/// One person's prediction, ready to draw.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PersonPrediction {
    /// Observed positions, oldest first (drawn green).
    pub observed: Vec<DVec2>,
    /// Where the prediction starts (usually the last observed position).
    pub start: DVec2,
    /// Ground-truth future positions (drawn red); may be empty.
    pub truth: Vec<DVec2>,
    /// Predicted samples, each a list of positions one step apart (drawn blue, fading
    /// along the horizon).
    pub samples: Vec<Vec<DVec2>>,
}

impl PersonPrediction {
    /// Take agent `agent`'s samples (their valid positions) from a prediction batch.
    ///
    /// ```
    /// use cliff::{map::CliffMap, motion::State, plot::PersonPrediction};
    /// use cliff::predict::{predict, Params, TrajectoryBatch};
    /// use glam::DVec2;
    /// let map = CliffMap::demo();
    /// let start = State { position: DVec2::new(-10.0, -1.0), speed: 1.2, heading: 0.0, time: 0.0 };
    /// let mut batch = TrajectoryBatch::new();
    /// predict(&map, &[start], &Params { k: 5, ..Params::default() }, &mut batch).unwrap();
    /// let p = PersonPrediction::from_batch(vec![DVec2::new(-11.0, -1.0), start.position], vec![], &batch, 0);
    /// assert_eq!(p.samples.len(), 5);
    /// assert_eq!(p.start, start.position);
    /// ```
    pub fn from_batch(
        observed: Vec<DVec2>,
        truth: Vec<DVec2>,
        batch: &TrajectoryBatch,
        agent: usize,
    ) -> Self {
        let (_, k, _) = batch.shape();
        let samples = (0..k)
            .map(|s| {
                batch
                    .sample(agent, s)
                    .iter()
                    .map(|p| DVec2::new(p[0] as f64, p[1] as f64))
                    .collect()
            })
            .collect();
        let start = observed.last().copied().unwrap_or(DVec2::NAN);
        PersonPrediction {
            observed,
            start,
            truth,
            samples,
        }
    }

    /// An evaluation case and agent `agent`'s samples: the observed rows up to the
    /// start (green), the ground-truth rows after the start up to the case's horizon
    /// (red) and the samples (blue).
    ///
    /// ```
    /// use cliff::eval::protocol::{prepare, Protocol, Settings};
    /// use cliff::map::CliffMap;
    /// use cliff::plot::PersonPrediction;
    /// use cliff::predict::{predict, Params, TrajectoryBatch};
    /// use cliff::tracks::scene::{demo_tracks, SceneOptions};
    /// let tracks = demo_tracks(&SceneOptions::default());
    /// let settings = Settings { protocol: Protocol::Seconds, ..Settings::default() };
    /// let case = prepare(&tracks[0], &settings).unwrap();
    /// let mut batch = TrajectoryBatch::new();
    /// let params = Params { horizon: case.steps as f64 * settings.dt, ..Params::default() };
    /// predict(&CliffMap::demo(), &[case.start], &params, &mut batch).unwrap();
    /// let p = PersonPrediction::from_case(&case, &batch, 0);
    /// assert_eq!(p.start, case.start.position);
    /// assert_eq!(*p.observed.last().unwrap(), case.start.position);
    /// assert!(!p.truth.is_empty() && p.samples.len() == params.k);
    /// ```
    pub fn from_case(case: &Case, batch: &TrajectoryBatch, agent: usize) -> Self {
        let mut observed: Vec<DVec2> = case.observed.iter().map(|r| r.position).collect();
        observed.push(case.start.position);
        let end = case.start.time + case.horizon + 1e-6;
        let truth = case
            .future
            .iter()
            .filter(|r| r.t > case.start.time + 1e-9 && r.t <= end)
            .map(|r| r.position)
            .collect();
        Self::from_batch(observed, truth, batch, agent)
    }

    fn points(&self) -> impl Iterator<Item = DVec2> + '_ {
        self.observed
            .iter()
            .chain(&self.truth)
            .chain(self.samples.iter().flatten())
            .copied()
            .chain(std::iter::once(self.start))
    }
}

/// How [`plot_predictions`] draws.
#[derive(Debug, Clone, PartialEq)]
pub struct PredictStyle {
    /// Picture width in pixels; the height follows from the shown extent.
    pub width: u32,
    /// The world rectangle shown; `None`: the floor plan's extent when there is one,
    /// else the map's extent, grown to hold every drawn point.
    pub view: Option<Extent>,
    /// Opacity of the map arrows under the tracks (0 hides them).
    pub arrow_opacity: f64,
    /// How dark the floor plan is drawn, from 0 to 1.
    pub floorplan_strength: f64,
    /// Title above the picture.
    pub title: Option<String>,
}

impl Default for PredictStyle {
    fn default() -> Self {
        PredictStyle {
            width: 1000,
            view: None,
            arrow_opacity: 0.3,
            floorplan_strength: 0.35,
            title: None,
        }
    }
}

impl PredictStyle {
    /// The extent shown (see [`PredictStyle::view`]).
    pub fn view_for(
        &self,
        map: &CliffMap,
        floorplan: Option<&Floorplan>,
        people: &[PersonPrediction],
    ) -> Extent {
        if let Some(v) = self.view {
            return v;
        }
        let base = floorplan.map_or_else(|| map_extent(map), |f| f.extent());
        let corners = [DVec2::new(base.x0, base.y0), DVec2::new(base.x1, base.y1)];
        let pts = people.iter().flat_map(|p| p.points());
        Extent::around(corners.into_iter().chain(pts), 0.0).unwrap_or(base)
    }
}

/// Draw the predictions of one or more people over `map` (faint arrows) and an
/// optional floor plan, and write the picture to `out` (PNG or SVG, by extension).
/// Returns the frame: where each world point was drawn.
pub fn plot_predictions(
    map: &CliffMap,
    floorplan: Option<&Floorplan>,
    people: &[PersonPrediction],
    style: &PredictStyle,
    out: &Path,
) -> Result<Frame, PlotError> {
    let format = ImageFormat::from_path(out)?;
    let (bytes, frame) = plot_predictions_to(map, floorplan, people, style, format)?;
    write_file(out, &bytes)?;
    Ok(frame)
}

/// Draw predictions into picture bytes of `format`; see [`plot_predictions`].
///
/// ```
/// use cliff::map::CliffMap;
/// use cliff::plot::{plot_predictions_to, ImageFormat, PersonPrediction, PredictStyle};
/// use glam::DVec2;
/// let person = PersonPrediction {
///     observed: vec![DVec2::new(-12.0, -1.0), DVec2::new(-11.0, -1.0)],
///     start: DVec2::new(-11.0, -1.0),
///     truth: vec![DVec2::new(-10.0, -1.0)],
///     samples: vec![vec![DVec2::new(-10.0, -1.1), DVec2::new(-9.0, -1.2)]],
/// };
/// let style = PredictStyle { width: 400, ..PredictStyle::default() };
/// let (svg, _) = plot_predictions_to(&CliffMap::demo(), None, &[person], &style, ImageFormat::Svg).unwrap();
/// assert!(String::from_utf8(svg).unwrap().contains("<svg"));
/// ```
pub fn plot_predictions_to(
    map: &CliffMap,
    floorplan: Option<&Floorplan>,
    people: &[PersonPrediction],
    style: &PredictStyle,
    format: ImageFormat,
) -> Result<(Vec<u8>, Frame), PlotError> {
    if style.width < 200 {
        return Err(PlotError::Invalid(format!(
            "width {} is too small (at least 200 pixels)",
            style.width
        )));
    }
    if !(0.0..=1.0).contains(&style.arrow_opacity)
        || !(0.0..=1.0).contains(&style.floorplan_strength)
    {
        return Err(PlotError::Invalid(
            "arrow opacity and floor plan strength must be within 0..1".into(),
        ));
    }
    let frame = Frame::for_map(style.view_for(map, floorplan, people), style.width);
    let background = Background::new(&frame, floorplan, style.floorplan_strength);
    let painter = PredictPainter {
        map,
        people,
        style,
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

struct PredictPainter<'a> {
    map: &'a CliffMap,
    people: &'a [PersonPrediction],
    style: &'a PredictStyle,
    frame: Frame,
}

fn rgb((r, g, b): (u8, u8, u8)) -> RGBColor {
    RGBColor(r, g, b)
}

impl Painter for PredictPainter<'_> {
    fn paint<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let k = self
            .people
            .iter()
            .map(|p| p.samples.len())
            .max()
            .unwrap_or(0);
        let title = self.style.title.clone().unwrap_or_else(|| {
            format!(
                "CLiFF-LHMP: {} {}, {k} samples each",
                self.people.len(),
                if self.people.len() == 1 {
                    "person"
                } else {
                    "people"
                }
            )
        });
        let chart = map_background(
            root,
            &title,
            &self.frame,
            self.map,
            self.style.arrow_opacity,
        )?;
        let area = chart.plotting_area();
        let view = self.frame.extent;
        let err = PlotError::draw;
        let xy = |p: DVec2| (p.x, p.y);
        // Samples first, so that the tracks stay on top. Each step's segment fades
        // with its time along the horizon.
        let steps = self
            .people
            .iter()
            .flat_map(|p| p.samples.iter().map(Vec::len))
            .max()
            .unwrap_or(0)
            .max(1);
        for person in self.people {
            for sample in &person.samples {
                let mut prev = person.start;
                for (j, &p) in sample.iter().enumerate() {
                    let alpha = 0.85 - 0.7 * (j as f64 / steps as f64);
                    if let Some((a, b)) = clip_segment(prev, p, &view) {
                        area.draw(&PathElement::new(
                            vec![xy(a), xy(b)],
                            rgb(SAMPLE).mix(alpha).stroke_width(2),
                        ))
                        .map_err(err)?;
                    }
                    prev = p;
                }
            }
        }
        // Tracks: lines cut to the view, dots where the rows are inside it.
        let track = |points: &[DVec2], colour: RGBColor| -> Result<(), PlotError> {
            for run in clip_polyline(points, &view) {
                area.draw(&PathElement::new(
                    run.iter().map(|&p| xy(p)).collect::<Vec<_>>(),
                    colour.stroke_width(3),
                ))
                .map_err(err)?;
            }
            Ok(())
        };
        let dots = |points: &[DVec2], colour: RGBColor| -> Result<(), PlotError> {
            for &p in points.iter().filter(|p| view.contains(**p)) {
                area.draw(&Circle::new(xy(p), 3, colour.filled()))
                    .map_err(err)?;
            }
            Ok(())
        };
        for person in self.people {
            let mut truth = Vec::with_capacity(person.truth.len() + 1);
            if person.start.is_finite() && !person.truth.is_empty() {
                truth.push(person.start);
            }
            truth.extend_from_slice(&person.truth);
            track(&truth, rgb(TRUTH))?;
            dots(&person.truth, rgb(TRUTH))?;
            track(&person.observed, rgb(OBSERVED))?;
            dots(&person.observed, rgb(OBSERVED))?;
            if person.start.is_finite() && view.contains(person.start) {
                area.draw(&Circle::new(xy(person.start), 6, BLACK.stroke_width(2)))
                    .map_err(err)?;
            }
        }
        draw_legend(root, &self.frame, k)?;
        Ok(())
    }
}

/// The key: observed, ground truth, predicted, in the plotting area's top-left corner.
fn draw_legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    frame: &Frame,
    k: usize,
) -> Result<(), PlotError> {
    let (x, y) = (frame.area.left + 10, frame.area.top + 10);
    let entries = [
        (OBSERVED, "observed".to_string()),
        (TRUTH, "ground truth".to_string()),
        (SAMPLE, format!("predicted ({k} samples)")),
    ];
    root.draw(&Rectangle::new(
        [(x, y), (x + 190, y + 12 + 20 * entries.len() as i32)],
        WHITE.mix(0.85).filled(),
    ))
    .map_err(PlotError::draw)?;
    let text = TextStyle::from(("sans-serif", 13).into_font())
        .color(&BLACK)
        .pos(plotters::style::text_anchor::Pos::new(
            plotters::style::text_anchor::HPos::Left,
            plotters::style::text_anchor::VPos::Center,
        ));
    for (i, (colour, label)) in entries.iter().enumerate() {
        let ly = y + 16 + 20 * i as i32;
        root.draw(&PathElement::new(
            vec![(x + 8, ly), (x + 36, ly)],
            rgb(*colour).stroke_width(3),
        ))
        .map_err(PlotError::draw)?;
        root.draw_text(label, &text, (x + 44, ly))
            .map_err(PlotError::draw)?;
    }
    Ok(())
}
