//! Four single-precision lanes, for the arithmetic the compiler does not vectorise on
//! its own (it split the sample scores' four-component evaluation into pairs).
//!
//! On x86-64 an [`F32x4`] is one SSE register (part of the baseline target); elsewhere
//! four floats with the same results (every operation is an IEEE single-precision one,
//! lane by lane).

/// Four `f32` lanes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct F32x4(imp::V);

#[cfg(target_arch = "x86_64")]
mod imp {
    use std::arch::x86_64::*;

    pub(super) type V = __m128;

    // SAFETY (every `unsafe` block here): SSE is part of the x86-64 baseline, so the
    // instructions exist on every machine this code runs on; the loads and stores go
    // through references to four floats.

    #[inline(always)]
    pub(super) fn splat(v: f32) -> V {
        unsafe { _mm_set1_ps(v) }
    }
    #[inline(always)]
    pub(super) fn load(a: &[f32; 4]) -> V {
        unsafe { _mm_loadu_ps(a.as_ptr()) }
    }
    #[cfg(test)]
    pub(super) fn store(v: V) -> [f32; 4] {
        let mut a = [0.0f32; 4];
        unsafe { _mm_storeu_ps(a.as_mut_ptr(), v) };
        a
    }
    #[inline(always)]
    pub(super) fn add(a: V, b: V) -> V {
        unsafe { _mm_add_ps(a, b) }
    }
    #[inline(always)]
    pub(super) fn sub(a: V, b: V) -> V {
        unsafe { _mm_sub_ps(a, b) }
    }
    #[inline(always)]
    pub(super) fn mul(a: V, b: V) -> V {
        unsafe { _mm_mul_ps(a, b) }
    }
    /// The largest lane (`a > b ? a : b`, SSE's rule).
    #[inline(always)]
    pub(super) fn hmax(a: V) -> f32 {
        unsafe {
            let b = _mm_max_ps(a, _mm_movehl_ps(a, a));
            let c = _mm_max_ss(b, _mm_shuffle_ps::<0b01>(b, b));
            _mm_cvtss_f32(c)
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod imp {
    pub(super) type V = [f32; 4];

    #[inline(always)]
    fn map2(a: V, b: V, f: impl Fn(f32, f32) -> f32) -> V {
        [f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2]), f(a[3], b[3])]
    }
    #[inline(always)]
    pub(super) fn splat(v: f32) -> V {
        [v; 4]
    }
    #[inline(always)]
    pub(super) fn load(a: &[f32; 4]) -> V {
        *a
    }
    #[cfg(test)]
    pub(super) fn store(v: V) -> [f32; 4] {
        v
    }
    #[inline(always)]
    pub(super) fn add(a: V, b: V) -> V {
        map2(a, b, |x, y| x + y)
    }
    #[inline(always)]
    pub(super) fn sub(a: V, b: V) -> V {
        map2(a, b, |x, y| x - y)
    }
    #[inline(always)]
    pub(super) fn mul(a: V, b: V) -> V {
        map2(a, b, |x, y| x * y)
    }
    #[inline(always)]
    pub(super) fn hmax(a: V) -> f32 {
        let m = |x: f32, y: f32| if x > y { x } else { y };
        m(m(a[0], a[2]), m(a[1], a[3]))
    }
}

/// 1.5 x 2^23: added and subtracted, it rounds an `f32` within `2^22` of zero to the
/// nearest whole number, ties to even ([`F32x4::round`]).
pub(crate) const ROUND_MAGIC: f32 = 12_582_912.0;

impl F32x4 {
    /// All lanes `v`.
    #[inline(always)]
    pub(crate) fn splat(v: f32) -> Self {
        Self(imp::splat(v))
    }
    /// The lanes of `a`.
    #[inline(always)]
    pub(crate) fn load(a: &[f32; 4]) -> Self {
        Self(imp::load(a))
    }
    /// The lanes as an array.
    #[cfg(test)]
    pub(crate) fn to_array(self) -> [f32; 4] {
        imp::store(self.0)
    }
    /// The largest lane.
    #[inline(always)]
    pub(crate) fn max_lane(self) -> f32 {
        imp::hmax(self.0)
    }
    /// Round to the nearest whole number (ties to even), lanes within `2^22` of zero.
    #[inline(always)]
    pub(crate) fn round(self) -> Self {
        (self + Self::splat(ROUND_MAGIC)) - Self::splat(ROUND_MAGIC)
    }
}

impl std::ops::Add for F32x4 {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self(imp::add(self.0, o.0))
    }
}

impl std::ops::Sub for F32x4 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self(imp::sub(self.0, o.0))
    }
}

impl std::ops::Mul for F32x4 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self(imp::mul(self.0, o.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_compute_lane_by_lane() {
        let a = F32x4::load(&[1.0, -7.0, 3.5, 2.0]);
        assert_eq!(a.max_lane(), 3.5);
        assert_eq!(F32x4::load(&[-1.0, -7.0, -3.5, -0.5]).max_lane(), -0.5);
        assert_eq!(
            F32x4::load(&[2.4, -2.6, 0.5, 1e6 + 0.75])
                .round()
                .to_array(),
            [2.0, -3.0, 0.0, 1e6 + 1.0]
        );
        assert_eq!((a - a * a + a).to_array(), [1.0, -63.0, -5.25, 0.0]);
        assert_eq!(F32x4::splat(1.5).to_array(), [1.5; 4]);
    }
}
