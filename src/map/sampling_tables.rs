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
    pub(super) cos_mu: [f32; 4],
    pub(super) sin_mu: [f32; 4],
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
            let mut block = FollowBlock {
                weight: [0.0; 4],
                cos_mu: [0.0; 4],
                sin_mu: [0.0; 4],
            };
            for l in 0..4 {
                let j = 4 * b + l;
                let c = &loc.components[j.min(n - 1)];
                if j < n {
                    block.weight[l] = (c.weight / total) as f32;
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
