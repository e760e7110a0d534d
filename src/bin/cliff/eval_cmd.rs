//! `cliff eval` and `cliff predict`: evaluation on datasets and one person's samples.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use cliff::eval::dataset::{Format, Track, read_many};
use cliff::eval::protocol::{Case, Protocol, Settings, prepare};
use cliff::eval::{
    EvalConfig, evaluate, person_seed, summary_table, table_horizons, write_reports,
};
use cliff::map::CliffMap;
use cliff::predict::{HeadingRule, Method, Params, TrajectoryBatch, predict};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::map_cmd::load_map;

/// Protocol and prediction parameters shared by `eval` and `predict`.
#[derive(Args, Debug, Clone)]
pub struct PredictionArgs {
    /// Evaluation protocol: `reference` (the published code's row-based rules, for parity)
    /// or `seconds` (the same rules stated in time, for data at any rate).
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
}

impl PredictionArgs {
    pub(crate) fn settings(&self) -> Settings {
        Settings {
            protocol: self.protocol,
            obs: self.obs,
            dt: self.dt,
            horizon: self.horizon,
            sigma: self.sigma,
            ..Settings::default()
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
    /// Map file (.csv or .cliff); omit for the built-in demo scene.
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Trajectory files to evaluate on.
    #[arg(long, required = true, num_args = 1..)]
    pub tracks: Vec<PathBuf>,
    /// Trajectory file format.
    #[arg(long, default_value = "thor")]
    pub format: Format,
    #[command(flatten)]
    pub prediction: PredictionArgs,
    /// Seeds per stochastic method; the summary holds means and standard deviations over them.
    #[arg(long, default_value_t = 1)]
    pub seeds: usize,
    /// Methods to compare on the same people, comma-separated: cliff, cvm.
    #[arg(long, value_delimiter = ',', default_value = "cliff,cvm")]
    pub methods: Vec<Method>,
    /// Output folder for summary.csv and per_person.csv.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Arguments of `cliff predict`.
#[derive(Args, Debug)]
pub struct PredictArgs {
    /// Map file (.csv or .cliff); omit for the built-in demo scene.
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Trajectory file holding the person.
    #[arg(long)]
    pub tracks: PathBuf,
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
    /// Random seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output CSV (sample, step, t, x, y); omit to print to standard output.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub(crate) fn load_tracks(paths: &[PathBuf], format: Format) -> Result<Vec<Track>> {
    for p in paths {
        if !p.exists() {
            bail!("track file {} does not exist", p.display());
        }
    }
    Ok(read_many(paths, format)?)
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
    let map = load_map(a.map.as_ref())?;
    let tracks = load_tracks(&a.tracks, a.format)?;
    let cfg = EvalConfig {
        settings: a.prediction.settings(),
        params: a.prediction.params(Method::Cliff, 0),
        seeds: a.seeds.max(1),
        methods: a.methods.clone(),
    };
    let progress = LateProgress::new(tracks.len() as u64, "evaluating");
    let t0 = Instant::now();
    let report = evaluate(&map, &tracks, &cfg, &|| progress.tick()).context("evaluation")?;
    progress.bar.finish_and_clear();
    println!(
        "{} of {} people evaluated ({} protocol, {} seed(s), {:.1} s)",
        report.people_evaluated,
        report.people_total,
        cfg.settings.protocol,
        cfg.seeds,
        t0.elapsed().as_secs_f64()
    );
    let horizons = table_horizons(cfg.settings.horizon);
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
        ..prediction.params(method, person_seed(seed, case.id))
    };
    predict(map, std::slice::from_ref(&case.start), &params, batch)
        .with_context(|| format!("predicting person {}", case.id))?;
    Ok(params)
}

/// Run `cliff predict`.
pub fn run_predict(a: PredictArgs) -> Result<()> {
    let map = load_map(a.map.as_ref())?;
    let tracks = load_tracks(std::slice::from_ref(&a.tracks), a.format)?;
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
    let params = predict_case(&map, &case, &a.prediction, a.method, a.seed, &mut batch)?;
    let mut out = String::from("sample,step,t,x,y\n");
    use std::fmt::Write as _;
    for s in 0..params.k {
        for (j, p) in batch.sample(0, s).iter().enumerate() {
            let t = case.start.time + (j + 1) as f64 * params.dt;
            let _ = writeln!(out, "{s},{},{t:.3},{:.4},{:.4}", j + 1, p[0], p[1]);
        }
    }
    match &a.out {
        Some(path) => {
            std::fs::write(path, out).with_context(|| format!("writing {}", path.display()))?;
            let reached = (0..params.k)
                .filter(|&s| batch.len(0, s) == case.steps)
                .count();
            println!(
                "person {}: start ({:.2}, {:.2}) at t {:.2}, speed {:.2} m/s, heading {:.1} deg; {} samples of {} steps ({} reach the end); wrote {}",
                case.id,
                case.start.position.x,
                case.start.position.y,
                case.start.time,
                case.start.speed,
                case.start.heading.to_degrees(),
                params.k,
                case.steps,
                reached,
                path.display()
            );
        }
        None => print!("{out}"),
    }
    Ok(())
}
