//! The log-density of a prediction step's velocity, for sample scores
//! ([`CliffMap::step_log_density`](super::CliffMap::step_log_density)), approximated for
//! speed: the log-density of the likeliest component.
//!
//! A location's mixture is stored in blocks of four components, field by field in
//! single precision, so that one step evaluates four components with four-lane
//! instructions and no branch. Per component, with the heading `theta` and the speed
//! offset `dr` from the component's mean speed, the bivariate normal is split into the
//! speed's marginal and the heading given the speed:
//! `log_norm - h_rho dr^2 - h_theta x^2`, where `x = theta - mu - slope dr` is the
//! heading's offset from its mean given the speed, wrapped to `[-pi, pi]`. The step's
//! value is the largest of these.
//!
//! The approximation, against the semi-wrapped mixture of
//! [`CliffMap::log_density`](super::CliffMap::log_density) (weights, all components,
//! windings -1, 0, 1 around `theta - mu`):
//!
//! * the likeliest component rather than the sum of all (a log-sum-exp replaced by its
//!   largest term): lower by at most `ln` of the number of components, and only where two
//!   components explain the step about equally; nothing where one does;
//! * one winding, the offset nearest the heading's mean given the speed: the two left
//!   out are at least pi from that mean and add at most
//!   `exp(-2 pi (pi - |x|) / s^2)` times the term each (`s` the heading's deviation given
//!   the speed), below 1e-3 of it for `|x| < pi - 1.1 s^2`, and up to `ln 3` lower for
//!   the widest components, which are near-uniform in the heading;
//! * where a component's heading and speed are strongly correlated and the speed far
//!   from its mean (the heading's mean given the speed many turns away), the windings
//!   around `theta - mu` miss the nearest one and this value is the higher (closer to
//!   the density the mixture defines);
//! * single precision and the polynomial `atan2` of the prediction loop: within 1e-3
//!   otherwise.
//!
//! Measured on real predictions (THÖR1 and ATC maps, 60 people each, with and without
//! the speed kernel; test `scores_rank_real_predictions_as_the_maps_density_does`): the
//! median step is 0.002 to 0.04 below the map's log-density, 99 % are within 0.2, and the
//! scores order 99 % of the pairs of samples of a person as the map's density does.

use std::f32::consts::TAU;

use super::stats::Gauss2;
use crate::math::f32x4::{F32x4, ROUND_MAGIC};

/// Four components, field by field (two cache lines), and where the location's other
/// blocks are.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Block {
    /// Mean heading, in `[-pi, pi]`.
    mu: [f32; 4],
    rho: [f32; 4],
    /// Change of the heading's mean given the speed, per m/s of speed offset.
    slope: [f32; 4],
    /// Half the heading's precision given the speed, `1 / (2 s^2)`.
    h_theta: [f32; 4],
    /// Half the speed's marginal precision.
    h_rho: [f32; 4],
    /// `ln(weight) - ln(2 pi) - ln(det) / 2`; [`EMPTY`] for padding.
    log_norm: [f32; 4],
    /// The location's further blocks (more than four components) in
    /// [`StepDensities::more`]: `more[0]..more[1]`, empty for most.
    more: [u32; 2],
}

impl Block {
    const EMPTY: Block = Block {
        mu: [0.0; 4],
        rho: [0.0; 4],
        slope: [0.0; 4],
        h_theta: [0.0; 4],
        h_rho: [0.0; 4],
        log_norm: [EMPTY; 4],
        more: [0; 2],
    };
}

/// The log-norm of a padding slot: its terms vanish beside any real component's, and
/// arithmetic on it stays finite. A location without components scores about this.
const EMPTY: f32 = -1e30;

/// Every location's components in blocks of four.
#[derive(Debug, Clone, Default)]
pub(super) struct StepDensities {
    /// Location `i`'s first four components are `first[i]`.
    first: Vec<Block>,
    /// The blocks of the components after the fourth.
    more: Vec<Block>,
}

impl StepDensities {
    /// Blocks for the components `density[density_start[i]..density_start[i + 1]]` of
    /// every location `i`.
    pub(super) fn new(density_start: &[u32], density: &[Gauss2]) -> Self {
        let mut first = Vec::with_capacity(density_start.len().saturating_sub(1));
        let mut more = Vec::new();
        for w in density_start.windows(2) {
            let comps = &density[w[0] as usize..w[1] as usize];
            let mut blocks = comps.chunks(4).map(block);
            let mut head = blocks.next().unwrap_or(Block::EMPTY);
            let from = more.len() as u32;
            more.extend(blocks);
            head.more = [from, more.len() as u32];
            first.push(head);
        }
        Self { first, more }
    }

    /// The log-density of the velocity (heading `theta`, any angle within a few turns
    /// of zero, and speed `rho`) under location `index`'s likeliest component (see the
    /// [module documentation](self)); about -1e30 for a location without components.
    #[inline(always)]
    pub(super) fn log_density(&self, index: usize, theta: f32, rho: f32) -> f32 {
        let b = &self.first[index];
        let (theta, rho) = (F32x4::splat(theta), F32x4::splat(rho));
        let m = b.terms(theta, rho).max_lane();
        if b.more[0] == b.more[1] {
            return m;
        }
        self.more[b.more[0] as usize..b.more[1] as usize]
            .iter()
            .fold(m, |m, blk| m.max(blk.terms(theta, rho).max_lane()))
    }
}

#[cfg(target_arch = "x86_64")]
impl StepDensities {
    /// [`log_density`](Self::log_density) of eight lanes (locations `loc`, headings
    /// `theta`, speeds `rho`): the first blocks' fields loaded whole and transposed, the
    /// four components' terms and their largest for eight lanes at once (the
    /// operations and the order of `Block::terms` and `F32x4::max_lane`, so the same
    /// bits), the further blocks lane by lane.
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA; every lane of `loc` must be a location.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(super) unsafe fn log_density8(
        &self,
        loc: std::arch::x86_64::__m256i,
        theta: std::arch::x86_64::__m256,
        rho: std::arch::x86_64::__m256,
    ) -> std::arch::x86_64::__m256 {
        use std::arch::x86_64::*;
        use std::mem::{offset_of, size_of};
        const { assert!(size_of::<Block>().is_power_of_two()) };
        let mut at = [0u32; 8];
        // SAFETY: eight lanes.
        unsafe { _mm256_storeu_si256(at.as_mut_ptr() as *mut __m256i, loc) };
        debug_assert!(at.iter().all(|&i| (i as usize) < self.first.len()));
        let base = self.first.as_ptr() as *const u8;
        // SAFETY: each lane's block is one of `first` (as this function requires).
        let field = |offset: usize| unsafe {
            super::block_loads::slots4(std::array::from_fn(|l| {
                base.add(at[l] as usize * size_of::<Block>() + offset) as *const f32
            }))
        };
        let (mu, rho_c, slope) = (
            field(offset_of!(Block, mu)),
            field(offset_of!(Block, rho)),
            field(offset_of!(Block, slope)),
        );
        let (h_theta, h_rho, log_norm) = (
            field(offset_of!(Block, h_theta)),
            field(offset_of!(Block, h_rho)),
            field(offset_of!(Block, log_norm)),
        );
        let s = _mm256_set1_ps;
        let (sub, mul) = (_mm256_sub_ps, _mm256_mul_ps);
        let magic = s(ROUND_MAGIC);
        let terms: [__m256; 4] = std::array::from_fn(|c| {
            let dr = sub(rho, rho_c[c]);
            let x = sub(sub(theta, mu[c]), mul(slope[c], dr));
            let turns = sub(_mm256_add_ps(mul(x, s(1.0 / TAU)), magic), magic);
            let x = sub(x, mul(s(TAU), turns));
            sub(
                sub(log_norm[c], mul(mul(h_rho[c], dr), dr)),
                mul(mul(h_theta[c], x), x),
            )
        });
        // (max_lane's pairs: the first with the third, the second with the fourth)
        let most = _mm256_max_ps(
            _mm256_max_ps(terms[0], terms[2]),
            _mm256_max_ps(terms[1], terms[3]),
        );
        // the lanes whose locations have further blocks (their `more` ranges gathered:
        // most have none, and then no lane is visited)
        let more = |i: usize| {
            let index = _mm256_add_epi32(
                _mm256_slli_epi32::<{ (size_of::<Block>() / 4).trailing_zeros() as i32 }>(loc),
                _mm256_set1_epi32((offset_of!(Block, more) / 4 + i) as i32),
            );
            // SAFETY: each lane's index is a word of its location's block.
            unsafe { _mm256_i32gather_epi32::<4>(base as *const i32, index) }
        };
        let further = _mm256_cmpgt_epi32(more(1), more(0));
        let mut lanes = _mm256_movemask_ps(_mm256_castsi256_ps(further)) as u32;
        if lanes == 0 {
            return most;
        }
        let mut out = [0.0f32; 8];
        let (mut th, mut r) = ([0.0f32; 8], [0.0f32; 8]);
        // SAFETY: eight lanes.
        unsafe {
            _mm256_storeu_ps(out.as_mut_ptr(), most);
            _mm256_storeu_ps(th.as_mut_ptr(), theta);
            _mm256_storeu_ps(r.as_mut_ptr(), rho);
        }
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let b = &self.first[at[l] as usize];
            let (theta, rho) = (F32x4::splat(th[l]), F32x4::splat(r[l]));
            out[l] = self.more[b.more[0] as usize..b.more[1] as usize]
                .iter()
                .fold(out[l], |m, blk| m.max(blk.terms(theta, rho).max_lane()));
        }
        // SAFETY: eight lanes.
        unsafe { _mm256_loadu_ps(out.as_ptr()) }
    }
}

/// One block of up to four components.
fn block(comps: &[Gauss2]) -> Block {
    let mut b = Block::EMPTY;
    for (c, g) in comps.iter().enumerate() {
        let [tt, tr, rr] = g.inv;
        let mu = g.mu[0].rem_euclid(std::f64::consts::TAU);
        b.mu[c] = (if mu > std::f64::consts::PI {
            mu - std::f64::consts::TAU
        } else {
            mu
        }) as f32;
        b.rho[c] = g.mu[1] as f32;
        // joint quadratic form tt d^2 + 2 tr d dr + rr dr^2
        //   = tt (d + tr / tt dr)^2 + (rr - tr^2 / tt) dr^2
        b.slope[c] = (-tr / tt) as f32;
        b.h_theta[c] = (0.5 * tt) as f32;
        b.h_rho[c] = (0.5 * (rr - tr * tr / tt)).max(0.0) as f32;
        b.log_norm[c] = g.log_norm.max(EMPTY as f64) as f32;
    }
    b
}

impl Block {
    /// The components' log-densities at the principal winding, four per instruction.
    #[inline(always)]
    fn terms(&self, theta: F32x4, rho: F32x4) -> F32x4 {
        let s = F32x4::splat;
        let dr = rho - F32x4::load(&self.rho);
        let x = (theta - F32x4::load(&self.mu)) - F32x4::load(&self.slope) * dr;
        let x = x - s(TAU) * (x * s(1.0 / TAU)).round();
        (F32x4::load(&self.log_norm) - F32x4::load(&self.h_rho) * dr * dr)
            - F32x4::load(&self.h_theta) * x * x
    }
}
