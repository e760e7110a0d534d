//! The map's density of a velocity at a location: [`CliffMap::log_density`] (exact)
//! and [`CliffMap::step_log_density`] (the prediction loop's single-precision score).

use super::cliff_map::CliffMap;
use super::stats::log_sum_exp_streaming;
use crate::math::wrap_2pi;

impl CliffMap {
    /// Log-density of the velocity `(theta, rho)` (rad, m/s) under location `index`'s
    /// mixture (weights renormalised, covariance eigenvalues floored at 1e-4, winding
    /// numbers -1, 0, 1), as [`score`](score::score) computes it; `-inf` for a location
    /// without components.
    pub fn log_density(&self, index: usize, theta: f64, rho: f64) -> f64 {
        let a = self.density_start[index] as usize;
        let b = self.density_start[index + 1] as usize;
        let theta = wrap_2pi(theta);
        log_sum_exp_streaming(
            self.density[a..b]
                .iter()
                .map(|g| g.log_density_wrapped(theta, rho)),
        )
    }
}

impl CliffMap {
    /// [`log_density`](Self::log_density) approximated for the prediction loop's sample
    /// scores: the log-density of the likeliest component at the winding nearest the
    /// heading, in single precision, the heading given as a unit vector `(ux, uy)`. At
    /// most [`log_density`](Self::log_density) (within 1e-3 relative) and at most
    /// `ln(3 x components)` below it, equal where one component explains the step, except for
    /// strongly correlated components far in the speed tail, where this is the closer
    /// to the mixture's density (see `src/map/density.rs`). `-inf` for a location without
    /// components.
    #[inline]
    pub fn step_log_density(&self, index: usize, ux: f32, uy: f32, rho: f64) -> f64 {
        let theta = crate::math::fastmath::atan2_f32(uy, ux);
        self.step_log_density_at(index, theta, rho as f32) as f64
    }

    /// [`step_log_density`](Self::step_log_density) at the heading `theta` (rad), for
    /// the prediction loop (which takes the headings' angles four samples at a time).
    #[inline(always)]
    pub(crate) fn step_log_density_at(&self, index: usize, theta: f32, rho: f32) -> f32 {
        let v = self.step_density.log_density(index, theta, rho);
        if v <= -1e29 { f32::NEG_INFINITY } else { v }
    }

    /// [`step_log_density_at`](Self::step_log_density_at) of eight lanes (locations
    /// `loc`, headings `theta`, speeds `rho`): the same bits, eight to a register.
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA; every lane of `loc` must be a location.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(crate) unsafe fn step_log_density8(
        &self,
        loc: std::arch::x86_64::__m256i,
        theta: std::arch::x86_64::__m256,
        rho: std::arch::x86_64::__m256,
    ) -> std::arch::x86_64::__m256 {
        use std::arch::x86_64::*;
        // SAFETY: as this function requires.
        let v = unsafe { self.step_density.log_density8(loc, theta, rho) };
        let none = _mm256_cmp_ps::<_CMP_LE_OQ>(v, _mm256_set1_ps(-1e29));
        _mm256_blendv_ps(v, _mm256_set1_ps(f32::NEG_INFINITY), none)
    }
}

impl CliffMap {
    /// Log-density of the heading `theta` (rad) given the speed `rho` (m/s) under
    /// location `index`'s mixture: [`log_density`](Self::log_density) less the log of
    /// the mixture's density of the speed `rho` (each component's speed marginal is
    /// normal, its windings summed out), so that a map explaining a person's speed but
    /// not their heading gains nothing from the speed. `-inf` for a location without
    /// components.
    pub fn heading_log_density(&self, index: usize, theta: f64, rho: f64) -> f64 {
        let joint = self.log_density(index, theta, rho);
        if joint == f64::NEG_INFINITY {
            return joint;
        }
        let a = self.density_start[index] as usize;
        let b = self.density_start[index + 1] as usize;
        // a component's speed marginal from its inverse covariance `inv`: variance
        // `inv_xx / det(inv)`, weight `exp(log_norm) 2 pi / sqrt(det(inv))`, so log-density
        // `log_norm - (rho - mu)^2 / (2 var) + ln(2 pi / inv_xx) / 2`; summed in one pass
        // (a speed far from every component underflows no term)
        let speed = log_sum_exp_streaming(self.density[a..b].iter().map(|g| {
            let det_inv = g.inv[0] * g.inv[2] - g.inv[1] * g.inv[1];
            let d = rho - g.mu[1];
            g.log_norm - 0.5 * d * d * det_inv / g.inv[0]
                + 0.5 * (std::f64::consts::TAU / g.inv[0]).ln()
        }));
        joint - speed
    }
}
