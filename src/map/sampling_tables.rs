//! The sampling tables a map derives from its locations at construction: per component
//! the cumulative weight, mean and spread of the direction draw, the speed given the
//! direction, and the follow blocks of the heading-weighted draw, padded so that the
//! hot loop reads whole blocks.

use super::location::Location;
use crate::math::wrap_2pi;

/// Per-component sampling table entry, precomputed at build time.
#[derive(Debug, Clone, Copy)]
pub(super) struct DirectionComponent {
    /// Cumulative normalised weight up to and including this component.
    pub(super) cum_weight: f64,
    /// Mean direction.
    pub(super) mu: f64,
    /// Standard deviation of the direction marginal of the PSD-clamped covariance.
    pub(super) sigma: f64,
}

/// Per-component speed entry, parallel to [`DirectionComponent`]: the speed given the
/// direction draw `mu + sigma * z` is `mean + slope * z + sd * z2` (the conditional of
/// the component's bivariate normal).
#[derive(Debug, Clone, Copy)]
pub(super) struct SpeedComponent {
    pub(super) mean: f32,
    pub(super) slope: f32,
    pub(super) sd: f32,
}

/// A standard normal deviate approximated by the sum of four uniforms (the bytes of
/// `bits`): mean 0, variance 1 (to 2e-5), its distribution function within 0.01 of the
/// normal's, bounded by +-3.46 (where a normal has 5e-4 of its mass). Costs a few integer instructions against a normal draw's table lookups
/// and second random word; the speed kernel's noise needs no more.
#[inline(always)]
pub(super) fn four_uniforms_normal(bits: u32) -> f32 {
    // the four bytes summed pairwise: 0..=1020
    let pairs = (bits & 0x00ff_00ff) + ((bits >> 8) & 0x00ff_00ff);
    let sum = (pairs & 0xffff) + (pairs >> 16);
    // each byte b stands for the uniform (b + 1/2) / 256 (mean 1/2, variance 1/12)
    const SCALE: f32 = 1.732_050_8 / 256.0;
    (sum as f32 + 2.0) * SCALE - 2.0 * 1.732_050_8
}

/// Four components of one location for [`CliffMap::direction_following`], field by
/// field so the four weights are computed together: normalised weights (0 for padding)
/// and the unit vectors of the mean directions (padding repeats the location's last
/// direction, so it never raises the largest cosine).
#[derive(Debug, Clone, Copy)]
pub(super) struct FollowBlock {
    pub(super) weight: [f32; 4],
    /// The weights' logarithms (minus infinity for padding).
    pub(super) log_weight: [f32; 4],
    pub(super) cos_mu: [f32; 4],
    pub(super) sin_mu: [f32; 4],
}

impl FollowBlock {
    /// A block of padding only (weight 0, log-weight minus infinity): the start of
    /// every block before its components are written in.
    pub(super) const PADDING: FollowBlock = FollowBlock {
        weight: [0.0; 4],
        log_weight: [f32::NEG_INFINITY; 4],
        cos_mu: [0.0; 4],
        sin_mu: [0.0; 4],
    };
}

/// The follow blocks of every location: location `i`'s are
/// `blocks[starts[i]..starts[i + 1]]`, the components in order, four to a block. On maps
/// whose widest mixture fits in two blocks every location gets the same number of blocks
/// (a count that changes from step to step costs a mispredicted branch).
pub(super) fn follow_blocks(locations: &[Location]) -> (Vec<u32>, Vec<FollowBlock>) {
    let blocks_for = |n: usize| n.div_ceil(4).max(1);
    let widest = locations
        .iter()
        .map(|l| l.components.len())
        .max()
        .unwrap_or(0);
    let fixed = (blocks_for(widest) <= 2).then(|| blocks_for(widest));
    let mut starts = Vec::with_capacity(locations.len() + 1);
    let mut blocks = Vec::new();
    for loc in locations {
        starts.push(blocks.len() as u32);
        let total: f64 = loc.components.iter().map(|c| c.weight).sum();
        let n = loc.components.len();
        for b in 0..fixed.unwrap_or(blocks_for(n)) {
            let mut block = FollowBlock::PADDING;
            for l in 0..4 {
                let j = 4 * b + l;
                let c = &loc.components[j.min(n - 1)];
                if j < n {
                    block.weight[l] = (c.weight / total) as f32;
                    block.log_weight[l] = block.weight[l].ln();
                }
                block.cos_mu[l] = c.theta.cos() as f32;
                block.sin_mu[l] = c.theta.sin() as f32;
            }
            blocks.push(block);
        }
    }
    starts.push(blocks.len() as u32);
    (starts, blocks)
}

/// The cumulative follow weights of a location's `blocks` (at most `W / 4`) for the heading
/// `(ux, uy)`: the weights `w_j exp(kappa (cos_j - max cos))` are those of the rule of
/// [`CliffMap::direction_following`] scaled by a common factor (so the likeliest
/// direction's term never underflows), in single precision, four at a time; their
/// relative error (about 1e-7) moves a choice only for draws within that of a boundary.
/// Slots past the blocks hold the total.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // four lanes, indexed alike
pub(super) fn follow_cumulative<const W: usize>(
    blocks: &[FollowBlock],
    ux: f32,
    uy: f32,
    kappa: f32,
) -> [f32; W] {
    use crate::math::fastmath::exp_neg_f32;
    let mut cos = [0.0f32; W];
    let mut most = -1.0f32;
    for (b, out) in blocks.iter().zip(cos.chunks_exact_mut(4)) {
        for l in 0..4 {
            out[l] = ux * b.cos_mu[l] + uy * b.sin_mu[l];
            most = most.max(out[l]);
        }
    }
    let mut weight = [0.0f32; W];
    for ((b, c), out) in blocks
        .iter()
        .zip(cos.chunks_exact(4))
        .zip(weight.chunks_exact_mut(4))
    {
        for l in 0..4 {
            out[l] = b.weight[l] * exp_neg_f32(kappa * (c[l] - most));
        }
    }
    let mut total = 0.0f32;
    for w in weight.iter_mut() {
        total += *w;
        *w = total;
    }
    weight
}

/// [`follow_cumulative`] for exactly `B` blocks (1 or 2) into eight slots: the same
/// arithmetic in the same order, so the same bits, four components per SSE instruction
/// on x86-64 (the general version's loops over a slice of blocks stay scalar, about
/// three times the instructions).
#[inline(always)]
pub(super) fn follow_cumulative_fixed<const B: usize>(
    blocks: &[FollowBlock; B],
    ux: f32,
    uy: f32,
    kappa: f32,
) -> [f32; 8] {
    debug_assert!((1..=2).contains(&B));
    #[cfg(not(target_arch = "x86_64"))]
    return follow_cumulative::<8>(blocks, ux, uy, kappa);
    #[cfg(target_arch = "x86_64")]
    {
        running_sums(follow_sse::weights(blocks, ux, uy, kappa))
    }
}

/// The mean direction `(cos, sin)` of the likeliest of `blocks`' components for the
/// heading `(ux, uy)` under the follow rule of concentration `kappa`: the largest
/// `ln w_j + kappa cos(heading - mu_j)`, ties to the first.
#[inline(always)]
pub(super) fn follow_mode_of(blocks: &[FollowBlock], ux: f32, uy: f32, kappa: f32) -> (f32, f32) {
    #[cfg(target_arch = "x86_64")]
    match blocks {
        [a, b] => return follow_sse::mode(&[*a, *b], ux, uy, kappa),
        [a] => return follow_sse::mode(&[*a], ux, uy, kappa),
        _ => {}
    }
    let (mut best, mut dir) = (f32::NEG_INFINITY, (ux, uy));
    for b in blocks {
        for l in 0..4 {
            let v = b.log_weight[l] + kappa * (ux * b.cos_mu[l] + uy * b.sin_mu[l]);
            if v > best {
                (best, dir) = (v, (b.cos_mu[l], b.sin_mu[l]));
            }
        }
    }
    dir
}

/// [`follow_cumulative_fixed`] of two blocks with eight components per AVX instruction:
/// the same operations on each component, in the same order (no fused multiply-adds),
/// so the same bits. The AVX2 lane loop's follow weights for maps whose locations hold
/// five to eight components.
///
/// # Safety
/// The processor must have AVX2 and FMA. (Inlined into the AVX2 lane loop, whose
/// target features it then compiles with.)
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) unsafe fn follow_cumulative_avx2(
    blocks: &[FollowBlock; 2],
    ux: f32,
    uy: f32,
    kappa: f32,
) -> [f32; 8] {
    // SAFETY: AVX2, as this function requires.
    running_sums(unsafe { follow_avx::weights(blocks, ux, uy, kappa) })
}

/// [`follow_cumulative_fixed`] of one block each for two headings (two lanes of the
/// lane loop, each with its location's block), both in one AVX register, operation for
/// operation: the same bits as two calls of the SSE version.
///
/// # Safety
/// The processor must have AVX2 and FMA. (Inlined into the AVX2 lane loop, whose
/// target features it then compiles with.)
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) unsafe fn follow_cumulative_pair_avx2(
    blocks: [&FollowBlock; 2],
    ux: [f32; 2],
    uy: [f32; 2],
    kappa: f32,
) -> [[f32; 8]; 2] {
    // SAFETY: AVX2, as this function requires.
    let weight = unsafe { follow_avx::weights_pair(blocks, ux, uy, kappa) };
    // (the second block's slots are zero)
    weight.map(running_sums)
}

/// The running sums of eight weights, one after the other (as
/// [`follow_cumulative`] sums: the same bits on every path).
#[inline(always)]
fn running_sums(weight: [f32; 8]) -> [f32; 8] {
    let mut cum = [0.0f32; 8];
    let mut total = 0.0f32;
    for (c, w) in cum.iter_mut().zip(weight) {
        total += w;
        *c = total;
    }
    cum
}

/// The follow weights of two blocks in one AVX register ([`follow_cumulative_avx2`]).
#[cfg(target_arch = "x86_64")]
pub(super) mod follow_avx {
    use super::FollowBlock;
    use std::arch::x86_64::*;

    /// Two blocks' four floats in one register: `lo` in the lower half.
    ///
    /// # Safety
    /// The processor must have AVX.
    #[inline(always)]
    unsafe fn pair(lo: &[f32; 4], hi: &[f32; 4]) -> __m256 {
        // SAFETY: AVX, as this function requires; the loads read four floats each.
        unsafe { _mm256_set_m128(_mm_loadu_ps(hi.as_ptr()), _mm_loadu_ps(lo.as_ptr())) }
    }

    /// `follow_sse::exp_neg` on eight lanes, operation for operation (also the follow
    /// weights of eight lanes' locations, `CliffMap::lane_following8`).
    ///
    /// # Safety
    /// The processor must have AVX2.
    #[inline(always)]
    pub(in crate::map) unsafe fn exp_neg(x: __m256) -> __m256 {
        const MAGIC: f32 = 12_582_912.0;
        const LN2_HI: f32 = 0.693_145_75;
        const LN2_LO: f32 = 1.428_606_8e-6;
        // SAFETY: AVX2, as this function requires.
        unsafe {
            let s = |v| _mm256_set1_ps(v);
            let xc = _mm256_max_ps(x, s(-87.0));
            let t = _mm256_add_ps(_mm256_mul_ps(xc, s(std::f32::consts::LOG2_E)), s(MAGIC));
            let k = _mm256_sub_ps(t, s(MAGIC));
            let nk = _mm256_xor_ps(k, s(-0.0));
            let r = _mm256_add_ps(
                _mm256_mul_ps(nk, s(LN2_LO)),
                _mm256_add_ps(_mm256_mul_ps(nk, s(LN2_HI)), xc),
            );
            let r2 = _mm256_mul_ps(r, r);
            let r4 = _mm256_mul_ps(r2, r2);
            let high = _mm256_add_ps(
                _mm256_mul_ps(r2, s(1.0 / 720.0)),
                _mm256_add_ps(_mm256_mul_ps(r, s(1.0 / 120.0)), s(1.0 / 24.0)),
            );
            let low = _mm256_add_ps(
                _mm256_mul_ps(r2, _mm256_add_ps(_mm256_mul_ps(r, s(1.0 / 6.0)), s(0.5))),
                _mm256_add_ps(s(1.0), r),
            );
            let p = _mm256_add_ps(_mm256_mul_ps(r4, high), low);
            let ki = _mm256_sub_epi32(
                _mm256_castps_si256(t),
                _mm256_set1_epi32(MAGIC.to_bits() as i32),
            );
            let scale = _mm256_castsi256_ps(_mm256_slli_epi32::<23>(_mm256_add_epi32(
                ki,
                _mm256_set1_epi32(127),
            )));
            let y = _mm256_mul_ps(p, scale);
            // below -87: 0
            _mm256_and_ps(y, _mm256_cmp_ps::<_CMP_NLT_US>(x, s(-87.0)))
        }
    }

    /// `follow_sse::weights` of two blocks, both in one register.
    ///
    /// # Safety
    /// The processor must have AVX2.
    #[inline(always)]
    pub(super) unsafe fn weights(
        blocks: &[FollowBlock; 2],
        ux: f32,
        uy: f32,
        kappa: f32,
    ) -> [f32; 8] {
        let [a, b] = blocks;
        // SAFETY: AVX2, as this function requires; the loads and the store go through
        // references to four and eight floats.
        unsafe {
            let c = _mm256_add_ps(
                _mm256_mul_ps(_mm256_set1_ps(ux), pair(&a.cos_mu, &b.cos_mu)),
                _mm256_mul_ps(_mm256_set1_ps(uy), pair(&a.sin_mu, &b.sin_mu)),
            );
            // the largest cosine, at least -1 (max is exact: its order does not matter)
            let m = _mm256_max_ps(c, _mm256_set1_ps(-1.0));
            let m = _mm_max_ps(_mm256_castps256_ps128(m), _mm256_extractf128_ps::<1>(m));
            let m = _mm_max_ps(m, _mm_movehl_ps(m, m));
            let m = _mm_max_ps(m, _mm_shuffle_ps::<0b01>(m, m));
            let most = _mm256_broadcastss_ps(m);
            let e = exp_neg(_mm256_mul_ps(_mm256_set1_ps(kappa), _mm256_sub_ps(c, most)));
            let w = _mm256_mul_ps(pair(&a.weight, &b.weight), e);
            let mut out = [0.0f32; 8];
            _mm256_storeu_ps(out.as_mut_ptr(), w);
            out
        }
    }

    /// `follow_sse::weights` of one block for each of two headings: the first in the
    /// register's lower half, the second in its upper half (every step within a half).
    ///
    /// # Safety
    /// The processor must have AVX2.
    #[inline(always)]
    pub(super) unsafe fn weights_pair(
        blocks: [&FollowBlock; 2],
        ux: [f32; 2],
        uy: [f32; 2],
        kappa: f32,
    ) -> [[f32; 8]; 2] {
        let [a, b] = blocks;
        // SAFETY: AVX2, as this function requires; the loads and the stores go through
        // references to four floats and to arrays of eight.
        unsafe {
            let halves = |lo: f32, hi: f32| _mm256_set_m128(_mm_set1_ps(hi), _mm_set1_ps(lo));
            let c = _mm256_add_ps(
                _mm256_mul_ps(halves(ux[0], ux[1]), pair(&a.cos_mu, &b.cos_mu)),
                _mm256_mul_ps(halves(uy[0], uy[1]), pair(&a.sin_mu, &b.sin_mu)),
            );
            // each half's largest cosine, at least -1 (max is exact: its order does not
            // matter), then broadcast within the half
            let m = _mm256_max_ps(c, _mm256_set1_ps(-1.0));
            let m = _mm256_max_ps(m, _mm256_permute_ps::<0b11_10_11_10>(m));
            let m = _mm256_max_ps(m, _mm256_permute_ps::<0b00_00_00_01>(m));
            let most = _mm256_permute_ps::<0>(m);
            let e = exp_neg(_mm256_mul_ps(_mm256_set1_ps(kappa), _mm256_sub_ps(c, most)));
            let w = _mm256_mul_ps(pair(&a.weight, &b.weight), e);
            let mut out = [[0.0f32; 8]; 2];
            _mm_storeu_ps(out[0].as_mut_ptr(), _mm256_castps256_ps128(w));
            _mm_storeu_ps(out[1].as_mut_ptr(), _mm256_extractf128_ps::<1>(w));
            out
        }
    }
}

/// The follow weights of [`follow_cumulative_fixed`] in SSE (part of the x86-64
/// baseline).
#[cfg(target_arch = "x86_64")]
mod follow_sse {
    use super::FollowBlock;
    use std::arch::x86_64::*;

    /// `exp_neg_f32` of four lanes of `x <= 0`, operation for operation (its upper
    /// clamp never binds here): the same bits.
    #[inline(always)]
    unsafe fn exp_neg(x: __m128) -> __m128 {
        const MAGIC: f32 = 12_582_912.0;
        const LN2_HI: f32 = 0.693_145_75;
        const LN2_LO: f32 = 1.428_606_8e-6;
        unsafe {
            let s = _mm_set1_ps;
            let (add, mul) = (|a, b| _mm_add_ps(a, b), |a, b| _mm_mul_ps(a, b));
            let xc = _mm_max_ps(x, s(-87.0));
            let t = add(mul(xc, s(std::f32::consts::LOG2_E)), s(MAGIC));
            let k = _mm_sub_ps(t, s(MAGIC));
            let nk = _mm_xor_ps(k, s(-0.0));
            let r = add(mul(nk, s(LN2_LO)), add(mul(nk, s(LN2_HI)), xc));
            let r2 = mul(r, r);
            let r4 = mul(r2, r2);
            let p = add(
                mul(
                    r4,
                    add(
                        mul(r2, s(1.0 / 720.0)),
                        add(mul(r, s(1.0 / 120.0)), s(1.0 / 24.0)),
                    ),
                ),
                add(mul(r2, add(mul(r, s(1.0 / 6.0)), s(0.5))), add(s(1.0), r)),
            );
            let ki = _mm_sub_epi32(_mm_castps_si128(t), _mm_set1_epi32(MAGIC.to_bits() as i32));
            let scale =
                _mm_castsi128_ps(_mm_slli_epi32::<23>(_mm_add_epi32(ki, _mm_set1_epi32(127))));
            let y = mul(p, scale);
            // below -87: 0
            _mm_and_ps(y, _mm_cmpnlt_ps(x, s(-87.0)))
        }
    }

    /// [`follow_mode_of`](super::follow_mode_of) for `B` blocks, four components per
    /// instruction.
    #[inline(always)]
    pub(super) fn mode<const B: usize>(
        blocks: &[FollowBlock; B],
        ux: f32,
        uy: f32,
        kappa: f32,
    ) -> (f32, f32) {
        // SAFETY: SSE is part of the x86-64 baseline; loads go through references to
        // four floats.
        unsafe {
            let (vx, vy, vk) = (_mm_set1_ps(ux), _mm_set1_ps(uy), _mm_set1_ps(kappa));
            let v: [__m128; B] = std::array::from_fn(|b| {
                let c = _mm_mul_ps(vx, _mm_loadu_ps(blocks[b].cos_mu.as_ptr()));
                let c = _mm_add_ps(c, _mm_mul_ps(vy, _mm_loadu_ps(blocks[b].sin_mu.as_ptr())));
                _mm_add_ps(
                    _mm_loadu_ps(blocks[b].log_weight.as_ptr()),
                    _mm_mul_ps(vk, c),
                )
            });
            let mut m = v[0];
            for x in &v[1..] {
                m = _mm_max_ps(m, *x);
            }
            let m = _mm_max_ps(m, _mm_movehl_ps(m, m));
            let m = _mm_max_ps(m, _mm_shuffle_ps::<0b01>(m, m));
            let most = _mm_shuffle_ps::<0>(m, m);
            for (b, x) in v.iter().enumerate() {
                let hit = _mm_movemask_ps(_mm_cmpeq_ps(*x, most));
                if hit != 0 {
                    let l = hit.trailing_zeros() as usize;
                    return (blocks[b].cos_mu[l], blocks[b].sin_mu[l]);
                }
            }
            (ux, uy)
        }
    }

    /// The weights `w_j exp(kappa (cos_j - max cos))` of the blocks' components (not yet
    /// summed), zero past the blocks.
    #[inline(always)]
    pub(super) fn weights<const B: usize>(
        blocks: &[FollowBlock; B],
        ux: f32,
        uy: f32,
        kappa: f32,
    ) -> [f32; 8] {
        // SAFETY: SSE and SSE2 are part of the x86-64 baseline; loads and stores go
        // through references to four floats.
        unsafe {
            let (vx, vy) = (_mm_set1_ps(ux), _mm_set1_ps(uy));
            let cos: [__m128; B] = std::array::from_fn(|b| {
                let c = _mm_mul_ps(vx, _mm_loadu_ps(blocks[b].cos_mu.as_ptr()));
                _mm_add_ps(c, _mm_mul_ps(vy, _mm_loadu_ps(blocks[b].sin_mu.as_ptr())))
            });
            // the largest cosine, at least -1 (no NaN: max's order does not matter)
            let mut m = _mm_max_ps(cos[0], _mm_set1_ps(-1.0));
            for c in &cos[1..] {
                m = _mm_max_ps(m, *c);
            }
            let m = _mm_max_ps(m, _mm_movehl_ps(m, m));
            let m = _mm_max_ps(m, _mm_shuffle_ps::<0b01>(m, m));
            let most = _mm_shuffle_ps::<0>(m, m);
            let mut out = [0.0f32; 8];
            for (b, c) in cos.iter().enumerate() {
                let e = exp_neg(_mm_mul_ps(_mm_set1_ps(kappa), _mm_sub_ps(*c, most)));
                let w = _mm_mul_ps(_mm_loadu_ps(blocks[b].weight.as_ptr()), e);
                _mm_storeu_ps(out.as_mut_ptr().add(4 * b), w);
            }
            out
        }
    }
}

/// The number of cumulative weights at or below `u` times the total (the last slot).
#[inline(always)]
pub(super) fn count_below(cum: &[f32], u: f32) -> usize {
    let x = u * cum[cum.len() - 1];
    cum.iter().map(|&c| (x >= c) as usize).sum()
}

/// The cumulative follow weights of one location for one heading
/// ([`CliffMap::follow_weights`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct FollowWeights(pub(super) [f32; 8]);

/// The direction draw's tables in single precision, for the prediction loop's lanes
/// (`CliffMap::lane_direction` and the AVX2 form): entry by entry parallel to the map's
/// sampling table, padding included, and the width every location's entries share where
/// they share one (so location `i`'s entries start at `i * width`, and eight lanes read
/// them with gathers).
#[derive(Debug, Clone, Default)]
pub(crate) struct LaneTables {
    /// The entries per location, where every location has the same number.
    pub(crate) width: Option<usize>,
    /// Cumulative weights (padding: infinite, never chosen).
    pub(crate) cum: Vec<f32>,
    /// Mean directions, wrapped to `[0, 2pi)`.
    pub(crate) mu: Vec<f32>,
    /// Spreads of the directions.
    pub(crate) sigma: Vec<f32>,
}

impl LaneTables {
    /// The tables of a (padded) sampling table whose location `i` holds the entries
    /// `comp_start[i]..comp_start[i + 1]`.
    pub(super) fn new(comp_start: &[u32], table: &[DirectionComponent]) -> Self {
        let mut widths = comp_start.windows(2).map(|w| (w[1] - w[0]) as usize);
        let first = widths.next().unwrap_or(0);
        let width = (first > 0 && widths.all(|w| w == first)).then_some(first);
        LaneTables {
            width,
            cum: table.iter().map(|e| e.cum_weight as f32).collect(),
            mu: table.iter().map(|e| wrap_2pi(e.mu) as f32).collect(),
            sigma: table.iter().map(|e| e.sigma as f32).collect(),
        }
    }
}

/// Widest mixture whose locations get padded (see [`pad_components`]): more comparisons
/// per draw than this cost more than the mispredicted branches they save.
pub(super) const MAX_PADDED_COMPONENTS: usize = 8;

/// Pad every location's sampling entries to the map's largest component count (at most
/// [`MAX_PADDED_COMPONENTS`], and at most four times the unpadded table): the component
/// choice in [`DirectionSampler`] then runs the same number of comparisons at every
/// location, which the processor predicts (a count that changes from step to step costs
/// a mispredicted branch: 22.0 -> 20.8 us on the THÖR1 benchmark, widest mixture 3;
/// 23.1 -> 21.1 us on the ATC one, widest 5). Padding entries have an infinite
/// cumulative weight, so they are never chosen.
pub(super) fn pad_components(
    comp_start: Vec<u32>,
    table: Vec<DirectionComponent>,
) -> (Vec<u32>, Vec<DirectionComponent>) {
    pad_with(comp_start, table, |last| DirectionComponent {
        cum_weight: f64::INFINITY,
        ..last
    })
}

/// [`pad_components`] for any per-component table: the same padding decision, each
/// location's entries followed by `filler(its last entry)`.
pub(super) fn pad_with<T: Copy>(
    comp_start: Vec<u32>,
    table: Vec<T>,
    filler: impl Fn(T) -> T,
) -> (Vec<u32>, Vec<T>) {
    let counts = comp_start.windows(2).map(|w| (w[1] - w[0]) as usize);
    let widest = counts.clone().max().unwrap_or(0);
    let locations = comp_start.len() - 1;
    if widest <= 1
        || widest > MAX_PADDED_COMPONENTS
        || locations.saturating_mul(widest) > 4 * table.len()
    {
        return (comp_start, table);
    }
    let mut padded = Vec::with_capacity(locations * widest);
    let mut starts = Vec::with_capacity(locations + 1);
    for (w, n) in comp_start.windows(2).zip(counts) {
        starts.push(padded.len() as u32);
        let own = &table[w[0] as usize..w[1] as usize];
        padded.extend_from_slice(own);
        padded.extend(std::iter::repeat_n(filler(own[n - 1]), widest - n));
    }
    starts.push(padded.len() as u32);
    (starts, padded)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks of `n` components with weights and directions spread over the circle.
    fn blocks(n: usize, seed: u32) -> Vec<FollowBlock> {
        let mut x = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x as f64) / (u32::MAX as f64)
        };
        let mut out = Vec::new();
        for b in 0..n.div_ceil(4) {
            let mut block = FollowBlock::PADDING;
            for l in 0..4 {
                let theta = next() * std::f64::consts::TAU;
                if 4 * b + l < n {
                    block.weight[l] = next() as f32;
                }
                block.cos_mu[l] = theta.cos() as f32;
                block.sin_mu[l] = theta.sin() as f32;
            }
            out.push(block);
        }
        out
    }

    #[test]
    fn fixed_follow_weights_are_the_general_ones_bit_for_bit() {
        let mut compared = 0;
        for seed in 0..200 {
            for n in [1, 3, 4, 5, 8] {
                let b = blocks(n, seed);
                for (h, kappa) in [
                    (0.0f32, 4.0f32),
                    (1.3, 4.0),
                    (2.9, 0.5),
                    (-2.0, 100.0),
                    (0.7, 0.0),
                ] {
                    let (ux, uy) = (h.cos(), h.sin());
                    let general = follow_cumulative::<8>(&b, ux, uy, kappa);
                    let fixed = match b.as_slice() {
                        [a] => follow_cumulative_fixed(&[*a], ux, uy, kappa),
                        [a, c] => follow_cumulative_fixed(&[*a, *c], ux, uy, kappa),
                        _ => unreachable!(),
                    };
                    assert_eq!(
                        fixed.map(f32::to_bits),
                        general.map(f32::to_bits),
                        "{seed} {n} {h} {kappa}"
                    );
                    compared += 1;
                }
            }
        }
        assert_eq!(compared, 200 * 5 * 5);
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx_follow_weights_of_two_blocks_are_the_sse_ones_bit_for_bit() {
        if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
            return;
        }
        let mut compared = 0;
        for seed in 0..500 {
            for n in [5, 6, 8] {
                let b = blocks(n, seed);
                let b = [b[0], b[1]];
                for i in 0..8 {
                    let h = -3.2 + 0.8 * i as f32 + 0.01 * seed as f32;
                    let kappa = [0.0f32, 0.5, 4.0, 100.0][(seed as usize + i) % 4];
                    let (ux, uy) = (h.cos(), h.sin());
                    let sse = follow_cumulative_fixed(&b, ux, uy, kappa);
                    // SAFETY: AVX2 and FMA were detected above.
                    let avx = unsafe { follow_cumulative_avx2(&b, ux, uy, kappa) };
                    assert_eq!(
                        avx.map(f32::to_bits),
                        sse.map(f32::to_bits),
                        "{seed} {n} {h} {kappa}"
                    );
                    compared += 1;
                }
            }
        }
        assert_eq!(compared, 500 * 3 * 8);
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx_follow_weights_of_two_lanes_are_the_sse_ones_bit_for_bit() {
        if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
            return;
        }
        let mut compared = 0;
        for seed in 0..500 {
            for n in [1, 2, 4] {
                let (a, b) = (blocks(n, seed)[0], blocks(4 - n / 2, seed + 1000)[0]);
                for i in 0..8 {
                    let h = [
                        -3.2 + 0.8 * i as f32 + 0.01 * seed as f32,
                        1.1 - 0.7 * i as f32 - 0.02 * seed as f32,
                    ];
                    let kappa = [0.0f32, 0.5, 4.0, 100.0][(seed as usize + i) % 4];
                    let (ux, uy) = (h.map(f32::cos), h.map(f32::sin));
                    let sse = [
                        follow_cumulative_fixed(&[a], ux[0], uy[0], kappa),
                        follow_cumulative_fixed(&[b], ux[1], uy[1], kappa),
                    ];
                    // SAFETY: AVX2 and FMA were detected above.
                    let avx = unsafe { follow_cumulative_pair_avx2([&a, &b], ux, uy, kappa) };
                    assert_eq!(
                        avx.map(|w| w.map(f32::to_bits)),
                        sse.map(|w| w.map(f32::to_bits)),
                        "{seed} {n} {h:?} {kappa}"
                    );
                    compared += 1;
                }
            }
        }
        assert_eq!(compared, 500 * 3 * 8);
    }

    #[test]
    fn follow_mode_is_the_component_of_the_largest_follow_weight() {
        for seed in 0..200 {
            for n in [1, 3, 5, 8] {
                let mut b = blocks(n, seed);
                for block in b.iter_mut() {
                    block.log_weight = block
                        .weight
                        .map(|w| if w > 0.0 { w.ln() } else { f32::NEG_INFINITY });
                }
                for (h, kappa) in [(0.0f32, 4.0f32), (2.0, 1.0), (-1.0, 0.0)] {
                    let (ux, uy) = (h.cos(), h.sin());
                    // the largest weight of the general rule, by hand
                    let (mut best, mut want) = (-1.0f64, (0.0, 0.0));
                    for block in &b {
                        for l in 0..4 {
                            let c = (ux * block.cos_mu[l] + uy * block.sin_mu[l]) as f64;
                            let w = block.weight[l] as f64 * (kappa as f64 * c).exp();
                            if w > best {
                                (best, want) = (w, (block.cos_mu[l], block.sin_mu[l]));
                            }
                        }
                    }
                    let got = follow_mode_of(&b, ux, uy, kappa);
                    assert_eq!(got, want, "{seed} {n} {h} {kappa}");
                }
            }
        }
    }
}
