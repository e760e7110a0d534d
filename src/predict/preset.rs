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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::CliffMap;
    use crate::motion::State;
    use crate::predict::{Rollout, TrajectoryBatch, predict, predict_with};
    use glam::DVec2;

    #[test]
    fn improved_predicts_as_cliff_with_the_preset() {
        let map = CliffMap::demo();
        let agents = [
            State {
                position: DVec2::new(-10.0, 0.5),
                speed: 1.2,
                heading: 0.0,
                time: 0.0,
            },
            State {
                position: DVec2::new(0.5, -6.0),
                speed: 1.0,
                heading: 1.5,
                time: 0.0,
            },
        ];
        let asked = Params {
            method: Method::Improved,
            k: 7,
            seed: 5,
            beta: 0.3,
            ..Params::default()
        };
        let (p, o) = resolve(&asked, &Options::default());
        assert_eq!(
            p,
            Params {
                method: Method::Cliff,
                beta: IMPROVED.beta,
                ..asked
            }
        );
        assert_eq!(o, IMPROVED.options);
        let mut direct = TrajectoryBatch::new();
        predict_with(&map, &agents, &p, &o, &mut direct).unwrap();
        // predict_with resolves: the same samples and scores
        let mut improved = TrajectoryBatch::new();
        predict_with(&map, &agents, &asked, &Options::default(), &mut improved).unwrap();
        assert_eq!(direct, improved);
        assert_eq!(improved.scores().len(), 14);
        // predict resolves too, but has nowhere to put scores
        let mut plain = TrajectoryBatch::new();
        predict(&map, &agents, &asked, &mut plain).unwrap();
        assert_eq!(plain.positions(), direct.positions());
        assert!(plain.scores().is_empty());
        // and the paper's method with the caller's beta is another prediction
        predict(
            &map,
            &agents,
            &Params {
                method: Method::Cliff,
                ..asked
            },
            &mut plain,
        )
        .unwrap();
        assert_ne!(plain.positions(), direct.positions());
        // a rollout resolves, whatever options it is given afterwards
        let r = Rollout::new(&asked)
            .unwrap()
            .with_options(Options {
                coast: 3.0,
                ..Options::default()
            })
            .unwrap();
        assert_eq!((r.params(), r.options()), (&p, &o));
        let mut b = TrajectoryBatch::new();
        b.reshape(2, 7, p.steps());
        let mut scores = vec![0.0f32; 14];
        let mut r = r;
        r.predict_agents(&map, &agents, b.as_mut(), Some(&mut scores))
            .unwrap();
        assert_eq!(b.positions(), direct.positions());
        assert_eq!(&scores[..], direct.scores());
    }

    #[test]
    fn other_methods_are_left_alone() {
        let o = Options {
            speed_beta: 1.0,
            coast: 2.0,
            follow: 1.0,
            ..Options::default()
        };
        for method in [Method::Cliff, Method::Cvm] {
            let p = Params {
                method,
                beta: 0.7,
                ..Params::default()
            };
            assert_eq!(resolve(&p, &o), (p, o));
        }
    }
}
