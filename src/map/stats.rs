//! Circular-linear statistics of a set of (direction, speed) samples (section 2 of
//! `cliffmap-building.md`) and small 2x2 helpers shared by the map type, mean shift, EM,
//! updates, densities and scores.

use std::f64::consts::TAU;

use crate::math::wrap_pi;

/// Circular-linear statistics of a sample set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircularLinearStats {
    /// Number of samples.
    pub n: usize,
    /// Mean direction in `[0, 2pi)`.
    pub mean_theta: f64,
    /// Length of the mean resultant vector.
    pub resultant: f64,
    /// Direction variance `-2 ln R`.
    pub var_theta: f64,
    /// Mean speed.
    pub mean_rho: f64,
    /// Sample variance of the speed (n - 1).
    pub var_rho: f64,
    /// Cross term: sum of `(rho - mean rho) * wrap_pi(theta - mean theta)` over `n - 1`.
    pub cross: f64,
}

impl CircularLinearStats {
    /// Statistics of the samples `(theta, rho)` (at least one; two for the variances).
    pub fn of<'a>(samples: impl Iterator<Item = &'a [f64; 2]> + Clone) -> Self {
        let (mut n, mut s, mut c, mut r) = (0usize, 0.0, 0.0, 0.0);
        for x in samples.clone() {
            n += 1;
            s += x[0].sin();
            c += x[0].cos();
            r += x[1];
        }
        let nf = n as f64;
        let (ms, mc) = (s / nf, c / nf);
        let resultant = ms.hypot(mc);
        let mean_theta = crate::math::wrap_2pi(ms.atan2(mc));
        let mean_rho = r / nf;
        let (mut vr, mut cross) = (0.0, 0.0);
        for x in samples {
            let dr = x[1] - mean_rho;
            vr += dr * dr;
            cross += dr * wrap_pi(x[0] - mean_theta);
        }
        let dof = nf - 1.0;
        Self {
            n,
            mean_theta,
            resultant,
            var_theta: -2.0 * resultant.ln(),
            mean_rho,
            var_rho: vr / dof,
            cross: cross / dof,
        }
    }

    /// The covariance `[V_theta, cross, cross, V_rho]`.
    pub fn cov(&self) -> [f64; 4] {
        [self.var_theta, self.cross, self.cross, self.var_rho]
    }
}

/// Eigenvalues `(large, small)` of the symmetric part of a 2x2 matrix.
#[inline]
pub fn eig_sym(cov: [f64; 4]) -> (f64, f64) {
    let a = cov[0];
    let d = cov[3];
    let b = 0.5 * (cov[1] + cov[2]);
    let disc = ((a - d) * 0.5).hypot(b);
    ((a + d) * 0.5 + disc, (a + d) * 0.5 - disc)
}

/// The symmetric 2x2 matrix with the same eigenvectors and every eigenvalue raised to
/// at least `floor`.
pub fn floor_eigenvalues(cov: [f64; 4], floor: f64) -> [f64; 4] {
    let a = cov[0];
    let d = cov[3];
    let b = 0.5 * (cov[1] + cov[2]);
    let (l1, l2) = eig_sym([a, b, b, d]);
    if l2 >= floor {
        return [a, b, b, d];
    }
    // Unit eigenvector of l1.
    let (v1x, v1y) = if b.abs() > 1e-300 {
        let (x, y) = (l1 - d, b);
        let n = x.hypot(y);
        (x / n, y / n)
    } else if a >= d {
        (1.0, 0.0)
    } else {
        (0.0, 1.0)
    };
    let (v2x, v2y) = (-v1y, v1x);
    let (l1, l2) = (l1.max(floor), l2.max(floor));
    let xx = l1 * v1x * v1x + l2 * v2x * v2x;
    let xy = l1 * v1x * v1y + l2 * v2x * v2y;
    let yy = l1 * v1y * v1y + l2 * v2y * v2y;
    [xx, xy, xy, yy]
}

/// A Gaussian over (theta, rho) prepared for density evaluation: the inverse covariance
/// and the log of the normalising constant times a weight.
#[derive(Debug, Clone, Copy)]
pub struct Gauss2 {
    /// Mean (theta, rho).
    pub mu: [f64; 2],
    /// Inverse covariance entries (xx, xy, yy).
    pub inv: [f64; 3],
    /// `ln(weight) - ln(2 pi) - ln(det) / 2`.
    pub log_norm: f64,
}

impl Gauss2 {
    /// Prepare a weighted Gaussian; `None` when the covariance is not positive definite.
    #[inline]
    pub fn new(mu: [f64; 2], cov: [f64; 4], weight: f64) -> Option<Self> {
        let (a, b, d) = (cov[0], 0.5 * (cov[1] + cov[2]), cov[3]);
        let det = a * d - b * b;
        if !(det > 0.0 && a > 0.0 && det.is_finite()) {
            return None;
        }
        Some(Self {
            mu,
            inv: [d / det, -b / det, a / det],
            log_norm: weight.ln() - TAU.ln() - 0.5 * det.ln(),
        })
    }

    /// Squared Mahalanobis distance of the offset `(dt, dr)`.
    #[inline]
    pub fn maha(&self, dt: f64, dr: f64) -> f64 {
        self.inv[0] * dt * dt + 2.0 * self.inv[1] * dt * dr + self.inv[2] * dr * dr
    }

    /// Log of the weighted semi-wrapped density at `(theta, rho)`, summed over winding
    /// numbers -1, 0, 1 (`theta` and the mean both in `[0, 2pi)`).
    #[inline]
    pub fn log_density_wrapped(&self, theta: f64, rho: f64) -> f64 {
        let d0 = theta - self.mu[0];
        let dr = rho - self.mu[1];
        let q = [
            self.maha(d0 + TAU, dr),
            self.maha(d0, dr),
            self.maha(d0 - TAU, dr),
        ];
        let m = q[0].min(q[1]).min(q[2]);
        let s: f64 = q.iter().map(|&x| (-0.5 * (x - m)).exp()).sum();
        self.log_norm - 0.5 * m + s.ln()
    }
}

/// `ln(sum(exp(v)))` of the values, `-inf` for an empty or all `-inf` slice.
#[inline]
pub fn log_sum_exp(v: &[f64]) -> f64 {
    let m = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if m == f64::NEG_INFINITY {
        return m;
    }
    m + v.iter().map(|x| (x - m).exp()).sum::<f64>().ln()
}

/// `ln(sum(exp(v)))` of the values in one pass, each term scaled by the largest so far
/// (so none underflows unless the largest does); `-inf` for none or all `-inf`.
#[inline]
pub(crate) fn log_sum_exp_streaming(values: impl IntoIterator<Item = f64>) -> f64 {
    let (mut m, mut sum) = (f64::NEG_INFINITY, 0.0);
    for v in values {
        if v > m {
            sum = sum * (m - v).exp() + 1.0;
            m = v;
        } else if v > f64::NEG_INFINITY {
            sum += (v - m).exp();
        }
    }
    if m == f64::NEG_INFINITY {
        m
    } else {
        m + sum.ln()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_across_zero() {
        let s = [[0.1, 1.0], [TAU - 0.1, 1.2], [0.0, 1.1]];
        let st = CircularLinearStats::of(s.iter());
        assert!(wrap_pi(st.mean_theta).abs() < 1e-12);
        assert!((st.mean_rho - 1.1).abs() < 1e-12);
        assert!(st.var_theta > 0.0 && st.var_theta < 0.02);
        // rho rises where theta falls: negative cross term
        assert!(st.cross < 0.0);
    }

    #[test]
    fn floor_keeps_eigenvectors() {
        let c = floor_eigenvalues([1.0, 0.999, 0.999, 1.0], 0.01);
        let (l1, l2) = eig_sym(c);
        assert!(
            (l1 - 1.999).abs() < 1e-9 && (l2 - 0.01).abs() < 1e-9,
            "{l1} {l2}"
        );
        assert!((c[1] - c[2]).abs() < 1e-15);
        let same = [0.5, 0.1, 0.1, 0.2];
        assert_eq!(floor_eigenvalues(same, 1e-4), same);
    }

    #[test]
    fn wrapped_density_integrates_to_weight() {
        let g = Gauss2::new([0.2, 1.0], [0.3, 0.01, 0.01, 0.04], 0.7).unwrap();
        let (nt, nr) = (400, 400);
        let (dt, dr) = (TAU / nt as f64, 3.0 / nr as f64);
        let mut total = 0.0;
        for i in 0..nt {
            for j in 0..nr {
                let t = (i as f64 + 0.5) * dt;
                let r = (j as f64 + 0.5) * dr - 0.5;
                total += g.log_density_wrapped(t, r).exp() * dt * dr;
            }
        }
        assert!((total - 0.7).abs() < 1e-3, "{total}");
    }
}
