//! Whether occupancy is calibrated: on held-out people, do the cells predicted at
//! probability p hold the person about p of the time?
//!
//! [`calibrate`] predicts every person (one seed) with every method, and at each
//! horizon computes that person's occupancy alone
//! ([`Occupancy::compute_agent`](crate::occupancy::Occupancy::compute_agent)) on a grid
//! centred on the samples' mean (the truth plays no part in where the grid lies), large
//! enough to hold every sample's kernel. Each cell is one forecast: its probability,
//! and whether the person's true position at that horizon lies in it. From these, per
//! method and horizon: a reliability table (cells binned by predicted probability:
//! mean predicted against observed frequency), the expected calibration error over the
//! cells predicted at 1 % or more, the Brier score per person (the squared errors
//! summed over the grid's cells: 0 is a certain and right forecast, 2 a certain and
//! wrong one), and the mean log-likelihood of the true position under the person's
//! predicted density ([`person_density`], floored).

use std::fmt::Write as _;

use rayon::prelude::*;

use super::EvalConfig;
use super::protocol::{Case, prepare_all};
use crate::map::MapAt;
use crate::occupancy::{GridSpec, Occupancy, Samples, Settings, person_density, spread};
use crate::predict::{Method, PredictError, TrajectoryBatch};
use crate::tracks::Track;

/// The edges of the reliability table's bins of predicted probability.
pub const BIN_EDGES: [f64; 11] = [0.0, 0.01, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.6, 1.0];

/// The least density (per square metre) the log-likelihood counts: a true position
/// the prediction puts (almost) nothing on costs ln(1e-4) = -9.2, not minus infinity.
pub const DENSITY_FLOOR: f64 = 1e-4;

/// What to check, beyond the evaluation's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationConfig {
    /// The evaluation: protocol settings, parameters, methods, options (one seed, 0).
    pub eval: EvalConfig,
    /// The occupancy kernel and stop rule.
    pub occupancy: Settings,
    /// The cells' side (m).
    pub resolution: f64,
    /// The horizons (s) checked; each rounded to the nearest step.
    pub horizons: Vec<f64>,
}

/// One bin of the reliability table.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Bin {
    /// Cells in the bin.
    pub cells: u64,
    /// Their summed predicted probability.
    pub predicted: f64,
    /// How many held the person.
    pub hits: u64,
}

impl Bin {
    /// The mean predicted probability.
    pub fn mean_predicted(&self) -> f64 {
        self.predicted / self.cells.max(1) as f64
    }

    /// The observed frequency.
    pub fn observed(&self) -> f64 {
        self.hits as f64 / self.cells.max(1) as f64
    }
}

/// Calibration of one method at one horizon.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationRow {
    /// Method.
    pub method: Method,
    /// Horizon (s).
    pub horizon: f64,
    /// People checked (a true position at the horizon and a sample there).
    pub people: usize,
    /// People with a true position at the horizon but no sample there (left out).
    pub uncovered: usize,
    /// The reliability table, one bin per [`BIN_EDGES`] interval.
    pub bins: Vec<Bin>,
    /// Mean Brier score per person (squared errors summed over the cells).
    pub brier: f64,
    /// Mean log-likelihood (ln of the density per square metre, floored at
    /// [`DENSITY_FLOOR`]) of the true positions.
    pub log_likelihood: f64,
    /// The share of people whose true position lies in the grid.
    pub in_grid: f64,
}

impl CalibrationRow {
    /// The expected calibration error over the cells predicted at 1 % or more: the
    /// cell-weighted mean of |mean predicted - observed| over those bins.
    pub fn ece(&self) -> f64 {
        let used = self
            .bins
            .iter()
            .zip(BIN_EDGES)
            .filter(|(_, lo)| *lo >= 0.01);
        let (mut n, mut e) = (0.0, 0.0);
        for (b, _) in used {
            n += b.cells as f64;
            e += b.cells as f64 * (b.mean_predicted() - b.observed()).abs();
        }
        if n > 0.0 { e / n } else { 0.0 }
    }
}

/// Per person, method and horizon: the bins, the Brier score, the log-likelihood,
/// whether the truth was in the grid; `None` when no sample reached the horizon.
type Check = Option<(Vec<Bin>, f64, f64, bool)>;

/// The largest grid side a person's check uses (m); kernels beyond are cut.
const MAX_SIDE: f64 = 60.0;

/// Check the calibration of every method of `cfg.eval` on the people of `tracks`.
pub fn calibrate<M: MapAt + Sync + ?Sized>(
    maps: &M,
    tracks: &[Track],
    cfg: &CalibrationConfig,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<CalibrationRow>, PredictError> {
    let e = &cfg.eval;
    e.params.validate()?;
    e.options.validate()?;
    let bad = |name: &'static str, why: String| PredictError::Param { name, why };
    cfg.occupancy
        .validate()
        .map_err(|x| bad("occupancy", x.to_string()))?;
    if !(cfg.resolution.is_finite() && cfg.resolution > 0.0) {
        return Err(bad(
            "resolution",
            format!("{} is not a positive number", cfg.resolution),
        ));
    }
    let dt = e.settings.dt;
    let steps: Vec<usize> = cfg
        .horizons
        .iter()
        .map(|h| (h / dt).round().max(1.0) as usize)
        .collect();
    let cases: Vec<Case> = prepare_all(tracks, &e.settings);
    // [case][method][horizon]
    let results: Vec<Vec<Vec<Check>>> = cases
        .par_iter()
        .map_init(
            || (TrajectoryBatch::new(), Occupancy::new(), Vec::new()),
            |(batch, occ, points), case| {
                let r = check_case(maps, case, cfg, &steps, batch, occ, points);
                progress();
                r
            },
        )
        .collect::<Result<_, _>>()?;
    let mut rows = Vec::new();
    for (mi, &method) in e.methods.iter().enumerate() {
        for (hi, &j) in steps.iter().enumerate() {
            let mut row = CalibrationRow {
                method,
                horizon: j as f64 * dt,
                people: 0,
                uncovered: 0,
                bins: vec![Bin::default(); BIN_EDGES.len() - 1],
                brier: 0.0,
                log_likelihood: 0.0,
                in_grid: 0.0,
            };
            for (case, r) in cases.iter().zip(&results) {
                if case.steps < j || case.truth_at(case.start.time + j as f64 * dt).is_none() {
                    continue;
                }
                let Some((bins, brier, ll, inside)) = &r[mi][hi] else {
                    row.uncovered += 1;
                    continue;
                };
                row.people += 1;
                for (t, b) in row.bins.iter_mut().zip(bins) {
                    t.cells += b.cells;
                    t.predicted += b.predicted;
                    t.hits += b.hits;
                }
                row.brier += brier;
                row.log_likelihood += ll;
                row.in_grid += f64::from(u8::from(*inside));
            }
            if row.people > 0 {
                let n = row.people as f64;
                row.brier /= n;
                row.log_likelihood /= n;
                row.in_grid /= n;
            }
            rows.push(row);
        }
    }
    Ok(rows)
}

/// Predict one person with every method and check each horizon.
fn check_case<M: MapAt + ?Sized>(
    maps: &M,
    case: &Case,
    cfg: &CalibrationConfig,
    steps: &[usize],
    batch: &mut TrajectoryBatch,
    occ: &mut Occupancy,
    points: &mut Vec<[f32; 2]>,
) -> Result<Vec<Vec<Check>>, PredictError> {
    let e = &cfg.eval;
    let dt = e.settings.dt;
    let map = maps.map_at(case.start.time);
    let history = case.history();
    let mut out = Vec::with_capacity(e.methods.len());
    for &method in &e.methods {
        e.predict_case(map, case, &history, method, 0, false, batch)?;
        let mut per_h = Vec::with_capacity(steps.len());
        for &j in steps {
            let truth = (j <= case.steps)
                .then(|| case.truth_at(case.start.time + j as f64 * dt))
                .flatten();
            per_h.push(match truth {
                Some(t) => check_horizon(batch, dt, j, [t.x, t.y], cfg, occ, points),
                None => None,
            });
        }
        out.push(per_h);
    }
    Ok(out)
}

/// One person's check at step `j` (time `j * dt`) against the true position.
fn check_horizon(
    batch: &TrajectoryBatch,
    dt: f64,
    j: usize,
    truth: [f64; 2],
    cfg: &CalibrationConfig,
    occ: &mut Occupancy,
    points: &mut Vec<[f32; 2]>,
) -> Check {
    let samples = Samples::from_batch(batch, dt).ok()?;
    let t = j as f64 * dt;
    let set = &cfg.occupancy;
    // the samples there: where the grid goes and how large it must be
    let density = person_density(&samples, 0, t, truth, set, points).ok()??;
    let n = points.len() as f64;
    let mean = points.iter().fold([0.0, 0.0], |a, p| {
        [a[0] + p[0] as f64 / n, a[1] + p[1] as f64 / n]
    });
    let far = points.iter().fold(0.0f64, |m, p| {
        m.max((p[0] as f64 - mean[0]).abs())
            .max((p[1] as f64 - mean[1]).abs())
    });
    let sigma = set.sigma(spread(points), points.len());
    let half = (far + set.truncate * sigma + cfg.resolution).min(MAX_SIDE / 2.0);
    let grid = GridSpec::around(mean, [2.0 * half, 2.0 * half], cfg.resolution);
    occ.compute_agent(&samples, 0, &grid, &[t], set).ok()?;
    let hit = grid
        .cell_of(truth[0], truth[1])
        .map(|(r, c)| r * grid.width + c);
    let mut bins = vec![Bin::default(); BIN_EDGES.len() - 1];
    let mut brier = 0.0;
    for (i, &p) in occ.layer(0).iter().enumerate() {
        let p = p as f64;
        let o = hit == Some(i);
        let b = BIN_EDGES[1..]
            .iter()
            .position(|&hi| p < hi)
            .unwrap_or(BIN_EDGES.len() - 2);
        bins[b].cells += 1;
        bins[b].predicted += p;
        bins[b].hits += u64::from(o);
        brier += (p - f64::from(u8::from(o))).powi(2);
    }
    if hit.is_none() {
        // the true position lies outside the grid: a miss the cells do not show
        brier += 1.0;
    }
    let ll = density.max(DENSITY_FLOOR).ln();
    Some((bins, brier, ll, hit.is_some()))
}

/// The calibration as a text table: per method and horizon the people, the Brier
/// score, the log-likelihood and the calibration error; then each reliability table.
pub fn calibration_table(rows: &[CalibrationRow]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<9} {:>8} {:>7} {:>9} {:>7} {:>9} {:>7}",
        "method", "horizon", "people", "uncovered", "brier", "loglik", "ece"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{:<9} {:>7.1}s {:>7} {:>9} {:>7.3} {:>9.2} {:>7.3}",
            r.method.name(),
            r.horizon,
            r.people,
            r.uncovered,
            r.brier,
            r.log_likelihood,
            r.ece()
        );
    }
    let _ = writeln!(s, "\nreliability: predicted -> observed (cells)");
    for r in rows {
        let _ = write!(s, "{:<9} {:>5.1}s", r.method.name(), r.horizon);
        for (b, lo) in r.bins.iter().zip(BIN_EDGES).skip(1) {
            if b.cells > 0 {
                let _ = write!(
                    s,
                    "  {:.3}->{:.3} ({})",
                    b.mean_predicted(),
                    b.observed(),
                    b.cells
                );
            } else {
                let _ = write!(s, "  [{lo}: none]");
            }
        }
        let _ = writeln!(s);
    }
    s
}

/// The calibration as CSV: one line per method, horizon and bin.
pub fn calibration_csv(rows: &[CalibrationRow]) -> String {
    let mut s = String::from(
        "method,horizon,people,uncovered,brier,log_likelihood,ece,bin_low,bin_high,cells,mean_predicted,observed\n",
    );
    for r in rows {
        for (i, b) in r.bins.iter().enumerate() {
            let _ = writeln!(
                s,
                "{},{},{},{},{:.6},{:.6},{:.6},{},{},{},{:.6},{:.6}",
                r.method.name(),
                r.horizon,
                r.people,
                r.uncovered,
                r.brier,
                r.log_likelihood,
                r.ece(),
                BIN_EDGES[i],
                BIN_EDGES[i + 1],
                b.cells,
                b.mean_predicted(),
                b.observed()
            );
        }
    }
    s
}
