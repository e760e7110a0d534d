//! Small, branch-light math kernels for the prediction loop.
//!
//! The loop needs `sin_cos` of a sampled direction, `acos` of a dot product and `exp`
//! of the kernel once per step; the C library's versions handle every input with full
//! care and cost most of a step. These kernels are exact enough for prediction (sin/cos
//! within a few 1e-16 for the angles that occur, exp within 1e-14 relative, acos within
//! 2e-8 rad) and give the same bits on every machine.

use std::f64::consts::{FRAC_2_PI, PI};

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
/// within a few turns of zero).
#[inline(always)]
pub fn sin_cos(x: f64) -> (f64, f64) {
    // Round to nearest by the 1.5 * 2^52 trick (no libm call on baseline x86-64).
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    let k = (x * FRAC_2_PI + MAGIC) - MAGIC;
    let r = (x - k * PIO2_HI) - k * PIO2_LO;
    let z = r * r;
    // Estrin's scheme: independent pairs, then powers of z (short dependency chains).
    let z2 = z * z;
    let z4 = z2 * z2;
    let ps = (S1 + z * S2) + z2 * (S3 + z * S4) + z4 * (S5 + z * S6);
    let pc = (C1 + z * C2) + z2 * (C3 + z * C4) + z4 * (C5 + z * C6);
    let s = r + r * z * ps;
    let c = 1.0 - 0.5 * z + z2 * pc;
    match (k as i64) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// `acos x` for `x` in `[-1, 1]` (clamped), within 2e-8 rad (Abramowitz & Stegun 4.4.46).
#[inline(always)]
pub fn acos(x: f64) -> f64 {
    let x = x.clamp(-1.0, 1.0);
    let a = x.abs();
    let a2 = a * a;
    let a4 = a2 * a2;
    let p = ((1.570_796_305_0 + a * -0.214_598_801_6)
        + a2 * (0.088_978_987_4 + a * -0.050_174_304_6))
        + a4 * ((0.030_891_881_0 + a * -0.017_088_125_6)
            + a2 * (0.006_670_090_1 + a * -0.001_262_491_1));
    let r = (1.0 - a).sqrt() * p;
    if x < 0.0 { PI - r } else { r }
}

/// `e^x` for `x <= 0` (0 below -708), within 1e-14 relative.
#[inline(always)]
pub fn exp_neg(x: f64) -> f64 {
    const LN2_HI: f64 = 0.693_147_180_369_123_8;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    if x < -708.0 {
        return 0.0;
    }
    let x = x.min(0.0);
    let k = (x * std::f64::consts::LOG2_E + MAGIC) - MAGIC;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    // Taylor to degree 11 on |r| <= ln2 / 2 (truncation below 1e-14), by Estrin's scheme.
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let p = ((1.0 + r) + r2 * (1.0 / 2.0 + r * (1.0 / 6.0)))
        + r4 * ((1.0 / 24.0 + r * (1.0 / 120.0)) + r2 * (1.0 / 720.0 + r * (1.0 / 5040.0)))
        + r8 * ((1.0 / 40_320.0 + r * (1.0 / 362_880.0))
            + r2 * (1.0 / 3_628_800.0 + r * (1.0 / 39_916_800.0)));
    let scale = f64::from_bits(((k as i64 + 1023) as u64) << 52);
    p * scale
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn acos_matches_libm() {
        let mut worst: f64 = 0.0;
        for i in -100_000..=100_000 {
            let x = i as f64 * 1e-5;
            worst = worst.max((acos(x) - x.acos()).abs());
        }
        assert!(worst < 3e-8, "{worst}");
        assert_eq!(acos(1.0), 0.0);
        assert!((acos(-1.0) - PI).abs() < 1e-8);
        assert_eq!(acos(1.5), 0.0);
    }
}
