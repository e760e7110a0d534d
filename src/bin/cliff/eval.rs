//! `cliff eval`: evaluation of methods on trajectory files.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use cliff::eval::calibration::{
    CalibrationConfig, CalibrationRow, calibrate, calibration_csv, calibration_table,
};
use cliff::eval::metrics::Counting;
use cliff::eval::protocol::Protocol;
use cliff::eval::{EvalConfig, evaluate, summary_table, table_horizons, write_reports};
use cliff::motion::MotionModel;
use cliff::occupancy::Settings as OccupancySettings;
use cliff::plot::{Line, LineChart, plot_lines};
use cliff::predict::Method;
use cliff::tracks::Format;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::args::{PredictionArgs, ReadArgs};
use crate::clock;
use crate::load::{load_map_set, load_tracks_with};

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
    /// Trajectory files to evaluate on (or rosbag2 recordings, MCAP files: see --topic).
    #[arg(long, required = true, num_args = 1..)]
    pub tracks: Vec<PathBuf>,
    /// Trajectory file format: thor, atc, magni (THÖR-MAGNI, header row), csv (header
    /// row, see --columns) or rosbag2 [default: recognised from each file: a bag or
    /// .mcap file, a header row, the time scale of six headerless columns]. MCAP files
    /// are read as recordings whatever the format.
    #[arg(long)]
    pub format: Option<Format>,
    #[command(flatten)]
    pub read: ReadArgs,
    #[command(flatten)]
    pub prediction: PredictionArgs,
    /// Seeds per stochastic method; the summary holds means and standard deviations over them.
    #[arg(long, default_value_t = 1)]
    pub seeds: usize,
    /// Methods to compare on the same people, comma-separated: cliff, cvm, improved
    /// (CLiFF-LHMP with the project's preset: its own beta and options), motion (the
    /// learned motion model alone, no map) and cvm-last (constant velocity of the last
    /// observed displacement, the THÖR-MAGNI benchmark's baseline).
    #[arg(long, value_delimiter = ',', default_value = "cliff,cvm")]
    pub methods: Vec<Method>,
    /// Which samples count at a horizon: `everyone` (a sample that stopped counts where
    /// it stopped, so every method is scored over the same people; reach is reported
    /// beside) or `reached` (only the samples that reached it, the published code's
    /// rule, as the parity tables use).
    #[arg(long, value_name = "RULE", default_value = "everyone")]
    pub count: Counting,
    /// Tracklets protocol: leave out tracklets with a step faster than this (m/s,
    /// tracking jumps) [default: none left out].
    #[arg(long, value_name = "M/S")]
    pub max_speed: Option<f64>,
    /// Motion model file (.motion, `cliff motion fit`) for the `motion` method
    /// [default: the built-in model].
    #[arg(long, value_name = "FILE")]
    pub motion_model: Option<PathBuf>,
    /// Output folder for summary.csv and per_person.csv (with --occupancy:
    /// calibration.csv and reliability-METHOD.png).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Check occupancy's calibration instead of the displacement errors: per method and
    /// horizon, the reliability table of each person's predicted cells against where
    /// they were, the Brier score and the log-likelihood (one seed).
    #[arg(long)]
    pub occupancy: bool,
    /// With --occupancy: the cells' side (m).
    #[arg(long, value_name = "M", default_value_t = 0.5)]
    pub resolution: f64,
    /// With --occupancy: the standard deviation of a person's body (m).
    #[arg(long, value_name = "M", default_value_t = 0.3)]
    pub person_radius: f64,
    /// With --occupancy: the factor on Silverman's bandwidth.
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0)]
    pub bandwidth_scale: f64,
    /// With --occupancy: the horizons checked (s, comma-separated) [default: those of
    /// the summary table].
    #[arg(long, value_delimiter = ',', value_name = "S")]
    pub horizons: Vec<f64>,
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
pub fn run(a: EvalArgs) -> Result<()> {
    if a.methods.is_empty() {
        bail!("--methods names no method");
    }
    let maps = load_map_set(a.map.as_ref(), a.clock_offset)?;
    let tracks = load_tracks_with(&a.tracks, a.format, &a.read)?;
    let mut settings = a.prediction.settings();
    settings.counting = a.count;
    if let Some(v) = a.max_speed {
        if v.is_nan() || v <= 0.0 {
            bail!("--max-speed {v} is not a positive speed");
        }
        settings.max_speed = v;
    }
    let motion_model = match &a.motion_model {
        Some(p) => Some(std::sync::Arc::new(MotionModel::load(p)?)),
        None => None,
    };
    let cfg = EvalConfig {
        motion_model,
        settings,
        params: a.prediction.params(Method::Cliff, 0),
        seeds: a.seeds.max(1),
        methods: a.methods.clone(),
        options: a.prediction.options(false),
    };
    if a.occupancy {
        return occupancy(&a, &maps, &tracks, cfg);
    }
    let progress = LateProgress::new(tracks.len() as u64, "evaluating");
    let t0 = Instant::now();
    let report = evaluate(&maps, &tracks, &cfg, &|| progress.tick()).context("evaluation")?;
    progress.bar.finish_and_clear();
    println!(
        "{} of {} people evaluated ({} protocol, {} seed(s), {:.1} s)",
        match cfg.settings.protocol {
            Protocol::Windows => format!("{} windows", report.people_evaluated),
            Protocol::Tracklets => format!("{} tracklets", report.people_evaluated),
            _ => report.people_evaluated.to_string(),
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

/// `cliff eval --occupancy`: the calibration table, and with --out its CSV and pictures.
fn occupancy(
    a: &EvalArgs,
    maps: &cliff::map::MapSet,
    tracks: &[cliff::tracks::Track],
    eval: EvalConfig,
) -> Result<()> {
    let horizons = if a.horizons.is_empty() {
        table_horizons(eval.settings.horizon, eval.settings.dt)
    } else {
        a.horizons.clone()
    };
    if let Some(h) = horizons.iter().find(|h| !(h.is_finite() && **h > 0.0)) {
        bail!("--horizons: {h} is not a positive number of seconds");
    }
    let cfg = CalibrationConfig {
        eval,
        occupancy: OccupancySettings {
            person_radius: a.person_radius,
            bandwidth_scale: a.bandwidth_scale,
            ..OccupancySettings::default()
        },
        resolution: a.resolution,
        horizons,
    };
    let progress = LateProgress::new(tracks.len() as u64, "checking occupancy");
    let t0 = Instant::now();
    let rows = calibrate(maps, tracks, &cfg, &|| progress.tick()).context("calibration")?;
    progress.bar.finish_and_clear();
    println!(
        "occupancy calibration: {} m cells, person {} m, bandwidth x{} ({:.1} s)",
        cfg.resolution,
        cfg.occupancy.person_radius,
        cfg.occupancy.bandwidth_scale,
        t0.elapsed().as_secs_f64()
    );
    print!("{}", calibration_table(&rows));
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let csv = dir.join("calibration.csv");
        std::fs::write(&csv, calibration_csv(&rows))
            .with_context(|| format!("writing {}", csv.display()))?;
        println!("wrote {}", csv.display());
        for &method in &cfg.eval.methods {
            let path = dir.join(format!("reliability-{}.png", method.name()));
            let chart = reliability_chart(&rows, method);
            plot_lines(&chart, &path).with_context(|| format!("writing {}", path.display()))?;
            println!("wrote {}", path.display());
        }
    }
    Ok(())
}

/// The reliability curves of one method: observed frequency against mean predicted
/// probability, one line per horizon, over the diagonal of perfect calibration.
pub fn reliability_chart(rows: &[CalibrationRow], method: Method) -> LineChart {
    let mut lines = Vec::new();
    let mut largest = 0.1f64;
    for r in rows.iter().filter(|r| r.method == method) {
        let points: Vec<(f64, f64)> = r
            .bins
            .iter()
            .filter(|b| b.cells >= 20)
            .map(|b| (b.mean_predicted(), b.observed()))
            .collect();
        largest = points.iter().fold(largest, |m, p| m.max(p.0).max(p.1));
        lines.push(Line {
            label: format!("{:.0} s", r.horizon),
            points,
            markers: true,
            faint: false,
        });
    }
    // the diagonal of perfect calibration, as far as the data goes
    let end = (largest * 1.1).min(1.0);
    lines.insert(
        0,
        Line {
            label: "calibrated".into(),
            points: vec![(0.0, 0.0), (end, end)],
            markers: false,
            faint: true,
        },
    );
    LineChart {
        title: format!("occupancy reliability: {}", method.name()),
        x_label: "predicted probability of the cell".into(),
        y_label: "observed frequency".into(),
        y_from_zero: true,
        legend_upper_left: true,
        size: (640, 560),
        lines,
        ..LineChart::default()
    }
}
