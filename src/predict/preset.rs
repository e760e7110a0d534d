//! Methods that are a configuration of CLiFF-LHMP: where [`Method::Improved`] becomes
//! CLiFF-LHMP parameters and [`Options`].
//!
//! [`resolve`] is the one place a preset is applied: [`Rollout`](super::Rollout) (and so
//! [`predict`](super::predict), [`predict_into`](super::predict_into),
//! [`predict_with`](super::predict_with) and the daemon's chunks) resolves the
//! parameters and options it is given, and never sees a preset method afterwards.
//!
//! ```
//! use cliff::predict::{Method, Options, Params, preset};
//!
//! let params = Params { method: Method::Improved, k: 30, beta: 5.0, ..Params::default() };
//! let (p, o) = preset::resolve(&params, &Options::default());
//! assert_eq!(p.method, Method::Cliff);
//! assert_eq!((p.k, p.beta), (30, preset::IMPROVED.beta)); // the caller's k, the preset's beta
//! assert!(o.scores);
//! ```

use super::{Method, Options, Params, Rank};

/// What a preset method sets; everything else (`k`, `dt`, `horizon`, `radius`, `seed`,
/// the heading rule, and [`Options::coast`]) is the caller's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Preset {
    /// Kernel parameter [`Params::beta`].
    pub beta: f64,
    /// The options beyond the paper; they replace the caller's, except
    /// [`Options::coast`], which stays the caller's (a planner that needs every sample
    /// to reach the horizon sets it to the horizon).
    pub options: Options,
}

/// The `improved` method ([`Method::Improved`]): CLiFF-LHMP with a heading kernel of
/// beta 2 (turning towards sampled directions more reluctantly than the paper's 1) and
///
/// * **follow 4** ([`Options::follow`]): the component drawn at each step is weighed by
///   how well it agrees with the walker's heading, so samples keep to the flows going
///   their way;
/// * **2 candidates** ([`Options::candidates`]), **pruned and resampled**
///   ([`Options::prune`], [`PRUNE_SCHEDULE`](super::PRUNE_SCHEDULE)): `2 k` samples are
///   drawn; at a fifth of the horizon the best `k / 2` of them go on, those that would
///   reach furthest following the map's likeliest flow and then the most likely under
///   the map, each twice (itself and a copy that draws from a generator of its own);
///   at half and at eight tenths of the horizon again the best half by the steps
///   reached and then the likelihood, each twice. So the samples choose among
///   candidates three times, and the candidates roll 1.2 times the paper's samples'
///   steps; pairs of samples share their path up to the last checkpoint;
/// * **the speed prior** ([`Options::speed_prior`]): the speed regresses to the
///   typical speed of the map's walkers ([`SpeedPrior`](crate::motion::SpeedPrior),
///   which `cliff map build` learns from its tracks; a map without one keeps the
///   observed speed);
/// * **trust 0.5 s** ([`Options::trust`]): the map's pull on the heading and the speed
///   prior's on the speed grow as `1 - exp(-t / 0.5 s)`, so the first step is the
///   observed motion's;
/// * **blend 3 s** ([`Options::blend`]): the positions leave the constant-velocity line
///   with weight `exp(-(t - dt) / 3 s)` on it: near the present the prediction is
///   constant velocity's, from about 10 s on the map's samples alone;
/// * **the motion model under the map** ([`Options::motion`]): the samples start from
///   the learned motion model ([`MotionModel`](crate::motion::MotionModel), the built-in
///   one unless the rollout is given another) and the map bends them by the evidence it
///   has for this person, a share growing with the horizon; a sample the map stops
///   stands where it stopped, so every sample reaches the horizon, and where no map
///   location is near the person the samples are the motion model's. The first sample
///   is the samples' mean path;
/// * **scores ranked by consensus** ([`Options::scores`], [`Rank::Consensus`]): the
///   best-ranked sample ([`TrajectoryBatch::best_sample`](super::TrajectoryBatch::best_sample))
///   is the most central of those that reach furthest, the single prediction to keep.
///
/// On held-out people (maps and motion models from training data only, every person
/// counted; docs/accuracy.md) its mean ADE and FDE stay within 1 % of the motion
/// model's alone near the present on THÖR1, THÖR3 and THÖR-MAGNI, with the right map
/// and a wrong one; on the THÖR-MAGNI benchmark's tracklets its best-ranked sample is
/// 0.80 / 0.74 of the last displacement's constant velocity (ADE / FDE) with the right
/// map; on ATC's dev hours its mean ADE is 22 % below the paper's at 5 s and more than
/// 40 % at 20 and 50 s. Its content is set by
/// the project's held-out experiments and may change between versions; `cliff` (the
/// paper's method) stays as it is.
pub const IMPROVED: Preset = Preset {
    beta: 2.0,
    options: Options {
        speed_beta: 0.0,
        coast: 0.0,
        scores: true,
        follow: 4.0,
        candidates: 2,
        prune: true,
        speed_prior: true,
        trust: 0.5,
        blend: 3.0,
        rank: Rank::Consensus,
        motion: true,
    },
};

/// How many times the paper's work a call of `params` with `options` does, at most
/// ([`Options::cost_factor`] of the preset's options for [`Method::Improved`]: 3): what
/// a daemon's cost limits count.
pub fn cost_factor(params: &Params, options: &Options) -> usize {
    resolve(params, options).1.cost_factor()
}

/// The CLiFF-LHMP parameters and options that `params` and `options` stand for: a
/// preset method ([`Method::Improved`]) becomes [`Method::Cliff`] with the preset's
/// settings; any other method is returned as it is.
pub fn resolve(params: &Params, options: &Options) -> (Params, Options) {
    match params.method {
        Method::Improved => (
            Params {
                method: Method::Cliff,
                beta: IMPROVED.beta,
                ..*params
            },
            Options {
                coast: options.coast,
                ..IMPROVED.options
            },
        ),
        Method::Cliff | Method::Cvm | Method::Motion | Method::CvmLast => (*params, *options),
    }
}
