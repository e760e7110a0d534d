//! Arguments that several commands share: clap groups flattened into their arguments
//! and the value parsers they use.
//!
//! - [`PredictionArgs`]: protocol and prediction parameters (`eval`, `predict`,
//!   `plot predict`, `demo`)
//! - [`ReadArgs`]: how trajectory files are read beyond their format (`eval`,
//!   `predict`, `map build | score | update`)
//! - [`TrackArgs`]: the trajectory input of `map build | score | update`
//! - [`FloorplanArgs`]: the floor plan and framing of pictures (`plot map`,
//!   `plot predict`, `demo`)
//! - [`Spread`]: where error curves take their means and bands from (`plot curves`,
//!   `demo`)
//!
//! Values of time (durations, clock offsets, times of day) are parsed in
//! [`crate::clock`].

use std::path::PathBuf;

use clap::Args;
use cliff::eval::protocol::{Protocol, Settings};
use cliff::plot::Extent;
use cliff::predict::{HeadingRule, Method, Options, Params, Rank};
use cliff::tracks::{Columns, Format};

/// Protocol and prediction parameters shared by `eval` and `predict`.
#[derive(Args, Debug, Clone)]
pub struct PredictionArgs {
    /// Evaluation protocol: `reference` (the published code's row-based rules, for parity:
    /// observed rows, 10-row idle filter whatever the rate), `seconds` (the same rules
    /// stated in time, with a 4 s idle window, for data at any rate) or `windows` (the
    /// seconds rules in a window every `--window-every` seconds along each track, for long
    /// recordings such as THÖR-MAGNI) or `tracklets` (the THÖR-MAGNI benchmark's cut:
    /// each track's contiguous rows back to back in --obs-rows + --pred-rows rows, no
    /// idle filter).
    #[arg(long, default_value = "seconds")]
    pub protocol: Protocol,
    /// Observed rows per tracklet (sets --obs to this many --dt); the benchmark's 8.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub obs_rows: Option<u32>,
    /// Predicted rows per tracklet (sets --horizon to this many --dt); the benchmark's 12.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub pred_rows: Option<u32>,
    /// Observed history (s); the reference protocol turns it into rows (3.2 s at 0.4 s = 8 rows).
    #[arg(long, default_value_t = 3.2)]
    pub obs: f64,
    /// Prediction time step (s). THÖR: 0.4, ATC: 1.
    #[arg(long, default_value_t = 0.4)]
    pub dt: f64,
    /// Longest prediction horizon (s). THÖR: 12, ATC: 50.
    #[arg(long, default_value_t = 12.0)]
    pub horizon: f64,
    /// Sampling radius (m): map locations strictly closer are used. The reference's
    /// r_s = 0.5 compares squared distances, i.e. a radius of 0.7071; ATC uses 1.
    #[arg(long, default_value_t = std::f64::consts::FRAC_1_SQRT_2)]
    pub radius: f64,
    /// Kernel parameter beta: how strongly the heading turns to a sampled direction.
    #[arg(long, default_value_t = 1.0)]
    pub beta: f64,
    /// Samples per person.
    #[arg(long, default_value_t = 20)]
    pub k: usize,
    /// Width of the Gaussian velocity kernel over the observed rows.
    #[arg(long, default_value_t = cliff::motion::DEFAULT_SIGMA)]
    pub sigma: f64,
    /// Heading update: `circular-mean` (the reference) or `paper` (the paper's formula).
    #[arg(long, default_value = "circular-mean")]
    pub heading: HeadingRule,
    /// Windows protocol: a new window every this many seconds along each track
    /// (0: back to back, every obs + horizon seconds).
    #[arg(long, default_value_t = 0.0, value_parser = non_negative)]
    pub window_every: f64,
    /// Speed kernel (beyond the paper): the speed moves towards speeds drawn from the map,
    /// `v += exp(-speed_beta (r - v)^2) (r - v)`; 0 keeps the observed speed (the paper).
    #[arg(long, default_value_t = 0.0, value_parser = non_negative)]
    pub speed_beta: f64,
    /// Evaluate only the people (or windows) whose ground truth lasts the whole
    /// horizon: the same people at every horizon.
    #[arg(long)]
    pub full_horizon_only: bool,
    /// Seconds a sample goes on at constant velocity where the map has no data (beyond
    /// the paper); 0 stops it there (the paper).
    #[arg(long, default_value_t = 0.0, value_parser = non_negative)]
    pub coast: f64,
    /// Follow (beyond the paper): choose the map component at each step by its weight
    /// times `exp(-follow (1 - cos(heading - its direction)))`, so that a walker keeps
    /// to the flows going its way; 0 chooses by weight alone (the paper).
    #[arg(long, default_value_t = 0.0, value_parser = non_negative)]
    pub follow: f64,
    /// Candidates (beyond the paper): draw this many times `k` samples per person and
    /// keep the `k` that reach furthest, then the highest-scored; costs as many times
    /// the work. 1 draws `k` (the paper).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=16))]
    pub candidates: u32,
    /// Prune the candidates (beyond the paper): roll them in stretches and let only the
    /// best go on at each checkpoint, each twice (itself and a copy with a generator of
    /// its own): the furthest projected reach (the steps reached plus those the map's
    /// likeliest flow would keep it on the map), then the highest partial score
    /// (`cliff::predict::PRUNE_SCHEDULE`), so most of them cost a few steps.
    #[arg(long)]
    pub prune: bool,
    /// Speed prior (beyond the paper): start from the speed the map's speed prior
    /// (learned by `cliff map build`) gives for the observed one; maps without a prior
    /// keep the observed speed.
    #[arg(long)]
    pub speed_prior: bool,
    /// Trust (beyond the paper): seconds over which the map takes over from the observed
    /// motion; the heading kernel and the speed prior act `1 - exp(-t / trust)` of their
    /// full strength `t` seconds ahead. 0: fully from the first step (the paper).
    #[arg(long, default_value_t = 0.0, value_parser = non_negative)]
    pub trust: f64,
    /// Blend (beyond the paper): seconds over which the predicted positions leave the
    /// constant-velocity line (weight `exp(-(t - dt) / blend)` on constant velocity's
    /// position `t` seconds ahead). 0: the samples as rolled (the paper).
    #[arg(long, default_value_t = 0.0, value_parser = non_negative)]
    pub blend: f64,
    /// What the scores (and so top-1) rank: `likelihood` under the map, or `consensus`
    /// (the sample nearest the samples' mean path, among those reaching furthest).
    #[arg(long, default_value = "likelihood", value_parser = parse_rank)]
    pub rank: Rank,
    /// Motion (beyond the paper; part of `improved`): start from the learned motion model
    /// instead of constant velocity; the map bends the model's samples by its evidence
    /// for the person (how much better it explains the headings of their observed steps,
    /// given their speeds, than a uniform heading), a share growing with the horizon; a sample the map stops stands there.
    #[arg(long)]
    pub motion: bool,
}

fn parse_rank(s: &str) -> Result<Rank, String> {
    match s {
        "likelihood" => Ok(Rank::Likelihood),
        "consensus" => Ok(Rank::Consensus),
        _ => Err(format!("{s:?}: expected likelihood or consensus")),
    }
}

impl PredictionArgs {
    /// The protocol settings these arguments name.
    pub fn settings(&self) -> Settings {
        Settings {
            protocol: self.protocol,
            obs: self.obs_rows.map_or(self.obs, |n| f64::from(n) * self.dt),
            dt: self.dt,
            horizon: self
                .pred_rows
                .map_or(self.horizon, |n| f64::from(n) * self.dt),
            sigma: self.sigma,
            window_every: self.window_every,
            full_horizon_only: self.full_horizon_only,
            ..Settings::default()
        }
    }

    /// The options beyond the paper, with or without a score per sample.
    pub fn options(&self, scores: bool) -> Options {
        Options {
            speed_beta: self.speed_beta,
            coast: self.coast,
            scores,
            follow: self.follow,
            candidates: self.candidates,
            prune: self.prune,
            speed_prior: self.speed_prior,
            trust: self.trust,
            blend: self.blend,
            rank: self.rank,
            motion: self.motion,
        }
    }

    /// The prediction parameters of `method` with `seed`.
    pub fn params(&self, method: Method, seed: u64) -> Params {
        Params {
            method,
            k: self.k,
            dt: self.dt,
            horizon: self
                .pred_rows
                .map_or(self.horizon, |n| f64::from(n) * self.dt),
            beta: self.beta,
            radius: self.radius,
            seed,
            heading: self.heading,
        }
    }
}

/// A number of seconds that is finite and not negative.
pub fn non_negative(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a non-negative number of seconds")),
    }
}

/// How trajectory files are read, beyond their format (shared by `eval`, `predict` and
/// `map build`).
#[derive(Args, Debug, Clone, Default)]
pub struct ReadArgs {
    /// Column names of a CSV with a header row (a csv file's, or to override `magni`'s): `t=Time,id=ag_id,x=x,y=y`, optionally with `speed=`, `angle=` (rad),
    /// `vx=`, `vy=`; without a velocity the positions give it.
    #[arg(long, value_name = "FIELD=COLUMN,...")]
    pub columns: Option<Columns>,
    /// The topic of a rosbag2 recording (an MCAP file or a bag's folder of them, read
    /// whatever --format says) to
    /// read tracks from: people_msgs/msg/People (`/people`) or
    /// autoware_perception_msgs/msg/TrackedObjects (its pedestrians); default: the
    /// recording's one topic of such a type.
    #[arg(long, value_name = "TOPIC")]
    pub topic: Option<String>,
    /// Keep only rows at or after this time (s, as in the file).
    #[arg(long, value_name = "S")]
    pub time_from: Option<f64>,
    /// Keep only rows before this time (s, as in the file).
    #[arg(long, value_name = "S")]
    pub time_until: Option<f64>,
}

/// Trajectory input shared by the learning commands.
#[derive(Args, Debug)]
pub struct TrackArgs {
    /// Trajectory files (THÖR or ATC CSV without header: time, person_id, x, y, speed,
    /// motion_angle; THÖR-MAGNI or other CSV with a header row), or rosbag2 recordings
    /// (MCAP files or bag folders of a people tracker, see --topic).
    #[arg(long, num_args = 1.., required = true, value_name = "FILE")]
    pub tracks: Vec<PathBuf>,
    /// Trajectory file format: thor, atc, magni (THÖR-MAGNI, header row), csv (header
    /// row, see --columns) or rosbag2 [default: recognised from each file: a bag or
    /// .mcap file, a header row, the time scale of six headerless columns]. MCAP files
    /// are read as recordings whatever the format.
    #[arg(long, value_parser = parse_format)]
    pub format: Option<Format>,
    #[command(flatten)]
    pub read: ReadArgs,
}

/// A trajectory file format by name (thor, atc, magni, csv, rosbag2).
pub fn parse_format(s: &str) -> Result<Format, String> {
    s.parse()
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

/// The source of the curves' means and bands.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spread {
    /// The summary file's columns.
    Summary,
    /// Over people, from the per_person.csv beside the summary.
    People,
}
