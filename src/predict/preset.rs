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

use super::{Method, Options, Params};

/// What a preset method sets; everything else (`k`, `dt`, `horizon`, `radius`, `seed`,
/// the heading rule) is the caller's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Preset {
    /// Kernel parameter [`Params::beta`].
    pub beta: f64,
    /// The options beyond the paper ([`Options::speed_beta`], [`Options::coast`],
    /// [`Options::scores`]); they replace the caller's.
    pub options: Options,
}

/// The `improved` method ([`Method::Improved`]): CLiFF-LHMP with a heading kernel of
/// beta 2 (turning towards sampled directions more reluctantly than the paper's 1) and
///
/// * **follow 4** ([`Options::follow`]): the component drawn at each step is weighed by
///   how well it agrees with the walker's heading, so samples keep to the flows going
///   their way;
/// * **5 candidates** ([`Options::candidates`]): the `k` samples kept are the best of
///   `5 k` drawn, those that reach furthest and then the most likely under the map
///   (five times the paper's work);
/// * **the speed prior** ([`Options::speed_prior`]): the start speed regresses to the
///   typical speed of the map's walkers ([`SpeedPrior`](crate::motion::SpeedPrior),
///   which `cliff map build` learns from its tracks; a map without one keeps the
///   observed speed);
/// * **scores** ([`Options::scores`]): callers that keep one prediction take the most
///   likely sample ([`TrajectoryBatch::best_sample`](super::TrajectoryBatch::best_sample)).
///
/// On ATC's held-out hours (atc/dev, map from atc/train, 10 seeds, the same people) its
/// mean ADE is 16 % below the paper's at 5 s, 27 % at 20 s and 13 % at 50 s (README,
/// "Beyond the paper"). Its content is set by the project's held-out experiments and may
/// change between versions; `cliff` (the paper's method) stays as it is.
pub const IMPROVED: Preset = Preset {
    beta: 2.0,
    options: Options {
        speed_beta: 0.0,
        coast: 0.0,
        scores: true,
        follow: 4.0,
        candidates: 5,
        speed_prior: true,
    },
};

/// How many times the paper's work a call of `params` with `options` does, at most
/// ([`Options::cost_factor`] of the preset's options for [`Method::Improved`]: 10): what
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
            IMPROVED.options,
        ),
        Method::Cliff | Method::Cvm => (*params, *options),
    }
}
