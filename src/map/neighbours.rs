//! Per-radius candidate lists: the fast path of [`CliffMap::best_near`](super::CliffMap::best_near).
//!
//! For a given sampling radius, every grid cell (and a margin of cells around the map)
//! lists the locations that can lie within the radius of some point of the cell, sorted
//! by observation ratio (largest first, then by index). The location CLiFF-LHMP samples
//! from is then the first candidate that is actually within the radius.
//!
//! Each cell is further split into `n x n` sub-cells (n = 16, 8 or 4: the finest whose
//! table fits [`MAX_SUB_CELLS`]). A sub-cell stores its answer as a pair: a location to test and the answer when the
//! test fails. Where one location is the answer for every point of the sub-cell (the
//! usual case), or none is near any of its points, the test is a sentinel that always
//! fails; on the edge of one location's circle the test is that location. A query is
//! then one table load and one distance test, and its only branches (nothing near,
//! scan) are rarely taken. Only sub-cells where more circles meet scan the cell's
//! candidates. The table keeps each distinct pair once and a sub-cell's index into
//! them (two bytes instead of eight, so more of a large map's table stays in the
//! caches), unless a map has more than 65,536 of them.

use glam::DVec2;

use super::grid::GridIndex;

/// Largest sub-cell table (entries of 8 bytes) one radius gets: 16 MiB.
pub const MAX_SUB_CELLS: usize = 2 << 20;
/// Sub-cells per cell along each axis, as powers of two, finest first.
const SUB_SHIFTS: [u32; 3] = [4, 3, 2];
/// Sub-cell code: no location is near any point of the sub-cell.
const NONE_NEAR: u32 = u32::MAX;
/// Sub-cell code: the answer varies within the sub-cell; scan the cell's candidates.
const SCAN: u32 = u32::MAX - 1;

/// A sub-cell's answer: `test` if it is strictly within the radius of the query point,
/// else `otherwise` (a location index, [`NONE_NEAR`] or [`SCAN`]).
#[derive(Debug, Clone, Copy)]
#[repr(C)] // (read by gathers: `test`, then `otherwise`)
struct SubCell {
    /// Index into [`NeighbourTable::points`]; the last point is a sentinel at infinity.
    test: u32,
    otherwise: u32,
}
/// Safety margin (m) for deciding a sub-cell's answer, larger than any rounding.
const MARGIN: f64 = 1e-9;
/// Largest number of candidate entries built.
const MAX_ENTRIES: usize = 16_000_000;

#[derive(Debug, Clone, Copy)]
struct Candidate {
    position: DVec2,
    index: u32,
}

/// Candidate lists for one radius.
#[derive(Debug)]
pub struct NeighbourTable {
    radius: f64,
    r2: f64,
    origin: DVec2,
    inv_sub: f64,
    /// Half the sub-cells per cell along an axis (the sub-cell grid is offset by it).
    half_sub: f64,
    /// log2 of the sub-cells per cell along an axis.
    shift: u32,
    nx: usize,
    /// Sub-cells along x and y, and the same as floats (for the range check).
    snx: usize,
    sub_dims: DVec2,
    offsets: Vec<u32>,
    candidates: Vec<Candidate>,
    /// The map's location positions, then the sentinel (never within the radius).
    points: Vec<DVec2>,
    /// The sub-cells' pairs, unless the table is compact (`ids` not empty).
    sub: Vec<SubCell>,
    /// Compact tables (the usual: at most 65,536 distinct pairs): each sub-cell's pair
    /// as its index in `pairs`, a quarter of the bytes, so more of a large map's table
    /// stays in the caches.
    ids: Vec<u16>,
    pairs: Vec<SubCell>,
}

/// The compact form of the sub-cells `sub`: each one's index in a list of the distinct
/// pairs, and that list; `(vec![], vec![])` if there are more than 65,536.
fn compact(sub: &[SubCell]) -> (Vec<u16>, Vec<SubCell>) {
    /// A multiplicative hash of one u64 (the pairs are few and their keys distinct: a
    /// sub-cell costs a multiplication, not a SipHash).
    #[derive(Default)]
    struct PairHash(u64);
    impl std::hash::Hasher for PairHash {
        fn finish(&self) -> u64 {
            self.0
        }
        fn write(&mut self, _: &[u8]) {
            unreachable!("pairs hash as one u64")
        }
        fn write_u64(&mut self, k: u64) {
            self.0 = (k ^ (k >> 29)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }
    let mut index: std::collections::HashMap<u64, usize, _> =
        std::collections::HashMap::with_hasher(std::hash::BuildHasherDefault::<PairHash>::default());
    let mut pairs = Vec::new();
    let mut ids = Vec::with_capacity(sub.len());
    let mut last = None;
    for c in sub {
        let key = (c.test as u64) << 32 | c.otherwise as u64;
        // (runs of equal sub-cells are the rule)
        if let Some((k, id)) = last
            && k == key
        {
            ids.push(id);
            continue;
        }
        let next = pairs.len();
        let id = *index.entry(key).or_insert(next);
        if id == next {
            if next > u16::MAX as usize {
                return (Vec::new(), Vec::new());
            }
            pairs.push(*c);
        }
        ids.push(id as u16);
        last = Some((key, id as u16));
    }
    (ids, pairs)
}

impl NeighbourTable {
    /// Build the table for `radius`, giving up (with [`TableError::TooLarge`]) as soon
    /// as it would take more than `max_bytes` (or more than [`MAX_SUB_CELLS`] sub-cells
    /// and 16 million candidate entries whatever the budget), so that the time spent on a
    /// table that is not kept stays bounded too.
    pub(super) fn build(
        grid: &GridIndex,
        positions: &[DVec2],
        ratios: &[f64],
        radius: f64,
        max_bytes: usize,
    ) -> Result<Self, TableError> {
        let too_large = TableError::TooLarge {
            radius,
            limit: max_bytes,
        };
        if !(radius.is_finite() && radius > 0.0) {
            return Err(TableError::BadRadius { radius });
        }
        let step = grid.step();
        let margin_f = (radius / step).ceil() + 1.0;
        if margin_f > 1e6 {
            return Err(too_large);
        }
        let margin = margin_f as usize;
        let (gx, gy) = grid.dims();
        let nx = gx + 2 * margin;
        let ny = gy + 2 * margin;
        let cells = nx.checked_mul(ny).ok_or(too_large)?;
        let shift = *SUB_SHIFTS
            .iter()
            .find(|&&s| cells.saturating_mul(1 << (2 * s)) <= MAX_SUB_CELLS)
            .ok_or(too_large)?;
        let sub_n = 1usize << shift;
        // Sizes known before the candidate lists: sub-cells, offsets, points.
        // (a compact table's sub-cells: checked again once built)
        let fixed = cells * sub_n * sub_n * size_of::<u16>()
            + (cells + 1) * size_of::<u32>()
            + (positions.len() + 1) * size_of::<DVec2>();
        if fixed > max_bytes {
            return Err(too_large);
        }
        let max_entries = ((max_bytes - fixed) / size_of::<Candidate>()).min(MAX_ENTRIES);
        let origin = grid.origin() - DVec2::splat(margin as f64 * step);
        let r2 = radius * radius;
        let mut offsets = Vec::with_capacity(nx * ny + 1);
        let mut candidates = Vec::new();
        let mut cell_list: Vec<u32> = Vec::new();
        // A cell (cx, cy) holds the points whose nearest cell centre it is:
        // the square of side `step` around origin + (cx, cy) * step.
        let half = 0.5 * step;
        for cy in 0..ny {
            for cx in 0..nx {
                offsets.push(candidates.len() as u32);
                let centre = origin + DVec2::new(cx as f64, cy as f64) * step;
                cell_list.clear();
                // Superset query: everything within radius + half-diagonal of the centre.
                grid.for_each_candidate(
                    centre,
                    radius + half * std::f64::consts::SQRT_2 + 1e-9,
                    |i| {
                        // Exact test: distance from the location to the cell square.
                        let d = (positions[i] - centre).abs() - DVec2::splat(half);
                        let d = d.max(DVec2::ZERO);
                        if d.length_squared() < r2 + 1e-12 {
                            cell_list.push(i as u32);
                        }
                    },
                );
                cell_list.sort_by(|&a, &b| {
                    ratios[b as usize]
                        .total_cmp(&ratios[a as usize])
                        .then(a.cmp(&b))
                });
                candidates.extend(cell_list.iter().map(|&i| Candidate {
                    position: positions[i as usize],
                    index: i,
                }));
                if candidates.len() > max_entries {
                    return Err(too_large);
                }
            }
        }
        offsets.push(candidates.len() as u32);
        // Resolve the sub-cells.
        let h = step / sub_n as f64;
        let snx = nx * sub_n;
        let sentinel = u32::try_from(positions.len())
            .ok()
            .filter(|&s| s < SCAN)
            .ok_or(too_large)?;
        let mut sub = Vec::with_capacity(snx * ny * sub_n);
        let (lo_r2, hi_r2) = (
            (radius - MARGIN).max(0.0).powi(2),
            (radius + MARGIN).powi(2),
        );
        for sy in 0..ny * sub_n {
            for sx in 0..snx {
                let cell = (sy >> shift) * nx + (sx >> shift);
                let list = &candidates[offsets[cell] as usize..offsets[cell + 1] as usize];
                // The sub-cell is the square of side h around `centre`.
                let centre = origin
                    + DVec2::new(
                        sx as f64 + 0.5 - sub_n as f64 / 2.0,
                        sy as f64 + 0.5 - sub_n as f64 / 2.0,
                    ) * h;
                let half = DVec2::splat(h / 2.0);
                let min_d2 = |q: DVec2| {
                    ((q - centre).abs() - half)
                        .max(DVec2::ZERO)
                        .length_squared()
                };
                let max_d2 = |q: DVec2| ((q - centre).abs() + half).length_squared();
                // The candidates (by ratio) that can be near some point of the sub-cell.
                let mut reachable = list.iter().filter(|c| min_d2(c.position) < hi_r2);
                let certain = |c: &Candidate| max_d2(c.position) < lo_r2;
                let (test, otherwise) = match reachable.next() {
                    None => (sentinel, NONE_NEAR),
                    Some(c) if certain(c) => (sentinel, c.index),
                    Some(c) => match reachable.next() {
                        None => (c.index, NONE_NEAR),
                        Some(d) if certain(d) => (c.index, d.index),
                        Some(_) => (sentinel, SCAN),
                    },
                };
                sub.push(SubCell { test, otherwise });
            }
        }
        let (ids, pairs) = compact(&sub);
        if !ids.is_empty() {
            sub = Vec::new();
        }
        let table = Self {
            radius,
            r2,
            origin,
            inv_sub: sub_n as f64 / step,
            half_sub: sub_n as f64 / 2.0,
            shift,
            nx,
            snx,
            sub_dims: DVec2::new(snx as f64, (ny * sub_n) as f64),
            offsets,
            candidates,
            points: positions
                .iter()
                .copied()
                .chain([DVec2::splat(f64::INFINITY)])
                .collect(),
            sub,
            ids,
            pairs,
        };
        if table.memory_bytes() > max_bytes {
            return Err(too_large);
        }
        Ok(table)
    }

    /// The radius this table answers for.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Bytes the table holds.
    pub fn memory_bytes(&self) -> usize {
        self.offsets.len() * size_of::<u32>()
            + self.candidates.len() * size_of::<Candidate>()
            + self.points.len() * size_of::<DVec2>()
            + self.sub.len() * size_of::<SubCell>()
            + self.ids.len() * size_of::<u16>()
            + self.pairs.len() * size_of::<SubCell>()
    }

    /// Sub-cell `i`'s pair.
    #[inline(always)]
    fn sub_cell(&self, i: usize) -> SubCell {
        if self.ids.is_empty() {
            self.sub[i]
        } else {
            self.pairs[self.ids[i] as usize]
        }
    }

    /// The longest candidate list of a cell: the most distance tests one query can make.
    pub fn max_scan(&self) -> usize {
        self.offsets
            .windows(2)
            .map(|w| (w[1] - w[0]) as usize)
            .max()
            .unwrap_or(0)
    }

    /// The location with the largest observation ratio strictly within the radius of
    /// `p` (ties: the lowest index), as [`CliffMap::best_near`](super::CliffMap::best_near).
    ///
    /// The usual answer is one table load and one distance test, inlined into the
    /// prediction loop; sub-cells where several circles meet scan their cell's
    /// candidates out of line.
    #[inline(always)]
    pub fn best_near(&self, p: DVec2) -> Option<usize> {
        let f = (p - self.origin) * self.inv_sub + DVec2::splat(self.half_sub);
        if !(f.x >= 0.0 && f.y >= 0.0 && f.x < self.sub_dims.x && f.y < self.sub_dims.y) {
            // Outside the map and its margin (or NaN): nothing can be near.
            return None;
        }
        // In range (checked above), so the truncating conversions are exact floors.
        let (sx, sy) = (f.x as u32 as usize, f.y as u32 as usize);
        let cell = self.sub_cell(sy * self.snx + sx);
        let test = self.points[cell.test as usize];
        // The pair's location if the point is within its circle, else the fallback.
        let code = if test.distance_squared(p) < self.r2 {
            cell.test
        } else {
            cell.otherwise
        };
        match code {
            NONE_NEAR => None,
            SCAN => self.scan(p, sx, sy),
            i => Some(i as usize),
        }
    }

    /// The first half of [`best_near`](Self::best_near) for eight points, `x[h]` and
    /// `y[h]` holding lanes `4 h..4 h + 4`: which lanes are within the table's range,
    /// and the pairs of their sub-cells (lanes outside read sub-cell 0).
    /// [`resolve8`](Self::resolve8) finishes the lookup; a caller with several groups of
    /// eight probes them all first, so that the sub-cells' cache misses (large maps)
    /// overlap.
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(crate) unsafe fn probe8(
        &self,
        x: [std::arch::x86_64::__m256d; 2],
        y: [std::arch::x86_64::__m256d; 2],
    ) -> Probe8 {
        use std::arch::x86_64::*;
        let (ox, oy) = (_mm256_set1_pd(self.origin.x), _mm256_set1_pd(self.origin.y));
        let (inv, half) = (_mm256_set1_pd(self.inv_sub), _mm256_set1_pd(self.half_sub));
        let (dx, dy) = (
            _mm256_set1_pd(self.sub_dims.x),
            _mm256_set1_pd(self.sub_dims.y),
        );
        let zero = _mm256_setzero_pd();
        let mut inside = 0u32;
        let mut sx = [_mm_setzero_si128(); 2];
        let mut sy = [_mm_setzero_si128(); 2];
        for h in 0..2 {
            // (p - origin) * inv_sub + half_sub, as the scalar lookup rounds it
            let fx = _mm256_add_pd(_mm256_mul_pd(_mm256_sub_pd(x[h], ox), inv), half);
            let fy = _mm256_add_pd(_mm256_mul_pd(_mm256_sub_pd(y[h], oy), inv), half);
            let ok = _mm256_and_pd(
                _mm256_and_pd(
                    _mm256_cmp_pd::<_CMP_GE_OQ>(fx, zero),
                    _mm256_cmp_pd::<_CMP_GE_OQ>(fy, zero),
                ),
                _mm256_and_pd(
                    _mm256_cmp_pd::<_CMP_LT_OQ>(fx, dx),
                    _mm256_cmp_pd::<_CMP_LT_OQ>(fy, dy),
                ),
            );
            inside |= (_mm256_movemask_pd(ok) as u32) << (4 * h);
            sx[h] = _mm256_cvttpd_epi32(fx);
            sy[h] = _mm256_cvttpd_epi32(fy);
        }
        let sx = _mm256_set_m128i(sx[1], sx[0]);
        let sy = _mm256_set_m128i(sy[1], sy[0]);
        let cell = _mm256_and_si256(
            _mm256_add_epi32(
                _mm256_mullo_epi32(sy, _mm256_set1_epi32(self.snx as i32)),
                sx,
            ),
            lane_mask(inside),
        );
        // (eight loads of a pair each, rather than two gathers: the sub-cells of large
        // maps miss the caches, and a gather waits for its slowest lane)
        let mut cells = [0u32; 8];
        let mut pairs = [0u64; 8];
        // SAFETY: eight lanes; every lane's cell is within the sub-cell table (checked
        // range, or 0), a `SubCell` is two u32 (`repr(C)`) read as one u64.
        let (test, otherwise) = unsafe {
            _mm256_storeu_si256(cells.as_mut_ptr() as *mut __m256i, cell);
            if self.ids.is_empty() {
                let sub = self.sub.as_ptr() as *const u64;
                for l in 0..8 {
                    pairs[l] = sub.add(cells[l] as usize).read_unaligned();
                }
            } else {
                let (ids, list) = (self.ids.as_ptr(), self.pairs.as_ptr() as *const u64);
                for l in 0..8 {
                    pairs[l] = list
                        .add(*ids.add(cells[l] as usize) as usize)
                        .read_unaligned();
                }
            }
            let lo = _mm256_castsi256_ps(_mm256_loadu_si256(pairs.as_ptr() as *const __m256i));
            let hi =
                _mm256_castsi256_ps(_mm256_loadu_si256(pairs.as_ptr().add(4) as *const __m256i));
            // (t0 o0 t1 o1 t2 o2 t3 o3), (t4 ..): even words are tests, odd ones the rest
            let even = _mm256_shuffle_ps::<0b10_00_10_00>(lo, hi);
            let odd = _mm256_shuffle_ps::<0b11_01_11_01>(lo, hi);
            (
                _mm256_permute4x64_epi64::<0b11_01_10_00>(_mm256_castps_si256(even)),
                _mm256_permute4x64_epi64::<0b11_01_10_00>(_mm256_castps_si256(odd)),
            )
        };
        Probe8 {
            inside,
            test,
            otherwise,
        }
    }

    /// The second half of the lookup of eight points ([`probe8`](Self::probe8)): the bits
    /// of the lanes that have a location near (bit `l` for lane `l`), and those
    /// locations (other lanes' are meaningless): [`best_near`](Self::best_near)'s answers,
    /// with the same arithmetic (the scans, rare, lane by lane).
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA, and `probe` be this table's probe of the
    /// same points.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(crate) unsafe fn resolve8(
        &self,
        probe: &Probe8,
        x: [std::arch::x86_64::__m256d; 2],
        y: [std::arch::x86_64::__m256d; 2],
    ) -> (u32, std::arch::x86_64::__m256i) {
        use std::arch::x86_64::*;
        let Probe8 {
            inside,
            test,
            otherwise,
        } = *probe;
        if inside == 0 {
            return (0, _mm256_setzero_si256());
        }
        let mut tests = [0u32; 8];
        let mut xy = [[0.0f64; 2]; 8];
        // SAFETY: eight lanes; `test` indexes `points` (a location or the sentinel).
        unsafe {
            _mm256_storeu_si256(tests.as_mut_ptr() as *mut __m256i, test);
            for l in 0..8 {
                let p = *self.points.as_ptr().add(tests[l] as usize);
                xy[l] = [p.x, p.y];
            }
        }
        let r2 = _mm256_set1_pd(self.r2);
        let mut near = 0u32;
        for h in 0..2 {
            // SAFETY: `xy` holds eight pairs.
            let (tx, ty) = unsafe {
                let a = _mm256_loadu_pd(xy.as_ptr().add(4 * h) as *const f64);
                let b = _mm256_loadu_pd(xy.as_ptr().add(4 * h + 2) as *const f64);
                // (x0 y0 x1 y1), (x2 y2 x3 y3) -> (x0 x1 x2 x3), (y0 y1 y2 y3)
                let xs = _mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_unpacklo_pd(a, b));
                let ys = _mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_unpackhi_pd(a, b));
                (xs, ys)
            };
            // test.distance_squared(p): (t - p).x^2 + (t - p).y^2
            let ddx = _mm256_sub_pd(tx, x[h]);
            let ddy = _mm256_sub_pd(ty, y[h]);
            let d2 = _mm256_add_pd(_mm256_mul_pd(ddx, ddx), _mm256_mul_pd(ddy, ddy));
            near |= (_mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(d2, r2)) as u32) << (4 * h);
        }
        let code = _mm256_blendv_epi8(otherwise, test, lane_mask(near));
        let none = _mm256_cmpeq_epi32(code, _mm256_set1_epi32(NONE_NEAR as i32));
        let scan = _mm256_cmpeq_epi32(code, _mm256_set1_epi32(SCAN as i32));
        let missing = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_or_si256(none, scan))) as u32;
        let mut found = inside & !missing;
        let scans = inside & _mm256_movemask_ps(_mm256_castsi256_ps(scan)) as u32;
        if scans == 0 {
            return (found, code);
        }
        // where several circles meet: the whole scalar lookup, lane by lane
        let mut codes = [0u32; 8];
        let (mut xs, mut ys) = ([0.0f64; 8], [0.0f64; 8]);
        // SAFETY: the arrays hold eight lanes each.
        unsafe {
            _mm256_storeu_si256(codes.as_mut_ptr() as *mut __m256i, code);
            _mm256_storeu_pd(xs.as_mut_ptr(), x[0]);
            _mm256_storeu_pd(xs.as_mut_ptr().add(4), x[1]);
            _mm256_storeu_pd(ys.as_mut_ptr(), y[0]);
            _mm256_storeu_pd(ys.as_mut_ptr().add(4), y[1]);
        }
        for l in 0..8 {
            if scans & (1 << l) != 0
                && let Some(i) = self.best_near(DVec2::new(xs[l], ys[l]))
            {
                codes[l] = i as u32;
                found |= 1 << l;
            }
        }
        // SAFETY: eight lanes.
        (found, unsafe {
            _mm256_loadu_si256(codes.as_ptr() as *const __m256i)
        })
    }

    /// The first candidate of sub-cell `(sx, sy)`'s cell within the radius of `p`.
    #[inline(never)]
    fn scan(&self, p: DVec2, sx: usize, sy: usize) -> Option<usize> {
        let cell = (sy >> self.shift) * self.nx + (sx >> self.shift);
        let (a, b) = (self.offsets[cell] as usize, self.offsets[cell + 1] as usize);
        self.candidates[a..b]
            .iter()
            .find(|c| c.position.distance_squared(p) < self.r2)
            .map(|c| c.index as usize)
    }
}

/// Eight points' sub-cells ([`NeighbourTable::probe8`]).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct Probe8 {
    /// The lanes within the table's range (bit `l` for lane `l`).
    inside: u32,
    test: std::arch::x86_64::__m256i,
    otherwise: std::arch::x86_64::__m256i,
}

#[cfg(target_arch = "x86_64")]
impl Default for Probe8 {
    /// No lane within range.
    fn default() -> Self {
        // SAFETY: all-zero bits are valid for integer vectors.
        let zero = unsafe { std::mem::zeroed() };
        Probe8 {
            inside: 0,
            test: zero,
            otherwise: zero,
        }
    }
}

/// The 32-bit lanes whose bits are set in `bits` (lane `l` for bit `l`): all ones,
/// the others zero.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(crate) fn lane_mask(bits: u32) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    let each = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(bits as i32), each), each)
}

/// Why a neighbour table was not built.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TableError {
    /// The radius is not a positive number.
    #[error("radius {radius} is not a positive number")]
    BadRadius {
        /// The radius asked for.
        radius: f64,
    },
    /// The table would be larger than the budget (or than a table can be at all).
    #[error("the table for radius {radius} m needs more than {limit} bytes")]
    TooLarge {
        /// The radius asked for.
        radius: f64,
        /// The size it exceeded (bytes).
        limit: usize,
    },
}
