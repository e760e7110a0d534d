//! `cliff plot occupancy`: the people present at one moment of a recording, predicted
//! together, and the probability that each place holds someone at a few times after.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use cliff::glam::DVec2;
use cliff::motion::{History, State};
use cliff::occupancy::{GridSpec, Occupancy, Samples, Settings};
use cliff::plot::{OccupancyStyle, plot_occupancy};
use cliff::predict::{Method, Params, TrajectoryBatch, predict_with_histories};
use cliff::tracks::Format;

use crate::args::{FloorplanArgs, PredictionArgs};
use crate::load::{load_floorplan, load_map, tracks_or_demo};

/// Arguments of `cliff plot occupancy`.
#[derive(Args, Debug)]
pub struct OccupancyPlotArgs {
    /// Map file (.csv or .cliff); omit for the built-in demo scene.
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Trajectory file; omit (with --map omitted too) for the demo hall's walkers.
    #[arg(long)]
    pub tracks: Option<PathBuf>,
    /// Trajectory file format [default: recognised from the file].
    #[arg(long)]
    pub format: Option<Format>,
    /// The moment (s, the recording's clock) the people are predicted from [default:
    /// the moment with the most people observed for --obs seconds].
    #[arg(long, value_name = "S")]
    pub at: Option<f64>,
    /// The times after that moment drawn (s, comma-separated; up to four colours).
    #[arg(long, value_delimiter = ',', default_value = "2,4,8")]
    pub times: Vec<f64>,
    /// The cells' side (m).
    #[arg(long, value_name = "M", default_value_t = 0.1)]
    pub resolution: f64,
    #[command(flatten)]
    pub prediction: PredictionArgs,
    /// Method.
    #[arg(long, default_value = "cliff")]
    pub method: Method,
    /// Random seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    #[command(flatten)]
    pub frame: FloorplanArgs,
    /// Output picture: .png or .svg.
    #[arg(long)]
    pub out: PathBuf,
}

/// Run `cliff plot occupancy`.
pub fn run(a: OccupancyPlotArgs) -> Result<()> {
    let map = load_map(a.map.as_ref())?;
    let floorplan = load_floorplan(&a.frame, a.map.as_ref())?;
    let tracks = tracks_or_demo(a.map.as_ref(), a.tracks.as_ref(), a.format)?;
    let obs = a.prediction.obs;
    if a.times.is_empty() || a.times.iter().any(|t| !(t.is_finite() && *t > 0.0)) {
        bail!("--times: every time must be a positive number of seconds");
    }
    // who is there at `at`, observed for `obs` seconds
    let present = |at: f64| {
        tracks
            .iter()
            .filter(|t| {
                let r = &t.rows;
                !r.is_empty() && r[0].t <= at - obs && r[r.len() - 1].t >= at
            })
            .count()
    };
    let at = match a.at {
        Some(t) => t,
        None => tracks
            .iter()
            .filter_map(|t| t.rows.first().map(|r| r.t + obs))
            .max_by_key(|&t| present(t))
            .context("no track to draw")?,
    };
    let mut states = Vec::new();
    let mut histories = Vec::new();
    let mut observed = Vec::new();
    for t in &tracks {
        let rows: Vec<_> = t
            .rows
            .iter()
            .filter(|r| r.t >= at - obs && r.t <= at)
            .copied()
            .collect();
        let (Some(first), Some(last)) = (rows.first(), rows.last()) else {
            continue;
        };
        if rows.len() < 2 || t.rows[t.rows.len() - 1].t < at || last.t < at - a.prediction.dt {
            continue;
        }
        let v = (last.position - first.position) / (last.t - first.t).max(1e-9);
        let Ok(history) = History::from_rows(&rows) else {
            continue;
        };
        states.push(State {
            position: last.position,
            speed: v.length(),
            heading: v.y.atan2(v.x).rem_euclid(std::f64::consts::TAU),
            time: at,
        });
        histories.push(history);
        observed.push(rows.iter().map(|r| r.position).collect::<Vec<DVec2>>());
    }
    if states.is_empty() {
        bail!("nobody is observed for {obs} s at {at} s");
    }
    let dt = a.prediction.dt;
    let last = a.times.iter().cloned().fold(0.0, f64::max);
    let params = Params {
        horizon: (last / dt).ceil() * dt,
        ..a.prediction.params(a.method, a.seed)
    };
    let mut batch = TrajectoryBatch::new();
    predict_with_histories(
        &map,
        &states,
        &histories,
        &params,
        &a.prediction.options(false),
        &mut batch,
    )
    .context("predicting")?;
    // the grid: the people's surroundings, as far as they can walk by the last time
    let reach = 2.0 * last + 2.0;
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for s in &states {
        lo = lo.min(s.position - reach);
        hi = hi.max(s.position + reach);
    }
    if let Some(v) = a.frame.view {
        lo = DVec2::new(v.x0, v.y0);
        hi = DVec2::new(v.x1, v.y1);
    }
    let grid = GridSpec::covering([lo.x, lo.y], [hi.x, hi.y], a.resolution);
    let samples = Samples::from_batch(&batch, dt)?;
    let mut occupancy = Occupancy::new();
    occupancy
        .compute(&samples, &grid, &a.times, &Settings::default())
        .context("occupancy")?;
    let style = OccupancyStyle {
        width: a.frame.width,
        view: a.frame.view,
        title: Some(format!(
            "{}: {} people at {at:.1} s, occupancy {} s later",
            a.method,
            states.len(),
            a.times
                .iter()
                .map(|t| format!("{t}"))
                .collect::<Vec<_>>()
                .join(", ")
        )),
        ..OccupancyStyle::default()
    };
    plot_occupancy(
        &map,
        floorplan.as_ref(),
        &occupancy,
        &observed,
        &style,
        &a.out,
    )?;
    println!(
        "wrote {} ({} people at {at:.1} s, {} x {} cells)",
        a.out.display(),
        states.len(),
        grid.width,
        grid.height
    );
    Ok(())
}
