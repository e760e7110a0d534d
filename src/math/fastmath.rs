//! Small, branch-light math kernels for the prediction loop.
//!
//! The loop needs `sin_cos` of a sampled direction, `acos` of a dot product and `exp`
//! of the kernel once per step; the C library's versions handle every input with full
//! care and cost most of a step. These kernels are exact enough for prediction (sin/cos
//! within a few 1e-16 for the angles that occur, exp within 1e-14 relative; single precision
//! versions within 3e-7) and give the same bits on every machine. The single-precision
//! kernels come in a second form (`..._with::<Fused>`) whose multiply-adds are fused, for
//! the loop's AVX2 + FMA copy ([`Simd`](super::Simd)): within the same bounds, not the
//! same bits.

use std::f64::consts::FRAC_2_PI;

use super::simd::{MulAdd, Separate};

// Cody-Waite split of pi/2 (the classic fdlibm constants).
const PIO2_HI: f64 = 1.570_796_326_734_125_6;
const PIO2_LO: f64 = 6.077_100_506_506_192e-11;

// Minimax coefficients of sin and cos on [-pi/4, pi/4] (fdlibm's kernels).
const S1: f64 = -1.666_666_666_666_663_2e-1;
const S2: f64 = 8.333_333_333_322_49e-3;
const S3: f64 = -1.984_126_982_985_795e-4;
const S4: f64 = 2.755_731_370_707_007e-6;
const S5: f64 = -2.505_076_025_340_686_3e-8;
const S6: f64 = 1.589_690_995_211_55e-10;
const C1: f64 = 0.041_666_666_666_666_6;
const C2: f64 = -1.388_888_888_887_411e-3;
const C3: f64 = 2.480_158_728_947_673e-5;
const C4: f64 = -2.755_731_435_139_066_3e-7;
const C5: f64 = 2.087_572_321_298_175e-9;
const C6: f64 = -1.135_964_755_778_819_5e-11;

/// `(sin x, cos x)` for moderate `|x|` (accurate for `|x| < 1e5`; the loop sees angles
/// within a few turns of zero). Branch-free, so a loop over lanes vectorises.
#[inline(always)]
pub fn sin_cos(x: f64) -> (f64, f64) {
    // Round to nearest by the 1.5 * 2^52 trick (no libm call on baseline x86-64); the
    // low bits of `t` then hold the quadrant k mod 4.
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    let t = x * FRAC_2_PI + MAGIC;
    let k = t - MAGIC;
    let q = t.to_bits() & 3;
    let r = (x - k * PIO2_HI) - k * PIO2_LO;
    let z = r * r;
    // Estrin's scheme: independent pairs, then powers of z (short dependency chains).
    let z2 = z * z;
    let z4 = z2 * z2;
    let ps = (S1 + z * S2) + z2 * (S3 + z * S4) + z4 * (S5 + z * S6);
    let pc = (C1 + z * C2) + z2 * (C3 + z * C4) + z4 * (C5 + z * C6);
    let s = (r + r * z * ps).to_bits();
    let c = (1.0 - 0.5 * z + z2 * pc).to_bits();
    // Quadrant 0: (s, c); 1: (c, -s); 2: (-s, -c); 3: (-c, s).
    let swap = 0u64.wrapping_sub(q & 1);
    let sin = (c & swap) | (s & !swap);
    let cos = (s & swap) | (c & !swap);
    let sin_sign = ((q >> 1) & 1) << 63;
    let cos_sign = (((q + 1) >> 1) & 1) << 63;
    (
        f64::from_bits(sin ^ sin_sign),
        f64::from_bits(cos ^ cos_sign),
    )
}

/// `e^x` for `x <= 0` (0 below -708), within 1e-14 relative. Branch-free.
#[inline(always)]
pub fn exp_neg(x: f64) -> f64 {
    const LN2_HI: f64 = 0.693_147_180_369_123_8;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    let xc = x.clamp(-708.0, 0.0);
    let t = xc * std::f64::consts::LOG2_E + MAGIC;
    let k = t - MAGIC;
    let r = (xc - k * LN2_HI) - k * LN2_LO;
    // Taylor to degree 11 on |r| <= ln2 / 2 (truncation below 1e-14), by Estrin's scheme.
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let p = ((1.0 + r) + r2 * (1.0 / 2.0 + r * (1.0 / 6.0)))
        + r4 * ((1.0 / 24.0 + r * (1.0 / 120.0)) + r2 * (1.0 / 720.0 + r * (1.0 / 5040.0)))
        + r8 * ((1.0 / 40_320.0 + r * (1.0 / 362_880.0))
            + r2 * (1.0 / 3_628_800.0 + r * (1.0 / 39_916_800.0)));
    // 2^k from k's integer bits (k in [-1022, 0]).
    let ki = t.to_bits().wrapping_sub(MAGIC.to_bits());
    let scale = f64::from_bits(ki.wrapping_add(1023) << 52);
    let y = p * scale;
    if x < -708.0 { 0.0 } else { y }
}

/// `atan2(y, x)` in single precision, in `[-pi, pi]`, within 1e-6 rad (0 for the
/// origin). Branch-free: octant reduction to `[0, 1]` and an odd polynomial of degree 13
/// (least squares on Chebyshev nodes).
#[inline(always)]
pub fn atan2_f32(y: f32, x: f32) -> f32 {
    atan2_f32_with::<Separate>(y, x)
}

/// [`atan2_f32`] with the multiply-adds of `M` (fused on the AVX2 path).
#[inline(always)]
pub(crate) fn atan2_f32_with<M: MulAdd>(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    let (ax, ay) = (x.abs(), y.abs());
    // (comparisons rather than f32::min / max, whose NaN rules cost instructions)
    let lo = if ax < ay { ax } else { ay };
    let hi = if ax < ay { ay } else { ax };
    let hi = if hi > f32::MIN_POSITIVE {
        hi
    } else {
        f32::MIN_POSITIVE
    };
    let a = lo / hi;
    let s = a * a;
    let s2 = s * s;
    let s4 = s2 * s2;
    let m = M::madd32;
    // ((c0 + s c1) + s2 (c2 + s c3)) + s4 ((c4 + s c5) + s2 c6)
    let p = m(
        s4,
        m(s2, 0.006_842_661, m(s, -0.033_726_055, 0.079_811_36)),
        m(
            s2,
            m(s, -0.132_475_32, 0.198_132_16),
            m(s, -0.333_183_03, 0.999_996_6),
        ),
    );
    let r = a * p;
    let r = if ay > ax { FRAC_PI_2 - r } else { r };
    let r = if x < 0.0 { PI - r } else { r };
    r.copysign(y)
}

/// `(sin x, cos x)` in single precision for `|x| < 1e4`, within 2e-7, with the
/// multiply-adds of `M` (fused on the AVX2 path). Branch-free.
#[inline(always)]
pub(crate) fn sin_cos_f32_with<M: MulAdd>(x: f32) -> (f32, f32) {
    const MAGIC: f32 = 12_582_912.0; // 1.5 * 2^23
    const PIO2_HI: f32 = 1.570_796_4;
    const PIO2_LO: f32 = -4.371_139e-8;
    let m = M::madd32;
    let t = x * std::f32::consts::FRAC_2_PI + MAGIC;
    let k = t - MAGIC;
    let q = t.to_bits() & 3;
    // (x - k PIO2_HI) - k PIO2_LO
    let r = m(-k, PIO2_LO, m(-k, PIO2_HI, x));
    let z = r * r;
    let z2 = z * z;
    let ps = m(
        z2,
        m(z, 1.0 / 362_880.0, -1.0 / 5040.0),
        m(z, 1.0 / 120.0, -1.0 / 6.0),
    );
    let pc = m(
        z2,
        m(z, -1.0 / 3_628_800.0, 1.0 / 40_320.0),
        m(z, -1.0 / 720.0, 1.0 / 24.0),
    );
    // r + r z ps, and 1 - z / 2 + z2 pc
    let s = m(r * z, ps, r).to_bits();
    let c = m(z2, pc, m(-0.5, z, 1.0)).to_bits();
    let swap = 0u32.wrapping_sub(q & 1);
    let sin = (c & swap) | (s & !swap);
    let cos = (s & swap) | (c & !swap);
    (
        f32::from_bits(sin ^ (((q >> 1) & 1) << 31)),
        f32::from_bits(cos ^ ((((q + 1) >> 1) & 1) << 31)),
    )
}

/// `acos x` in single precision for `x` in `[-1, 1]` (clamped), within 3e-7 rad, with
/// the multiply-adds of `M` (fused on the AVX2 path).
#[inline(always)]
pub(crate) fn acos_f32_with<M: MulAdd>(x: f32) -> f32 {
    let x = x.clamp(-1.0, 1.0);
    let a = x.abs();
    let a2 = a * a;
    let a4 = a2 * a2;
    let m = M::madd32;
    let p = m(
        a4,
        m(
            a2,
            m(a, -0.001_262_491_1, 0.006_670_09),
            m(a, -0.017_088_126, 0.030_891_88),
        ),
        m(
            a2,
            m(a, -0.050_174_303, 0.088_978_99),
            m(a, -0.214_598_8, 1.570_796_3),
        ),
    );
    let r = (1.0 - a).sqrt() * p;
    if x < 0.0 { std::f32::consts::PI - r } else { r }
}

/// `e^x` in single precision for `x <= 0` (0 below -87), within 3e-7 relative.
#[inline(always)]
pub fn exp_neg_f32(x: f32) -> f32 {
    exp_neg_f32_with::<Separate>(x)
}

/// [`exp_neg_f32`] with the multiply-adds of `M` (fused on the AVX2 path).
#[inline(always)]
pub(crate) fn exp_neg_f32_with<M: MulAdd>(x: f32) -> f32 {
    exp_up_to::<M>(x, 0.0)
}

/// `e^x` in single precision for `x <= 87` (0 below -87), within 3e-7 relative: the
/// reduction and polynomial of [`exp_neg_f32`] over both signs (no division for a
/// positive `x`).
#[inline(always)]
pub fn exp_f32(x: f32) -> f32 {
    exp_up_to::<Separate>(x, 87.0)
}

/// `e^x` for `x` clamped to `[-87, hi]` (0 below -87) with the multiply-adds of `M`:
/// `2^k` times a degree-6 polynomial of the rest after a two-part `ln 2` reduction.
#[inline(always)]
fn exp_up_to<M: MulAdd>(x: f32, hi: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0;
    const LN2_HI: f32 = 0.693_145_75;
    const LN2_LO: f32 = 1.428_606_8e-6;
    let m = M::madd32;
    let xc = x.clamp(-87.0, hi);
    let t = xc * std::f32::consts::LOG2_E + MAGIC;
    let k = t - MAGIC;
    let r = m(-k, LN2_LO, m(-k, LN2_HI, xc));
    let r2 = r * r;
    let r4 = r2 * r2;
    // ((1 + r) + r2 (1/2 + r/6)) + r4 ((1/24 + r/120) + r2/720)
    let p = m(
        r4,
        m(r2, 1.0 / 720.0, m(r, 1.0 / 120.0, 1.0 / 24.0)),
        m(r2, m(r, 1.0 / 6.0, 0.5), 1.0 + r),
    );
    let ki = t.to_bits().wrapping_sub(MAGIC.to_bits());
    let scale = f32::from_bits(ki.wrapping_add(127) << 23);
    let y = p * scale;
    if x < -87.0 { 0.0 } else { y }
}

/// The AVX2 forms of the single-precision kernels on `V` registers of eight lanes:
/// each operation for all registers before the next, so that the registers' chains
/// of dependent operations overlap. Each gives the bits of its scalar form with fused
/// multiply-adds (`..._with::<Fused>`) for finite inputs.
#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use std::arch::x86_64::*;

    /// `[f(0), .., f(V - 1)]`, written out (a loop the compiler unrolls: the
    /// registers' operations interleave).
    macro_rules! per {
        ($V:expr, |$v:ident| $e:expr) => {{
            // SAFETY: all-zero bits are a valid vector (overwritten below).
            let mut out = [unsafe { std::mem::zeroed() }; $V];
            for $v in 0..$V {
                out[$v] = $e;
            }
            out
        }};
    }
    pub(crate) use per;

    /// [`sin_cos_f32_with`](super::sin_cos_f32_with)`::<Fused>` of `V` registers.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(crate) fn sin_cos<const V: usize>(x: [__m256; V]) -> ([__m256; V], [__m256; V]) {
        const MAGIC: f32 = 12_582_912.0;
        const PIO2_HI: f32 = 1.570_796_4;
        const PIO2_LO: f32 = -4.371_139e-8;
        let c = _mm256_set1_ps;
        let t = per!(V, |v| _mm256_add_ps(
            _mm256_mul_ps(x[v], c(std::f32::consts::FRAC_2_PI)),
            c(MAGIC)
        ));
        let nk = per!(V, |v| _mm256_xor_ps(_mm256_sub_ps(t[v], c(MAGIC)), c(-0.0)));
        let r = per!(V, |v| _mm256_fmadd_ps(nk[v], c(PIO2_HI), x[v]));
        let r = per!(V, |v| _mm256_fmadd_ps(nk[v], c(PIO2_LO), r[v]));
        let z = per!(V, |v| _mm256_mul_ps(r[v], r[v]));
        let z2 = per!(V, |v| _mm256_mul_ps(z[v], z[v]));
        let s1 = per!(V, |v| _mm256_fmadd_ps(
            z[v],
            c(1.0 / 362_880.0),
            c(-1.0 / 5040.0)
        ));
        let s0 = per!(V, |v| _mm256_fmadd_ps(z[v], c(1.0 / 120.0), c(-1.0 / 6.0)));
        let c1 = per!(V, |v| _mm256_fmadd_ps(
            z[v],
            c(-1.0 / 3_628_800.0),
            c(1.0 / 40_320.0)
        ));
        let c0 = per!(V, |v| _mm256_fmadd_ps(z[v], c(-1.0 / 720.0), c(1.0 / 24.0)));
        let ps = per!(V, |v| _mm256_fmadd_ps(z2[v], s1[v], s0[v]));
        let pc = per!(V, |v| _mm256_fmadd_ps(z2[v], c1[v], c0[v]));
        let rz = per!(V, |v| _mm256_mul_ps(r[v], z[v]));
        let s = per!(V, |v| _mm256_fmadd_ps(rz[v], ps[v], r[v]));
        let half = per!(V, |v| _mm256_fmadd_ps(c(-0.5), z[v], c(1.0)));
        let co = per!(V, |v| _mm256_fmadd_ps(z2[v], pc[v], half[v]));
        // quadrants 1 and 3 swap; 2 and 3 negate the sine, 1 and 2 the cosine
        let one = _mm256_set1_epi32(1);
        let q = per!(V, |v| _mm256_and_si256(
            _mm256_castps_si256(t[v]),
            _mm256_set1_epi32(3)
        ));
        let swap = per!(V, |v| _mm256_castsi256_ps(_mm256_cmpeq_epi32(
            _mm256_and_si256(q[v], one),
            one
        )));
        let sin = per!(V, |v| _mm256_xor_ps(
            _mm256_blendv_ps(s[v], co[v], swap[v]),
            _mm256_castsi256_ps(_mm256_slli_epi32::<31>(_mm256_srli_epi32::<1>(q[v])))
        ));
        let cos = per!(V, |v| _mm256_xor_ps(
            _mm256_blendv_ps(co[v], s[v], swap[v]),
            _mm256_castsi256_ps(_mm256_slli_epi32::<31>(_mm256_srli_epi32::<1>(
                _mm256_add_epi32(q[v], one)
            )))
        ));
        (sin, cos)
    }

    /// [`acos_f32_with`](super::acos_f32_with)`::<Fused>` of `V` registers.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(crate) fn acos<const V: usize>(x: [__m256; V]) -> [__m256; V] {
        let c = _mm256_set1_ps;
        let x = per!(V, |v| _mm256_min_ps(_mm256_max_ps(x[v], c(-1.0)), c(1.0)));
        let a = per!(V, |v| _mm256_andnot_ps(c(-0.0), x[v]));
        let a2 = per!(V, |v| _mm256_mul_ps(a[v], a[v]));
        let a4 = per!(V, |v| _mm256_mul_ps(a2[v], a2[v]));
        let p3 = per!(V, |v| _mm256_fmadd_ps(
            a[v],
            c(-0.001_262_491_1),
            c(0.006_670_09)
        ));
        let p2 = per!(V, |v| _mm256_fmadd_ps(
            a[v],
            c(-0.017_088_126),
            c(0.030_891_88)
        ));
        let p1 = per!(V, |v| _mm256_fmadd_ps(
            a[v],
            c(-0.050_174_303),
            c(0.088_978_99)
        ));
        let p0 = per!(V, |v| _mm256_fmadd_ps(
            a[v],
            c(-0.214_598_8),
            c(1.570_796_3)
        ));
        let hi = per!(V, |v| _mm256_fmadd_ps(a2[v], p3[v], p2[v]));
        let lo = per!(V, |v| _mm256_fmadd_ps(a2[v], p1[v], p0[v]));
        let p = per!(V, |v| _mm256_fmadd_ps(a4[v], hi[v], lo[v]));
        let r = per!(V, |v| _mm256_mul_ps(
            _mm256_sqrt_ps(_mm256_sub_ps(c(1.0), a[v])),
            p[v]
        ));
        per!(V, |v| _mm256_blendv_ps(
            r[v],
            _mm256_sub_ps(c(std::f32::consts::PI), r[v]),
            _mm256_cmp_ps::<_CMP_LT_OQ>(x[v], c(0.0))
        ))
    }

    /// [`atan2_f32_with`](super::atan2_f32_with)`::<Fused>` of `V` registers.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(crate) fn atan2<const V: usize>(y: [__m256; V], x: [__m256; V]) -> [__m256; V] {
        use std::f32::consts::{FRAC_PI_2, PI};
        let c = _mm256_set1_ps;
        let sign = c(-0.0);
        let ax = per!(V, |v| _mm256_andnot_ps(sign, x[v]));
        let ay = per!(V, |v| _mm256_andnot_ps(sign, y[v]));
        let x_below = per!(V, |v| _mm256_cmp_ps::<_CMP_LT_OQ>(ax[v], ay[v]));
        let lo = per!(V, |v| _mm256_blendv_ps(ay[v], ax[v], x_below[v]));
        let hi = per!(V, |v| _mm256_blendv_ps(ax[v], ay[v], x_below[v]));
        let tiny = c(f32::MIN_POSITIVE);
        let hi = per!(V, |v| _mm256_blendv_ps(
            tiny,
            hi[v],
            _mm256_cmp_ps::<_CMP_GT_OQ>(hi[v], tiny)
        ));
        let a = per!(V, |v| _mm256_div_ps(lo[v], hi[v]));
        let s = per!(V, |v| _mm256_mul_ps(a[v], a[v]));
        let s2 = per!(V, |v| _mm256_mul_ps(s[v], s[v]));
        let s4 = per!(V, |v| _mm256_mul_ps(s2[v], s2[v]));
        let p3 = per!(V, |v| _mm256_fmadd_ps(
            s2[v],
            c(0.006_842_661),
            _mm256_fmadd_ps(s[v], c(-0.033_726_055), c(0.079_811_36))
        ));
        let p1 = per!(V, |v| _mm256_fmadd_ps(
            s[v],
            c(-0.132_475_32),
            c(0.198_132_16)
        ));
        let p0 = per!(V, |v| _mm256_fmadd_ps(
            s[v],
            c(-0.333_183_03),
            c(0.999_996_6)
        ));
        let lo_p = per!(V, |v| _mm256_fmadd_ps(s2[v], p1[v], p0[v]));
        let p = per!(V, |v| _mm256_fmadd_ps(s4[v], p3[v], lo_p[v]));
        let r = per!(V, |v| _mm256_mul_ps(a[v], p[v]));
        let r = per!(V, |v| _mm256_blendv_ps(
            r[v],
            _mm256_sub_ps(c(FRAC_PI_2), r[v]),
            _mm256_cmp_ps::<_CMP_GT_OQ>(ay[v], ax[v])
        ));
        let r = per!(V, |v| _mm256_blendv_ps(
            r[v],
            _mm256_sub_ps(c(PI), r[v]),
            _mm256_cmp_ps::<_CMP_LT_OQ>(x[v], _mm256_setzero_ps())
        ));
        // r.copysign(y)
        per!(V, |v| _mm256_or_ps(
            _mm256_andnot_ps(sign, r[v]),
            _mm256_and_ps(sign, y[v])
        ))
    }

    /// [`exp_neg_f32_with`](super::exp_neg_f32_with)`::<Fused>` of `V` registers.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(crate) fn exp_neg<const V: usize>(x: [__m256; V]) -> [__m256; V] {
        const MAGIC: f32 = 12_582_912.0;
        const LN2_HI: f32 = 0.693_145_75;
        const LN2_LO: f32 = 1.428_606_8e-6;
        let c = _mm256_set1_ps;
        // (a zero of either sign gives 1 either way)
        let xc = per!(V, |v| _mm256_min_ps(_mm256_max_ps(x[v], c(-87.0)), c(0.0)));
        let t = per!(V, |v| _mm256_add_ps(
            _mm256_mul_ps(xc[v], c(std::f32::consts::LOG2_E)),
            c(MAGIC)
        ));
        let nk = per!(V, |v| _mm256_xor_ps(_mm256_sub_ps(t[v], c(MAGIC)), c(-0.0)));
        let r = per!(V, |v| _mm256_fmadd_ps(nk[v], c(LN2_HI), xc[v]));
        let r = per!(V, |v| _mm256_fmadd_ps(nk[v], c(LN2_LO), r[v]));
        let r2 = per!(V, |v| _mm256_mul_ps(r[v], r[v]));
        let r4 = per!(V, |v| _mm256_mul_ps(r2[v], r2[v]));
        let h0 = per!(V, |v| _mm256_fmadd_ps(r[v], c(1.0 / 120.0), c(1.0 / 24.0)));
        let l0 = per!(V, |v| _mm256_fmadd_ps(r[v], c(1.0 / 6.0), c(0.5)));
        let hi = per!(V, |v| _mm256_fmadd_ps(r2[v], c(1.0 / 720.0), h0[v]));
        let lo = per!(V, |v| _mm256_fmadd_ps(
            r2[v],
            l0[v],
            _mm256_add_ps(c(1.0), r[v])
        ));
        let p = per!(V, |v| _mm256_fmadd_ps(r4[v], hi[v], lo[v]));
        let magic = _mm256_set1_epi32(MAGIC.to_bits() as i32);
        let scale = per!(V, |v| _mm256_castsi256_ps(_mm256_slli_epi32::<23>(
            _mm256_add_epi32(
                _mm256_sub_epi32(_mm256_castps_si256(t[v]), magic),
                _mm256_set1_epi32(127)
            )
        )));
        per!(V, |v| _mm256_andnot_ps(
            _mm256_cmp_ps::<_CMP_LT_OQ>(x[v], c(-87.0)),
            _mm256_mul_ps(p[v], scale[v])
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn sin_cos_matches_libm() {
        let mut worst: f64 = 0.0;
        for i in -200_000..=200_000 {
            let x = i as f64 * 1e-4 + 0.123_456_789e-5;
            let (s, c) = sin_cos(x);
            worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        assert!(worst < 1e-15, "{worst}");
        for x in [0.0, PI, -PI, 2.0 * PI, PI / 2.0, 1e3, -1e4 + 0.5] {
            let (s, c) = sin_cos(x);
            assert!(
                (s - x.sin()).abs() < 1e-12 && (c - x.cos()).abs() < 1e-12,
                "{x}"
            );
        }
    }

    #[test]
    fn exp_neg_matches_libm() {
        let mut worst: f64 = 0.0;
        for i in 0..=200_000 {
            let x = -(i as f64) * 1e-4 * 3.5;
            worst = worst.max((exp_neg(x) / x.exp() - 1.0).abs());
        }
        assert!(worst < 1e-14, "{worst}");
        assert_eq!(exp_neg(0.0), 1.0);
        assert_eq!(exp_neg(-1000.0), 0.0);
        assert!((exp_neg(-700.0) / (-700.0f64).exp() - 1.0).abs() < 1e-13);
    }

    #[test]
    fn exp_f32_matches_libm_over_both_signs() {
        let mut worst: f64 = 0.0;
        for i in -286_000i32..=286_000 {
            let x = i as f32 * 3e-4;
            worst = worst.max((exp_f32(x) as f64 / (x as f64).exp() - 1.0).abs());
        }
        assert!(worst < 5e-7, "{worst}");
        assert_eq!(exp_f32(0.0), 1.0);
        assert_eq!(exp_f32(-100.0), 0.0);
        // the same values as the negative-only form where both apply
        for i in 0..=10_000 {
            let x = -(i as f32) * 8e-3;
            assert_eq!(exp_f32(x).to_bits(), exp_neg_f32(x).to_bits(), "{x}");
        }
    }

    /// The single-precision kernels with the multiply-adds of `M` against libm.
    fn single_precision_kernels_within_bounds<M: MulAdd>() {
        let (mut ws, mut wa, mut we) = (0.0f64, 0.0f64, 0.0f64);
        for i in -100_000i32..=100_000 {
            let x = i as f32 * 1e-4;
            let (s, c) = sin_cos_f32_with::<M>(x);
            ws = ws
                .max((s as f64 - (x as f64).sin()).abs())
                .max((c as f64 - (x as f64).cos()).abs());
            let y = i as f32 * 1e-5;
            wa = wa.max((acos_f32_with::<M>(y) as f64 - (y as f64).acos()).abs());
            let e = -(i.unsigned_abs() as f32) * 3e-4;
            we = we.max((exp_neg_f32_with::<M>(e) as f64 / (e as f64).exp() - 1.0).abs());
        }
        assert!(ws < 3e-7, "sin/cos {ws}");
        assert!(wa < 5e-7, "acos {wa}");
        assert!(we < 5e-7, "exp {we}");
        assert_eq!(exp_neg_f32_with::<M>(-100.0), 0.0);
        let mut wt = 0.0f64;
        for i in 0..=100_000 {
            let t = -PI + i as f64 * 2.0 * PI / 100_000.0;
            for r in [1.0, 1e-3, 7.0] {
                let (y, x) = ((t.sin() * r) as f32, (t.cos() * r) as f32);
                let d = atan2_f32_with::<M>(y, x) as f64 - (y as f64).atan2(x as f64);
                wt = wt.max(d.abs());
            }
        }
        assert!(wt < 1e-6, "atan2 {wt}");
        assert_eq!(atan2_f32_with::<M>(0.0, 0.0), 0.0);
    }

    #[test]
    fn single_precision_kernels_match_libm() {
        single_precision_kernels_within_bounds::<Separate>();
    }

    #[test]
    fn fused_single_precision_kernels_match_libm() {
        // (software fused multiply-adds where the processor has none: the same bits)
        single_precision_kernels_within_bounds::<crate::math::simd::Fused>();
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_kernels_give_the_fused_bits() {
        use crate::math::simd::Fused;
        use std::arch::x86_64::*;
        if !crate::math::Simd::Avx2Fma.available() {
            return;
        }
        let inputs: Vec<f32> = (-40_000i32..=40_000)
            .map(|i| i as f32 * 2.5e-4)
            .chain([0.0, -0.0, 1.0, -1.0, 87.5, -87.5, -100.0, 3.0e3])
            .collect();
        for chunk in inputs.chunks_exact(8) {
            let x: [f32; 8] = chunk.try_into().unwrap();
            // SAFETY: AVX2 and FMA (checked above); eight lanes.
            let (s, c, a, e) = unsafe {
                let v = _mm256_loadu_ps(x.as_ptr());
                let (s, c) = x8::sin_cos([v]);
                let neg = _mm256_sub_ps(_mm256_setzero_ps(), _mm256_mul_ps(v, v));
                let (a, e) = (x8::acos([v, v, v]), x8::exp_neg([neg, neg]));
                let out = |v: __m256| std::mem::transmute::<__m256, [f32; 8]>(v);
                (out(s[0]), out(c[0]), out(a[2]), out(e[1]))
            };
            for l in 0..8 {
                let (ws, wc) = sin_cos_f32_with::<Fused>(x[l]);
                assert_eq!(
                    (s[l].to_bits(), c[l].to_bits()),
                    (ws.to_bits(), wc.to_bits()),
                    "{}",
                    x[l]
                );
                assert_eq!(
                    a[l].to_bits(),
                    acos_f32_with::<Fused>(x[l]).to_bits(),
                    "{}",
                    x[l]
                );
                let neg = 0.0 - x[l] * x[l];
                assert_eq!(
                    e[l].to_bits(),
                    exp_neg_f32_with::<Fused>(neg).to_bits(),
                    "{}",
                    x[l]
                );
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_atan2_gives_the_fused_bits() {
        use crate::math::simd::Fused;
        use std::arch::x86_64::*;
        if !crate::math::Simd::Avx2Fma.available() {
            return;
        }
        // every octant, the axes, zeros of both signs and the tiny and huge
        let mut pairs: Vec<(f32, f32)> = (0..20_000)
            .map(|i| {
                let t = i as f32 * 3.7e-4 - 3.7;
                let r = 0.3 + (i % 17) as f32 * 0.9;
                (r * t.sin(), r * t.cos())
            })
            .collect();
        for a in [0.0f32, -0.0, 1.0, -1.0, 1e-30, -1e-39, 3e38, -2.5] {
            for b in [0.0f32, -0.0, 1.0, -1.0, 1e-30, -1e-39, 3e38, 0.7] {
                pairs.push((a, b));
            }
        }
        pairs.resize(pairs.len().next_multiple_of(16), (0.5, 0.5));
        for chunk in pairs.chunks_exact(16) {
            let y: [f32; 16] = std::array::from_fn(|i| chunk[i].0);
            let x: [f32; 16] = std::array::from_fn(|i| chunk[i].1);
            // SAFETY: AVX2 and FMA (checked above); sixteen lanes.
            let out = unsafe {
                let load = |a: &[f32; 16], h: usize| _mm256_loadu_ps(a.as_ptr().add(8 * h));
                let r = x8::atan2([load(&y, 0), load(&y, 1)], [load(&x, 0), load(&x, 1)]);
                std::mem::transmute::<[__m256; 2], [f32; 16]>(r)
            };
            for l in 0..16 {
                assert_eq!(
                    out[l].to_bits(),
                    atan2_f32_with::<Fused>(y[l], x[l]).to_bits(),
                    "atan2({}, {})",
                    y[l],
                    x[l]
                );
            }
        }
    }
}
