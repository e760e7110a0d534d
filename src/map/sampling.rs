//! The draws a prediction makes at a location: a direction ([`DirectionSampler`], a
//! rand [`Distribution`]), a direction weighted by the heading (follow), and a velocity.

use rand::distr::Distribution;
use rand::{Rng, RngExt};
use rand_distr::StandardNormal;

use super::cliff_map::CliffMap;
use super::limits::MAX_COMPONENTS;
use super::sampling_tables::{
    DirectionComponent, FollowWeights, count_below, follow_cumulative, follow_cumulative_fixed,
    follow_mode_of, four_uniforms_normal,
};
#[cfg(target_arch = "x86_64")]
use super::sampling_tables::{follow_cumulative_avx2, follow_cumulative_pair_avx2};
use crate::math::simd::MulAdd;
use crate::math::wrap_2pi;

impl CliffMap {
    /// The direction distribution of location `index`: a draw picks a component by
    /// weight and returns a direction from its (PSD-clamped) normal, wrapped to `[0, 2pi)`.
    ///
    /// Only the direction marginal is drawn: CLiFF-LHMP keeps the sampled direction and
    /// discards the sampled speed, and the marginal of a bivariate normal is exactly
    /// the normal of its first coordinate.
    #[inline]
    pub fn direction_at(&self, index: usize) -> DirectionSampler<'_> {
        let a = self.comp_start[index] as usize;
        let b = self.comp_start[index + 1] as usize;
        DirectionSampler {
            table: &self.table[a..b],
        }
    }

    /// A direction draw at location `index` that favours the components going the way
    /// the walker heads (unit vector `(ux, uy)`): component `j` is chosen with
    /// probability proportional to `w_j exp(-kappa (1 - cos(heading - mu_j)))`, the
    /// posterior of the component given a heading observed with a von Mises likelihood
    /// of concentration `kappa`; the direction is then drawn from that component as in
    /// [`direction_at`](Self::direction_at) (one uniform and one normal draw, unwrapped).
    /// `kappa = 0` chooses by weight alone, like `direction_at` (up to the rounding of the
    /// cumulative weights).
    ///
    /// ```
    /// use cliff::map::{CliffMap, Component, Location};
    /// use glam::DVec2;
    /// use rand::SeedableRng;
    /// // one location, two equal flows: east and west
    /// let c = |theta: f64| Component { theta, rho: 1.0, cov: [0.01, 0.0, 0.0, 0.01], weight: 0.5 };
    /// let loc = Location { position: DVec2::ZERO, components: vec![c(0.0), c(std::f64::consts::PI)], motion_ratio: 1.0, observation_ratio: 1.0 };
    /// let map = CliffMap::new(vec![loc]).unwrap();
    /// let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(1);
    /// // a walker heading east keeps to the eastward flow
    /// let east = (0..1000).filter(|_| map.direction_following(0, 1.0, 0.0, 4.0, &mut rng).cos() > 0.0).count();
    /// assert!(east > 990);
    /// ```
    #[inline]
    pub fn direction_following<R: Rng + ?Sized>(
        &self,
        index: usize,
        ux: f64,
        uy: f64,
        kappa: f64,
        rng: &mut R,
    ) -> f64 {
        let a = self.comp_start[index] as usize;
        let b = self.comp_start[index + 1] as usize;
        let blocks =
            &self.follow[self.follow_start[index] as usize..self.follow_start[index + 1] as usize];
        let (ux, uy, kappa) = (ux as f32, uy as f32, kappa as f32);
        let u = rng.random::<f64>() as f32;
        let below = if blocks.len() <= 2 {
            count_below(&follow_cumulative::<8>(blocks, ux, uy, kappa), u)
        } else {
            count_below(
                &follow_cumulative::<MAX_COMPONENTS>(blocks, ux, uy, kappa),
                u,
            )
        };
        // (padding repeats the last component)
        let i = below.min(b - a - 1);
        let c = &self.table[a + i];
        let z: f64 = StandardNormal.sample(rng);
        c.mu + c.sigma * z
    }

    /// Whether every location's follow components fit [`FollowWeights`] (at most
    /// eight components per location): then a predictor may split
    /// [`direction_following`](Self::direction_following) into
    /// [`follow_weights`](Self::follow_weights) and
    /// [`draw_following`](Self::draw_following).
    #[inline]
    pub fn follow_weights_fit(&self) -> bool {
        self.follow_fits
    }

    /// The part of [`direction_following`](Self::direction_following) that draws
    /// nothing: location `index`'s cumulative component weights for the heading
    /// `(ux, uy)`, scaled by a common factor. For maps where
    /// [`follow_weights_fit`](Self::follow_weights_fit) (others get the weights of their
    /// first eight components). A predictor computes them for all its samples before
    /// they draw (the samples' arithmetic then overlaps).
    #[inline(always)]
    pub fn follow_weights(&self, index: usize, ux: f32, uy: f32, kappa: f32) -> FollowWeights {
        let s = self.follow_start[index] as usize;
        let e = (self.follow_start[index + 1] as usize).min(s + 2);
        // (every location of a map has the same number of blocks; a second block that
        // holds only padding, weight 0 and the first's last direction again, changes no
        // bit of the running sums, so a location of at most four components leaves it out)
        match &self.follow[s..e] {
            [a] | [a, _] if self.follow_count[index] <= 4 => {
                FollowWeights(follow_cumulative_fixed(&[*a], ux, uy, kappa))
            }
            [a, b] => FollowWeights(follow_cumulative_fixed(&[*a, *b], ux, uy, kappa)),
            blocks => FollowWeights(follow_cumulative::<8>(blocks, ux, uy, kappa)),
        }
    }

    /// [`follow_weights`](Self::follow_weights) on AVX2 (the same bits; eight components
    /// per instruction where the location has more than four).
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA. (Inlined into the AVX2 lane loop, whose
    /// target features it then compiles with.)
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn follow_weights_avx2(
        &self,
        index: usize,
        ux: f32,
        uy: f32,
        kappa: f32,
    ) -> FollowWeights {
        let s = self.follow_start[index] as usize;
        let e = (self.follow_start[index + 1] as usize).min(s + 2);
        match &self.follow[s..e] {
            // SAFETY: AVX2 and FMA, as this function requires.
            [a, b] => FollowWeights(unsafe { follow_cumulative_avx2(&[*a, *b], ux, uy, kappa) }),
            _ => self.follow_weights(index, ux, uy, kappa),
        }
    }

    /// [`follow_weights`](Self::follow_weights) of two lanes at once on AVX2, the same
    /// bits: locations `index[0]` and `index[1]` for the headings `(ux[i], uy[i])`, where
    /// both hold at most four components (one register for both); `None` otherwise.
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA. (Inlined into the AVX2 lane loop, whose
    /// target features it then compiles with.)
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn follow_weights_pair_avx2(
        &self,
        index: [usize; 2],
        ux: [f32; 2],
        uy: [f32; 2],
        kappa: f32,
    ) -> Option<[FollowWeights; 2]> {
        let one = |i: usize| {
            let s = self.follow_start[i] as usize;
            match &self.follow[s..self.follow_start[i + 1] as usize] {
                [block] => Some(block),
                _ => None,
            }
        };
        let blocks = [one(index[0])?, one(index[1])?];
        // SAFETY: AVX2 and FMA, as this function requires.
        let w = unsafe { follow_cumulative_pair_avx2(blocks, ux, uy, kappa) };
        Some(w.map(FollowWeights))
    }

    /// The mean direction (a unit vector `(cos, sin)`) of location `index`'s likeliest
    /// component for a walker heading `(ux, uy)` under
    /// [`direction_following`](Self::direction_following)'s rule with concentration
    /// `kappa` (the largest `w_j exp(kappa cos(heading - mu_j))`, ties to the first): the
    /// flow a sample there most likely follows.
    #[inline]
    pub fn follow_mode(&self, index: usize, ux: f32, uy: f32, kappa: f32) -> (f32, f32) {
        let s = self.follow_start[index] as usize;
        let e = self.follow_start[index + 1] as usize;
        follow_mode_of(&self.follow[s..e], ux, uy, kappa)
    }

    /// The draw of [`direction_following`](Self::direction_following) at location
    /// `index` with its [`follow_weights`](Self::follow_weights): the same component
    /// and direction for the same generator.
    #[inline(always)]
    pub fn draw_following<R: Rng + ?Sized>(
        &self,
        index: usize,
        weights: &FollowWeights,
        rng: &mut R,
    ) -> f64 {
        let a = self.comp_start[index] as usize;
        let b = self.comp_start[index + 1] as usize;
        let u = rng.random::<f64>() as f32;
        let i = count_below(&weights.0, u).min(b - a - 1);
        let c = &self.table[a + i];
        let z: f64 = StandardNormal.sample(rng);
        c.mu + c.sigma * z
    }

    /// A velocity draw at location `index`: a component by weight, a direction from its
    /// normal (unwrapped, as [`DirectionSampler::sample_unwrapped`]) and a speed from the
    /// component's normal given that direction (clamped at 0). One random word chooses the
    /// component (its high 32 bits) and gives the speed's noise (its low 32 bits, a sum
    /// of four uniforms: variance 1, within 0.01 of the normal's distribution function,
    /// bounded by +-3.46), then a normal draw gives the direction, so its stream differs
    /// from [`direction_at`](Self::direction_at)'s.
    #[inline(always)]
    pub fn velocity_at<R: Rng + ?Sized>(&self, index: usize, rng: &mut R) -> (f64, f64) {
        let a = self.comp_start[index] as usize;
        let b = self.comp_start[index + 1] as usize;
        let table = &self.table[a..b];
        // one word for the component (its high half) and the speed's noise (its low one)
        let bits = rng.next_u64();
        let u = (bits >> 32) as f64 * (1.0 / 4_294_967_296.0);
        let i = table
            .iter()
            .map(|e| (u >= e.cum_weight) as usize)
            .sum::<usize>()
            .min(table.len() - 1);
        let (c, sp) = (&table[i], &self.speed[a + i]);
        let z: f64 = StandardNormal.sample(rng);
        (
            c.mu + c.sigma * z,
            (sp.mean + sp.slope * z as f32 + sp.sd * four_uniforms_normal(bits as u32)).max(0.0)
                as f64,
        )
    }
}

/// Sampling a direction at one location, as a [`Distribution`] (see [`CliffMap::direction_at`]).
#[derive(Debug, Clone, Copy)]
pub struct DirectionSampler<'a> {
    table: &'a [DirectionComponent],
}

impl DirectionSampler<'_> {
    /// A draw as [`sample`](Distribution::sample) gives it, before wrapping to
    /// `[0, 2pi)` (for callers that only take its sine and cosine).
    #[inline(always)]
    pub fn sample_unwrapped<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        let u: f64 = rng.random();
        // Branch-free choice: the number of cumulative weights at or below u.
        let i = self
            .table
            .iter()
            .map(|e| (u >= e.cum_weight) as usize)
            .sum::<usize>();
        let c = &self.table[i.min(self.table.len() - 1)];
        let z: f64 = StandardNormal.sample(rng);
        c.mu + c.sigma * z
    }
}

impl Distribution<f64> for DirectionSampler<'_> {
    #[inline(always)]
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        wrap_2pi(self.sample_unwrapped(rng))
    }
}

/// The draws of the prediction loop's lanes: each from a uniform `u` in `[0, 1)` that
/// picks the component and a standard normal `z` (the loop makes both from its
/// generators' words, `crate::math::lane_rng`), in single precision, with the
/// multiply-adds of `M` (fused on the AVX2 path). Directions come unwrapped.
impl CliffMap {
    /// The entry of the sampling tables that `u` picks at location `index`: a component
    /// by weight.
    #[inline(always)]
    fn lane_pick(&self, index: usize, u: f32) -> usize {
        let (a, n) = match self.lane.width {
            Some(w) => (index * w, w),
            None => {
                let a = self.comp_start[index] as usize;
                (a, self.comp_start[index + 1] as usize - a)
            }
        };
        // branch-free: the number of cumulative weights at or below u
        let i = self.lane.cum[a..a + n]
            .iter()
            .map(|&c| (u >= c) as usize)
            .sum::<usize>();
        // (padding repeats the last component)
        a + i.min(n - 1)
    }

    /// A direction drawn at location `index` (as [`direction_at`](Self::direction_at)).
    #[inline(always)]
    pub(crate) fn lane_direction<M: MulAdd>(&self, index: usize, u: f32, z: f32) -> f32 {
        let e = self.lane_pick(index, u);
        M::madd32(self.lane.sigma[e], z, self.lane.mu[e])
    }

    /// A velocity drawn at location `index` (as [`velocity_at`](Self::velocity_at)),
    /// the speed's noise from the word `noise` (a sum of four uniforms).
    #[inline(always)]
    pub(crate) fn lane_velocity<M: MulAdd>(
        &self,
        index: usize,
        u: f32,
        z: f32,
        noise: u32,
    ) -> (f32, f64) {
        let e = self.lane_pick(index, u);
        let sp = &self.speed[e];
        (
            M::madd32(self.lane.sigma[e], z, self.lane.mu[e]),
            (sp.mean + sp.slope * z + sp.sd * four_uniforms_normal(noise)).max(0.0) as f64,
        )
    }

    /// A direction drawn at location `index` with its follow weights (as
    /// [`draw_following`](Self::draw_following)).
    #[inline(always)]
    pub(crate) fn lane_following<M: MulAdd>(
        &self,
        index: usize,
        weights: &FollowWeights,
        u: f32,
        z: f32,
    ) -> f32 {
        let a = self.comp_start[index] as usize;
        let b = self.comp_start[index + 1] as usize;
        let e = a + count_below(&weights.0, u).min(b - a - 1);
        M::madd32(self.lane.sigma[e], z, self.lane.mu[e])
    }

    /// A direction drawn at location `index` for the heading `(ux, uy)` (as
    /// [`direction_following`](Self::direction_following), for maps whose follow weights
    /// do not fit [`FollowWeights`]).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)] // the draw's inputs
    pub(crate) fn lane_direction_following<M: MulAdd>(
        &self,
        index: usize,
        ux: f32,
        uy: f32,
        kappa: f32,
        u: f32,
        z: f32,
    ) -> f32 {
        let a = self.comp_start[index] as usize;
        let b = self.comp_start[index + 1] as usize;
        let blocks =
            &self.follow[self.follow_start[index] as usize..self.follow_start[index + 1] as usize];
        let below = if blocks.len() <= 2 {
            count_below(&follow_cumulative::<8>(blocks, ux, uy, kappa), u)
        } else {
            count_below(
                &follow_cumulative::<MAX_COMPONENTS>(blocks, ux, uy, kappa),
                u,
            )
        };
        let e = a + below.min(b - a - 1);
        M::madd32(self.lane.sigma[e], z, self.lane.mu[e])
    }

    /// The entries every location's draw reads, where all locations have the same
    /// number (the padded maps): then [`lane_direction8`](Self::lane_direction8) draws.
    #[inline]
    pub(crate) fn lane_width(&self) -> Option<usize> {
        self.lane.width
    }

    /// [`lane_direction`](Self::lane_direction)`::<Fused>` at the locations `loc` of
    /// `V` registers of eight lanes (the same bits), reading the tables with gathers.
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA, `width` must be
    /// [`lane_width`](Self::lane_width), and every lane of `loc` a location of the map.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(crate) unsafe fn lane_direction8<const V: usize>(
        &self,
        width: usize,
        loc: &[std::arch::x86_64::__m256i; V],
        u: &[std::arch::x86_64::__m256; V],
        z: &[std::arch::x86_64::__m256; V],
    ) -> [std::arch::x86_64::__m256; V] {
        use crate::math::fastmath::x8::per;
        use std::arch::x86_64::*;
        debug_assert_eq!(self.lane.width, Some(width));
        let w = _mm256_set1_epi32(width as i32);
        let row = per!(V, |v| _mm256_mullo_epi32(loc[v], w));
        let cum = self.lane.cum.as_ptr();
        let mut count = [_mm256_setzero_si256(); V];
        for j in 0..width {
            for v in 0..V {
                // SAFETY: row + j < locations * width = the table's length.
                let c = unsafe { _mm256_i32gather_ps::<4>(cum.add(j), row[v]) };
                // (a true comparison is all ones: -1)
                let below = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GE_OQ>(u[v], c));
                count[v] = _mm256_sub_epi32(count[v], below);
            }
        }
        // SAFETY: as this function requires.
        unsafe { self.lane_entry_draw8(width, row, count, z) }
    }

    /// The direction drawn from entry `count` (at most the last) of the lane tables'
    /// rows `row` (`location * width`), with the normals `z`: `mu + sigma z`, fused.
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA, `width` must be
    /// [`lane_width`](Self::lane_width), and every lane of `row` a row of the tables.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn lane_entry_draw8<const V: usize>(
        &self,
        width: usize,
        row: [std::arch::x86_64::__m256i; V],
        count: [std::arch::x86_64::__m256i; V],
        z: &[std::arch::x86_64::__m256; V],
    ) -> [std::arch::x86_64::__m256; V] {
        use crate::math::fastmath::x8::per;
        use std::arch::x86_64::*;
        let last = _mm256_set1_epi32(width as i32 - 1);
        let e = per!(V, |v| _mm256_add_epi32(
            row[v],
            _mm256_min_epi32(count[v], last)
        ));
        // SAFETY: e < row + width, within the tables.
        let mu = per!(V, |v| unsafe {
            _mm256_i32gather_ps::<4>(self.lane.mu.as_ptr(), e[v])
        });
        // SAFETY: as above.
        let sigma = per!(V, |v| unsafe {
            _mm256_i32gather_ps::<4>(self.lane.sigma.as_ptr(), e[v])
        });
        per!(V, |v| _mm256_fmadd_ps(sigma[v], z[v], mu[v]))
    }

    /// The follow draw ([`lane_following`](Self::lane_following) after
    /// [`follow_weights`](Self::follow_weights)) at the locations `loc` of `V` registers
    /// of eight lanes, for the headings `(ux, uy)`: the same bits, each lane's follow
    /// blocks loaded whole and transposed into slots (each slot's weight for all eight
    /// lanes at once, with the operations of the one-location forms in the same order;
    /// eight loads and eight shuffles per field of a block, where gathers took 1.1 times
    /// as long for the whole of `improved` on ATC).
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA, the map's follow weights must fit
    /// ([`follow_weights_fit`](Self::follow_weights_fit)), `width` must be
    /// [`lane_width`](Self::lane_width), and every lane of `loc` a location of the map.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    #[allow(clippy::too_many_arguments)] // the draw's inputs, eight lanes each
    pub(crate) unsafe fn lane_following8<const V: usize>(
        &self,
        width: usize,
        loc: &[std::arch::x86_64::__m256i; V],
        ux: &[std::arch::x86_64::__m256; V],
        uy: &[std::arch::x86_64::__m256; V],
        kappa: f32,
        u: &[std::arch::x86_64::__m256; V],
        z: &[std::arch::x86_64::__m256; V],
    ) -> [std::arch::x86_64::__m256; V] {
        use super::sampling_tables::FollowBlock;
        use crate::math::fastmath::x8::per;
        use std::arch::x86_64::*;
        debug_assert!(self.follow_fits && self.lane.width == Some(width));
        // every location has the same number of blocks (one or two) where they fit
        let blocks = (self.follow_start[1] - self.follow_start[0]) as usize;
        let floats = std::mem::size_of::<FollowBlock>() / 4;
        let first = per!(V, |v| _mm256_mullo_epi32(
            loc[v],
            _mm256_set1_epi32((blocks * floats) as i32)
        ));
        // Slots past a location's components are padding: weight 0 and the location's
        // last direction again, so they neither raise the largest cosine nor add to the
        // total, and their running sums are the total. Only the slots of the lanes'
        // largest mixture are read (on ATC's map, of five slots, most locations hold
        // one or two components).
        // SAFETY: every lane of `loc` is a location (as this function requires).
        let slots = unsafe { self.most_components8(loc) }.clamp(1, width.min(4 * blocks));
        let args = (width, first, loc, (ux, uy), kappa, (u, z));
        // SAFETY: as this function requires; `slots` is at most eight (two blocks).
        unsafe {
            match slots {
                1 => self.follow_draw8::<V, 1>(args),
                2 => self.follow_draw8::<V, 2>(args),
                3 => self.follow_draw8::<V, 3>(args),
                4 => self.follow_draw8::<V, 4>(args),
                5 => self.follow_draw8::<V, 5>(args),
                6 => self.follow_draw8::<V, 6>(args),
                7 => self.follow_draw8::<V, 7>(args),
                _ => self.follow_draw8::<V, 8>(args),
            }
        }
    }

    /// The most components any lane of `loc` (`V` registers of eight locations) holds.
    ///
    /// # Safety
    /// The processor must have AVX2; every lane of `loc` must be a location of the map.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn most_components8<const V: usize>(
        &self,
        loc: &[std::arch::x86_64::__m256i; V],
    ) -> usize {
        use std::arch::x86_64::*;
        let counts = self.follow_count.as_ptr() as *const i32;
        let mut most = _mm256_setzero_si256();
        for l in loc {
            // SAFETY: `follow_count` holds an entry per location.
            let n = unsafe { _mm256_i32gather_epi32::<4>(counts, *l) };
            most = _mm256_max_epi32(most, n);
        }
        let m = _mm_max_epi32(
            _mm256_castsi256_si128(most),
            _mm256_extracti128_si256::<1>(most),
        );
        let m = _mm_max_epi32(m, _mm_shuffle_epi32::<0b01_00_11_10>(m));
        let m = _mm_max_epi32(m, _mm_shuffle_epi32::<0b10_11_00_01>(m));
        _mm_cvtsi128_si32(m) as usize
    }

    /// [`lane_following8`](Self::lane_following8) of `S` slots (at most eight, the
    /// most components of the lanes' locations), each lane's blocks starting at float
    /// `first`: the loops over slots unrolled and the slots' registers on the stack.
    ///
    /// # Safety
    /// As [`lane_following8`](Self::lane_following8); `first` is each lane's location
    /// times the floats of its blocks, and `S` at most the slots of its blocks.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    #[allow(clippy::type_complexity)] // the draw's inputs, eight lanes each
    unsafe fn follow_draw8<const V: usize, const S: usize>(
        &self,
        (width, first, loc, (ux, uy), kappa, (u, z)): (
            usize,
            [std::arch::x86_64::__m256i; V],
            &[std::arch::x86_64::__m256i; V],
            (
                &[std::arch::x86_64::__m256; V],
                &[std::arch::x86_64::__m256; V],
            ),
            f32,
            (
                &[std::arch::x86_64::__m256; V],
                &[std::arch::x86_64::__m256; V],
            ),
        ),
    ) -> [std::arch::x86_64::__m256; V] {
        use super::sampling_tables::{FollowBlock, follow_avx};
        use crate::math::fastmath::x8::per;
        use std::arch::x86_64::*;
        use std::mem::{MaybeUninit, offset_of, size_of};
        let floats = size_of::<FollowBlock>() / 4;
        let field = |offset: usize| offset / 4;
        let (weight, cos_mu, sin_mu) = (
            field(offset_of!(FollowBlock, weight)),
            field(offset_of!(FollowBlock, cos_mu)),
            field(offset_of!(FollowBlock, sin_mu)),
        );
        let base = self.follow.as_ptr() as *const f32;
        let slots = S;
        // each lane's first float, for the block loads
        let lane_first: [[i32; 8]; V] = std::array::from_fn(|v| {
            let mut a = [0i32; 8];
            // SAFETY: eight lanes.
            unsafe { _mm256_storeu_si256(a.as_mut_ptr() as *mut __m256i, first[v]) };
            a
        });
        // a field of block `b` of the eight lanes of register `v`, slot by slot (SAFETY:
        // the block lies in each lane's location's blocks)
        let field4 = |b: usize, f: usize, v: usize| unsafe {
            super::block_loads::slots4(std::array::from_fn(|l| {
                base.add(lane_first[v][l] as usize + b * floats + f)
            }))
        };
        // each slot's weight, the cosines of the heading with each slot's mean
        // direction, and the largest (the first `slots` written: arrays left
        // uninitialised, as zeroing them cost more than a tenth of the draw)
        let mut weights = [[MaybeUninit::<__m256>::uninit(); V]; S];
        let mut cos = [[MaybeUninit::<__m256>::uninit(); V]; S];
        let mut most = [_mm256_set1_ps(-1.0); V];
        for b in 0..slots.div_ceil(4) {
            for v in 0..V {
                let (w, cm, sm) = (
                    field4(b, weight, v),
                    field4(b, cos_mu, v),
                    field4(b, sin_mu, v),
                );
                for i in 0..(slots - 4 * b).min(4) {
                    weights[4 * b + i][v].write(w[i]);
                    let c = _mm256_add_ps(_mm256_mul_ps(ux[v], cm[i]), _mm256_mul_ps(uy[v], sm[i]));
                    cos[4 * b + i][v].write(c);
                    most[v] = _mm256_max_ps(most[v], c);
                }
            }
        }
        // the weights' running sums, in place of the cosines (slots past the blocks: the
        // total)
        let k = _mm256_set1_ps(kappa);
        let mut total = [_mm256_setzero_ps(); V];
        for s in 0..slots {
            for v in 0..V {
                // SAFETY: slot s < slots was written above; AVX2, as this function
                // requires.
                let (w, e) = unsafe {
                    let c = cos[s][v].assume_init();
                    (
                        weights[s][v].assume_init(),
                        follow_avx::exp_neg(_mm256_mul_ps(k, _mm256_sub_ps(c, most[v]))),
                    )
                };
                total[v] = _mm256_add_ps(total[v], _mm256_mul_ps(w, e));
                cos[s][v].write(total[v]);
            }
        }
        let cum = &cos;
        // the component: how many running sums are at or below u times the total
        let x = per!(V, |v| _mm256_mul_ps(u[v], total[v]));
        let mut count = [_mm256_setzero_si256(); V];
        for c in cum.iter().take(slots) {
            for v in 0..V {
                // SAFETY: the running sums of the first `slots` were written above.
                let c = unsafe { c[v].assume_init() };
                let below = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GE_OQ>(x[v], c));
                count[v] = _mm256_sub_epi32(count[v], below);
            }
        }
        // the slots after them (to eight, as the one-location forms count) hold the total
        let rest = _mm256_set1_epi32(8 - slots as i32);
        for v in 0..V {
            let below = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GE_OQ>(x[v], total[v]));
            count[v] = _mm256_sub_epi32(count[v], _mm256_mullo_epi32(below, rest));
        }
        let w = _mm256_set1_epi32(width as i32);
        let row = per!(V, |v| _mm256_mullo_epi32(loc[v], w));
        // SAFETY: as this function requires.
        unsafe { self.lane_entry_draw8(width, row, count, z) }
    }
}
