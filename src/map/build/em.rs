//! EM for the semi-wrapped Gaussian mixture of one node (section 4 of
//! `cliffmap-building.md`), in log space.

use std::f64::consts::{PI, TAU};

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

/// `exp(a)` for `a <= 0` (the scaled terms of a log-sum-exp), branch-free so that
/// loops over samples vectorise: `a = k ln 2 + r` with `|r| <= ln 2 / 2`, a degree-11
/// Taylor polynomial for `exp(r)` (relative error below 1e-14) and `2^k` built in the
/// exponent bits.
#[inline(always)]
pub(crate) fn exp_neg(a: f64) -> f64 {
    const LOG2E: f64 = std::f64::consts::LOG2_E;
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    // 1.5 * 2^52: adding it rounds to an integer held in the low mantissa bits.
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    let a = a.max(-700.0);
    let t = a * LOG2E + SHIFT;
    let k = t - SHIFT;
    let r = (a - k * LN2_HI) - k * LN2_LO;
    let mut p = 1.0 / 39_916_800.0;
    for c in [
        1.0 / 3_628_800.0,
        1.0 / 362_880.0,
        1.0 / 40_320.0,
        1.0 / 5_040.0,
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        0.5,
        1.0,
        1.0,
    ] {
        p = p * r + c;
    }
    // k sits in the low bits of t as a two's-complement offset from SHIFT's bits.
    let ki = t.to_bits().wrapping_sub(SHIFT.to_bits()) as i64;
    p * f64::from_bits(((ki + 1023) as u64) << 52)
}

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
    let ns = samples.len();
    // Component-major buffers, reused across iterations: for component j and sample i,
    // `near[j * ns + i]` is the direction offset of the nearest winding (|d| <= pi) and
    // `e[(3 j + w) * ns + i]` the log term, then the scaled density, of winding w
    // (0: nearest, 1: the next one on the other side, 2: the far one).
    let mut near: Vec<f64> = Vec::new();
    let mut e: Vec<f64> = Vec::new();
    let mut mx = vec![0.0f64; ns];
    let mut inv_s = vec![0.0f64; ns];
    let mut live: Vec<bool> = Vec::new();
    // Per component: R, sum r d (2), sum r d d^T (xx, xy, yy).
    let mut acc: Vec<[f64; 6]> = Vec::with_capacity(comps.len());
    while !comps.is_empty() && out.iterations < p.max_iter {
        let nj = comps.len();
        near.resize(nj * ns, 0.0);
        e.resize(3 * nj * ns, 0.0);
        mx.fill(f64::NEG_INFINITY);
        for (j, c) in comps.iter().enumerate() {
            let near = &mut near[j * ns..(j + 1) * ns];
            let (e0, rest) = e[3 * j * ns..3 * (j + 1) * ns].split_at_mut(ns);
            let (e1, e2) = rest.split_at_mut(ns);
            let Some(g) = Gauss2::new(c.mu, c.cov, c.weight) else {
                // Unusable covariance: no density.
                e0.fill(f64::NEG_INFINITY);
                e1.fill(f64::NEG_INFINITY);
                e2.fill(f64::NEG_INFINITY);
                continue;
            };
            let [ia, ib, ic] = g.inv;
            for i in 0..ns {
                let x = samples[i];
                let d0 = x[0] - g.mu[0];
                // Nearest winding, then the one across, then the far one.
                let d = if d0 > PI {
                    d0 - TAU
                } else if d0 < -PI {
                    d0 + TAU
                } else {
                    d0
                };
                let side = if d >= 0.0 { -TAU } else { TAU };
                let dr = x[1] - g.mu[1];
                let qr = ic * dr * dr;
                let u = 2.0 * ib * dr;
                let q = |t: f64| t * (ia * t + u) + qr;
                let v0 = g.log_norm - 0.5 * q(d);
                let v1 = g.log_norm - 0.5 * q(d + side);
                let v2 = g.log_norm - 0.5 * q(d - side);
                near[i] = d;
                e0[i] = v0;
                e1[i] = v1;
                e2[i] = v2;
                mx[i] = mx[i].max(v0).max(v1).max(v2);
            }
        }
        inv_s.fill(0.0);
        live.clear();
        for col in e.chunks_exact_mut(ns) {
            // Windings that never come near the best term of any sample (the far
            // windings of all but wide components) are skipped whole.
            let top = col
                .iter()
                .zip(&mx)
                .map(|(v, m)| v - m)
                .fold(f64::NEG_INFINITY, f64::max);
            let is_live = top > SKIP_LOG;
            live.push(is_live);
            if !is_live {
                continue;
            }
            for i in 0..ns {
                let a = col[i] - mx[i];
                let v = if a > SKIP_LOG { exp_neg(a) } else { 0.0 };
                col[i] = v;
                inv_s[i] += v;
            }
        }
        let mut ll = 0.0;
        for i in 0..ns {
            let m = mx[i];
            if m == f64::NEG_INFINITY || m.is_nan() {
                // All-zero density: the sample gets no weight.
                inv_s[i] = 0.0;
                continue;
            }
            ll += m + inv_s[i].ln();
            inv_s[i] = 1.0 / inv_s[i];
        }
        acc.clear();
        acc.resize(nj, [0.0; 6]);
        for (j, c) in comps.iter().enumerate() {
            let near = &near[j * ns..(j + 1) * ns];
            let mut a = [0.0f64; 6];
            for w in 0..3 {
                if !live[3 * j + w] {
                    continue;
                }
                let col = &e[(3 * j + w) * ns..(3 * j + w + 1) * ns];
                for i in 0..ns {
                    let r = col[i] * inv_s[i];
                    let d = near[i];
                    let side = if d >= 0.0 { -TAU } else { TAU };
                    let dt = match w {
                        0 => d,
                        1 => d + side,
                        _ => d - side,
                    };
                    let dr = samples[i][1] - c.mu[1];
                    a[0] += r;
                    a[1] += r * dt;
                    a[2] += r * dr;
                    a[3] += r * dt * dt;
                    a[4] += r * dt * dr;
                    a[5] += r * dr * dr;
                }
            }
            // Offsets were taken from the nearest winding of each sample; the M-step
            // below adds them to the old mean, which is the same as the original's
            // sum over x - k e.
            acc[j] = a;
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
    fn exp_neg_matches_std_exp() {
        let mut worst: f64 = 0.0;
        for i in 0..=400_000 {
            let a = -40.0 * i as f64 / 400_000.0;
            let (x, y) = (exp_neg(a), a.exp());
            worst = worst.max(((x - y) / y).abs());
        }
        assert!(worst < 1e-14, "{worst}");
        assert_eq!(exp_neg(0.0), 1.0);
        assert!(exp_neg(-800.0) < 1e-300);
    }

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
