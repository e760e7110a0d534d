//! Running an evaluation over many people and seeds, and its reports.
//!
//! [`evaluate`] prepares every track with the protocol, predicts with every method and
//! seed (in parallel over people), and aggregates: per horizon, the plain mean over the
//! people that have a value there, then the mean and standard deviation over seeds.

use std::fmt::Write as _;
use std::io;
use std::path::Path;
use std::sync::Arc;

use rayon::prelude::*;

use super::metrics::{Scratch, StepErrors, person_errors};
use super::protocol::{Case, Settings, prepare_all};
use crate::map::{CliffMap, MapAt};
use crate::motion::{History, MotionModel};
use crate::predict::{Method, Options, Params, PredictError, Rollout, TrajectoryBatch};
use crate::tracks::Track;

/// What to evaluate.
#[derive(Debug, Clone, PartialEq)]
pub struct EvalConfig {
    /// Protocol settings (observation, dt, horizon).
    pub settings: Settings,
    /// Prediction parameters: `k`, `beta`, `radius` and `heading` are used; method,
    /// dt, horizon and seed are set per run.
    pub params: Params,
    /// Seeds per method (seeds `0..seeds`); deterministic methods run once.
    pub seeds: usize,
    /// Methods, all on the same people.
    pub methods: Vec<Method>,
    /// Options beyond the paper's method (all off: the paper's). Scores are always
    /// computed, for the top-1 errors (they leave the samples as they are).
    pub options: Options,
    /// The motion model of [`Method::Motion`] (none: the built-in one).
    pub motion_model: Option<Arc<MotionModel>>,
}

impl EvalConfig {
    /// Predict `case` (its start state and observed `history`) with `method` and seed
    /// number `seed` into `batch`, as every evaluation does: the case's horizon, the
    /// config's parameters, options and motion model, one sample for a deterministic
    /// method; `scores` asks for the samples' scores. Returns the samples drawn.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn predict_case(
        &self,
        map: &CliffMap,
        case: &Case,
        history: &History,
        method: Method,
        seed: u64,
        scores: bool,
        batch: &mut TrajectoryBatch,
    ) -> Result<usize, PredictError> {
        let dt = self.settings.dt;
        let params = Params {
            method,
            dt,
            horizon: case.steps as f64 * dt,
            seed: person_seed(seed, case.seed_key()),
            // constant velocity draws nothing: one sample stands for all k
            k: if method.is_deterministic() {
                1
            } else {
                self.params.k
            },
            ..self.params
        };
        let options = Options {
            scores,
            ..self.options
        };
        let mut rollout = Rollout::new(&params)?.with_options(options)?;
        if let Some(model) = &self.motion_model {
            rollout = rollout.with_motion_model(model.clone());
        }
        rollout.predict_batch(
            map,
            std::slice::from_ref(&case.start),
            Some(std::slice::from_ref(history)),
            batch,
        )?;
        Ok(params.k)
    }
}

/// One row of the summary: a method at a horizon.
#[derive(Debug, Clone, PartialEq)]
pub struct SummaryRow {
    /// Method.
    pub method: Method,
    /// Horizon (s).
    pub horizon: f64,
    /// People counted at this horizon (mean over seeds; see [`SummaryRow::reach`]).
    pub people: f64,
    /// Mean ADE over people (mean over seeds).
    pub ade: f64,
    /// Mean FDE.
    pub fde: f64,
    /// Mean minADE (top-k).
    pub min_ade: f64,
    /// Mean minFDE (top-k).
    pub min_fde: f64,
    /// Standard deviation over seeds of the ADE.
    pub ade_sd: f64,
    /// Standard deviation over seeds of the FDE.
    pub fde_sd: f64,
    /// Standard deviation over seeds of the minADE.
    pub min_ade_sd: f64,
    /// Standard deviation over seeds of the minFDE.
    pub min_fde_sd: f64,
    /// Mean top-1 ADE (the best-scored sample; mean over seeds).
    pub top1_ade: f64,
    /// Mean top-1 FDE.
    pub top1_fde: f64,
    /// Share of the people whose ground truth lasts this long that a prediction (one
    /// seed's samples) reaches, a mean over seeds. (With
    /// [`Counting::Reached`](super::metrics::Counting) `people` counts those people
    /// alone; with [`Counting::Everyone`](super::metrics::Counting) `people` counts them
    /// all.)
    pub reach: f64,
    /// Seeds run.
    pub seeds: usize,
}

/// One row per person, method and horizon (means over seeds with a value).
#[derive(Debug, Clone, PartialEq)]
pub struct PersonRow {
    /// Person id.
    pub person_id: u64,
    /// Window number along the person's track (windows protocol; 0 otherwise).
    pub window: u32,
    /// Method.
    pub method: Method,
    /// Horizon (s).
    pub horizon: f64,
    /// ADE.
    pub ade: f64,
    /// FDE.
    pub fde: f64,
    /// minADE.
    pub min_ade: f64,
    /// minFDE.
    pub min_fde: f64,
    /// Top-1 ADE (the best-scored sample).
    pub top1_ade: f64,
    /// Top-1 FDE.
    pub top1_fde: f64,
    /// Samples reaching this horizon (mean over seeds).
    pub samples_reaching: f64,
}

/// The result of [`evaluate`].
#[derive(Debug, Clone, PartialEq)]
pub struct EvalReport {
    /// People in the input.
    pub people_total: usize,
    /// People the protocol kept (windows, with the windows protocol).
    pub people_evaluated: usize,
    /// One row per method and horizon step, in method order then horizon.
    pub summary: Vec<SummaryRow>,
    /// One row per person, method and horizon where the person has a value.
    pub per_person: Vec<PersonRow>,
}

/// Mix a run seed and a person id into the seed of one prediction call (splitmix64).
pub fn person_seed(seed: u64, person: u64) -> u64 {
    let mut z =
        seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ person.wrapping_add(0xD1B5_4A32_D192_ED03);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Errors of one person: `[method][seed][step]`.
type PersonResult = Vec<Vec<Vec<Option<StepErrors>>>>;

struct Worker {
    batch: TrajectoryBatch,
    scratch: Scratch,
}

fn seeds_for(method: Method, seeds: usize) -> usize {
    if method.is_deterministic() {
        1
    } else {
        seeds.max(1)
    }
}

fn run_case(
    map: &CliffMap,
    case: &Case,
    cfg: &EvalConfig,
    w: &mut Worker,
) -> Result<PersonResult, PredictError> {
    let dt = cfg.settings.dt;
    // for the methods that read the observed path
    let history = case.history();
    let mut res = Vec::with_capacity(cfg.methods.len());
    for &method in &cfg.methods {
        let mut per_seed = Vec::new();
        for seed in 0..seeds_for(method, cfg.seeds) {
            let k =
                cfg.predict_case(map, case, &history, method, seed as u64, true, &mut w.batch)?;
            let batch = &w.batch;
            let mut out = Vec::new();
            person_errors(
                case,
                dt,
                cfg.settings.counting,
                (0..k).map(|s| batch.sample(0, s)),
                batch.scores(),
                &mut w.scratch,
                &mut out,
            );
            per_seed.push(out);
        }
        res.push(per_seed);
    }
    Ok(res)
}

/// Evaluate `methods` on `tracks` with `maps`. `progress` is called once per person done.
///
/// `maps` is a [`CliffMap`] (every person gets it) or a time-of-day
/// [`MapSet`](crate::map::MapSet): each person (or window) gets the map of the time of
/// its last observed row ([`MapAt::map_at`]).
pub fn evaluate<M: MapAt + Sync + ?Sized>(
    maps: &M,
    tracks: &[Track],
    cfg: &EvalConfig,
    progress: &(dyn Fn() + Sync),
) -> Result<EvalReport, PredictError> {
    cfg.params.validate()?;
    cfg.options.validate()?;
    Params {
        dt: cfg.settings.dt,
        horizon: cfg.settings.horizon,
        ..cfg.params
    }
    .validate()?;
    let cases: Vec<Case> = prepare_all(tracks, &cfg.settings);
    let results: Vec<PersonResult> = cases
        .par_iter()
        .map_init(
            || Worker {
                batch: TrajectoryBatch::new(),
                scratch: Scratch::default(),
            },
            |w, case| {
                let r = run_case(maps.map_at(case.start.time), case, cfg, w);
                progress();
                r
            },
        )
        .collect::<Result<_, _>>()?;
    let max_steps = cases.iter().map(|c| c.steps).max().unwrap_or(0);
    let dt = cfg.settings.dt;
    let mut summary = Vec::new();
    let mut per_person = Vec::new();
    for (mi, &method) in cfg.methods.iter().enumerate() {
        let n_seeds = seeds_for(method, cfg.seeds);
        for j in 0..max_steps {
            // per seed: (people, sums of ade, fde, min_ade, min_fde, top1_ade, top1_fde,
            // people a sample reached)
            let mut per_seed = vec![[0.0f64; 8]; n_seeds];
            let eligible = cases.iter().filter(|c| c.steps > j).count();
            for r in &results {
                for (s, acc) in per_seed.iter_mut().enumerate() {
                    if let Some(Some(e)) = r[mi][s].get(j) {
                        acc[0] += 1.0;
                        acc[1] += e.ade;
                        acc[2] += e.fde;
                        acc[3] += e.min_ade;
                        acc[4] += e.min_fde;
                        acc[5] += e.top1_ade;
                        acc[6] += e.top1_fde;
                        acc[7] += f64::from(u8::from(e.reaching > 0));
                    }
                }
            }
            let means: Vec<[f64; 8]> = per_seed
                .iter()
                .filter(|a| a[0] > 0.0)
                .map(|a| {
                    let mut m = a.map(|v| v / a[0]);
                    m[0] = a[0];
                    m
                })
                .collect();
            if means.is_empty() {
                continue;
            }
            let stat = |i: usize| mean_sd(means.iter().map(|m| m[i]));
            let people = per_seed.iter().map(|a| a[0]).sum::<f64>() / n_seeds as f64;
            let reached = per_seed.iter().map(|a| a[7]).sum::<f64>() / n_seeds as f64;
            let (ade, ade_sd) = stat(1);
            let (fde, fde_sd) = stat(2);
            let (min_ade, min_ade_sd) = stat(3);
            let (min_fde, min_fde_sd) = stat(4);
            let (top1_ade, _) = stat(5);
            let (top1_fde, _) = stat(6);
            summary.push(SummaryRow {
                method,
                horizon: (j + 1) as f64 * dt,
                people,
                ade,
                fde,
                min_ade,
                min_fde,
                ade_sd,
                fde_sd,
                min_ade_sd,
                min_fde_sd,
                top1_ade,
                top1_fde,
                reach: if eligible > 0 {
                    reached / eligible as f64
                } else {
                    0.0
                },
                seeds: n_seeds,
            });
        }
        for (case, r) in cases.iter().zip(&results) {
            for j in 0..case.steps {
                let vals: Vec<&StepErrors> = r[mi]
                    .iter()
                    .filter_map(|s| s.get(j).and_then(Option::as_ref))
                    .collect();
                if vals.is_empty() {
                    continue;
                }
                let n = vals.len() as f64;
                let avg = |f: fn(&StepErrors) -> f64| vals.iter().map(|e| f(e)).sum::<f64>() / n;
                per_person.push(PersonRow {
                    person_id: case.id,
                    window: case.window,
                    method,
                    horizon: (j + 1) as f64 * dt,
                    ade: avg(|e| e.ade),
                    fde: avg(|e| e.fde),
                    min_ade: avg(|e| e.min_ade),
                    min_fde: avg(|e| e.min_fde),
                    top1_ade: avg(|e| e.top1_ade),
                    top1_fde: avg(|e| e.top1_fde),
                    samples_reaching: vals.iter().map(|e| e.reaching as f64).sum::<f64>()
                        / n_seeds as f64,
                });
            }
        }
    }
    Ok(EvalReport {
        people_total: tracks.len(),
        people_evaluated: cases.len(),
        summary,
        per_person,
    })
}

/// Mean and population standard deviation.
fn mean_sd(v: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let n = v.clone().count() as f64;
    let mean = v.clone().sum::<f64>() / n;
    let var = v.map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
    (mean, var.sqrt())
}

/// The summary CSV header.
pub const SUMMARY_HEADER: &str = "method,horizon,people,ade,fde,min_ade,min_fde,ade_sd,fde_sd,min_ade_sd,min_fde_sd,reach,seeds,top1_ade,top1_fde";

/// The summary as CSV text (header row; horizon with one decimal).
pub fn summary_csv(rows: &[SummaryRow]) -> String {
    let mut s = String::from(SUMMARY_HEADER);
    s.push('\n');
    for r in rows {
        let _ = writeln!(
            s,
            "{},{:.1},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.4},{},{:.6},{:.6}",
            r.method,
            r.horizon,
            r.people,
            r.ade,
            r.fde,
            r.min_ade,
            r.min_fde,
            r.ade_sd,
            r.fde_sd,
            r.min_ade_sd,
            r.min_fde_sd,
            r.reach,
            r.seeds,
            r.top1_ade,
            r.top1_fde
        );
    }
    s
}

/// The per-person CSV text; with windows (any row's window above 0) a `window` column
/// follows `person_id`.
pub fn per_person_csv(rows: &[PersonRow]) -> String {
    let windows = rows.iter().any(|r| r.window > 0);
    let mut s = String::from(if windows {
        "person_id,window,method,horizon,ade,fde,min_ade,min_fde,samples_reaching,top1_ade,top1_fde\n"
    } else {
        "person_id,method,horizon,ade,fde,min_ade,min_fde,samples_reaching,top1_ade,top1_fde\n"
    });
    for r in rows {
        let _ = write!(s, "{},", r.person_id);
        if windows {
            let _ = write!(s, "{},", r.window);
        }
        let _ = writeln!(
            s,
            "{},{:.1},{:.6},{:.6},{:.6},{:.6},{},{:.6},{:.6}",
            r.method,
            r.horizon,
            r.ade,
            r.fde,
            r.min_ade,
            r.min_fde,
            r.samples_reaching,
            r.top1_ade,
            r.top1_fde
        );
    }
    s
}

/// Write `summary.csv` and `per_person.csv` into `dir` (created if missing).
pub fn write_reports(report: &EvalReport, dir: &Path) -> io::Result<()> {
    std::fs::create_dir_all(dir)?;
    std::fs::write(dir.join("summary.csv"), summary_csv(&report.summary))?;
    std::fs::write(
        dir.join("per_person.csv"),
        per_person_csv(&report.per_person),
    )?;
    Ok(())
}

/// A text table of the summary at the given horizons (rows whose horizon is within
/// 1e-6 of one of them), one line per method and horizon.
pub fn summary_table(rows: &[SummaryRow], horizons: &[f64]) -> String {
    let mut s = format!(
        "{:<7} {:>7} {:>7} {:>15} {:>15} {:>7} {:>7} {:>6}\n",
        "method", "horizon", "people", "ADE (sd)", "FDE (sd)", "minADE", "minFDE", "reach"
    );
    for r in rows
        .iter()
        .filter(|r| horizons.iter().any(|h| (h - r.horizon).abs() < 1e-6))
    {
        let _ = writeln!(
            s,
            "{:<7} {:>6.1}s {:>7.2} {:>7.3} ({:.3}) {:>7.3} ({:.3}) {:>7.3} {:>7.3} {:>5.0}%",
            r.method.name(),
            r.horizon,
            r.people,
            r.ade,
            r.ade_sd,
            r.fde,
            r.fde_sd,
            r.min_ade,
            r.min_fde,
            100.0 * r.reach
        );
    }
    s
}

/// The horizons `cliff eval` prints for a run up to `horizon` seconds at steps of `dt`:
/// 2, 4, ..., 12 s (those within the horizon), or 5 s and every 10 s beyond a horizon of
/// 12 s; and the last predicted step when it is not among them (4.8 s for THÖR-MAGNI's
/// 12 rows at 0.4 s).
///
/// ```
/// assert_eq!(cliff::eval::table_horizons(8.0, 0.4), vec![2.0, 4.0, 6.0, 8.0]);
/// assert_eq!(cliff::eval::table_horizons(30.0, 1.0), vec![5.0, 10.0, 20.0, 30.0]);
/// // (12 steps of 0.4 s: 4.8 s up to rounding)
/// assert_eq!(cliff::eval::table_horizons(4.8, 0.4), vec![2.0, 4.0, 12.0 * 0.4]);
/// ```
pub fn table_horizons(horizon: f64, dt: f64) -> Vec<f64> {
    let mut h: Vec<f64> = if horizon > 12.0 + 1e-9 {
        let mut h: Vec<f64> = (1..=(horizon / 10.0) as usize)
            .map(|i| i as f64 * 10.0)
            .collect();
        h.insert(0, 5.0);
        h
    } else {
        [2.0, 4.0, 6.0, 8.0, 10.0, 12.0]
            .into_iter()
            .filter(|h| *h <= horizon + 1e-9)
            .collect()
    };
    let last = crate::predict::steps_for(horizon, dt) as f64 * dt;
    if last > 0.0 && h.last().is_none_or(|x| *x < last - 1e-6) {
        h.push(last);
    }
    h
}
