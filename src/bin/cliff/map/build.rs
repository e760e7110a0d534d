//! `cliff map build`: a CLiFF-map (or a time-of-day set) learned from trajectories.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use cliff::map::build::{BuildParams, EmParams, FitParams, MeanShift, build_map_with_progress};
use cliff::map::timeofday::build_map_set_with_progress;
use cliff::map::{MapFormat, SliceParams, Smoothing};
use cliff::motion::SpeedPrior;
use cliff::tracks::Track;
use indicatif::{ProgressBar, ProgressStyle};

use crate::args::TrackArgs;
use crate::clock;
use crate::load::{observations, timed_observations};

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
    /// Build a time-of-day map set: the all-day map and one map per slice of the day of
    /// this length (1h, 30min, 7200; it must divide the day), each slice smoothed
    /// towards its neighbours and the all-day map. The output must be a .cliff snapshot.
    #[arg(long, value_name = "DURATION", value_parser = clock::duration)]
    pub slice: Option<f64>,
    /// Seconds added to the tracks' timestamps to get the local time of day that picks
    /// the slice (stored in the set; ATC holds unix time in Japan: +9h or 32400).
    #[arg(long, value_name = "DURATION", default_value = "0", value_parser = clock::signed_duration, allow_hyphen_values = true)]
    pub clock_offset: f64,
    /// How far in time a slice borrows from its neighbours: the width (standard
    /// deviation) of the Gaussian kernel over slices (0: its own data only).
    #[arg(long, value_name = "DURATION", default_value = "0", value_parser = clock::duration)]
    pub slice_kernel: f64,
    /// What the all-day map is worth at each location of a slice map, in observations
    /// (the prior: a location the slice's data hardly visit keeps the all-day mixture).
    #[arg(long, value_name = "N", default_value_t = Smoothing::default().prior_weight)]
    pub slice_prior: f64,
    /// Share of the all-day mixture in every slice mixture, whatever the slice's data
    /// (0 to 1).
    #[arg(long, value_name = "SHARE", default_value_t = Smoothing::default().all_day_share)]
    pub slice_all_day: f64,
    /// Most components per location of a slice map (near-duplicates are merged).
    #[arg(long, value_name = "N", default_value_t = Smoothing::default().max_components)]
    pub slice_max_components: usize,
    /// Do not learn a speed prior (by default the map keeps how the tracks' speeds over
    /// the next 10-50 s regress to their typical speed, for `--methods improved`; from
    /// windows along the tracks when they hold too few people, and over 4-8 s too
    /// when those windows are too few; stored in .cliff snapshots only).
    #[arg(long)]
    pub no_speed_prior: bool,
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
pub fn run(a: BuildArgs) -> Result<()> {
    if let Some(length) = a.slice {
        return build_set(a, length);
    }
    let params = a.params();
    params.check()?;
    let t0 = Instant::now();
    let (obs, tracks) = observations(&a.input)?;
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
    let mut map = built.map;
    let prior = speed_prior(&a, &tracks)?;
    map.set_speed_prior(prior)?;
    map.save(&a.out)
        .with_context(|| format!("writing {}", a.out.display()))?;
    let s = built.summary;
    println!("wrote {}", a.out.display());
    print_speed_prior(&a, prior);
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

/// The speed prior of the map being built (none with `--no-speed-prior`, or when the
/// tracks hold too few walkers).
fn speed_prior(a: &BuildArgs, tracks: &[Track]) -> Result<Option<SpeedPrior>> {
    if a.no_speed_prior {
        return Ok(None);
    }
    Ok(SpeedPrior::fit_tracks(tracks))
}

fn print_speed_prior(a: &BuildArgs, prior: Option<SpeedPrior>) {
    match prior {
        Some(p) => {
            let kept = if MapFormat::from_path(&a.out).ok() == Some(MapFormat::Csv) {
                " (not in the CSV file: the published format has no place for it; write .cliff to keep it)"
            } else {
                ""
            };
            println!(
                "speed prior         v = {:.3} + {:.3} (v0 - {:.3}) m/s, from {} pairs{kept}",
                p.mean, p.keep, p.mean, p.pairs
            );
        }
        None if a.no_speed_prior => println!("speed prior         none (--no-speed-prior)"),
        None => println!(
            "speed prior         none (fewer than {} pairs of start speed and speed 4-50 s ahead, from people or windows along the tracks)",
            cliff::eval::speed_prior_fit::MIN_PAIRS
        ),
    }
}

/// `cliff map build --slice`: a time-of-day set.
fn build_set(a: BuildArgs, slice_length: f64) -> Result<()> {
    let params = a.params();
    params.check()?;
    if MapFormat::from_path(&a.out)? != MapFormat::Snapshot {
        bail!(
            "--out {}: a time-of-day set is written as a .cliff snapshot (a CSV file holds one map; `cliff map convert --slice` exports one)",
            a.out.display()
        );
    }
    let slicing = SliceParams {
        slice_length,
        clock_offset: a.clock_offset,
        smoothing: Smoothing {
            kernel_width: a.slice_kernel,
            prior_weight: a.slice_prior,
            all_day_share: a.slice_all_day,
            max_components: a.slice_max_components,
            ..Smoothing::default()
        },
    };
    slicing.check()?;
    let t0 = Instant::now();
    let (obs, times, tracks) = timed_observations(&a.input)?;
    let t_read = t0.elapsed();
    let pb = progress_bar(a.quiet);
    let part = std::sync::Mutex::new(String::new());
    let built = with_threads(a.threads, || {
        build_map_set_with_progress(&obs, &times, &params, &slicing, &|name, total| {
            let mut p = part.lock().unwrap_or_else(|e| e.into_inner());
            if *p != name {
                *p = name.to_string();
                pb.set_message(format!("fitting {name}"));
                pb.set_length(total as u64);
                pb.set_position(0);
            }
            pb.inc(1);
        })
    })??;
    pb.finish_and_clear();
    let t_fit = t0.elapsed() - t_read;
    let mut built = built;
    let prior = speed_prior(&a, &tracks)?;
    built.set.set_speed_prior(prior)?;
    built
        .set
        .save(&a.out)
        .with_context(|| format!("writing {}", a.out.display()))?;
    let s = built.all_day.summary;
    println!("wrote {}", a.out.display());
    print_speed_prior(&a, prior);
    println!(
        "observations        {} ({} standing, not used)",
        s.observations, s.standing
    );
    println!(
        "all-day map         {} locations ({} components, {:.2} per location)",
        s.locations,
        s.components,
        s.components as f64 / s.locations as f64
    );
    println!(
        "slices              {} of {} s, clock offset {} s; kernel width {} s, prior {} observations, all-day share {}, at most {} components",
        built.set.slices().len(),
        slice_length,
        a.clock_offset,
        a.slice_kernel,
        a.slice_prior,
        a.slice_all_day,
        a.slice_max_components
    );
    println!(
        "{:<13} {:>12} {:>14} {:>10} {:>11}",
        "slice", "observations", "own locations", "locations", "components"
    );
    for sl in built
        .slices
        .iter()
        .filter(|sl| sl.observations > 0 || sl.locations > 0)
    {
        if sl.locations == 0 {
            println!(
                "{:<13} {:>12} {:>14}   (all-day map)",
                sl.label, sl.observations, sl.own_locations
            );
        } else {
            println!(
                "{:<13} {:>12} {:>14} {:>10} {:>11}",
                sl.label, sl.observations, sl.own_locations, sl.locations, sl.components
            );
        }
    }
    let without = built.slices.iter().filter(|sl| sl.locations == 0).count();
    if without > 0 {
        println!("({without} slices without data use the all-day map)");
    }
    println!(
        "time                {:.2} s reading, {:.2} s fitting",
        t_read.as_secs_f64(),
        t_fit.as_secs_f64()
    );
    Ok(())
}
