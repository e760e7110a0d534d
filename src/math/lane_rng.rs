//! The prediction loop's random numbers: one small generator per sample (lane), so that
//! the lanes draw side by side, eight to an AVX2 register, and a sample's draws depend
//! on its own seed alone (not on how many other samples are still going).
//!
//! The generator is xoshiro128++ (Blackman and Vigna): four 32-bit words of state, one
//! 32-bit word out per call, only adds, shifts, rotations and exclusive ors, the same
//! in every lane. A lane's state comes from splitmix64 (the seeding those authors
//! recommend): lane `s` of a key takes the stream's outputs `2 s` and `2 s + 1`.
//!
//! From a word the loop makes a uniform in `[0, 1)` ([`unit_f32`]) and a standard normal
//! ([`normal_f32`]: the inverse of the normal distribution function, through Giles's
//! single-precision approximation of erfinv, within 2e-7 relative of the exact
//! quantile), both branch-free so that a loop over lanes vectorises. The AVX2 forms
//! ([`next8`], [`normal8`]) give the same numbers as the scalar ones with fused
//! multiply-adds (the generator's and the uniform's bits exactly).

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use super::simd::MulAdd;
#[cfg(test)]
use super::simd::Separate;

/// splitmix64's increment.
const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;

/// splitmix64's output function.
#[inline(always)]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The xoshiro128++ state of lane `lane` of the key `key`: splitmix64's outputs
/// `2 lane` and `2 lane + 1` from the state `key`, as four words (never all zero).
#[inline]
pub(crate) fn lane_seed(key: u64, lane: u64) -> [u32; 4] {
    let a = mix64(key.wrapping_add((2 * lane + 1).wrapping_mul(GOLDEN)));
    let b = mix64(key.wrapping_add((2 * lane + 2).wrapping_mul(GOLDEN)));
    let s = [a as u32, (a >> 32) as u32, b as u32, (b >> 32) as u32];
    // (the one state xoshiro never leaves)
    if s == [0; 4] { [1, 0, 0, 0] } else { s }
}

/// `N` xoshiro128++ generators side by side, word by word (`s[w][lane]`), so a step of
/// all of them is straight-line code over the lanes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LaneRngs<const N: usize> {
    pub(crate) s: [[u32; N]; 4],
}

impl<const N: usize> LaneRngs<N> {
    /// All lanes' states zero (not a valid state: [`set`](Self::set) every lane used).
    pub(crate) fn zero() -> Self {
        LaneRngs { s: [[0; N]; 4] }
    }

    /// Lane `l`'s state.
    #[inline]
    pub(crate) fn get(&self, l: usize) -> [u32; 4] {
        [self.s[0][l], self.s[1][l], self.s[2][l], self.s[3][l]]
    }

    /// Set lane `l`'s state.
    #[inline]
    pub(crate) fn set(&mut self, l: usize, state: [u32; 4]) {
        for (w, v) in self.s.iter_mut().zip(state) {
            w[l] = v;
        }
    }

    /// The next word of every lane.
    #[inline(always)]
    pub(crate) fn next(&mut self) -> [u32; N] {
        let [s0, s1, s2, s3] = &mut self.s;
        let mut out = [0u32; N];
        for l in 0..N {
            out[l] = s0[l].wrapping_add(s3[l]).rotate_left(7).wrapping_add(s0[l]);
            let t = s1[l] << 9;
            s2[l] ^= s0[l];
            s3[l] ^= s1[l];
            s1[l] ^= s2[l];
            s0[l] ^= s3[l];
            s2[l] ^= t;
            s3[l] = s3[l].rotate_left(11);
        }
        out
    }
}

/// The next word of eight xoshiro128++ generators (`s[w]` holds word `w` of the eight
/// states): [`LaneRngs::next`] in AVX2 registers.
///
/// # Safety
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(crate) fn next8(s: &mut [__m256i; 4]) -> __m256i {
    let [s0, s1, s2, s3] = *s;
    let sum = _mm256_add_epi32(s0, s3);
    let rot = _mm256_or_si256(_mm256_slli_epi32::<7>(sum), _mm256_srli_epi32::<25>(sum));
    let out = _mm256_add_epi32(rot, s0);
    let t = _mm256_slli_epi32::<9>(s1);
    let s2 = _mm256_xor_si256(s2, s0);
    let s3 = _mm256_xor_si256(s3, s1);
    let s1 = _mm256_xor_si256(s1, s2);
    let s0 = _mm256_xor_si256(s0, s3);
    let s2 = _mm256_xor_si256(s2, t);
    let s3 = _mm256_or_si256(_mm256_slli_epi32::<11>(s3), _mm256_srli_epi32::<21>(s3));
    *s = [s0, s1, s2, s3];
    out
}

/// 2^-24.
const INV_2_24: f32 = 1.0 / 16_777_216.0;

/// A uniform in `[0, 1)` from the high 24 bits of a word (exact in single precision).
#[inline(always)]
pub(crate) fn unit_f32(w: u32) -> f32 {
    (w >> 8) as f32 * INV_2_24
}

/// [`unit_f32`] of eight words.
///
/// # Safety
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(crate) fn unit8(w: __m256i) -> __m256 {
    _mm256_mul_ps(
        _mm256_cvtepi32_ps(_mm256_srli_epi32::<8>(w)),
        _mm256_set1_ps(INV_2_24),
    )
}

/// Bits of sqrt(1/2) in single precision: `ln` reduces to a mantissa in
/// `[sqrt(1/2), sqrt(2))`.
const SQRT_HALF_BITS: i32 = 0x3f35_04f3;
const LN2: f32 = std::f32::consts::LN_2;
/// Giles's erfinv, central part (w < 5): coefficients of `w - 2.5`, highest first.
const CENTRAL: [f32; 9] = [
    2.810_226_4e-8,
    3.432_739_4e-7,
    -3.523_387_7e-6,
    -4.391_506_5e-6,
    0.000_218_580_87,
    -0.001_253_725,
    -0.004_177_681_6,
    0.246_640_73,
    1.501_409_4,
];
/// Giles's erfinv, tails (w >= 5): coefficients of `sqrt(w) - 3`, highest first.
const TAIL: [f32; 9] = [
    -0.000_200_214_26,
    0.000_100_950_56,
    0.001_349_343_2,
    -0.003_673_428_4,
    0.005_739_507_7,
    -0.007_622_461_3,
    0.009_438_870_5,
    1.001_674,
    2.832_976_8,
];

/// A standard normal deviate from the high 24 bits of a word: the quantile of
/// `(b + 1/2) / 2^24`, so within +-5.42, and symmetric (the words `b` and `2^24 - 1 - b`
/// give `z` and `-z`). Branch-free. (The loop uses [`normal_f32_with`].)
#[cfg(test)]
#[inline(always)]
pub(crate) fn normal_f32(w: u32) -> f32 {
    normal_f32_with::<Separate>(w)
}

/// [`normal_f32`] with the multiply-adds of `M` (fused on the AVX2 path).
#[inline(always)]
pub(crate) fn normal_f32_with<M: MulAdd>(w: u32) -> f32 {
    let m = M::madd32;
    // x = 2 u - 1 = (2 b + 1 - 2^24) / 2^24: an odd multiple of 2^-24, exact
    let b = (w >> 8) as i32;
    let x = (2 * b + 1 - (1 << 24)) as f32 * INV_2_24;
    // erfinv(x) = x p(w), w = -ln(1 - x^2)
    let y = (1.0 - x) * (1.0 + x);
    let i = y.to_bits() as i32;
    let k = (i - SQRT_HALF_BITS) >> 23;
    let f = f32::from_bits((i - (k << 23)) as u32) - 1.0;
    // ln(1 + f) = 2 s (1 + s^2 / 3 + s^4 / 5 + s^6 / 7 + s^8 / 9), s = f / (2 + f)
    let s = f / (2.0 + f);
    let s2 = s * s;
    let p = m(
        s2,
        m(s2, m(s2, m(s2, 1.0 / 9.0, 1.0 / 7.0), 1.0 / 5.0), 1.0 / 3.0),
        1.0,
    );
    let w = -m(k as f32, LN2, (s + s) * p);
    let c = w - 2.5;
    let mut pc = CENTRAL[0];
    for &a in &CENTRAL[1..] {
        pc = m(pc, c, a);
    }
    let t = w.sqrt() - 3.0;
    let mut pt = TAIL[0];
    for &a in &TAIL[1..] {
        pt = m(pt, t, a);
    }
    let p = if w < 5.0 { pc } else { pt };
    (p * x) * std::f32::consts::SQRT_2
}

/// [`normal_f32_with`]`::<Fused>` of eight words (the same bits).
///
/// # Safety
/// The processor must have AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(crate) fn normal8(w: __m256i) -> __m256 {
    let one = _mm256_set1_ps(1.0);
    let b = _mm256_srli_epi32::<8>(w);
    let xi = _mm256_add_epi32(_mm256_slli_epi32::<1>(b), _mm256_set1_epi32(1 - (1 << 24)));
    let x = _mm256_mul_ps(_mm256_cvtepi32_ps(xi), _mm256_set1_ps(INV_2_24));
    let y = _mm256_mul_ps(_mm256_sub_ps(one, x), _mm256_add_ps(one, x));
    let i = _mm256_castps_si256(y);
    let k = _mm256_srai_epi32::<23>(_mm256_sub_epi32(i, _mm256_set1_epi32(SQRT_HALF_BITS)));
    let mant = _mm256_castsi256_ps(_mm256_sub_epi32(i, _mm256_slli_epi32::<23>(k)));
    let f = _mm256_sub_ps(mant, one);
    let s = _mm256_div_ps(f, _mm256_add_ps(_mm256_set1_ps(2.0), f));
    let s2 = _mm256_mul_ps(s, s);
    let p = _mm256_fmadd_ps(s2, _mm256_set1_ps(1.0 / 9.0), _mm256_set1_ps(1.0 / 7.0));
    let p = _mm256_fmadd_ps(s2, p, _mm256_set1_ps(1.0 / 5.0));
    let p = _mm256_fmadd_ps(s2, p, _mm256_set1_ps(1.0 / 3.0));
    let p = _mm256_fmadd_ps(s2, p, one);
    let ln = _mm256_fmadd_ps(
        _mm256_cvtepi32_ps(k),
        _mm256_set1_ps(LN2),
        _mm256_mul_ps(_mm256_add_ps(s, s), p),
    );
    let w = _mm256_xor_ps(ln, _mm256_set1_ps(-0.0));
    let cw = _mm256_sub_ps(w, _mm256_set1_ps(2.5));
    let mut pc = _mm256_set1_ps(CENTRAL[0]);
    for &a in &CENTRAL[1..] {
        pc = _mm256_fmadd_ps(pc, cw, _mm256_set1_ps(a));
    }
    let central = _mm256_cmp_ps::<_CMP_LT_OQ>(w, _mm256_set1_ps(5.0));
    // the tails (a third of a percent of the draws) only where a lane needs them
    let p = if _mm256_movemask_ps(central) == 0xff {
        pc
    } else {
        let t = _mm256_sub_ps(_mm256_sqrt_ps(w), _mm256_set1_ps(3.0));
        let mut pt = _mm256_set1_ps(TAIL[0]);
        for &a in &TAIL[1..] {
            pt = _mm256_fmadd_ps(pt, t, _mm256_set1_ps(a));
        }
        _mm256_blendv_ps(pt, pc, central)
    };
    _mm256_mul_ps(
        _mm256_mul_ps(p, x),
        _mm256_set1_ps(std::f32::consts::SQRT_2),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::simd::Fused;
    use rand::{Rng, SeedableRng};

    #[test]
    fn the_lane_generator_is_xoshiro128_plus_plus() {
        let mut lanes = LaneRngs::<3>::zero();
        for l in 0..3 {
            lanes.set(l, lane_seed(99, l as u64));
        }
        let mut reference: Vec<rand_xoshiro::Xoshiro128PlusPlus> = (0..3)
            .map(|l| {
                let s = lane_seed(99, l);
                let mut bytes = [0u8; 16];
                for (chunk, w) in bytes.chunks_exact_mut(4).zip(s) {
                    chunk.copy_from_slice(&w.to_le_bytes());
                }
                rand_xoshiro::Xoshiro128PlusPlus::from_seed(bytes)
            })
            .collect();
        for _ in 0..100 {
            let words = lanes.next();
            for (l, r) in reference.iter_mut().enumerate() {
                assert_eq!(words[l], r.next_u32());
            }
        }
        // lanes and keys seed apart
        let seeds: std::collections::HashSet<[u32; 4]> = (0..1000)
            .flat_map(|key| (0..20).map(move |l| lane_seed(key, l)))
            .collect();
        assert_eq!(seeds.len(), 20_000);
    }

    #[test]
    fn the_normal_draw_is_the_normal_quantile() {
        // (quantiles from Python's statistics.NormalDist)
        for (b, z) in [
            (0u32, -5.419_983_174_916_869),
            (1, -5.220_113_060_600_539),
            (10, -4.847_273_591_697_625_5),
            (1000, -3.847_624_040_881_180_4),
            (1 << 23, 7.470_334_394_666_561e-8),
            ((1 << 24) - 1, 5.419_983_174_916_869),
        ] {
            let got = normal_f32(b << 8) as f64;
            assert!((got - z).abs() <= 4e-7 * z.abs().max(1.0), "{b}: {got} {z}");
        }
        // every 24-bit input: symmetric, mean 0, variance 1 (the midpoint rule's)
        let (mut sum, mut sq) = (0.0f64, 0.0f64);
        for b in 0..1u32 << 24 {
            let z = normal_f32(b << 8);
            assert_eq!(z, -normal_f32(((1 << 24) - 1 - b) << 8));
            sum += z as f64;
            sq += z as f64 * z as f64;
        }
        let n = (1u64 << 24) as f64;
        assert!((sum / n).abs() < 1e-12, "{}", sum / n);
        assert!((sq / n - 1.0).abs() < 2e-5, "{}", sq / n);
        // the low eight bits are not used
        assert_eq!(normal_f32(0x1234_5600), normal_f32(0x1234_56ff));
        assert_eq!(unit_f32(u32::MAX), 1.0 - INV_2_24);
        assert_eq!(unit_f32(0xff), 0.0);
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_kernels_give_the_scalar_bits() {
        if !crate::math::Simd::Avx2Fma.available() {
            return;
        }
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(5);
        let mut lanes = LaneRngs::<8>::zero();
        for l in 0..8 {
            lanes.set(l, lane_seed(rng.next_u64(), l as u64));
        }
        let mut words: Vec<[u32; 8]> = (0..2000)
            .map(|_| std::array::from_fn(|_| rng.next_u32()))
            .collect();
        // the tails' ends
        words.push([
            0,
            0xff,
            0x100,
            0x1ff,
            u32::MAX,
            0xffff_fe00,
            0x8000_0000,
            0x7fff_ffff,
        ]);
        // SAFETY: the processor has AVX2 and FMA (checked above).
        unsafe {
            let mut state: [__m256i; 4] = std::mem::transmute(lanes.s);
            for _ in 0..100 {
                let want = lanes.next();
                let got: [u32; 8] = std::mem::transmute(next8(&mut state));
                assert_eq!(got, want);
            }
            for w in &words {
                let v: __m256i = std::mem::transmute(*w);
                let z: [f32; 8] = std::mem::transmute(normal8(v));
                let u: [f32; 8] = std::mem::transmute(unit8(v));
                for l in 0..8 {
                    assert_eq!(
                        z[l].to_bits(),
                        normal_f32_with::<Fused>(w[l]).to_bits(),
                        "{:x}",
                        w[l]
                    );
                    assert_eq!(u[l], unit_f32(w[l]));
                }
            }
        }
    }
}
