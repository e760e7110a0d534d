//! `cliff plot ...`: map, prediction and error-curve pictures (PNG or SVG).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use cliff::eval::protocol::prepare;
use cliff::plot::{
    CurveRun, CurvesStyle, Extent, Floorplan, MapStyle, PersonPrediction, PredictStyle, SummaryRow,
    plot_curves, plot_map, plot_predictions, read_per_person_spread, read_summary,
};
use cliff::predict::{Method, TrajectoryBatch};
use cliff::tracks::scene::{SceneOptions, demo_tracks};
use cliff::tracks::{Format, Track};

use crate::eval_cmd::{PredictionArgs, load_tracks, predict_case};
use crate::map_cmd::load_map;

/// Plot subcommands.
#[derive(Subcommand)]
pub enum PlotCommand {
    /// Draw a CLiFF-map: one arrow per mixture component at its location.
    ///
    /// An arrow points along the component's mean direction, is as long as its mean
    /// speed (scaled so neighbouring arrows do not touch, see --arrow-seconds), has the
    /// colour of its direction on a colour wheel (east red, north yellow-green, west
    /// cyan, south violet) and the opacity of its weight.
    ///
    /// Example (THÖR1 over its floor plan):
    /// cliff plot map --map ../shared/data/thor1/cliffmap.csv
    ///   --floorplan ../shared/data/thor1/floorplan.png --extent=-11,12,-10,13.5 --out thor1-map.png
    Map(MapArgs),
    /// Draw one person's prediction: floor plan, faint map arrows, the observed track
    /// (green), the ground truth (red) and the k predicted samples (blue, fading along
    /// the horizon).
    ///
    /// The person is prepared with the evaluation protocol (--protocol, --obs, --dt,
    /// --horizon) and predicted with the same seed as `cliff predict`, so the picture
    /// shows the samples that command writes.
    ///
    /// Example (THÖR1, person 3):
    /// cliff plot predict --map ../shared/data/thor1/cliffmap.csv
    ///   --tracks ../shared/data/thor1/exp-1-run-2.csv --format thor --person 3
    ///   --floorplan ../shared/data/thor1/floorplan.png --extent=-11,12,-10,13.5 --out p3.png
    Predict(PredictPlotArgs),
    /// Draw ADE and FDE against the prediction horizon from `cliff eval` summaries,
    /// per method (and per run when several summaries are given), with
    /// one-standard-deviation bands.
    ///
    /// Example: cliff plot curves --summary thor1-eval/summary.csv --out thor1-curves.png
    Curves(CurvesArgs),
}

/// The floor plan and the framing of map pictures.
#[derive(Args, Debug, Clone)]
pub struct FloorplanArgs {
    /// Floor plan image (PNG or JPEG) drawn faded under the picture; needs --extent.
    /// Shipped: ../shared/data/thor1/floorplan.png and thor3/floorplan.png (extent
    /// -11,12,-10,13.5), atc/floorplan.jpg (extent -60,80,-40,20). Without --map and
    /// --floorplan the demo hall's floor is drawn.
    #[arg(long, requires = "extent")]
    pub floorplan: Option<PathBuf>,
    /// The world rectangle the floor plan image covers, X0,X1,Y0,Y1 in metres (its
    /// left column at X0, its top row at Y1). Write it as --extent=-11,12,-10,13.5.
    #[arg(long, requires = "floorplan", allow_hyphen_values = true)]
    pub extent: Option<Extent>,
    /// The world rectangle shown, X0,X1,Y0,Y1 in metres [default: the floor plan's
    /// extent, else the map's locations with a border of one grid step].
    #[arg(long, allow_hyphen_values = true)]
    pub view: Option<Extent>,
    /// Picture width in pixels; the height follows from the shown rectangle (equal
    /// scale on both axes).
    #[arg(long, default_value_t = 1000)]
    pub width: u32,
    /// How dark the floor plan is drawn, from 0 (invisible) to 1 (as in the file).
    #[arg(long, default_value_t = 0.35)]
    pub floorplan_strength: f64,
    /// Title above the picture [default: a description of what is drawn].
    #[arg(long)]
    pub title: Option<String>,
}

impl FloorplanArgs {
    /// The floor plan: the given image, or the demo hall's floor when no map file is
    /// used, or none.
    pub(crate) fn load(&self, map_file: Option<&PathBuf>) -> Result<Option<Floorplan>> {
        match (&self.floorplan, self.extent) {
            (Some(path), Some(extent)) => {
                Ok(Some(Floorplan::load(path, extent).with_context(|| {
                    format!("loading floor plan {}", path.display())
                })?))
            }
            (Some(_), None) | (None, Some(_)) => {
                bail!("--floorplan and --extent go together: give both or neither")
            }
            (None, None) if map_file.is_none() => Ok(Some(Floorplan::demo())),
            (None, None) => Ok(None),
        }
    }
}

/// Arguments of `cliff plot map`.
#[derive(Args, Debug)]
pub struct MapArgs {
    /// Map file (.csv or .cliff); omit for the built-in demo scene.
    #[arg(long)]
    pub map: Option<PathBuf>,
    #[command(flatten)]
    pub frame: FloorplanArgs,
    /// Arrow length per unit of speed, in seconds (an arrow is as long as the way
    /// walked in that time) [default: the fastest component's arrow is 0.45 grid
    /// steps long].
    #[arg(long)]
    pub arrow_seconds: Option<f64>,
    /// Skip components whose weight (normalised per location) is below this.
    #[arg(long, default_value_t = 0.0)]
    pub min_weight: f64,
    /// Leave out the direction colour wheel.
    #[arg(long)]
    pub no_legend: bool,
    /// Output picture: .png or .svg.
    #[arg(long)]
    pub out: PathBuf,
}

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
    /// Trajectory file format.
    #[arg(long, default_value = "thor")]
    pub format: Format,
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

/// Arguments of `cliff plot curves`.
#[derive(Args, Debug)]
pub struct CurvesArgs {
    /// summary.csv files written by `cliff eval --out DIR` (DIR/summary.csv); give
    /// several to compare runs.
    #[arg(long, required = true, num_args = 1..)]
    pub summary: Vec<PathBuf>,
    /// A legend label per summary, in the same order [default: the summary's folder
    /// name].
    #[arg(long, num_args = 1..)]
    pub label: Vec<String>,
    /// Picture width in pixels.
    #[arg(long, default_value_t = 1100)]
    pub width: u32,
    /// Picture height in pixels.
    #[arg(long, default_value_t = 460)]
    pub height: u32,
    /// Where means and bands come from: `summary` (the summary's ade, ade_sd, fde,
    /// fde_sd; `cliff eval` writes the spread over seeds there) or `people` (mean and
    /// standard deviation over people, from the per_person.csv beside each summary,
    /// as in the CLiFF-LHMP paper's figures).
    #[arg(long, value_enum, default_value_t = Spread::Summary)]
    pub spread: Spread,
    /// Leave out the one-standard-deviation bands.
    #[arg(long)]
    pub no_bands: bool,
    /// Title above the picture.
    #[arg(long)]
    pub title: Option<String>,
    /// Output picture: .png or .svg.
    #[arg(long)]
    pub out: PathBuf,
}

/// The source of the curves' means and bands.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spread {
    /// The summary file's columns.
    Summary,
    /// Over people, from the per_person.csv beside the summary.
    People,
}

/// The rows of one run: the summary itself, or its per-person file summarised.
pub(crate) fn run_rows(summary: &Path, spread: Spread) -> Result<Vec<SummaryRow>> {
    Ok(match spread {
        Spread::Summary => read_summary(summary)?,
        Spread::People => {
            let pp = summary.with_file_name("per_person.csv");
            if !pp.is_file() {
                bail!(
                    "--spread people needs {} beside {} (written by cliff eval --out)",
                    pp.display(),
                    summary.display()
                );
            }
            read_per_person_spread(&pp)?
        }
    })
}

/// Run a plot subcommand.
pub fn run(cmd: PlotCommand) -> Result<()> {
    match cmd {
        PlotCommand::Map(a) => run_map(a),
        PlotCommand::Predict(a) => run_predict(a),
        PlotCommand::Curves(a) => run_curves(a),
    }
}

fn run_map(a: MapArgs) -> Result<()> {
    let map = load_map(a.map.as_ref())?;
    let floorplan = a.frame.load(a.map.as_ref())?;
    let style = MapStyle {
        width: a.frame.width,
        view: a.frame.view,
        arrow_seconds: a.arrow_seconds,
        min_weight: a.min_weight,
        floorplan_strength: a.frame.floorplan_strength,
        title: a.frame.title.clone(),
        legend: !a.no_legend,
        ..MapStyle::default()
    };
    let frame = plot_map(&map, floorplan.as_ref(), &style, &a.out)
        .with_context(|| format!("drawing {}", a.out.display()))?;
    let info = map.info();
    println!(
        "wrote {} ({}x{} px): {} locations, {} components, arrows {:.2} s x speed",
        a.out.display(),
        frame.size.0,
        frame.size.1,
        info.locations,
        info.components,
        style.arrow_seconds_for(&map)
    );
    Ok(())
}

/// The tracks of `plot predict` and `demo`: the file given, or the demo walkers.
pub(crate) fn tracks_or_demo(
    map: Option<&PathBuf>,
    tracks: Option<&PathBuf>,
    format: Format,
) -> Result<Vec<Track>> {
    match (map, tracks) {
        (_, Some(t)) => load_tracks(std::slice::from_ref(t), format),
        (None, None) => Ok(demo_tracks(&SceneOptions::default())),
        (Some(_), None) => {
            bail!("--tracks is needed with --map (the demo walkers only walk the demo hall)")
        }
    }
}

fn run_predict(a: PredictPlotArgs) -> Result<()> {
    let map = load_map(a.map.as_ref())?;
    let floorplan = a.frame.load(a.map.as_ref())?;
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

/// A run's default label: the summary's folder name, else its path.
fn default_label(path: &Path) -> String {
    path.parent()
        .and_then(|p| p.file_name())
        .map(|n| n.to_string_lossy().into_owned())
        .filter(|n| !n.is_empty())
        .unwrap_or_else(|| path.display().to_string())
}

fn run_curves(a: CurvesArgs) -> Result<()> {
    if !a.label.is_empty() && a.label.len() != a.summary.len() {
        bail!(
            "{} --label value(s) for {} --summary file(s): give one label per summary or none",
            a.label.len(),
            a.summary.len()
        );
    }
    let mut runs = Vec::with_capacity(a.summary.len());
    for (i, path) in a.summary.iter().enumerate() {
        let rows = run_rows(path, a.spread)?;
        let label = a
            .label
            .get(i)
            .cloned()
            .unwrap_or_else(|| default_label(path));
        runs.push(CurveRun { label, rows });
    }
    // Same folder names: fall back to the full paths.
    if a.label.is_empty() {
        let labels: Vec<&String> = runs.iter().map(|r| &r.label).collect();
        if (1..labels.len()).any(|i| labels[..i].contains(&labels[i])) {
            for (r, p) in runs.iter_mut().zip(&a.summary) {
                r.label = p.display().to_string();
            }
        }
    }
    let style = CurvesStyle {
        size: (a.width, a.height),
        bands: !a.no_bands,
        title: a.title.clone().or_else(|| {
            (a.spread == Spread::People).then(|| {
                "Displacement error against prediction horizon (mean ± 1 sd over people)"
                    .to_string()
            })
        }),
    };
    let layout = plot_curves(&runs, &style, &a.out)
        .with_context(|| format!("drawing {}", a.out.display()))?;
    let names: Vec<&str> = layout.series.iter().map(|s| s.0.as_str()).collect();
    println!(
        "wrote {} ({}x{} px): {} curve(s) up to {:.1} s: {}",
        a.out.display(),
        layout.size.0,
        layout.size.1,
        names.len(),
        layout.ade.extent.x1,
        names.join(", ")
    );
    Ok(())
}
