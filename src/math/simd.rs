//! Which instructions the prediction loop runs on: the x86-64 baseline (SSE2), or AVX2
//! with fused multiply-add where the processor has them, chosen at run time.
//!
//! One binary serves every x86-64 machine: the lane loop is compiled twice, once for
//! the baseline and once with `avx2,fma` enabled, and [`Simd::active`] picks the copy
//! the processor can run. The environment variable `CLIFF_SIMD` overrides the choice:
//! `baseline` forces the baseline copy, `avx2` asks for the AVX2 copy (ignored, with the
//! baseline kept, where the processor lacks AVX2 or FMA), `auto` (or unset) detects.
//!
//! Both copies draw the same numbers from the same per-sample generators and do the
//! same IEEE operations, except that the AVX2 copy fuses the lane loop's multiply-adds
//! (one rounding instead of two: the normal draw, the sampled direction, the heading
//! update, the position step), so the two paths give positions that differ in their
//! last bits. (The paper's method, with or without scores, and `improved`'s step run
//! in intrinsics on AVX2, eight samples to a register, with the bits of the generic
//! AVX2 copy.) On one path results are
//! deterministic for a seed, and every process on a machine (the daemon, in-process
//! calls, Python) takes the same path unless `CLIFF_SIMD` tells one otherwise.
//!
//! ```
//! use cliff::math::Simd;
//! let active = Simd::active();
//! assert!(active.available());
//! assert!(Simd::Baseline.available());
//! println!("prediction loop on {}", active.name());
//! ```

use std::sync::OnceLock;

/// An instruction set the prediction loop can run on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Simd {
    /// The x86-64 baseline (SSE2), or portable code elsewhere: runs everywhere.
    #[default]
    Baseline,
    /// AVX2 with fused multiply-add (x86-64 processors since about 2013-2015).
    Avx2Fma,
}

impl Simd {
    /// The path this process predicts on: the best the processor has, unless
    /// `CLIFF_SIMD` says otherwise (read once, at the first call).
    pub fn active() -> Simd {
        static ACTIVE: OnceLock<Simd> = OnceLock::new();
        *ACTIVE.get_or_init(|| Simd::choose(std::env::var("CLIFF_SIMD").ok().as_deref()))
    }

    /// The path for a `CLIFF_SIMD` value: `baseline` forces the baseline, anything
    /// else (`auto`, `avx2`, unset) takes the best available.
    pub fn choose(setting: Option<&str>) -> Simd {
        match setting.map(|s| s.trim().to_ascii_lowercase()) {
            Some(s) if s == "baseline" => Simd::Baseline,
            _ => Simd::detect(),
        }
    }

    /// The best path the processor has.
    pub fn detect() -> Simd {
        if Simd::Avx2Fma.available() {
            Simd::Avx2Fma
        } else {
            Simd::Baseline
        }
    }

    /// Whether this processor can run the path.
    pub fn available(self) -> bool {
        match self {
            Simd::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2Fma => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
            }
            #[cfg(not(target_arch = "x86_64"))]
            Simd::Avx2Fma => false,
        }
    }

    /// The path's name (`baseline`, `avx2`), as `CLIFF_SIMD` takes it.
    pub fn name(self) -> &'static str {
        match self {
            Simd::Baseline => "baseline",
            Simd::Avx2Fma => "avx2",
        }
    }
}

/// How the kernels multiply and add: separately rounded (the baseline) or fused. The
/// fused kind is only instantiated inside functions compiled with the `fma` target
/// feature, where `mul_add` is one instruction.
pub(crate) trait MulAdd {
    /// `a * b + c` in double precision.
    fn madd(a: f64, b: f64, c: f64) -> f64;
    /// `a * b + c` in single precision.
    fn madd32(a: f32, b: f32, c: f32) -> f32;
}

/// Multiply, round, add, round: the baseline's arithmetic.
pub(crate) struct Separate;

/// One fused multiply-add (one rounding).
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub(crate) struct Fused;

impl MulAdd for Separate {
    #[inline(always)]
    fn madd(a: f64, b: f64, c: f64) -> f64 {
        a * b + c
    }
    #[inline(always)]
    fn madd32(a: f32, b: f32, c: f32) -> f32 {
        a * b + c
    }
}

impl MulAdd for Fused {
    #[inline(always)]
    fn madd(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
    #[inline(always)]
    fn madd32(a: f32, b: f32, c: f32) -> f32 {
        a.mul_add(b, c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_setting_forces_the_baseline_and_otherwise_detects() {
        assert_eq!(Simd::choose(Some("baseline")), Simd::Baseline);
        assert_eq!(Simd::choose(Some(" Baseline ")), Simd::Baseline);
        assert_eq!(Simd::choose(None), Simd::detect());
        assert_eq!(Simd::choose(Some("avx2")), Simd::detect());
        assert!(Simd::detect().available());
        assert_eq!(Separate::madd(3.0, 0.1, 1.0), 3.0 * 0.1 + 1.0);
        // a fused multiply-add rounds once: 0.1 * 10 - 1 is the rounding error of 0.1
        assert_ne!(Fused::madd(0.1, 10.0, -1.0), 0.0);
        assert_eq!(Separate::madd(0.1, 10.0, -1.0), 0.0);
    }
}
