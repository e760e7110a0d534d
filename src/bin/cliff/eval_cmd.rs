//! `cliff eval` and `cliff predict`: evaluation on datasets and one person's samples.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use cliff::eval::protocol::{Case, Protocol, Settings, prepare};
use cliff::eval::{
    EvalConfig, evaluate, person_seed, summary_table, table_horizons, write_reports,
};
use cliff::map::CliffMap;
use cliff::map::timeofday::slice_label;
use cliff::predict::{HeadingRule, Method, Options, Params, TrajectoryBatch, predict_with};
use cliff::tracks::{Columns, read_many_as};
use cliff::tracks::{Format, Track, keep_time_range};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::clock;
use crate::map_cmd::load_map_set;

/// Protocol and prediction parameters shared by `eval` and `predict`.
#[derive(Args, Debug, Clone)]
pub struct PredictionArgs {
    /// Evaluation protocol: `reference` (the published code's row-based rules, for parity:
    /// observed rows, 10-row idle filter whatever the rate), `seconds` (the same rules
    /// stated in time, with a 4 s idle window, for data at any rate) or `windows` (the
    /// seconds rules in a window every `--window-every` seconds along each track, for long
    /// recordings such as THÖR-MAGNI).
    #[arg(long, default_value = "seconds")]
    pub protocol: Protocol,
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
    /// Speed prior (beyond the paper): start from the speed the map's speed prior
    /// (learned by `cliff map build`) gives for the observed one; maps without a prior
    /// keep the observed speed.
    #[arg(long)]
    pub speed_prior: bool,
}

fn non_negative(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a non-negative number of seconds")),
    }
}

/// How trajectory files are read, beyond their format (shared by `eval`, `predict` and
/// `map build`).
#[derive(Args, Debug, Clone, Default)]
pub struct ReadArgs {
    /// Column names of a CSV with a header row (with `--format csv`, or to override
    /// `magni`'s): `t=Time,id=ag_id,x=x,y=y`, optionally with `speed=`, `angle=` (rad),
    /// `vx=`, `vy=`; without a velocity the positions give it.
    #[arg(long, value_name = "FIELD=COLUMN,...")]
    pub columns: Option<Columns>,
    /// Keep only rows at or after this time (s, as in the file).
    #[arg(long, value_name = "S")]
    pub time_from: Option<f64>,
    /// Keep only rows before this time (s, as in the file).
    #[arg(long, value_name = "S")]
    pub time_until: Option<f64>,
}

impl PredictionArgs {
    pub(crate) fn settings(&self) -> Settings {
        Settings {
            protocol: self.protocol,
            obs: self.obs,
            dt: self.dt,
            horizon: self.horizon,
            sigma: self.sigma,
            window_every: self.window_every,
            full_horizon_only: self.full_horizon_only,
            ..Settings::default()
        }
    }

    pub(crate) fn options(&self, scores: bool) -> Options {
        Options {
            speed_beta: self.speed_beta,
            coast: self.coast,
            scores,
            follow: self.follow,
            candidates: self.candidates,
            speed_prior: self.speed_prior,
        }
    }

    pub(crate) fn params(&self, method: Method, seed: u64) -> Params {
        Params {
            method,
            k: self.k,
            dt: self.dt,
            horizon: self.horizon,
            beta: self.beta,
            radius: self.radius,
            seed,
            heading: self.heading,
        }
    }
}

/// Arguments of `cliff eval`.
#[derive(Args, Debug)]
pub struct EvalArgs {
    /// Map file (.csv or .cliff); omit for the built-in demo scene. With a time-of-day
    /// set (`cliff map build --slice`), each person is predicted with the map of the
    /// slice of their last observed row's time (plus the clock offset).
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Seconds added to the tracks' timestamps to get the local time of day that picks
    /// a set's slice (+9h, 32400, -5h); default: the offset stored in the set.
    #[arg(long, value_name = "DURATION", value_parser = clock::signed_duration, allow_hyphen_values = true)]
    pub clock_offset: Option<f64>,
    /// Trajectory files to evaluate on.
    #[arg(long, required = true, num_args = 1..)]
    pub tracks: Vec<PathBuf>,
    /// Trajectory file format: thor, atc, magni (THÖR-MAGNI, header row) or csv (header
    /// row, see --columns).
    #[arg(long, default_value = "thor")]
    pub format: Format,
    #[command(flatten)]
    pub read: ReadArgs,
    #[command(flatten)]
    pub prediction: PredictionArgs,
    /// Seeds per stochastic method; the summary holds means and standard deviations over them.
    #[arg(long, default_value_t = 1)]
    pub seeds: usize,
    /// Methods to compare on the same people, comma-separated: cliff, cvm, improved
    /// (CLiFF-LHMP with the project's preset: its own beta and options).
    #[arg(long, value_delimiter = ',', default_value = "cliff,cvm")]
    pub methods: Vec<Method>,
    /// Output folder for summary.csv and per_person.csv.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Arguments of `cliff predict`.
#[derive(Args, Debug)]
pub struct PredictArgs {
    /// Map file (.csv or .cliff); omit for the built-in demo scene. With a time-of-day
    /// set, the map of the slice of the person's last observed row's time.
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Seconds added to the tracks' timestamps to get the local time of day that picks
    /// a set's slice; default: the offset stored in the set.
    #[arg(long, value_name = "DURATION", value_parser = clock::signed_duration, allow_hyphen_values = true)]
    pub clock_offset: Option<f64>,
    /// Trajectory file holding the person.
    #[arg(long)]
    pub tracks: PathBuf,
    /// Trajectory file format: thor, atc, magni or csv.
    #[arg(long, default_value = "thor")]
    pub format: Format,
    #[command(flatten)]
    pub read: ReadArgs,
    /// Person id.
    #[arg(long)]
    pub person: u64,
    #[command(flatten)]
    pub prediction: PredictionArgs,
    /// Method: cliff, cvm or improved (CLiFF-LHMP with the project's preset: its own
    /// beta and options).
    #[arg(long, default_value = "cliff")]
    pub method: Method,
    /// Random seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output CSV (sample, step, t, x, y); omit to print to standard output.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub(crate) fn load_tracks(paths: &[PathBuf], format: Format) -> Result<Vec<Track>> {
    load_tracks_with(paths, format, &ReadArgs::default())
}

/// Read trajectory files with a column mapping and time range.
pub(crate) fn load_tracks_with(
    paths: &[PathBuf],
    format: Format,
    read: &ReadArgs,
) -> Result<Vec<Track>> {
    for p in paths {
        if !p.exists() {
            bail!("track file {} does not exist", p.display());
        }
    }
    let mut tracks = read_many_as(paths, format, read.columns.as_ref())?;
    if read.time_from.is_some() || read.time_until.is_some() {
        let from = read.time_from.unwrap_or(f64::NEG_INFINITY);
        let until = read.time_until.unwrap_or(f64::INFINITY);
        if from.is_nan() || until.is_nan() || from >= until {
            bail!("--time-from {from} is not before --time-until {until}");
        }
        keep_time_range(&mut tracks, from, until);
    }
    Ok(tracks)
}

/// A progress bar that appears only once the run has taken more than a second.
struct LateProgress {
    bar: ProgressBar,
    start: Instant,
    shown: AtomicBool,
}

impl LateProgress {
    fn new(len: u64, what: &str) -> Self {
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} ({eta} left)")
                .expect("static template")
                .progress_chars("=> "),
        );
        bar.set_message(what.to_string());
        Self {
            bar,
            start: Instant::now(),
            shown: AtomicBool::new(false),
        }
    }

    fn tick(&self) {
        self.bar.inc(1);
        if !self.shown.load(Ordering::Relaxed)
            && self.start.elapsed() > Duration::from_secs(1)
            && !self.shown.swap(true, Ordering::Relaxed)
        {
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
        }
    }
}

/// Run `cliff eval`.
pub fn run_eval(a: EvalArgs) -> Result<()> {
    if a.methods.is_empty() {
        bail!("--methods names no method");
    }
    let maps = load_map_set(a.map.as_ref(), a.clock_offset)?;
    let tracks = load_tracks_with(&a.tracks, a.format, &a.read)?;
    let cfg = EvalConfig {
        settings: a.prediction.settings(),
        params: a.prediction.params(Method::Cliff, 0),
        seeds: a.seeds.max(1),
        methods: a.methods.clone(),
        options: a.prediction.options(false),
    };
    let progress = LateProgress::new(tracks.len() as u64, "evaluating");
    let t0 = Instant::now();
    let report = evaluate(&maps, &tracks, &cfg, &|| progress.tick()).context("evaluation")?;
    progress.bar.finish_and_clear();
    println!(
        "{} of {} people evaluated ({} protocol, {} seed(s), {:.1} s)",
        if cfg.settings.protocol == Protocol::Windows {
            format!("{} windows", report.people_evaluated)
        } else {
            report.people_evaluated.to_string()
        },
        report.people_total,
        cfg.settings.protocol,
        cfg.seeds,
        t0.elapsed().as_secs_f64()
    );
    let horizons = table_horizons(cfg.settings.horizon, cfg.settings.dt);
    print!("{}", summary_table(&report.summary, &horizons));
    if let Some(dir) = &a.out {
        write_reports(&report, dir)
            .with_context(|| format!("writing reports to {}", dir.display()))?;
        println!(
            "wrote {} and {}",
            dir.join("summary.csv").display(),
            dir.join("per_person.csv").display()
        );
    }
    Ok(())
}

/// Predict one prepared person: its own horizon, and the seed mixed with its id as in
/// `cliff eval` (so `cliff predict`, `cliff plot predict` and the demo draw the same
/// samples for the same seed).
pub(crate) fn predict_case(
    map: &CliffMap,
    case: &Case,
    prediction: &PredictionArgs,
    method: Method,
    seed: u64,
    batch: &mut TrajectoryBatch,
) -> Result<Params> {
    let params = Params {
        horizon: case.steps as f64 * prediction.dt,
        ..prediction.params(method, person_seed(seed, case.seed_key()))
    };
    predict_with(
        map,
        std::slice::from_ref(&case.start),
        &params,
        &prediction.options(true),
        batch,
    )
    .with_context(|| format!("predicting person {}", case.id))?;
    Ok(params)
}

/// Run `cliff predict`.
pub fn run_predict(a: PredictArgs) -> Result<()> {
    let maps = load_map_set(a.map.as_ref(), a.clock_offset)?;
    let tracks = load_tracks_with(std::slice::from_ref(&a.tracks), a.format, &a.read)?;
    let track = tracks
        .iter()
        .find(|t| t.id == a.person)
        .with_context(|| format!("person {} is not in {}", a.person, a.tracks.display()))?;
    let settings = a.prediction.settings();
    let case = prepare(track, &settings).with_context(|| {
        format!(
            "person {} is skipped by the {} protocol (too short, idle, or no future to predict)",
            a.person, settings.protocol
        )
    })?;
    let mut batch = TrajectoryBatch::new();
    let map = maps.at(case.start.time);
    let params = predict_case(map, &case, &a.prediction, a.method, a.seed, &mut batch)?;
    // score: the sample's log-likelihood under the map (the same on each of its rows)
    let mut out = String::from("sample,step,t,x,y,score\n");
    use std::fmt::Write as _;
    for s in 0..params.k {
        let score = batch.score(0, s).unwrap_or(f32::NAN);
        for (j, p) in batch.sample(0, s).iter().enumerate() {
            let t = case.start.time + (j + 1) as f64 * params.dt;
            let _ = writeln!(
                out,
                "{s},{},{t:.3},{:.4},{:.4},{score:.3}",
                j + 1,
                p[0],
                p[1]
            );
        }
    }
    match &a.out {
        Some(path) => {
            std::fs::write(path, out).with_context(|| format!("writing {}", path.display()))?;
            let reached = (0..params.k)
                .filter(|&s| batch.len(0, s) == case.steps)
                .count();
            let slice = match maps.slice_index(case.start.time) {
                Some(k) => format!(
                    " (slice {}{})",
                    slice_label(k, maps.slice_length()),
                    if maps.slices()[k].is_none() {
                        ": the all-day map"
                    } else {
                        ""
                    }
                ),
                None => String::new(),
            };
            println!(
                "person {}: start ({:.2}, {:.2}) at t {:.2}{slice}, speed {:.2} m/s, heading {:.1} deg; {} samples of {} steps ({} reach the end, the most likely is sample {}); wrote {}",
                case.id,
                case.start.position.x,
                case.start.position.y,
                case.start.time,
                case.start.speed,
                case.start.heading.to_degrees(),
                params.k,
                case.steps,
                reached,
                batch.best_sample(0).unwrap_or(0),
                path.display()
            );
        }
        None => print!("{out}"),
    }
    Ok(())
}
