//! Fitting a [`MotionModel`] to recorded tracks, and scoring it on held-out ones.
//!
//! Each track is cut where the tracker lost the person for longer than
//! [`MotionFit::max_gap`], and each piece is put on the model's 0.4 s grid (linear
//! between rows, so 1 Hz ATC rows serve as well as 2.5 Hz THÖR rows). Every grid point
//! with 2.8 s of history behind it starts a window: the history's displacements in the
//! walker's frame are the inputs, the positions of the next steps (as many as the piece
//! holds, up to [`MotionFit::steps`]) the targets. A step faster than
//! [`MotionFit::max_speed`] is a tracking jump: a window with one in its history is left
//! out, and its targets end before it. Each window also counts mirrored (left and right
//! swapped), so the model turns left and right alike. Per step, the coefficients solve
//! the ridge regression's normal equations over the windows that reach that step
//! (the constant is not penalised). Then, unless [`MotionFit::network`] is `None`, a
//! small network learns what the linear part leaves over ([`NetworkFit`]); the step's
//! spread is the residuals' covariance of the whole model.
//!
//! Why a network and not only the linear part: on the THÖR-MAGNI benchmark's tracklets
//! (a model fitted on a recording's first 16 minutes, scored on its last 16) the linear
//! model's expected path is 0.88 / 0.84 of constant velocity's top-1 ADE / FDE, the
//! model with the network 0.82 / 0.80: people who slow to a stop, start or turn are not
//! linear in their history. The network is small (two layers of 64 units) and written
//! here (forward and backward passes, Adam), not taken from a learning framework: its
//! inference must run without allocating, in well under a microsecond, and give the
//! same bits on every instruction path, and training it takes seconds.
//!
//! ```
//! use cliff::motion::{fit_motion_model, History, MotionFit, State};
//! use cliff::tracks::{Row, Track};
//! use glam::DVec2;
//!
//! // people walking at 1.0 to 1.5 m/s in every direction, each slowing to a stop
//! let tracks: Vec<Track> = (0..40)
//!     .map(|i| {
//!         let dir = DVec2::from_angle(i as f64 * 0.7);
//!         let v0 = 1.0 + 0.0125 * i as f64;
//!         let rows = (0..60)
//!             .map(|r| {
//!                 let t = r as f64 * 0.4;
//!                 let d = v0 * t - 0.01 * t * t; // 0.02 m/s^2 slower
//!                 Row { t, position: dir * d, speed: 0.0, angle: 0.0 }
//!             })
//!             .collect();
//!         Track { id: i, rows }
//!     })
//!     .collect();
//! let model = fit_motion_model(&tracks, &MotionFit { steps: 12, ..MotionFit::default() }).unwrap();
//! assert_eq!(model.steps(), 12);
//! ```

use nalgebra::{SMatrix, SVector};

use super::history::{HISTORY_POINTS, History, MODEL_DT};
use super::model::{FEATURES, MAX_MODEL_STEPS, ModelInfo, MotionModel, features};
use super::network::MAX_HIDDEN;
pub use super::network_fit::NetworkFit;
use super::network_fit::{Examples, train_network};
use crate::tracks::Track;
use glam::DVec2;

/// How to fit a [`MotionModel`] (see the [module documentation](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct MotionFit {
    /// Grid steps to forecast (0.4 s each; 30 is 12 s).
    pub steps: usize,
    /// Ridge penalty (m^2) on the displacement coefficients.
    pub lambda: f64,
    /// Steps faster than this (m/s) are tracking jumps.
    pub max_speed: f64,
    /// A track is cut where two rows are further apart than this (s).
    pub max_gap: f64,
    /// Fewest windows a step needs; the model ends before the first step with fewer.
    pub min_windows: usize,
    /// What the tracks are (kept in the model's file).
    pub source: String,
    /// The network that corrects the linear part, if any ([`NetworkFit`]).
    pub network: Option<NetworkFit>,
}

impl Default for MotionFit {
    /// 30 steps (12 s), lambda 1, jumps above 3 m/s, gaps over 1.5 s, 200 windows, the
    /// default network ([`NetworkFit::default`]).
    fn default() -> Self {
        Self {
            steps: 30,
            lambda: 1.0,
            max_speed: 3.0,
            max_gap: 1.5,
            min_windows: 200,
            source: String::new(),
            network: Some(NetworkFit::default()),
        }
    }
}

/// Why a model could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// A setting is unusable.
    #[error("{name}: {why}")]
    Setting {
        /// The setting.
        name: &'static str,
        /// What is wrong.
        why: String,
    },
    /// The tracks hold too few windows.
    #[error(
        "the tracks give {windows} windows of 2.8 s history and 0.4 s ahead, a fit needs at least {need}"
    )]
    TooFewWindows {
        /// Windows found.
        windows: usize,
        /// Windows needed.
        need: usize,
    },
    /// The normal equations of a step have no solution (the inputs do not vary).
    #[error("step {0}: the windows' inputs do not vary enough to fit")]
    Singular(usize),
}

impl MotionFit {
    fn validate(&self) -> Result<(), FitError> {
        let bad = |name, why: String| Err(FitError::Setting { name, why });
        if !(1..=MAX_MODEL_STEPS).contains(&self.steps) {
            return bad(
                "steps",
                format!("{} is not in 1..={MAX_MODEL_STEPS}", self.steps),
            );
        }
        if !(self.lambda.is_finite() && self.lambda >= 0.0) {
            return bad(
                "lambda",
                format!("{} is not a non-negative number", self.lambda),
            );
        }
        if !(self.max_speed.is_finite() && self.max_speed > 0.0) {
            return bad(
                "max_speed",
                format!("{} is not a positive speed", self.max_speed),
            );
        }
        if let Some(n) = &self.network {
            if !(1..=MAX_HIDDEN).contains(&n.hidden) {
                return bad(
                    "hidden",
                    format!("{} hidden units is not 1 to {MAX_HIDDEN}", n.hidden),
                );
            }
            if !(1..=MAX_EPOCHS).contains(&n.epochs) {
                return bad(
                    "epochs",
                    format!("{} passes is not 1 to {MAX_EPOCHS}", n.epochs),
                );
            }
        }
        if !(self.max_gap.is_finite() && self.max_gap >= MODEL_DT) {
            return bad(
                "max_gap",
                format!(
                    "{} s is shorter than the model's step {MODEL_DT} s",
                    self.max_gap
                ),
            );
        }
        Ok(())
    }
}

/// One window: the history, its features and the targets in the walker's frame.
struct Window<'a> {
    history: History,
    forward: DVec2,
    features: [f64; FEATURES],
    /// Offsets of the future grid points from the newest one, in the walker's frame.
    targets: &'a [DVec2],
}

/// Call `f` with every window of `tracks` (and, when `mirrored`, its mirror image).
fn each_window(tracks: &[Track], fit: &MotionFit, mirrored: bool, mut f: impl FnMut(&Window<'_>)) {
    let mut grid: Vec<DVec2> = Vec::new();
    let mut targets: Vec<DVec2> = Vec::with_capacity(fit.steps);
    let jump = fit.max_speed * MODEL_DT;
    for track in tracks {
        // the pieces the tracker followed without losing the person
        for piece in track.rows.chunk_by(|a, b| b.t - a.t <= fit.max_gap) {
            on_grid(piece, &mut grid);
            let jump_in_history = |m: usize| {
                grid[m + 1 - HISTORY_POINTS..=m]
                    .windows(2)
                    .any(|w| w[0].distance(w[1]) > jump)
            };
            for m in HISTORY_POINTS - 1..grid.len().saturating_sub(1) {
                if jump_in_history(m) {
                    continue;
                }
                let mut points = [DVec2::ZERO; HISTORY_POINTS];
                points.copy_from_slice(&grid[m + 1 - HISTORY_POINTS..=m]);
                let history = History::from_grid(points);
                let (forward, features) = features(&history);
                let left = forward.perp();
                targets.clear();
                for j in 1..=fit.steps {
                    let Some(&p) = grid.get(m + j) else { break };
                    if p.distance(grid[m + j - 1]) > jump {
                        break;
                    }
                    let d = p - grid[m];
                    targets.push(DVec2::new(d.dot(forward), d.dot(left)));
                }
                if targets.is_empty() {
                    continue;
                }
                f(&Window {
                    history,
                    forward,
                    features,
                    targets: &targets,
                });
                if mirrored {
                    let mut mf = features;
                    for i in 0..HISTORY_POINTS - 1 {
                        mf[2 * i + 1] = -mf[2 * i + 1];
                    }
                    for t in targets.iter_mut() {
                        t.y = -t.y;
                    }
                    f(&Window {
                        history,
                        forward,
                        features: mf,
                        targets: &targets,
                    });
                }
            }
        }
    }
}

/// The rows' positions on the model's grid from the first row's time (linear between
/// rows) into `out`.
fn on_grid(rows: &[crate::tracks::Row], out: &mut Vec<DVec2>) {
    out.clear();
    let Some(first) = rows.first() else { return };
    let end = rows[rows.len() - 1].t;
    let mut j = 0;
    for m in 0.. {
        let t = first.t + m as f64 * MODEL_DT;
        if t > end + 1e-9 {
            break;
        }
        while j + 1 < rows.len() && rows[j + 1].t < t {
            j += 1;
        }
        let p = if j + 1 < rows.len() {
            let (a, b) = (&rows[j], &rows[j + 1]);
            a.position
                .lerp(b.position, ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0))
        } else {
            rows[j].position
        };
        out.push(p);
    }
}

type Gram = SMatrix<f64, FEATURES, FEATURES>;
type Rhs = SMatrix<f64, FEATURES, 2>;

/// Fit a motion model to `tracks` (see the [module documentation](self)).
pub fn fit_motion_model(tracks: &[Track], fit: &MotionFit) -> Result<MotionModel, FitError> {
    fit_motion_model_sources(&[tracks], fit)
}

/// Sums over one source's windows.
struct Sums {
    /// The Gram matrix of the windows that reach exactly `n` steps.
    gram_by_reach: Vec<Gram>,
    /// The right-hand sides per step.
    rhs: Vec<Rhs>,
    /// Windows (mirror images counted) per step.
    count: Vec<usize>,
}

fn sums(tracks: &[Track], fit: &MotionFit) -> Sums {
    let mut s = Sums {
        gram_by_reach: vec![Gram::zeros(); fit.steps + 1],
        rhs: vec![Rhs::zeros(); fit.steps],
        count: vec![0usize; fit.steps],
    };
    each_window(tracks, fit, true, |w| {
        let x = SVector::<f64, FEATURES>::from(w.features);
        s.gram_by_reach[w.targets.len()] += x * x.transpose();
        for (j, t) in w.targets.iter().enumerate() {
            s.rhs[j].column_mut(0).axpy(t.x, &x, 1.0);
            s.rhs[j].column_mut(1).axpy(t.y, &x, 1.0);
            s.count[j] += 1;
        }
    });
    s
}

/// Fit a motion model to several sources of tracks (recordings of different sites or
/// trackers), each weighing the same however many windows it holds: a day of a
/// shopping mall at 1 Hz does not drown a room at 2.5 Hz. Each source's windows weigh
/// `N / (S n_s)` (`N` windows in all, `S` sources, `n_s` in this one), so the penalty
/// acts as it would on `N` windows of one source.
pub fn fit_motion_model_sources(
    sources: &[&[Track]],
    fit: &MotionFit,
) -> Result<MotionModel, FitError> {
    fit.validate()?;
    let per_source: Vec<Sums> = sources.iter().map(|t| sums(t, fit)).collect();
    let total: usize = per_source.iter().map(|s| s.count[0]).sum();
    let used = per_source.iter().filter(|s| s.count[0] > 0).count().max(1);
    let weight = |s: &Sums| {
        if s.count[0] == 0 {
            0.0
        } else {
            total as f64 / (used * s.count[0]) as f64
        }
    };
    let mut gram_by_reach = vec![Gram::zeros(); fit.steps + 1];
    let mut rhs = vec![Rhs::zeros(); fit.steps];
    let mut count = vec![0usize; fit.steps];
    for s in &per_source {
        let w = weight(s);
        for (g, sg) in gram_by_reach.iter_mut().zip(&s.gram_by_reach) {
            *g += sg * w;
        }
        for (r, sr) in rhs.iter_mut().zip(&s.rhs) {
            *r += sr * w;
        }
        for (c, sc) in count.iter_mut().zip(&s.count) {
            *c += sc;
        }
    }
    let windows = (count[0] / 2) as u64; // each window counted with its mirror image
    let need = fit.min_windows.max(2 * FEATURES);
    let steps = count.iter().take_while(|&&c| c / 2 >= need).count();
    if steps == 0 {
        return Err(FitError::TooFewWindows {
            windows: count[0] / 2,
            need,
        });
    }
    let mut penalty = Gram::identity() * fit.lambda;
    penalty[(FEATURES - 1, FEATURES - 1)] = 0.0;
    let mut gram = Gram::zeros();
    let mut reaching = vec![Gram::zeros(); steps];
    for n in (1..=fit.steps).rev() {
        gram += gram_by_reach[n];
        if n <= steps {
            reaching[n - 1] = gram;
        }
    }
    let mut weights = Vec::with_capacity(steps);
    for j in 0..steps {
        let chol = (reaching[j] + penalty)
            .cholesky()
            .ok_or(FitError::Singular(j + 1))?;
        let w = chol.solve(&rhs[j]);
        let mut wj = [[0.0; FEATURES]; 2];
        for (c, out) in wj.iter_mut().enumerate() {
            for (i, v) in out.iter_mut().enumerate() {
                *v = w[(i, c)];
            }
        }
        weights.push(wj);
    }
    let info = ModelInfo {
        windows,
        lambda: fit.lambda,
        max_speed: fit.max_speed,
        source: fit.source.clone(),
    };
    let invalid = |e: super::model::ModelValueError| FitError::Setting {
        name: "fit",
        why: e.to_string(),
    };
    let zero = vec![[0.0; 3]; steps];
    let mut model = MotionModel::new(weights.clone(), zero, info.clone()).map_err(invalid)?;
    if let Some(net) = &fit.network {
        let examples = network_examples(sources, &per_source, &model, fit, total, &weight);
        let network = train_network(&examples, 2 * steps, net);
        model = model.with_network(network).map_err(invalid)?;
    }
    // the residuals' covariance per step, each source's windows weighed as in the fit
    let mut residuals = vec![[0.0f64; 3]; steps];
    let mut weights_at = vec![0.0f64; steps];
    let mut mean = vec![DVec2::ZERO; steps];
    for (tracks, s) in sources.iter().zip(&per_source) {
        let w = weight(s);
        each_window(tracks, fit, true, |win| {
            model.local_means(&win.features, &mut mean);
            for (j, t) in win.targets.iter().take(steps).enumerate() {
                let (rx, ry) = (t.x - mean[j].x, t.y - mean[j].y);
                residuals[j][0] += w * rx * rx;
                residuals[j][1] += w * rx * ry;
                residuals[j][2] += w * ry * ry;
                weights_at[j] += w;
            }
        });
    }
    let covariance = residuals
        .iter()
        .zip(&weights_at)
        .map(|(s, &n)| s.map(|v| v / n))
        .collect();
    let fitted = MotionModel::new(weights, covariance, info).map_err(invalid)?;
    match model.network() {
        Some(net) => fitted.with_network(net.clone()).map_err(invalid),
        None => Ok(fitted),
    }
}

/// Most windows (mirror images counted) the network learns from; with more, every n-th
/// is taken.
pub const MAX_NETWORK_WINDOWS: usize = 300_000;
/// Most passes over the windows a network's fit may make.
pub const MAX_EPOCHS: usize = 1000;

/// The windows the network learns from: the linear `model`'s residuals, each window
/// weighed as its source is in the fit, at most [`MAX_NETWORK_WINDOWS`].
fn network_examples(
    sources: &[&[Track]],
    per_source: &[Sums],
    model: &MotionModel,
    fit: &MotionFit,
    total: usize,
    weight: &dyn Fn(&Sums) -> f64,
) -> Examples {
    let steps = model.steps();
    let every = total.div_ceil(MAX_NETWORK_WINDOWS).max(1);
    let mut ex = Examples::default();
    let mut mean = vec![DVec2::ZERO; steps];
    let mut seen = 0usize;
    for (tracks, s) in sources.iter().zip(per_source) {
        let w = weight(s);
        each_window(tracks, fit, true, |win| {
            seen += 1;
            if !(seen - 1).is_multiple_of(every) {
                return;
            }
            model.local_means(&win.features, &mut mean);
            let reach = win.targets.len().min(steps);
            ex.features.push(win.features);
            for (j, m) in mean.iter().enumerate() {
                let r = win.targets.get(j).map_or(DVec2::ZERO, |t| *t - *m);
                ex.targets.extend([r.x, r.y]);
            }
            ex.reach.push(reach);
            ex.weight.push(w);
        });
    }
    ex
}

/// Errors of a model and of constant velocity over the same windows, at one horizon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HorizonErrors {
    /// Horizon (s).
    pub horizon: f64,
    /// Windows with ground truth that far.
    pub windows: usize,
    /// The model's expected path: mean error over the steps up to the horizon (m).
    pub ade: f64,
    /// The model's expected path: mean error at the horizon (m).
    pub fde: f64,
    /// Constant velocity of the last displacement: ADE (m).
    pub cvm_ade: f64,
    /// Constant velocity of the last displacement: FDE (m).
    pub cvm_fde: f64,
}

/// The errors of `model`'s expected path on the windows of `tracks` (cut as the fit
/// cuts them, not mirrored), beside constant velocity of the last displacement, at
/// each of `horizons` (seconds, rounded to the grid): every window with ground truth
/// to the horizon counts.
pub fn motion_model_errors(
    model: &MotionModel,
    tracks: &[Track],
    fit: &MotionFit,
    horizons: &[f64],
) -> Vec<HorizonErrors> {
    let fit = MotionFit {
        steps: horizons
            .iter()
            .map(|h| (h / MODEL_DT).round() as usize)
            .max()
            .unwrap_or(1)
            .clamp(1, MAX_MODEL_STEPS),
        ..fit.clone()
    };
    let mut out: Vec<HorizonErrors> = horizons
        .iter()
        .map(|&h| HorizonErrors {
            horizon: h,
            windows: 0,
            ade: 0.0,
            fde: 0.0,
            cvm_ade: 0.0,
            cvm_fde: 0.0,
        })
        .collect();
    each_window(tracks, &fit, false, |w| {
        let forecast = model.forecast(&w.history);
        let (origin, left) = (w.history.last(), w.forward.perp());
        let last = DVec2::new(
            w.features[2 * (HISTORY_POINTS - 2)],
            w.features[2 * (HISTORY_POINTS - 2) + 1],
        );
        for h in out.iter_mut() {
            let n = (h.horizon / MODEL_DT).round() as usize;
            if n == 0 || w.targets.len() < n {
                continue;
            }
            let (mut sum, mut cv_sum, mut fde, mut cv_fde) = (0.0, 0.0, 0.0, 0.0);
            for (j, t) in w.targets[..n].iter().enumerate() {
                let d = forecast.position((j + 1) as f64 * MODEL_DT, DVec2::ZERO) - origin;
                let e = DVec2::new(d.dot(w.forward), d.dot(left)).distance(*t);
                let cv = (last * (j + 1) as f64).distance(*t);
                sum += e;
                cv_sum += cv;
                (fde, cv_fde) = (e, cv);
            }
            h.windows += 1;
            h.ade += sum / n as f64;
            h.fde += fde;
            h.cvm_ade += cv_sum / n as f64;
            h.cvm_fde += cv_fde;
        }
    });
    for h in &mut out {
        let n = h.windows.max(1) as f64;
        h.ade /= n;
        h.fde /= n;
        h.cvm_ade /= n;
        h.cvm_fde /= n;
    }
    out
}
