//! The command tree: the top-level parser, its subcommands and the `map` and `plot`
//! groups (clap derive). Each leaf holds the arguments of its own file's command.

use clap::{Parser, Subcommand};

use crate::demo::DemoArgs;
use crate::eval::EvalArgs;
use crate::map::build::BuildArgs;
use crate::map::convert::ConvertArgs;
use crate::map::diff::DiffArgs;
use crate::map::info::InfoArgs;
use crate::map::score::ScoreArgs;
use crate::map::update::UpdateArgs;
use crate::motion::fit::FitArgs;
use crate::motion::info::InfoArgs as MotionInfoArgs;
use crate::observe::ObserveArgs;
use crate::plot::curves::CurvesArgs;
use crate::plot::map::MapArgs;
use crate::plot::occupancy::OccupancyPlotArgs;
use crate::plot::predict::PredictPlotArgs;
use crate::predict::PredictArgs;

/// CLiFF-maps and long-term human motion prediction (CLiFF-LHMP).
///
/// Without --map, commands use the built-in demo scene: a hall with two crossing
/// pedestrian flows, so everything runs on a fresh machine without data.
#[derive(Parser)]
#[command(name = "cliff", version, about, long_about = None, propagate_version = true)]
pub struct Cli {
    /// The subcommand to run.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands of `cliff`.
#[derive(Subcommand)]
pub enum Command {
    /// Inspect, convert, build, score and update CLiFF-maps.
    #[command(subcommand)]
    Map(MapCommand),
    /// Fit and inspect the learned motion model (how people walk on over the next
    /// seconds, whatever the site).
    #[command(subcommand)]
    Motion(MotionCommand),
    /// Evaluate methods on trajectory files: ADE/FDE, top-k, per horizon, over seeds.
    ///
    /// Example (THÖR1, parity with the published implementation):
    /// cliff eval --map ../shared/data/thor1/cliffmap.csv --tracks ../shared/data/thor1/exp-1-run-2.csv
    ///   --format thor --protocol reference --radius 0.7071 --seeds 20 --out thor1-eval
    Eval(EvalArgs),
    /// Predict the samples of one person of a trajectory file and write them as CSV.
    Predict(PredictArgs),
    /// Draw pictures: a map as coloured arrows, a person's prediction, error curves.
    #[command(subcommand)]
    Plot(PlotCommand),
    /// The guided tour: predict and evaluate in the demo hall (or on --map/--tracks)
    /// and write a map, a prediction and an error-curve picture as PNG.
    ///
    /// Example: cliff demo --out cliff-demo
    Demo(DemoArgs),
    /// Stream recorded trajectory files to a learning cliffd (`cliffd --learn NAME`) as
    /// observations, as fast as it accepts or at --rate rows per second.
    ///
    /// Runs `cliff-observe` (of the cliff-client package) with these arguments.
    /// Example: cliff observe --map thor1 --tracks ../shared/data/thor1/exp-1-run-2.csv --format thor
    Observe(ObserveArgs),
}

/// Map subcommands.
#[derive(Subcommand)]
pub enum MapCommand {
    /// Print a map's extent, grid step, locations, components and observation ratios.
    ///
    /// Also counts what was fixed at load: covariances clamped to positive
    /// semi-definite and locations whose weights were renormalised. For a time-of-day
    /// set: the all-day map, the slice length, the clock offset, the smoothing and one
    /// line per slice.
    Info(InfoArgs),
    /// Convert a map between formats, chosen by extension (.csv or .cliff).
    ///
    /// A time-of-day set (.cliff) copies to another .cliff whole; one of its maps is
    /// exported with --slice (to .csv or to a single-map .cliff).
    ///
    /// Example: cliff map convert ../shared/data/thor1/cliffmap.csv thor1.cliff
    ///
    /// Example: cliff map convert atc-set.cliff atc-13h.csv --slice 13
    Convert(ConvertArgs),
    /// Build a CLiFF-map from recorded trajectories (mean shift + EM per grid node).
    ///
    /// Example: cliff map build --tracks ../shared/data/atc/train/*.csv --format atc
    /// --grid 1 --radius 1 --out atc-train.csv
    Build(BuildArgs),
    /// Score a map on held-out trajectories: mean log-likelihood of the observed
    /// velocities at the nearest location.
    ///
    /// Example: cliff map score --map atc-train.csv --tracks ../shared/data/atc/dev/*.csv
    /// --format atc --json
    Score(ScoreArgs),
    /// Update a map with a new batch of trajectories, without the old data.
    ///
    /// Online learning: the map's counts decay, components are updated from their
    /// sufficient statistics, samples the map does not explain get new components,
    /// near-duplicates are merged. The result goes to --out.
    ///
    /// Example: cliff map update --map hour9.csv --count-scale 336 --tracks
    /// ../shared/data/atc/train/atc-1024-10_train.csv --format atc --out hour10.csv
    Update(UpdateArgs),
    /// Show what changed between two maps of one place: locations added and removed,
    /// how far each location's mixture moved (total-variation distance), components
    /// and the heaviest component before and after; --png draws it.
    ///
    /// Example: cliff map diff ../shared/data/thor1/cliffmap.csv learned/thor1.v00000003.cliff
    /// --png diff.png
    Diff(DiffArgs),
}

/// Motion model subcommands.
#[derive(Subcommand)]
pub enum MotionCommand {
    /// Fit a motion model to recorded trajectories: ridge regression of the next
    /// seconds' displacements on the last 2.8 s, in the walker's own frame, corrected
    /// by a small network (two layers of --hidden units) where walking is not linear
    /// in the history. Prints a validation split's errors beside constant velocity's,
    /// then writes the model fitted on all the tracks.
    ///
    /// Example: cliff motion fit --tracks ../shared/data/magni/magni-A-first-16min.csv
    /// --format magni --out site.motion
    ///
    /// The built-in model (src/motion/builtin.motion, linear) is made by:
    /// cliff motion fit --tracks ../shared/data/atc/train/*.csv --format atc --hidden 0
    ///   --out src/motion/builtin.motion
    Fit(Box<FitArgs>),
    /// Show what a motion model file holds (without a file: the built-in model).
    Info(MotionInfoArgs),
}

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
    /// Draw the probability that each place holds someone at a few times: the people
    /// present at one moment (--at) predicted together, the occupancy at each of
    /// --times in its colour, over the map's arrows and the people's observed tracks.
    ///
    /// Example (THÖR1 over its floor plan):
    /// cliff plot occupancy --map ../shared/data/thor1/cliffmap.csv
    ///   --tracks ../shared/data/thor1/exp-1-run-2.csv --format thor --times 2,4,8
    ///   --floorplan ../shared/data/thor1/floorplan.png --extent=-11,12,-10,13.5 --out occupancy.png
    Occupancy(OccupancyPlotArgs),
    /// Draw ADE and FDE against the prediction horizon from `cliff eval` summaries,
    /// per method (and per run when several summaries are given), with
    /// one-standard-deviation bands.
    ///
    /// Example: cliff plot curves --summary thor1-eval/summary.csv --out thor1-curves.png
    Curves(CurvesArgs),
}
