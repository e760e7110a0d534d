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
/// * **4 candidates** ([`Options::candidates`]), **pruned** ([`Options::prune`]): the
///   `k` samples kept are the best of `4 k` drawn, those that reach furthest and then
///   the most likely under the map; the candidates are cut to `2 k` at a fifth of the
///   horizon, ranked by how far they would reach following the map's likeliest flow,
///   and to `k` at seven tenths ([`PRUNE_SCHEDULE`](super::PRUNE_SCHEDULE)), so they
///   roll 2.1 times the paper's samples' steps instead of 4 times;
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
/// * **scores ranked by consensus** ([`Options::scores`], [`Rank::Consensus`]): the
///   best-ranked sample ([`TrajectoryBatch::best_sample`](super::TrajectoryBatch::best_sample))
///   is the most central of those that reach furthest, the single prediction to keep.
///
/// On held-out people (maps from training data only, 10 seeds, paired over the same
/// people or windows; docs/accuracy.md) its mean ADE and FDE are no higher than constant
/// velocity's at any horizon on THÖR3, THÖR-MAGNI and ATC, and on THÖR1 but at its last
/// horizons (FDE 1 % above constant velocity's at 11-12 s, a handful of people), and on
/// ATC's dev hours 14 % below the paper's at 5 s, 17 % at 20 s and 12 % at 50 s. Its content is set by
/// the project's held-out experiments and may change between versions; `cliff` (the
/// paper's method) stays as it is.
pub const IMPROVED: Preset = Preset {
    beta: 2.0,
    options: Options {
        speed_beta: 0.0,
        coast: 0.0,
        scores: true,
        follow: 4.0,
        candidates: 4,
        prune: true,
        speed_prior: true,
        trust: 0.5,
        blend: 3.0,
        rank: Rank::Consensus,
    },
};

/// How many times the paper's work a call of `params` with `options` does, at most
/// ([`Options::cost_factor`] of the preset's options for [`Method::Improved`]: 6): what
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
        Method::Cliff | Method::Cvm => (*params, *options),
    }
}
