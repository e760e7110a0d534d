//! EM for the semi-wrapped Gaussian mixture of one node (section 4 of
//! `cliffmap-building.md`), in log space.

use std::f64::consts::{PI, TAU};

use crate::map::stats::{Gauss2, eig_sym};
use crate::math::wrap_2pi;

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
#[cfg(test)]
fn exp_neg(a: f64) -> f64 {
    exp_neg_impl::<false>(a)
}

/// `a * b + c`, fused where the caller is compiled with FMA.
#[inline(always)]
fn fma<const F: bool>(a: f64, b: f64, c: f64) -> f64 {
    if F { a.mul_add(b, c) } else { a * b + c }
}

#[inline(always)]
fn exp_neg_impl<const F: bool>(a: f64) -> f64 {
    const LOG2E: f64 = std::f64::consts::LOG2_E;
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    // 1.5 * 2^52: adding it rounds to an integer held in the low mantissa bits.
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    let a = a.max(-700.0);
    let t = a * LOG2E + SHIFT;
    let k = t - SHIFT;
    let r = fma::<F>(-k, LN2_LO, fma::<F>(-k, LN2_HI, a));
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
        p = fma::<F>(p, r, c);
    }
    // k sits in the low bits of t as a two's-complement offset from SHIFT's bits.
    let ki = t.to_bits().wrapping_sub(SHIFT.to_bits()) as i64;
    p * f64::from_bits(((ki + 1023) as u64) << 52)
}

/// E-step buffers, reused across iterations, component-major: for component j and
/// sample i, `near[j * n + i]` is the direction offset of the nearest winding
/// (`|d| <= pi`) and `e[(3 j + w) * n + i]` the log term, then the scaled density, of
/// winding w (0: nearest, 1: the next one on the other side, 2: the far one).
struct Buffers {
    theta: Vec<f64>,
    rho: Vec<f64>,
    near: Vec<f64>,
    e: Vec<f64>,
    mx: Vec<f64>,
    inv_s: Vec<f64>,
    live: Vec<bool>,
}

impl Buffers {
    fn new(samples: &[[f64; 2]]) -> Self {
        let n = samples.len();
        Self {
            theta: samples.iter().map(|x| x[0]).collect(),
            rho: samples.iter().map(|x| x[1]).collect(),
            near: Vec::new(),
            e: Vec::new(),
            mx: vec![0.0; n],
            inv_s: vec![0.0; n],
            live: Vec::new(),
        }
    }
}

/// One E-step: fills `acc` (per component: R, first and second moments of the offsets
/// from its mean) and returns the log-likelihood. Compiled twice: for AVX2 + FMA when
/// the processor has them, and for the baseline.
fn e_step(comps: &[EmComponent], b: &mut Buffers, acc: &mut Vec<[f64; 6]>) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the processor supports the features the function is compiled for.
            return unsafe { e_step_avx2(comps, b, acc) };
        }
    }
    e_step_impl::<false>(comps, b, acc)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn e_step_avx2(comps: &[EmComponent], b: &mut Buffers, acc: &mut Vec<[f64; 6]>) -> f64 {
    e_step_impl::<true>(comps, b, acc)
}

/// Lanes of the explicit partial sums (lets reductions vectorise, in a fixed order).
const LANES: usize = 4;

#[inline(always)]
fn e_step_impl<const F: bool>(
    comps: &[EmComponent],
    b: &mut Buffers,
    acc: &mut Vec<[f64; 6]>,
) -> f64 {
    let ns = b.theta.len();
    let nj = comps.len();
    b.near.resize(nj * ns, 0.0);
    b.e.resize(3 * nj * ns, 0.0);
    b.mx.fill(f64::NEG_INFINITY);
    // Slices of exactly `ns` elements: indexing below needs no bounds checks and the
    // loops vectorise.
    let theta = &b.theta[..ns];
    let rho = &b.rho[..ns];
    let mx = &mut b.mx[..ns];
    for (j, c) in comps.iter().enumerate() {
        let near = &mut b.near[j * ns..(j + 1) * ns];
        let (e0, rest) = b.e[3 * j * ns..3 * (j + 1) * ns].split_at_mut(ns);
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
            let d0 = theta[i] - g.mu[0];
            // Nearest winding, then the one across, then the far one.
            let d = if d0 > PI {
                d0 - TAU
            } else if d0 < -PI {
                d0 + TAU
            } else {
                d0
            };
            let side = if d >= 0.0 { -TAU } else { TAU };
            let dr = rho[i] - g.mu[1];
            let qr = ic * dr * dr;
            let u = 2.0 * ib * dr;
            let q = |t: f64| fma::<F>(t, fma::<F>(ia, t, u), qr);
            let v0 = fma::<F>(-0.5, q(d), g.log_norm);
            let v1 = fma::<F>(-0.5, q(d + side), g.log_norm);
            let v2 = fma::<F>(-0.5, q(d - side), g.log_norm);
            near[i] = d;
            e0[i] = v0;
            e1[i] = v1;
            e2[i] = v2;
            mx[i] = mx[i].max(v0).max(v1).max(v2);
        }
    }
    let inv_s = &mut b.inv_s[..ns];
    inv_s.fill(0.0);
    b.live.clear();
    for col in b.e.chunks_exact_mut(ns) {
        // Windings that never come near the best term of any sample (the far
        // windings of all but wide components) are skipped whole.
        let mut top = [f64::NEG_INFINITY; LANES];
        let (cc, mc) = (col.chunks_exact(LANES), mx.chunks_exact(LANES));
        let (cr, mr) = (cc.remainder(), mc.remainder());
        for (v, m) in cc.zip(mc) {
            for l in 0..LANES {
                top[l] = top[l].max(v[l] - m[l]);
            }
        }
        for (v, m) in cr.iter().zip(mr) {
            top[0] = top[0].max(v - m);
        }
        let is_live = top.iter().any(|&t| t > SKIP_LOG);
        b.live.push(is_live);
        if !is_live {
            continue;
        }
        for ((c, m), s) in col.iter_mut().zip(mx.iter()).zip(inv_s.iter_mut()) {
            let a = *c - m;
            // Computed unconditionally, then selected: keeps the loop branch-free.
            let v = exp_neg_impl::<F>(a);
            let v = if a > SKIP_LOG { v } else { 0.0 };
            *c = v;
            *s += v;
        }
    }
    let mut ll = 0.0;
    for (m, s) in mx.iter().zip(inv_s.iter_mut()) {
        if *m == f64::NEG_INFINITY || m.is_nan() {
            // All-zero density: the sample gets no weight.
            *s = 0.0;
            continue;
        }
        ll += m + s.ln();
        *s = 1.0 / *s;
    }
    acc.clear();
    acc.resize(nj, [0.0; 6]);
    for (j, c) in comps.iter().enumerate() {
        let near = &b.near[j * ns..(j + 1) * ns];
        let mut lanes = [[0.0f64; 6]; LANES];
        for w in 0..3 {
            if !b.live[3 * j + w] {
                continue;
            }
            let col = &b.e[(3 * j + w) * ns..(3 * j + w + 1) * ns];
            let inv_s = &*inv_s;
            let shift = match w {
                0 => 0.0,
                1 => 1.0,
                _ => -1.0,
            };
            let term = |i: usize| {
                let r = col[i] * inv_s[i];
                let d = near[i];
                let side = if d >= 0.0 { -TAU } else { TAU };
                let dt = fma::<F>(shift, side, d);
                let dr = rho[i] - c.mu[1];
                [r, r * dt, r * dr, r * dt * dt, r * dt * dr, r * dr * dr]
            };
            let full = ns / LANES * LANES;
            for i0 in (0..full).step_by(LANES) {
                for (l, lane) in lanes.iter_mut().enumerate() {
                    for (a, v) in lane.iter_mut().zip(term(i0 + l)) {
                        *a += v;
                    }
                }
            }
            for i in full..ns {
                for (a, v) in lanes[0].iter_mut().zip(term(i)) {
                    *a += v;
                }
            }
        }
        // Offsets are taken from the nearest winding of each sample; the M-step adds
        // them to the old mean, which is the original's sum over x - k e.
        for (k, a) in acc[j].iter_mut().enumerate() {
            *a = (lanes[0][k] + lanes[1][k]) + (lanes[2][k] + lanes[3][k]);
        }
    }
    ll
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
    let mut buf = Buffers::new(samples);
    // Per component: R, sum r d (2), sum r d d^T (xx, xy, yy).
    let mut acc: Vec<[f64; 6]> = Vec::with_capacity(comps.len());
    while !comps.is_empty() && out.iterations < p.max_iter {
        let ll = e_step(&comps, &mut buf, &mut acc);
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
    fn baseline_and_dispatched_e_steps_agree() {
        // The dispatched E-step may run the AVX2 + FMA build; the baseline must give
        // the same answer up to rounding.
        let x: Vec<[f64; 2]> = (0..1001)
            .map(|i| {
                let t = (i as f64 * 0.7548776662).fract();
                [wrap_2pi(6.0 + 1.5 * t + 0.3 * (i % 3) as f64), 0.5 + t]
            })
            .collect();
        let comps = vec![
            EmComponent {
                mu: [0.1, 1.0],
                cov: [0.3, 0.01, 0.01, 0.05],
                weight: 0.6,
            },
            EmComponent {
                mu: [3.0, 0.7],
                cov: [2.0, 0.0, 0.0, 0.2],
                weight: 0.4,
            },
        ];
        let (mut a, mut b) = (Vec::new(), Vec::new());
        let la = e_step(&comps, &mut Buffers::new(&x), &mut a);
        let lb = e_step_impl::<false>(&comps, &mut Buffers::new(&x), &mut b);
        assert!((la - lb).abs() < 1e-9 * la.abs(), "{la} {lb}");
        for (p, q) in a.iter().zip(&b) {
            for k in 0..6 {
                assert!(
                    (p[k] - q[k]).abs() < 1e-9 * (1.0 + q[k].abs()),
                    "{p:?} {q:?}"
                );
            }
        }
    }

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
