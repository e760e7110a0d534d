//! How far a location's velocity mixture moved: the total-variation distance between two
//! mixtures ([`total_variation`]), the measure that damps online updates
//! ([`UpdateParams::max_move`](super::update::UpdateParams::max_move)) and that
//! `cliff map diff` reports.
//!
//! The distance is `TV(p, q) = 1/2 * integral of |p(v) - q(v)|` over velocities `v`
//! (heading and speed), with `p` and `q` the locations' semi-wrapped mixtures (weights
//! renormalised, covariance eigenvalues floored at 1e-4 as scoring does, windings -1, 0,
//! 1): 0 when the mixtures are equal, 1 when they have nothing in common. It is the
//! largest difference between the probabilities `p` and `q` give any set of
//! velocities, so a move of 0.05 changes the chance of any heading and speed range by at
//! most 5 points; and `TV(p, (1 - a) p + a q) = a TV(p, q)`, so blending a mixture
//! towards another moves it in proportion.
//!
//! It is computed as `E_m[|p - q| / (p + q)]` under `m = (p + q) / 2`, each component of
//! `m` integrated by a fixed rule of 96 points (8 radii at the 2-D normal's radial
//! quantiles times 12 angles, equal weights, through the component's Cholesky factor):
//! deterministic, exact for a mixture against a disjoint one, and within about 0.01 of
//! the exact value on real maps' mixtures (test
//! `total_variation_matches_monte_carlo_on_real_locations`).
//!
//! ```
//! use cliff::map::{Component, movement::total_variation};
//! let east = Component { theta: 0.0, rho: 1.0, cov: [0.05, 0.0, 0.0, 0.02], weight: 1.0 };
//! let west = Component { theta: std::f64::consts::PI, ..east };
//! assert!(total_variation(&[east], &[east]) < 1e-12);
//! assert!((total_variation(&[east], &[west]) - 1.0).abs() < 1e-6);
//! // a fifth of the weight turned around
//! let mixed = [Component { weight: 0.8, ..east }, Component { weight: 0.2, ..west }];
//! assert!((total_variation(&[east], &mixed) - 0.2).abs() < 1e-6);
//! ```

use std::f64::consts::TAU;
use std::sync::OnceLock;

use super::Component;
use super::stats::{Gauss2, floor_eigenvalues};
use crate::math::wrap_2pi;

/// Covariance eigenvalues are raised to at least this for the measure (as for scoring).
pub const MOVE_EIGENVALUE_FLOOR: f64 = 1e-4;

const RADII: usize = 8;
const ANGLES: usize = 12;

/// The rule's points for a standard 2-D normal (equal weights).
fn rule() -> &'static [[f64; 2]] {
    static RULE: OnceLock<Vec<[f64; 2]>> = OnceLock::new();
    RULE.get_or_init(|| {
        let mut pts = Vec::with_capacity(RADII * ANGLES);
        for k in 0..RADII {
            // the radius of a standard 2-D normal has P(R <= r) = 1 - exp(-r^2 / 2)
            let u = (k as f64 + 0.5) / RADII as f64;
            let r = (-2.0 * (1.0 - u).ln()).sqrt();
            for l in 0..ANGLES {
                // every other ring turned by half a step
                let phi = TAU * (l as f64 + 0.5 * (k % 2) as f64) / ANGLES as f64;
                pts.push([r * phi.cos(), r * phi.sin()]);
            }
        }
        pts
    })
}

/// A mixture prepared for the measure: its components with weights renormalised and
/// covariances floored, and their Cholesky factors.
struct Prepared {
    gauss: Vec<Gauss2>,
    /// Per component: weight, mean, lower Cholesky factor `[l11, l21, l22]`.
    parts: Vec<(f64, [f64; 2], [f64; 3])>,
}

fn prepare(comps: &[Component]) -> Prepared {
    let total: f64 = comps.iter().map(|c| c.weight.max(0.0)).sum();
    let mut gauss = Vec::with_capacity(comps.len());
    let mut parts = Vec::with_capacity(comps.len());
    if total > 0.0 && total.is_finite() {
        for c in comps {
            let w = c.weight.max(0.0) / total;
            if w == 0.0 {
                continue;
            }
            let cov = floor_eigenvalues(c.cov, MOVE_EIGENVALUE_FLOOR);
            let mu = [wrap_2pi(c.theta), c.rho];
            let Some(g) = Gauss2::new(mu, cov, w) else {
                continue;
            };
            let l11 = cov[0].sqrt();
            let l21 = cov[1] / l11;
            let l22 = (cov[3] - l21 * l21).max(0.0).sqrt();
            gauss.push(g);
            parts.push((w, mu, [l11, l21, l22]));
        }
    }
    Prepared { gauss, parts }
}

fn density(g: &[Gauss2], theta: f64, rho: f64) -> f64 {
    g.iter()
        .map(|g| g.log_density_wrapped(theta, rho).exp())
        .sum()
}

/// The total-variation distance between two locations' mixtures (see the
/// [module documentation](self)): in `[0, 1]`; 1 when either has no usable component
/// and the other has, 0 when neither has.
pub fn total_variation(a: &[Component], b: &[Component]) -> f64 {
    let (p, q) = (prepare(a), prepare(b));
    match (p.parts.is_empty(), q.parts.is_empty()) {
        (true, true) => return 0.0,
        (true, false) | (false, true) => return 1.0,
        _ => {}
    }
    let pts = rule();
    let mut tv = 0.0;
    for (w, mu, l) in p.parts.iter().chain(&q.parts) {
        let mut sum = 0.0;
        for z in pts {
            let theta = wrap_2pi(mu[0] + l[0] * z[0]);
            let rho = mu[1] + l[1] * z[0] + l[2] * z[1];
            let (dp, dq) = (density(&p.gauss, theta, rho), density(&q.gauss, theta, rho));
            if dp + dq > 0.0 {
                sum += (dp - dq).abs() / (dp + dq);
            }
        }
        // the component's weight in m = (p + q) / 2
        tv += 0.5 * w * sum / pts.len() as f64;
    }
    tv.clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::CliffMap;
    use rand::{RngExt, SeedableRng};
    use rand_distr::{Distribution, Normal};

    /// Plain Monte Carlo of `E_m[|p - q| / (p + q)]`, with samples drawn from `m`.
    fn monte_carlo(a: &[Component], b: &[Component], n: usize, seed: u64) -> f64 {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        let z = Normal::new(0.0, 1.0).unwrap();
        let (p, q) = (prepare(a), prepare(b));
        let all: Vec<_> = p
            .parts
            .iter()
            .map(|&(w, m, l)| (0.5 * w, m, l))
            .chain(q.parts.iter().map(|&(w, m, l)| (0.5 * w, m, l)))
            .collect();
        let mut sum = 0.0;
        for _ in 0..n {
            let mut u: f64 = rng.random();
            let (_, mu, l) = *all
                .iter()
                .find(|(w, _, _)| {
                    u -= w;
                    u <= 0.0
                })
                .unwrap_or(all.last().unwrap());
            let (z0, z1) = (z.sample(&mut rng), z.sample(&mut rng));
            let theta = wrap_2pi(mu[0] + l[0] * z0);
            let rho = mu[1] + l[1] * z0 + l[2] * z1;
            let (dp, dq) = (density(&p.gauss, theta, rho), density(&q.gauss, theta, rho));
            sum += (dp - dq).abs() / (dp + dq);
        }
        sum / n as f64
    }

    #[test]
    fn total_variation_matches_monte_carlo_on_real_locations() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
        let thor = CliffMap::load(root.join("thor1/cliffmap.csv")).unwrap();
        let atc = CliffMap::load(root.join("atc/cliffmap-20121024.csv")).unwrap();
        let mut worst: f64 = 0.0;
        let mut pairs = 0;
        for map in [&thor, &atc] {
            let locs = map.locations();
            // neighbours on the grid: mixtures that differ a little or a lot
            for i in (0..locs.len() - 1).step_by(locs.len() / 40) {
                let (a, b) = (&locs[i].components, &locs[i + 1].components);
                let exact = monte_carlo(a, b, 40_000, i as u64);
                let rule = total_variation(a, b);
                worst = worst.max((rule - exact).abs());
                pairs += 1;
            }
        }
        assert!(pairs >= 70, "{pairs}");
        // Monte Carlo's own error with 40,000 samples is below 0.005
        assert!(worst < 0.015, "largest difference {worst}");
    }

    #[test]
    fn blending_moves_in_proportion() {
        let map = CliffMap::demo();
        let a = &map.locations()[10].components;
        let turned: Vec<Component> = a
            .iter()
            .map(|c| Component {
                theta: wrap_2pi(c.theta + 2.0),
                ..*c
            })
            .collect();
        let full = total_variation(a, &turned);
        assert!(full > 0.5, "{full}");
        for share in [0.1, 0.3, 0.6] {
            let blend: Vec<Component> = a
                .iter()
                .map(|c| Component {
                    weight: c.weight * (1.0 - share),
                    ..*c
                })
                .chain(turned.iter().map(|c| Component {
                    weight: c.weight * share,
                    ..*c
                }))
                .collect();
            let tv = total_variation(a, &blend);
            assert!(
                (tv - share * full).abs() < 0.02,
                "{share}: {tv} vs {}",
                share * full
            );
        }
        assert_eq!(total_variation(&[], &[]), 0.0);
        assert_eq!(total_variation(a, &[]), 1.0);
    }
}
