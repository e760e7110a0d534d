//! `cliff plot predict`: one person's prediction drawn over the map (PNG or SVG).

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use cliff::eval::protocol::prepare;
use cliff::plot::{PersonPrediction, PredictStyle, plot_predictions};
use cliff::predict::{Method, TrajectoryBatch};
use cliff::tracks::Format;

use crate::args::{FloorplanArgs, PredictionArgs};
use crate::load::{load_floorplan, load_map, tracks_or_demo};
use crate::person::predict_case;

/// Arguments of `cliff plot predict`.
#[derive(Args, Debug)]
pub struct PredictPlotArgs {
    /// Map file (.csv or .cliff); omit for the built-in demo scene.
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Trajectory file holding the person; omit (with --map omitted too) for the
    /// demo hall's synthetic walkers (ids 1 to 40).
    #[arg(long)]
    pub tracks: Option<PathBuf>,
    /// Trajectory file format: thor, atc, magni, csv or rosbag2 [default: recognised
    /// from the file].
    #[arg(long)]
    pub format: Option<Format>,
    /// Person id.
    #[arg(long)]
    pub person: u64,
    #[command(flatten)]
    pub prediction: PredictionArgs,
    /// Method.
    #[arg(long, default_value = "cliff")]
    pub method: Method,
    /// Random seed (mixed with the person id, as in `cliff predict`).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    #[command(flatten)]
    pub frame: FloorplanArgs,
    /// Opacity of the map arrows under the tracks, 0 (hidden) to 1.
    #[arg(long, default_value_t = 0.3)]
    pub arrow_opacity: f64,
    /// Output picture: .png or .svg.
    #[arg(long)]
    pub out: PathBuf,
}

/// Run `cliff plot predict`.
pub fn run(a: PredictPlotArgs) -> Result<()> {
    let map = load_map(a.map.as_ref())?;
    let floorplan = load_floorplan(&a.frame, a.map.as_ref())?;
    let tracks = tracks_or_demo(a.map.as_ref(), a.tracks.as_ref(), a.format)?;
    let source = a
        .tracks
        .as_ref()
        .map_or("the demo walkers".to_string(), |p| p.display().to_string());
    let settings = a.prediction.settings();
    let track = tracks.iter().find(|t| t.id == a.person).with_context(|| {
        let ids: Vec<String> = tracks.iter().take(12).map(|t| t.id.to_string()).collect();
        format!(
            "person {} is not in {source} ({} people; ids include {})",
            a.person,
            tracks.len(),
            ids.join(", ")
        )
    })?;
    let case = prepare(track, &settings).with_context(|| {
        let usable: Vec<String> = tracks
            .iter()
            .filter(|t| prepare(t, &settings).is_some())
            .take(12)
            .map(|t| t.id.to_string())
            .collect();
        format!(
            "person {} is skipped by the {} protocol (too short, idle, or no future to predict); people that can be drawn include: {}",
            a.person,
            settings.protocol,
            usable.join(", ")
        )
    })?;
    let mut batch = TrajectoryBatch::new();
    let params = predict_case(&map, &case, &a.prediction, a.method, a.seed, &mut batch)?;
    let person = PersonPrediction::from_case(&case, &batch, 0);
    let style = PredictStyle {
        width: a.frame.width,
        view: a.frame.view,
        arrow_opacity: a.arrow_opacity,
        floorplan_strength: a.frame.floorplan_strength,
        title: Some(a.frame.title.clone().unwrap_or_else(|| {
            format!(
                "{} prediction of person {}: {:.1} s observed, {:.1} s predicted, k = {}",
                a.method.name(),
                case.id,
                case.start.time - track.rows[0].t,
                case.horizon,
                params.k
            )
        })),
    };
    let frame = plot_predictions(&map, floorplan.as_ref(), &[person], &style, &a.out)
        .with_context(|| format!("drawing {}", a.out.display()))?;
    let reached = (0..params.k)
        .filter(|&s| batch.len(0, s) == case.steps)
        .count();
    println!(
        "wrote {} ({}x{} px): person {}, start ({:.2}, {:.2}) at t {:.2}, {} samples of {} steps ({} reach the end)",
        a.out.display(),
        frame.size.0,
        frame.size.1,
        case.id,
        case.start.position.x,
        case.start.position.y,
        case.start.time,
        params.k,
        case.steps,
        reached
    );
    Ok(())
}
