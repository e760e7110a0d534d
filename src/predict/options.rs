//! Options beyond the paper's method: speed from the map, coasting where the map has no
//! data, and a score per sample. All are off by default; with [`Options::default`]
//! [`predict_with`] is [`predict`](super::predict), byte for byte.
//!
//! * **Speed kernel** ([`Options::speed_beta`] > 0): at each step the speed is drawn
//!   with the direction (from the chosen component's bivariate normal, the speed given
//!   the drawn direction; its noise a sum of four uniforms, see
//!   [`CliffMap::velocity_at`]) and the current speed `v` moves towards the drawn speed `r` as
//!   the heading does towards the drawn direction:
//!   `v <- v + lambda * (r - v)`, `lambda = exp(-speed_beta * (r - v)^2)` (m/s; `lambda`
//!   in single precision). The paper keeps the observed speed.
//! * **Coasting** ([`Options::coast`] > 0 seconds): a sample that reaches a position with
//!   no map location near does not stop there (the paper's rule) but goes on at constant
//!   velocity for up to `floor(coast / dt)` positions; back near a location it samples
//!   the map again (and may coast again later). A start with no location near coasts too.
//! * **Scores** ([`Options::scores`]): every sample gets the log-likelihood of its
//!   rollout under the map, summed over the `steps` of the horizon. A step taken from a
//!   map location adds the log-density of the step's velocity (the heading and speed after
//!   the update) under that location's mixture, approximated by its likeliest component
//!   ([`CliffMap::step_log_density`]: at most `ln(3 x components)` below
//!   [`CliffMap::log_density`], equal where one component explains the step; on real
//!   predictions the median step is within 0.04 of it and the scores order 99 % of the
//!   pairs of samples alike); any other
//!   step (coasting, after the sample ended, or every step of constant velocity far from
//!   the map) adds [`NO_LOCATION_LOG_DENSITY`], the log-density of a uniform velocity
//!   over all headings and speeds of 0 to 2 m/s. Scores compare samples of the same
//!   call; [`TrajectoryBatch::best_sample`] picks the most likely.
//!
//! * **Follow** ([`Options::follow`] > 0): at each step the component is chosen by its
//!   weight times a von Mises likelihood of the walker's heading,
//!   `w_j exp(-follow (1 - cos(heading - mu_j)))` ([`CliffMap::direction_following`]):
//!   a walker keeps to the flows going its way instead of jumping to a crossing one.
//! * **Candidates** ([`Options::candidates`] > 1): each agent's samples are the best
//!   `k` of `candidates x k` drawn ones: those that reach furthest (the paper's rule
//!   stops a sample where the map has no data), then the highest-scored. Costs
//!   `candidates` times the work (with follow, twice that: [`Options::cost_factor`]).
//! * **Speed prior** ([`Options::speed_prior`]): the start speed regresses to the
//!   typical speed of the map's walkers with the map's
//!   [`SpeedPrior`](crate::motion::SpeedPrior) (`cliff map build` learns one; a map
//!   without one leaves the speed as observed).
//!
//! The draws: with the speed kernel, each live sample's draw takes one uniform and two
//! normals (direction, then speed) instead of one uniform and one normal; coasting
//! samples draw nothing. Scores draw nothing.
//!
//! ```
//! use cliff::map::CliffMap;
//! use cliff::motion::State;
//! use cliff::predict::{predict_with, Options, Params, TrajectoryBatch};
//! use glam::DVec2;
//!
//! let map = CliffMap::demo();
//! let walker = State { position: DVec2::new(-10.0, 0.5), speed: 1.2, heading: 0.0, time: 0.0 };
//! let opts = Options { speed_beta: 2.0, coast: 4.0, scores: true, ..Options::default() };
//! let mut batch = TrajectoryBatch::new();
//! predict_with(&map, &[walker], &Params::default(), &opts, &mut batch).unwrap();
//! let best = batch.best_sample(0).unwrap();
//! assert!(batch.scores().iter().all(|s| *s <= batch.score(0, best).unwrap()));
//! ```

use super::{BatchMut, Params, PredictError, Rollout, TrajectoryBatch};
use crate::map::CliffMap;
use crate::motion::State;

/// Log-density of a step without a map location in a sample's score: a uniform
/// velocity over headings `[0, 2pi)` and speeds `[0, 2]` m/s, `-ln(4 pi)`.
pub const NO_LOCATION_LOG_DENSITY: f64 = -2.531_024_246_969_290_7;

/// Options beyond the paper's method (see the [module documentation](self)).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Options {
    /// Speed kernel parameter (per (m/s)^2); 0 keeps the observed speed (the paper).
    pub speed_beta: f64,
    /// Seconds a sample goes on at constant velocity where the map has no location near;
    /// 0 stops it there (the paper).
    pub coast: f64,
    /// Compute a score per sample ([`TrajectoryBatch::scores`]).
    pub scores: bool,
    /// Concentration of the heading likelihood that weighs the components at each
    /// step (0: by weight alone, the paper; at most [`MAX_FOLLOW`]).
    pub follow: f64,
    /// Keep the best `k` of `candidates x k` samples per agent (0 or 1: draw `k`, the
    /// paper; at most [`MAX_CANDIDATES`]).
    pub candidates: u32,
    /// Start from the speed the map's speed prior gives for the observed one.
    pub speed_prior: bool,
}

/// Largest [`Options::follow`]: beyond it a heading's likelihood under a component
/// 180 degrees away underflows towards zero and nothing changes.
pub const MAX_FOLLOW: f64 = 100.0;

/// Largest [`Options::candidates`].
pub const MAX_CANDIDATES: u32 = 16;

impl Options {
    /// True when every option is off: the paper's method.
    pub fn is_paper(&self) -> bool {
        self.speed_beta == 0.0
            && self.coast == 0.0
            && !self.scores
            && self.follow == 0.0
            && self.candidates <= 1
            && !self.speed_prior
    }

    /// How many times the paper's work a call with these options does, at most: the
    /// samples drawn per kept sample ([`Options::candidates`], at least 1), times 2 with
    /// follow on. What a daemon's cost limits and its scheduler count.
    ///
    /// Measured per predicted position on the benchmark people (`cargo bench --bench
    /// options_cost`, BENCHMARKS.md): scores, the speed kernel and coasting each cost
    /// under 1.3 times the paper's step, follow about 1.6 times; all of them together
    /// 1.7 times, `improved` (5 candidates, follow, scores) 9.4-9.5 times per kept
    /// position.
    ///
    /// ```
    /// use cliff::predict::Options;
    /// assert_eq!(Options::default().cost_factor(), 1);
    /// assert_eq!(Options { scores: true, speed_beta: 1.0, ..Options::default() }.cost_factor(), 1);
    /// assert_eq!(Options { follow: 4.0, candidates: 5, ..Options::default() }.cost_factor(), 10);
    /// ```
    pub fn cost_factor(&self) -> usize {
        let follow = if self.follow > 0.0 { 2 } else { 1 };
        self.candidates.max(1) as usize * follow
    }

    /// Check the options; the error names the first unusable one.
    pub fn validate(&self) -> Result<(), PredictError> {
        if !(self.speed_beta.is_finite() && self.speed_beta >= 0.0) {
            return Err(PredictError::Param {
                name: "speed_beta",
                why: format!("{} is not a non-negative number", self.speed_beta),
            });
        }
        if !(self.coast.is_finite() && self.coast >= 0.0) {
            return Err(PredictError::Param {
                name: "coast",
                why: format!("{} is not a non-negative number of seconds", self.coast),
            });
        }
        if !(self.follow.is_finite() && (0.0..=MAX_FOLLOW).contains(&self.follow)) {
            return Err(PredictError::Param {
                name: "follow",
                why: format!("{} is not a number in [0, {MAX_FOLLOW}]", self.follow),
            });
        }
        if self.candidates > MAX_CANDIDATES {
            return Err(PredictError::Param {
                name: "candidates",
                why: format!(
                    "{} candidates per sample, at most {MAX_CANDIDATES}",
                    self.candidates
                ),
            });
        }
        Ok(())
    }

    /// Positions a sample may coast off the map at time step `dt`.
    pub(super) fn coast_steps(&self, dt: f64) -> u32 {
        (self.coast / dt + 1e-9).floor().min(u32::MAX as f64) as u32
    }
}

/// [`predict`](super::predict) with [`Options`]: scores, when asked (by the options or a
/// preset method), go to [`TrajectoryBatch::scores`].
pub fn predict_with(
    map: &CliffMap,
    agents: &[State],
    params: &Params,
    options: &Options,
    out: &mut TrajectoryBatch,
) -> Result<(), PredictError> {
    let mut rollout = Rollout::new(params)?.with_options(*options)?;
    let scored = rollout.options().scores;
    out.try_reshape(agents.len(), params.k, params.steps())?;
    out.try_size_scores(scored)?;
    let (batch, scores) = out.parts_mut();
    rollout.predict_agents(map, agents, batch, scored.then_some(scores))
}

/// [`predict_into`](super::predict_into) with [`Options`]; `scores` holds one score per
/// sample (`agents x k`), or is empty for none. Scores are computed when the options
/// ask for them ([`Options::scores`], or a preset method's) and `scores` is not empty;
/// a non-empty `scores` without scores asked for is filled with NaN. [`Options::scores`]
/// with an empty `scores` is an error.
pub fn predict_into_with(
    map: &CliffMap,
    agents: &[State],
    params: &Params,
    options: &Options,
    out: BatchMut<'_>,
    scores: &mut [f32],
) -> Result<(), PredictError> {
    let buffer = (options.scores || !scores.is_empty()).then_some(scores);
    Rollout::new(params)?
        .with_options(*options)?
        .predict_agents(map, agents, out, buffer)
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use glam::DVec2;
    use rand::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;

    use super::*;
    use crate::map::{Component, Location};
    use crate::predict::predict;
    use crate::predict::{HeadingRule, Method};

    fn walker(x: f64, y: f64, heading: f64, speed: f64) -> State {
        State {
            position: DVec2::new(x, y),
            speed,
            heading,
            time: 0.0,
        }
    }

    /// Locations on a 1 m grid over x in [x0, x1], y in [-3, 3], all saying "theta at rho".
    fn flow(x0: i32, x1: i32, theta: f64, rho: f64) -> CliffMap {
        let mut locs = vec![];
        for ix in x0..=x1 {
            for iy in -3..=3 {
                locs.push(Location {
                    position: DVec2::new(ix as f64, iy as f64),
                    components: vec![Component {
                        theta,
                        rho,
                        cov: [0.01, 0.0, 0.0, 0.01],
                        weight: 1.0,
                    }],
                    motion_ratio: 1.0,
                    observation_ratio: 1.0,
                });
            }
        }
        CliffMap::new(locs).unwrap()
    }

    fn bits(b: &TrajectoryBatch) -> Vec<u32> {
        b.positions()
            .iter()
            .flatten()
            .map(|v| v.to_bits())
            .collect()
    }

    #[test]
    fn scores_alone_leave_the_samples_byte_identical() {
        let map = CliffMap::demo();
        let agents = [
            walker(-10.0, 0.5, 0.0, 1.2),
            walker(0.5, -6.0, PI / 2.0, 1.0),
        ];
        for heading in [HeadingRule::CircularMean, HeadingRule::Paper] {
            for k in [3, 12, 20, 27] {
                let p = Params {
                    k,
                    seed: 7,
                    heading,
                    ..Params::default()
                };
                let (mut a, mut b) = (TrajectoryBatch::new(), TrajectoryBatch::new());
                predict(&map, &agents, &p, &mut a).unwrap();
                let opts = Options {
                    scores: true,
                    ..Options::default()
                };
                predict_with(&map, &agents, &p, &opts, &mut b).unwrap();
                assert_eq!(bits(&a), bits(&b), "{heading:?} k {k}");
                assert_eq!(a.lens(), b.lens());
                assert!(a.scores().is_empty());
                assert_eq!(b.scores().len(), 2 * k);
                assert!(b.scores().iter().all(|s| s.is_finite() && *s < 30.0 * 3.0));
                // distinct samples, distinct scores
                assert!(b.scores().windows(2).any(|w| w[0] != w[1]));
                // a later call without scores empties them
                predict(&map, &agents, &p, &mut b).unwrap();
                assert!(b.scores().is_empty() && b.score(0, 0).is_none());
            }
        }
    }

    #[test]
    fn a_sample_along_the_flow_scores_higher_than_one_against_it() {
        // everything flows east at 1 m/s
        let map = flow(-5, 30, 0.0, 1.0);
        let opts = Options {
            scores: true,
            ..Options::default()
        };
        let p = Params {
            k: 4,
            dt: 1.0,
            horizon: 5.0,
            radius: 1.0,
            ..Params::default()
        };
        let mut b = TrajectoryBatch::new();
        // east along the flow; west against it (the kernel barely turns a heading pi away)
        let agents = [walker(0.0, 0.0, 0.0, 1.0), walker(20.0, 0.0, PI, 1.0)];
        predict_with(&map, &agents, &p, &opts, &mut b).unwrap();
        for s in 0..4 {
            assert_eq!((b.len(0, s), b.len(1, s)), (5, 5));
            let (along, against) = (b.score(0, s).unwrap(), b.score(1, s).unwrap());
            // along: 5 steps near the density's peak (ln(1 / (2 pi 0.01)) = 2.77; a
            // heading drawn 0.1 rad off costs 0.5)
            assert!(along > 5.0 * 1.0 && along < 5.0 * 2.77, "{along}");
            assert!(against < -1000.0, "{against}");
        }
        // constant velocity is scored by the same rule
        let cvm = Params {
            method: Method::Cvm,
            k: 1,
            ..p
        };
        predict_with(&map, &agents, &cvm, &opts, &mut b).unwrap();
        assert!(b.score(0, 0).unwrap() > 10.0 && b.score(1, 0).unwrap() < -1000.0);
        // and the best of a mixed call is the one along the flow
        let map2 = CliffMap::new(
            map.locations()
                .iter()
                .map(|l| Location {
                    components: vec![
                        Component {
                            weight: 0.5,
                            ..l.components[0]
                        },
                        Component {
                            theta: PI / 2.0,
                            weight: 0.5,
                            ..l.components[0]
                        },
                    ],
                    ..l.clone()
                })
                .collect(),
        )
        .unwrap();
        let p = Params {
            k: 20,
            beta: 0.2,
            ..p
        };
        predict_with(&map2, &agents[..1], &p, &opts, &mut b).unwrap();
        let best = b.best_sample(0).unwrap();
        assert!(b.scores().iter().all(|s| *s <= b.score(0, best).unwrap()));
    }

    #[test]
    fn coasting_goes_on_straight_for_the_bounded_time() {
        // the map covers x in [0, 3]; walking east from 0 at 1 m/s, 1 s steps
        let map = flow(0, 3, 0.0, 1.0);
        let p = Params {
            k: 2,
            dt: 1.0,
            horizon: 10.0,
            radius: 0.9,
            ..Params::default()
        };
        let mut b = TrajectoryBatch::new();
        let agents = [walker(0.0, 0.0, 0.0, 1.0), walker(-2.0, 0.0, 0.0, 1.0)];
        predict(&map, &agents, &p, &mut b).unwrap();
        // the paper: x = 4 has no location near: the sample ends after x = 3; off the map
        // from the start: nothing
        assert_eq!((b.len(0, 0), b.len(1, 0)), (3, 0));
        let opts = Options {
            coast: 2.5,
            scores: true,
            ..Options::default()
        };
        predict_with(&map, &agents, &p, &opts, &mut b).unwrap();
        for s in 0..2 {
            // 2 positions off the map after x = 3: x = 4, 5
            let x: Vec<f32> = b.sample(0, s).iter().map(|q| q[0]).collect();
            assert_eq!(x.len(), 5);
            let q = b.sample(0, s);
            assert!((x[4] - 5.0).abs() < 0.15, "{x:?}");
            // constant velocity: the coasting step repeats the last one
            for c in 0..2 {
                assert!(
                    ((q[4][c] - q[3][c]) - (q[3][c] - q[2][c])).abs() < 1e-4,
                    "{q:?}"
                );
            }
            // from x = -2: coasts to -1 and 0, samples the map there, on to x = 5
            let x: Vec<f32> = b.sample(1, s).iter().map(|q| q[0]).collect();
            assert_eq!(x.len(), 7, "{x:?}");
            assert!(
                (x[1] - 0.0).abs() < 1e-3 && (x[6] - 5.0).abs() < 0.15,
                "{x:?}"
            );
        }
        // score: the steps off the map (2 coasting + 5 after the end) at the uniform rule
        let s = b.score(0, 0).unwrap() as f64;
        let on_map = s - 7.0 * NO_LOCATION_LOG_DENSITY;
        assert!(on_map > 3.0 * 1.0 && on_map < 3.0 * 2.8, "{on_map}");
    }

    #[test]
    fn speed_kernel_moves_towards_the_maps_speed() {
        // the map says 2 m/s east; the walker goes 1 m/s east
        let map = flow(-5, 60, 0.0, 2.0);
        let p = Params {
            k: 8,
            dt: 1.0,
            horizon: 10.0,
            radius: 1.0,
            ..Params::default()
        };
        let step = |b: &TrajectoryBatch, s: usize, j: usize| {
            let q = b.sample(0, s);
            DVec2::new(
                (q[j][0] - q[j - 1][0]) as f64,
                (q[j][1] - q[j - 1][1]) as f64,
            )
            .length()
        };
        let mut b = TrajectoryBatch::new();
        let agents = [walker(0.0, 0.0, 0.0, 1.0)];
        predict(&map, &agents, &p, &mut b).unwrap();
        assert!((step(&b, 0, 9) - 1.0).abs() < 1e-3);
        let opts = Options {
            speed_beta: 1.0,
            ..Options::default()
        };
        predict_with(&map, &agents, &p, &opts, &mut b).unwrap();
        let mut mean = 0.0;
        for s in 0..8 {
            assert_eq!(b.len(0, s), 10);
            // the drawn speeds scatter with sd 0.1 around 2
            let last = step(&b, s, 9);
            assert!((last - 2.0).abs() < 0.4, "sample {s}: {last}");
            mean += last / 8.0;
        }
        assert!((mean - 2.0).abs() < 0.1, "{mean}");
        // a kernel so narrow that 1 m/s of difference is ignored keeps the speed
        let opts = Options {
            speed_beta: 50.0,
            ..Options::default()
        };
        predict_with(&map, &agents, &p, &opts, &mut b).unwrap();
        assert!((step(&b, 0, 9) - 1.0).abs() < 0.01);
    }

    #[test]
    fn the_loops_density_agrees_with_the_maps() {
        use rand::RngExt;
        let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/");
        for path in ["thor1/cliffmap.csv", "atc/cliffmap-20121024.csv"] {
            let map = CliffMap::load(format!("{data}{path}")).unwrap();
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
            let (mut above, mut below, mut single, mut checked) = (0.0f64, 0.0f64, 0.0f64, 0);
            for _ in 0..50_000 {
                let i = rng.random_range(0..map.locations().len());
                let theta: f64 = rng.random_range(0.0..std::f64::consts::TAU);
                let rho: f64 = rng.random_range(0.0..2.5);
                let comps = &map.locations()[i].components;
                // where a component's heading mean given the speed moves by more than
                // half a radian, the map's windings (around theta - mu) and the loop's
                // (around that mean) are not the same three
                if comps
                    .iter()
                    .any(|c| (c.cov[1] / c.cov[3].max(1e-4) * (rho - c.rho)).abs() > 0.5)
                {
                    continue;
                }
                let exact = map.log_density(i, theta, rho);
                let (s, c) = theta.sin_cos();
                let fast = map.step_log_density(i, c as f32, s as f32, rho);
                let tol = 1e-3 * exact.abs().max(1.0);
                checked += 1;
                // the likeliest component at one winding: never above the mixture, and
                // below it by at most ln(3 x components)
                above = above.max(fast - exact - tol);
                below = below.max(exact - fast - tol - (3.0 * comps.len() as f64).ln());
                // a single component narrower than 0.5 rad, the heading within 2 rad of
                // its mean given the speed: the same
                if let [c] = &comps[..] {
                    let off = (theta - c.theta - c.cov[1] / c.cov[3].max(1e-4) * (rho - c.rho))
                        .rem_euclid(std::f64::consts::TAU);
                    if c.cov[0] < 0.25 && off.min(std::f64::consts::TAU - off) < 2.0 {
                        single = single.max((exact - fast).abs() - tol);
                    }
                }
            }
            assert!(checked > 10_000, "{path}: {checked}");
            assert!(above <= 0.0, "{path}: above the mixture by {above}");
            assert!(below <= 0.0, "{path}: below the bound by {below}");
            assert!(single <= 0.0, "{path}: one component off by {single}");
        }
    }

    /// Each step's exact log-density ([`CliffMap::log_density`] at the location the
    /// step was drawn at, the heading and speed the step moved with), summed as the
    /// loop sums its approximation.
    fn exact_score(
        map: &CliffMap,
        radius: f64,
        start: &State,
        dt: f64,
        steps: usize,
        sample: &[[f32; 2]],
    ) -> f64 {
        let lookup = map.lookup(radius);
        let mut prev = start.position;
        let mut score = (steps - sample.len()) as f64 * NO_LOCATION_LOG_DENSITY;
        for q in sample {
            let p = DVec2::new(q[0] as f64, q[1] as f64);
            let step = p - prev;
            let loc = lookup
                .best_near(prev)
                .expect("a step is drawn at a location");
            score += map.log_density(loc, step.y.atan2(step.x), step.length() / dt);
            prev = p;
        }
        score
    }

    #[test]
    fn scores_rank_real_predictions_as_the_maps_density_does() {
        use crate::eval::protocol::{Protocol, Settings, prepare};
        use crate::tracks::{Format, read_tracks};
        let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/");
        let atc = Settings {
            protocol: Protocol::Seconds,
            dt: 1.0,
            horizon: 50.0,
            ..Settings::default()
        };
        let atc_params = Params {
            dt: 1.0,
            horizon: 50.0,
            radius: 1.0,
            ..Params::default()
        };
        for (map, tracks, format, settings, params) in [
            (
                "thor1/cliffmap.csv",
                "thor1/exp-1-run-2.csv",
                Format::Thor,
                Settings::default(),
                Params::default(),
            ),
            (
                "atc/cliffmap-20121024.csv",
                "atc/dev/atc-1024-13_test.csv",
                Format::Atc,
                atc,
                atc_params,
            ),
        ] {
            let map = CliffMap::load(format!("{data}{map}")).unwrap();
            let tracks =
                read_tracks(std::path::Path::new(&format!("{data}{tracks}")), format).unwrap();
            let people: Vec<State> = tracks
                .iter()
                .filter_map(|t| prepare(t, &settings))
                .map(|c| c.start)
                .take(60)
                .collect();
            for speed_beta in [0.0, 1.0] {
                let opts = Options {
                    speed_beta,
                    scores: true,
                    ..Options::default()
                };
                let mut b = TrajectoryBatch::new();
                let p = Params { seed: 3, ..params };
                predict_with(&map, &people, &p, &opts, &mut b).unwrap();
                let steps = p.steps();
                let (mut same_best, mut regret) = (0, 0.0f64);
                let (mut pairs, mut concordant) = (0usize, 0usize);
                let mut gaps = Vec::new();
                for (a, start) in people.iter().enumerate() {
                    let exact: Vec<f64> = (0..p.k)
                        .map(|s| exact_score(&map, p.radius, start, p.dt, steps, b.sample(a, s)))
                        .collect();
                    for (s, e) in exact.iter().enumerate() {
                        let d = e - b.score(a, s).unwrap() as f64;
                        gaps.push(d / b.len(a, s).max(1) as f64);
                    }
                    for x in 0..p.k {
                        for y in 0..x {
                            let ex = exact[x] - exact[y];
                            let ey = (b.score(a, x).unwrap() - b.score(a, y).unwrap()) as f64;
                            pairs += 1;
                            concordant +=
                                (ex * ey > 0.0 || (ex.abs() < 1e-3 && ey.abs() < 1e-3)) as usize;
                        }
                    }
                    let best = (0..p.k)
                        .max_by(|&x, &y| exact[x].total_cmp(&exact[y]))
                        .unwrap();
                    let chosen = b.best_sample(a).unwrap();
                    same_best += (best == chosen) as usize;
                    regret = regret.max(exact[best] - exact[chosen]);
                }
                let what = format!("{} people, speed_beta {speed_beta}", people.len());
                gaps.sort_by(f64::total_cmp);
                let q = |p: f64| gaps[(p * (gaps.len() - 1) as f64) as usize];
                let concordance = concordant as f64 / pairs as f64;
                // per step, the loop's value is the map's or a little below it (the
                // likeliest component instead of the sum: at most ln 2 with two
                // components explaining a step equally) ...
                assert!(q(0.01) > -1e-3, "{what}: {gaps:?}");
                assert!(q(0.5) < 0.05 && q(0.95) < 0.2, "{what}: {gaps:?}");
                // ... and the scores order the samples as the map's density does
                assert!(concordance > 0.98, "{what}: {concordance}");
                assert!(same_best * 10 >= people.len() * 9, "{what}: {same_best}");
                assert!(regret < 1.5, "{what}: {regret}");
            }
        }
    }

    #[test]
    fn bad_options_are_refused() {
        let map = CliffMap::demo();
        let mut b = TrajectoryBatch::new();
        let w = [walker(0.0, 0.0, 0.0, 1.0)];
        for (o, name) in [
            (
                Options {
                    speed_beta: -1.0,
                    ..Options::default()
                },
                "speed_beta",
            ),
            (
                Options {
                    coast: f64::NAN,
                    ..Options::default()
                },
                "coast",
            ),
        ] {
            match predict_with(&map, &w, &Params::default(), &o, &mut b) {
                Err(PredictError::Param { name: n, .. }) => assert_eq!(n, name),
                other => panic!("{name}: {other:?}"),
            }
        }
        let mut pos = vec![[0.0f32; 2]; 20 * 30];
        let mut lens = vec![0u32; 20];
        let e = predict_into_with(
            &map,
            &w,
            &Params::default(),
            &Options {
                scores: true,
                ..Options::default()
            },
            BatchMut {
                positions: &mut pos,
                lens: &mut lens,
            },
            &mut [],
        );
        assert!(matches!(e, Err(PredictError::Param { name: "scores", .. })));
    }

    /// Locations on a 1 m grid over x, y in [-30, 30], each with two equal flows: east
    /// and north.
    fn crossing() -> CliffMap {
        let c = |theta: f64| Component {
            theta,
            rho: 1.0,
            cov: [0.02, 0.0, 0.0, 0.01],
            weight: 0.5,
        };
        let mut locs = vec![];
        for ix in -30..=30 {
            for iy in -30..=30 {
                locs.push(Location {
                    position: DVec2::new(ix as f64, iy as f64),
                    components: vec![c(0.0), c(PI / 2.0)],
                    motion_ratio: 1.0,
                    observation_ratio: 1.0,
                });
            }
        }
        CliffMap::new(locs).unwrap()
    }

    #[test]
    fn follow_keeps_a_walker_to_the_flow_going_its_way() {
        let map = crossing();
        let p = Params {
            k: 200,
            dt: 1.0,
            horizon: 10.0,
            radius: 1.0,
            seed: 5,
            ..Params::default()
        };
        let east = walker(0.0, 0.0, 0.0, 1.0);
        let drift = |follow: f64| {
            let mut b = TrajectoryBatch::new();
            let o = Options {
                follow,
                ..Options::default()
            };
            predict_with(&map, &[east], &p, &o, &mut b).unwrap();
            (0..p.k)
                .map(|s| b.sample(0, s)[p.steps() - 1][1] as f64)
                .sum::<f64>()
                / p.k as f64
        };
        let (paper, follow) = (drift(0.0), drift(8.0));
        // by weight alone half the draws pull north; following, few do
        assert!(paper > 1.0, "paper drift {paper}");
        assert!(follow < 0.5 * paper, "follow drift {follow}, paper {paper}");
        // follow 0 is the paper's method, byte for byte
        let mut a = TrajectoryBatch::new();
        let mut b = TrajectoryBatch::new();
        predict(&map, &[east], &p, &mut a).unwrap();
        predict_with(&map, &[east], &p, &Options::default(), &mut b).unwrap();
        assert_eq!(bits(&a), bits(&b));
    }

    #[test]
    fn the_speed_prior_sets_the_start_speed() {
        use crate::motion::SpeedPrior;
        let mut map = flow(-5, 30, 0.0, 1.0);
        let p = Params {
            k: 4,
            dt: 1.0,
            horizon: 10.0,
            radius: 1.0,
            beta: 1.0,
            ..Params::default()
        };
        let slow = walker(0.0, 0.0, 0.0, 0.4);
        let on = Options {
            speed_prior: true,
            ..Options::default()
        };
        let x_after = |map: &CliffMap, o: &Options| {
            let mut b = TrajectoryBatch::new();
            predict_with(map, &[slow], &p, o, &mut b).unwrap();
            b.sample(0, 0)[p.steps() - 1][0] as f64
        };
        // no prior on the map: the observed speed
        assert!((x_after(&map, &on) - 4.0).abs() < 0.1);
        map.set_speed_prior(Some(SpeedPrior {
            mean: 1.2,
            keep: 0.5,
            pairs: 100,
        }))
        .unwrap();
        // 1.2 + 0.5 (0.4 - 1.2) = 0.8 m/s for 10 s
        assert!((x_after(&map, &on) - 8.0).abs() < 0.1);
        assert!((x_after(&map, &Options::default()) - 4.0).abs() < 0.1);
        // a bad prior is refused
        let bad = SpeedPrior {
            mean: -1.0,
            keep: 0.5,
            pairs: 1,
        };
        assert!(map.set_speed_prior(Some(bad)).is_err());
    }

    #[test]
    fn bad_follow_and_candidates_are_refused() {
        for (o, name) in [
            (
                Options {
                    follow: -1.0,
                    ..Options::default()
                },
                "follow",
            ),
            (
                Options {
                    follow: f64::NAN,
                    ..Options::default()
                },
                "follow",
            ),
            (
                Options {
                    candidates: 17,
                    ..Options::default()
                },
                "candidates",
            ),
        ] {
            assert!(
                matches!(o.validate(), Err(PredictError::Param { name: n, .. }) if n == name),
                "{o:?}"
            );
        }
    }
}
