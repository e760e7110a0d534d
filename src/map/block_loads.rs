//! Eight lanes' blocks of a map table read into registers: a location's components
//! sit four to a block, field by field, so one 16-byte load per lane and a
//! transposition give a field's four slots for eight lanes (the AVX2 lane loops' follow
//! draw and step scores), where gathers would take one instruction per slot.

/// The four floats at each of eight addresses, slot by slot: register `i` holds float
/// `i` of each address, lane `l` from `at[l]` (a transposition of eight loads, cheaper
/// than four gathers).
///
/// # Safety
/// The processor must have AVX2; each address must have four readable floats.
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) unsafe fn slots4(at: [*const f32; 8]) -> [std::arch::x86_64::__m256; 4] {
    use std::arch::x86_64::*;
    // SAFETY: as this function requires.
    let r: [__m256; 4] = std::array::from_fn(|j| unsafe {
        _mm256_insertf128_ps::<1>(
            _mm256_castps128_ps256(_mm_loadu_ps(at[j])),
            _mm_loadu_ps(at[j + 4]),
        )
    });
    // (lanes j and j + 4 in register j; then pairs, then quadruples)
    let (t0, t1) = (
        _mm256_unpacklo_ps(r[0], r[1]),
        _mm256_unpackhi_ps(r[0], r[1]),
    );
    let (t2, t3) = (
        _mm256_unpacklo_ps(r[2], r[3]),
        _mm256_unpackhi_ps(r[2], r[3]),
    );
    let pd = _mm256_castps_pd;
    [
        _mm256_castpd_ps(_mm256_unpacklo_pd(pd(t0), pd(t2))),
        _mm256_castpd_ps(_mm256_unpackhi_pd(pd(t0), pd(t2))),
        _mm256_castpd_ps(_mm256_unpacklo_pd(pd(t1), pd(t3))),
        _mm256_castpd_ps(_mm256_unpackhi_pd(pd(t1), pd(t3))),
    ]
}
