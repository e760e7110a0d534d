//! EM for the semi-wrapped Gaussian mixture of one node (section 4 of
//! `cliffmap-building.md`), in log space.

use std::f64::consts::TAU;

use super::stats::{Gauss2, eig_sym};
use crate::map::wrap_2pi;

/// Stopping rules of EM.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmParams {
    /// Largest number of iterations (the original: 500).
    pub max_iter: usize,
    /// Stop when the log-likelihood changes by at most this much (the original: 1e-5).
    pub abs_tol: f64,
    /// ... or by at most this share of its magnitude (0 for the original's rule). A
    /// relative tolerance keeps large nodes from running long for no gain.
    pub rel_tol: f64,
}

impl Default for EmParams {
    fn default() -> Self {
        Self {
            max_iter: 500,
            abs_tol: 1e-5,
            rel_tol: 1e-5,
        }
    }
}

/// One mixture component during EM.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmComponent {
    /// Mean (theta in `[0, 2pi)`, rho).
    pub mu: [f64; 2],
    /// Covariance, row-major.
    pub cov: [f64; 4],
    /// Mixing weight.
    pub weight: f64,
}

/// What an EM run did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmOutcome {
    /// Iterations (E-steps) run.
    pub iterations: usize,
    /// Log-likelihood of the samples under the returned mixture's predecessor (the
    /// last E-step).
    pub log_likelihood: f64,
}

/// Terms more than this far below the largest log term of a sample are below f64
/// resolution of the sum and are skipped.
const SKIP_LOG: f64 = -40.0;

/// A variance below this drops the component.
const MIN_VARIANCE: f64 = 1e-9;
/// An eigenvalue below this adds `1e-10 I` to the covariance.
const NEAR_SINGULAR: f64 = 1e-10;

/// Fit the mixture to `samples` ((theta in `[0, 2pi)`, rho)) starting from `comps`.
/// Components whose covariance degenerates are dropped; the weights of the rest are
/// renormalised.
pub fn em(
    samples: &[[f64; 2]],
    mut comps: Vec<EmComponent>,
    p: &EmParams,
) -> (Vec<EmComponent>, EmOutcome) {
    let n = samples.len() as f64;
    let mut prev_ll = f64::NEG_INFINITY;
    let mut out = EmOutcome {
        iterations: 0,
        log_likelihood: f64::NEG_INFINITY,
    };
    let mut gauss: Vec<Gauss2> = Vec::with_capacity(comps.len());
    let mut terms: Vec<f64> = Vec::with_capacity(3 * comps.len());
    // Per component: R, sum r d (2), sum r d d^T (xx, xy, yy).
    let mut acc: Vec<[f64; 6]> = Vec::with_capacity(comps.len());
    while !comps.is_empty() && out.iterations < p.max_iter {
        gauss.clear();
        for c in &comps {
            match Gauss2::new(c.mu, c.cov, c.weight) {
                Some(g) => gauss.push(g),
                None => {
                    // Unusable covariance: give it no density.
                    gauss.push(Gauss2 {
                        mu: c.mu,
                        inv: [0.0; 3],
                        log_norm: f64::NEG_INFINITY,
                    })
                }
            }
        }
        acc.clear();
        acc.resize(comps.len(), [0.0; 6]);
        let mut ll = 0.0;
        for x in samples {
            terms.clear();
            let mut m = f64::NEG_INFINITY;
            for g in &gauss {
                let d0 = x[0] - g.mu[0];
                let dr = x[1] - g.mu[1];
                for dt in [d0 + TAU, d0, d0 - TAU] {
                    let v = g.log_norm - 0.5 * g.maha(dt, dr);
                    m = m.max(v);
                    terms.push(v);
                }
            }
            if m == f64::NEG_INFINITY || m.is_nan() {
                // All-zero density: the sample gets no weight.
                continue;
            }
            let mut s = 0.0;
            for t in terms.iter_mut() {
                let a = *t - m;
                *t = if a > SKIP_LOG { a.exp() } else { 0.0 };
                s += *t;
            }
            ll += m + s.ln();
            let inv_s = 1.0 / s;
            for (j, g) in gauss.iter().enumerate() {
                let d0 = x[0] - g.mu[0];
                let dr = x[1] - g.mu[1];
                for (k, dt) in [d0 + TAU, d0, d0 - TAU].into_iter().enumerate() {
                    let e = terms[3 * j + k];
                    if e == 0.0 {
                        continue;
                    }
                    let r = e * inv_s;
                    let a = &mut acc[j];
                    a[0] += r;
                    a[1] += r * dt;
                    a[2] += r * dr;
                    a[3] += r * dt * dt;
                    a[4] += r * dt * dr;
                    a[5] += r * dr * dr;
                }
            }
        }
        out.iterations += 1;
        out.log_likelihood = ll;
        if (ll - prev_ll).abs() <= p.abs_tol.max(p.rel_tol * ll.abs()) {
            break;
        }
        prev_ll = ll;
        // M-step.
        let mut next = Vec::with_capacity(comps.len());
        for (c, a) in comps.iter().zip(&acc) {
            let r = a[0];
            if r.is_nan() || r <= 0.0 {
                continue;
            }
            let (mt, mr) = (a[1] / r, a[2] / r);
            let mut cov = [
                a[3] / r - mt * mt,
                a[4] / r - mt * mr,
                0.0,
                a[5] / r - mr * mr,
            ];
            cov[2] = cov[1];
            if !(cov[0] >= MIN_VARIANCE && cov[3] >= MIN_VARIANCE)
                || cov.iter().any(|v| !v.is_finite())
            {
                continue;
            }
            if eig_sym(cov).1 < NEAR_SINGULAR {
                let (cc, _) = crate::map::clamp_psd(cov);
                cov = cc;
                cov[0] += NEAR_SINGULAR;
                cov[3] += NEAR_SINGULAR;
            }
            next.push(EmComponent {
                mu: [wrap_2pi(c.mu[0] + mt), c.mu[1] + mr],
                cov,
                weight: r / n,
            });
        }
        let total: f64 = next.iter().map(|c| c.weight).sum();
        if next.len() < comps.len() && total > 0.0 {
            for c in &mut next {
                c.weight /= total;
            }
        }
        comps = next;
    }
    (comps, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_component_converges_to_sample_moments() {
        // A symmetric cross of samples around (0.02, 1.0): mean and covariance known.
        let mut x = Vec::new();
        for &(dt, dr) in &[
            (0.1, 0.0),
            (-0.1, 0.0),
            (0.0, 0.2),
            (0.0, -0.2),
            (0.05, 0.1),
            (-0.05, -0.1),
        ] {
            x.push([wrap_2pi(0.02 + dt), 1.0 + dr]);
        }
        let init = vec![EmComponent {
            mu: [0.0, 0.9],
            cov: [0.01, 0.0, 0.0, 0.01],
            weight: 1.0,
        }];
        let (c, o) = em(&x, init, &EmParams::default());
        assert_eq!(c.len(), 1);
        assert!(o.iterations >= 2);
        let c = c[0];
        assert!(
            (c.mu[0] - 0.02).abs() < 1e-9 && (c.mu[1] - 1.0).abs() < 1e-9,
            "{c:?}"
        );
        let vt = (0.01 * 2.0 + 0.0025 * 2.0) / 6.0;
        let vr = (0.04 * 2.0 + 0.01 * 2.0) / 6.0;
        let ctr = (0.005 * 2.0) / 6.0;
        assert!(
            (c.cov[0] - vt).abs() < 1e-9
                && (c.cov[3] - vr).abs() < 1e-9
                && (c.cov[1] - ctr).abs() < 1e-9,
            "{c:?}"
        );
        assert!((c.weight - 1.0).abs() < 1e-12);
    }

    #[test]
    fn degenerate_component_is_dropped_and_weights_renormalised() {
        // Three identical samples collapse one component; the other explains the rest.
        let mut x = vec![[3.0, 0.5]; 3];
        for i in 0..20 {
            x.push([1.0 + 0.01 * i as f64, 1.0 + 0.013 * (i % 7) as f64]);
        }
        let init = vec![
            EmComponent {
                mu: [3.0, 0.5],
                cov: [0.001, 0.0, 0.0, 0.001],
                weight: 0.5,
            },
            EmComponent {
                mu: [1.1, 1.0],
                cov: [0.01, 0.0, 0.0, 0.01],
                weight: 0.5,
            },
        ];
        let (c, _) = em(&x, init, &EmParams::default());
        assert_eq!(c.len(), 1, "{c:?}");
        assert!((c[0].weight - 1.0).abs() < 1e-12);
        // EM runs on all samples: the dropped component's samples join the other.
        assert!((c[0].mu[0] - 30.9 / 23.0).abs() < 1e-6, "{c:?}");
    }
}
