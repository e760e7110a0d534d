//! `cliff map build | score | update`: learning maps from trajectories.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use cliff::eval::dataset::Format;
use cliff::map::CliffMap;
use cliff::map::build::{
    BuildParams, EmParams, FitParams, MeanShift, Observation, build_map_with_progress,
    observations_from_tracks,
};
use cliff::map::score::{ScoreParams, score as score_map};
use cliff::map::update::{OnlineMap, UpdateParams};
use indicatif::{ProgressBar, ProgressStyle};

use crate::eval_cmd::{ReadArgs, load_tracks_with};

/// Trajectory input shared by the learning commands.
#[derive(Args, Debug)]
pub struct TrackArgs {
    /// Trajectory files (CSV without header: time, person_id, x, y, speed, motion_angle).
    #[arg(long, num_args = 1.., required = true, value_name = "FILE")]
    pub tracks: Vec<PathBuf>,
    /// Trajectory file format: thor, atc, magni or csv.
    #[arg(long, default_value = "atc", value_parser = parse_format)]
    pub format: Format,
    #[command(flatten)]
    pub read: ReadArgs,
}

fn parse_format(s: &str) -> Result<Format, String> {
    s.parse()
}

impl TrackArgs {
    fn observations(&self) -> Result<Vec<Observation>> {
        let tracks = load_tracks_with(&self.tracks, self.format, &self.read)
            .context("reading trajectories")?;
        let obs = observations_from_tracks(&tracks);
        if obs.is_empty() {
            bail!("the trajectory files hold no rows");
        }
        Ok(obs)
    }
}

/// Options of `cliff map build`.
#[derive(Args, Debug)]
pub struct BuildArgs {
    #[command(flatten)]
    pub input: TrackArgs,
    /// Grid step (m): nodes sit on whole multiples of it (ATC 1, THÖR 0.5).
    #[arg(long, default_value_t = 1.0)]
    pub grid: f64,
    /// Each node collects the observations within this distance (m).
    #[arg(long, default_value_t = 1.0)]
    pub radius: f64,
    /// Output map: .csv (published format) or .cliff (snapshot).
    #[arg(long, value_name = "MAP")]
    pub out: PathBuf,
    /// Mean shift over every sample (the original, O(n^2) per node) instead of
    /// weighted binning.
    #[arg(long)]
    pub exact_mean_shift: bool,
    /// Largest bin width of binned mean shift along the direction (degrees).
    #[arg(long, default_value_t = 2.0)]
    pub theta_bin_deg: f64,
    /// Largest bin width of binned mean shift along the speed (m/s).
    #[arg(long, default_value_t = 0.02)]
    pub rho_bin: f64,
    /// Largest number of EM iterations per node.
    #[arg(long, default_value_t = 500)]
    pub em_max_iter: usize,
    /// EM stops when the log-likelihood changes by at most this share of its size
    /// (0: the original's absolute 1e-5 only).
    #[arg(long, default_value_t = 1e-5)]
    pub em_rel_tol: f64,
    /// Worker threads (0: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

impl BuildArgs {
    fn params(&self) -> BuildParams {
        BuildParams {
            grid: self.grid,
            radius: self.radius,
            fit: FitParams {
                mean_shift: if self.exact_mean_shift {
                    MeanShift::Exact
                } else {
                    MeanShift::Binned {
                        theta_bin: self.theta_bin_deg.to_radians(),
                        rho_bin: self.rho_bin,
                    }
                },
                em: EmParams {
                    max_iter: self.em_max_iter,
                    rel_tol: self.em_rel_tol,
                    ..EmParams::default()
                },
                ..FitParams::default()
            },
        }
    }
}

fn progress_bar(quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(0);
    pb.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} nodes ({eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    pb.set_message("fitting");
    pb
}

fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> Result<T> {
    if threads == 0 {
        return Ok(f());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("starting worker threads")?;
    Ok(pool.install(f))
}

/// Run `cliff map build`.
pub fn build(a: BuildArgs) -> Result<()> {
    let params = a.params();
    params.check()?;
    let t0 = Instant::now();
    let obs = a.input.observations()?;
    let t_read = t0.elapsed();
    let pb = progress_bar(a.quiet);
    let built = with_threads(a.threads, || {
        build_map_with_progress(&obs, &params, &|total| {
            if pb.length() != Some(total as u64) {
                pb.set_length(total as u64);
            }
            pb.inc(1);
        })
    })??;
    pb.finish_and_clear();
    let t_fit = t0.elapsed() - t_read;
    built
        .map
        .save(&a.out)
        .with_context(|| format!("writing {}", a.out.display()))?;
    let s = built.summary;
    println!("wrote {}", a.out.display());
    println!(
        "observations        {} ({} standing, not used)",
        s.observations, s.standing
    );
    println!(
        "nodes               {} with data, {} fitted (>= 3 moving samples)",
        s.nodes, s.fitted
    );
    println!(
        "locations           {} ({} components, {:.2} per location)",
        s.locations,
        s.components,
        s.components as f64 / s.locations as f64
    );
    println!(
        "busiest node        {} moving samples (the count scale for `cliff map update`)",
        s.max_count
    );
    println!(
        "time                {:.2} s reading, {:.2} s fitting",
        t_read.as_secs_f64(),
        t_fit.as_secs_f64()
    );
    Ok(())
}

/// Options of `cliff map score`.
#[derive(Args, Debug)]
pub struct ScoreArgs {
    /// Map to score (.csv or .cliff).
    #[arg(long, value_name = "MAP")]
    pub map: PathBuf,
    #[command(flatten)]
    pub input: TrackArgs,
    /// An observation is scored at the nearest location strictly within this
    /// distance (m) [default: the map's grid step, 1 m for ATC, 0.5 m for THÖR].
    #[arg(long)]
    pub radius: Option<f64>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Run `cliff map score`.
pub fn score(a: ScoreArgs) -> Result<()> {
    let map = CliffMap::load(&a.map).with_context(|| format!("loading map {}", a.map.display()))?;
    let obs = a.input.observations()?;
    let params = ScoreParams {
        radius: a.radius.unwrap_or(map.grid().step()),
        ..ScoreParams::default()
    };
    let r = score_map(&map, &obs, &params)?;
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!("map                  {}", a.map.display());
        println!(
            "observations         {} moving ({} standing skipped)",
            r.observations, r.standing
        );
        println!(
            "unmatched            {} (no location within {} m)",
            r.unmatched, r.radius
        );
        println!("mean log-likelihood  {:.4}", r.mean_log_likelihood);
        println!("median               {:.4}", r.median_log_likelihood);
        println!(
            "{:<21}{:.2} %",
            format!("below {}", r.bad_below),
            100.0 * r.share_below
        );
    }
    Ok(())
}

/// Options of `cliff map update`.
#[derive(Args, Debug)]
pub struct UpdateArgs {
    /// Map to update (.csv or .cliff).
    #[arg(long, value_name = "MAP")]
    pub map: PathBuf,
    #[command(flatten)]
    pub input: TrackArgs,
    /// Output map (.csv or .cliff).
    #[arg(long, value_name = "MAP")]
    pub out: PathBuf,
    /// Moving samples that an observation ratio of 1 stands for in MAP: the busiest
    /// node's count, printed by `cliff map build` and by earlier updates. Without it
    /// the map weighs as much as the busiest node of the new batch.
    #[arg(long)]
    pub count_scale: Option<f64>,
    /// Decay of the map's effective counts before the batch is added, in (0, 1]
    /// (1: all data weigh the same).
    #[arg(long, default_value_t = 0.5)]
    pub decay: f64,
    /// Each node collects the observations within this distance (m) [default: the
    /// map's grid step].
    #[arg(long)]
    pub radius: Option<f64>,
    /// Largest number of components per location.
    #[arg(long, default_value_t = 10)]
    pub max_components: usize,
}

/// Run `cliff map update`.
pub fn update(a: UpdateArgs) -> Result<()> {
    let map = CliffMap::load(&a.map).with_context(|| format!("loading map {}", a.map.display()))?;
    let obs = a.input.observations()?;
    let params = UpdateParams {
        decay: a.decay,
        radius: a.radius,
        max_components: a.max_components,
        ..UpdateParams::default()
    };
    let mut online = OnlineMap::from_map(&map, a.count_scale.unwrap_or(1.0), params)?;
    let scale = match a.count_scale {
        Some(s) => s,
        None => {
            let s = online.busiest_node(&obs)?.max(1) as f64;
            online.set_count_scale(s)?;
            s
        }
    };
    let t0 = Instant::now();
    let r = online.update(&obs)?;
    let out = online.to_map()?;
    out.save(&a.out)
        .with_context(|| format!("writing {}", a.out.display()))?;
    println!("wrote {}", a.out.display());
    println!("count scale in      {scale}");
    println!("observations        {}", r.observations);
    println!(
        "locations           {} updated, {} new, {} in all",
        r.updated,
        r.created,
        online.len()
    );
    println!(
        "components          {} added, {} merged, {} pruned, {} in all",
        r.added,
        r.merged,
        r.pruned,
        out.info().components
    );
    println!(
        "count scale out     {:.1} (pass --count-scale {:.1} to the next update)",
        online.count_scale(),
        online.count_scale()
    );
    println!("time                {:.2} s", t0.elapsed().as_secs_f64());
    Ok(())
}
