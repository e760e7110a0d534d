//! The kernel that smooths each sample into the cells: its settings, its width from
//! the samples' spread, and the normal distribution function it integrates over a cell.

use std::sync::OnceLock;

use crate::math::fastmath::{exp_f32, exp_neg_f32};

use super::{OccupancyError, Stopped};

/// Cells handled together: the masses of an axis, a tile row's cells (an AVX2 register
/// of f32).
pub(super) const LANES: usize = 8;

/// How samples become occupancy: the kernel's width and cut-off and what a stopped
/// sample means.
///
/// Each sample of a person at a time is a normal distribution (the same sigma on both
/// axes) with `sigma = sqrt(person_radius^2 + bandwidth^2)`: the person's body, and the
/// uncertainty that `k` samples leave about the distribution they were drawn from.
/// `bandwidth = max(min_bandwidth, bandwidth_scale * spread * n^(-1/6))`, where
/// `spread` is the root mean square distance of the person's `n` samples at that time
/// from their mean, divided by sqrt(2) (the per-axis standard deviation), and
/// `n^(-1/6)` is Silverman's rule for two dimensions. A cell receives the kernel's
/// probability mass over its area (the product of the normal distribution function's
/// differences across its edges, so cells smaller or larger than a person are both
/// exact); the kernel is cut at `truncate` sigmas, which bounds the cost of a sample.
/// [`Occupancy::compute`](super::Occupancy::compute) adds a kernel 4 or more cells of
/// sigma wide on a coarser grid and interpolates it onto the cells, within 1 % of the
/// person's largest cell probability (`levels.rs`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// The standard deviation of a person's body about their track (m).
    pub person_radius: f64,
    /// The factor on Silverman's bandwidth (1: the rule itself; 0: no bandwidth).
    pub bandwidth_scale: f64,
    /// The least bandwidth (m).
    pub min_bandwidth: f64,
    /// Where the kernel is cut, in sigmas (at least 1, at most 8).
    pub truncate: f64,
    /// What a sample that stopped before a time means there.
    pub stopped: Stopped,
}

impl Default for Settings {
    /// A person of 0.3 m, Silverman's bandwidth, cut at 3 sigmas (0.27 % of a
    /// sample's mass left out per axis), stopped samples renormalised.
    fn default() -> Self {
        Self {
            person_radius: 0.3,
            bandwidth_scale: 1.0,
            min_bandwidth: 0.0,
            truncate: 3.0,
            stopped: Stopped::Renormalise,
        }
    }
}

impl Settings {
    /// Check every setting; the error names the first unusable one.
    pub fn validate(&self) -> Result<(), OccupancyError> {
        let bad = |name: &'static str, why: String| Err(OccupancyError::Setting { name, why });
        if !(self.person_radius.is_finite() && self.person_radius > 0.0) {
            return bad(
                "person_radius",
                format!("{} is not a positive number", self.person_radius),
            );
        }
        if !(self.bandwidth_scale.is_finite() && self.bandwidth_scale >= 0.0) {
            return bad(
                "bandwidth_scale",
                format!("{} is not a non-negative number", self.bandwidth_scale),
            );
        }
        if !(self.min_bandwidth.is_finite() && self.min_bandwidth >= 0.0) {
            return bad(
                "min_bandwidth",
                format!("{} is not a non-negative number", self.min_bandwidth),
            );
        }
        if !(self.truncate.is_finite() && (1.0..=8.0).contains(&self.truncate)) {
            return bad(
                "truncate",
                format!("{} is not between 1 and 8 sigmas", self.truncate),
            );
        }
        Ok(())
    }

    /// The kernel's sigma for `n` samples whose positions have the given spread (the
    /// per-axis standard deviation, m).
    pub fn sigma(&self, spread: f64, n: usize) -> f64 {
        self.sigma_rooted(spread, n, silverman_root(n))
    }

    /// [`sigma`](Self::sigma) given `root`, the [`silverman_root`] of `n`.
    pub(super) fn sigma_rooted(&self, spread: f64, n: usize, root: f64) -> f64 {
        let silverman = if n > 0 {
            self.bandwidth_scale * spread * root
        } else {
            0.0
        };
        let bw = silverman.max(self.min_bandwidth);
        (self.person_radius * self.person_radius + bw * bw).sqrt()
    }
}

/// `n^(-1/6)`, Silverman's factor on the spread of `n` samples in two dimensions.
pub(super) fn silverman_root(n: usize) -> f64 {
    (n as f64).powf(-1.0 / 6.0)
}

/// The per-axis standard deviation of points about their mean: the root mean square
/// distance from the mean divided by sqrt(2). Zero for fewer than two points.
pub fn spread(points: &[[f32; 2]]) -> f64 {
    let n = points.len();
    if n < 2 {
        return 0.0;
    }
    let (mut sx, mut sy) = (0.0f64, 0.0f64);
    for p in points {
        sx += p[0] as f64;
        sy += p[1] as f64;
    }
    let (mx, my) = (sx / n as f64, sy / n as f64);
    let mut ss = 0.0;
    for p in points {
        let (dx, dy) = (p[0] as f64 - mx, p[1] as f64 - my);
        ss += dx * dx + dy * dy;
    }
    (ss / (2.0 * n as f64)).sqrt()
}

/// The table of the standard normal distribution function: `PHI_CELLS + 1` values over
/// `[-PHI_RANGE, PHI_RANGE]`, read with linear interpolation (error below 1e-6).
const PHI_RANGE: f32 = 8.0;
const PHI_CELLS: usize = 4096;

fn phi_table() -> &'static [f32; PHI_CELLS + 1] {
    static TABLE: OnceLock<[f32; PHI_CELLS + 1]> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = [0.0f32; PHI_CELLS + 1];
        for (i, v) in t.iter_mut().enumerate() {
            let z = -PHI_RANGE as f64 + 2.0 * PHI_RANGE as f64 * i as f64 / PHI_CELLS as f64;
            *v = normal_cdf(z) as f32;
        }
        t
    })
}

/// The standard normal distribution function, from the complementary error function
/// (W. J. Cody's rational approximations as given by Numerical Recipes' `erfcc`,
/// relative error below 1.2e-7).
pub fn normal_cdf(z: f64) -> f64 {
    let x = -z / std::f64::consts::SQRT_2;
    let a = x.abs();
    let t = 1.0 / (1.0 + 0.5 * a);
    let poly = -a * a - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    let erfc = if x >= 0.0 { erfc } else { 2.0 - erfc };
    0.5 * erfc
}

/// The kernel's mass along one axis: for the cells `first..first + out.len()` whose
/// edges lie at `origin + i * resolution`, the mass of a normal distribution of mean
/// `mu` and standard deviation `sigma` over each cell ([`AxisNormal::mass`]).
#[cfg(test)]
pub(super) fn axis_mass(
    mu: f32,
    sigma: f32,
    origin: f32,
    resolution: f32,
    first: usize,
    out: &mut [f32],
) {
    AxisNormal::new(sigma, resolution).mass(mu, origin, first, out)
}

/// What the masses of a normal of one width over cells of one size along an axis share
/// ([`mass`](Self::mass)); a person's samples at a time share it.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct AxisNormal {
    /// The normal's standard deviation (m).
    pub sigma: f32,
    /// The cells' width (m).
    pub resolution: f32,
    /// Cells narrower than half a sigma: masses from densities.
    narrow: bool,
    /// One over the standard deviation the densities are taken with (m^-1).
    inv: f32,
    /// The cells' width in those standard deviations.
    d: f32,
    /// The cells' width (in those standard deviations) times the standard normal
    /// density's factor 1 / sqrt(2 pi).
    scale: f32,
    /// `exp(-64 d^2)`: how the ratio of densities eight cells apart changes eight
    /// cells on.
    step: f32,
}

impl AxisNormal {
    /// The normal of width `sigma` on cells `resolution` wide.
    #[inline(always)]
    pub fn new(sigma: f32, resolution: f32) -> Self {
        let d0 = resolution / sigma;
        let narrow = d0 <= 0.5;
        // a narrow cell's mass: the density at its centre of the normal widened by the
        // cell's own variance (resolution^2 / 12), times its width
        let widened = if narrow {
            (sigma * sigma + resolution * resolution * (1.0 / 12.0)).sqrt()
        } else {
            sigma
        };
        let inv = 1.0 / widened;
        let d = resolution * inv;
        Self {
            sigma,
            resolution,
            narrow,
            inv,
            d,
            scale: d * std::f32::consts::FRAC_1_SQRT_2 * 0.5 * std::f32::consts::FRAC_2_SQRT_PI,
            step: exp_neg_f32(-64.0 * d * d),
        }
    }

    /// For the cells `first..first + out.len()` whose edges lie at `origin + i *
    /// resolution`, the mass of the normal of mean `mu` over each cell.
    ///
    /// Cells narrower than half a sigma take the density at the cell's centre of the
    /// normal convolved with the cell (its variance `sigma^2 + resolution^2 / 12`)
    /// times the cell's width: exact to the fourth order in `d`, the cell's width in
    /// sigmas (what is left is `d^4 (z^4 - 6 z^2 + 3) / 2880` of the mass, at most
    /// `d^4 / 960` of the largest cell's, 7e-5 of it at `d = 1/2`). The densities come
    /// eight cells at a time (a register on AVX2): the first eight from a branch-free
    /// single-precision exponential, each later eight from the eight before by the
    /// ratio `exp(-8 d z - 32 d^2)` of a density eight cells on, itself carried on by
    /// the factor `exp(-64 d^2)` (two multiplications a cell instead of an
    /// exponential; the rounding this adds stays below 1e-6 of a mass over the cells a
    /// kernel reaches). Wider cells take differences of the normal distribution
    /// function's table.
    #[inline(always)]
    pub fn mass(&self, mu: f32, origin: f32, first: usize, out: &mut [f32]) {
        let (inv, d, resolution) = (self.inv, self.d, self.resolution);
        if self.narrow {
            // z of the first cell's centre, in sigmas
            let z0 = (origin + (first as f32 + 0.5) * resolution - mu) * inv;
            let d2 = d * d;
            let (chunks, tail) = out.as_chunks_mut::<LANES>();
            let done = chunks.len() * LANES;
            if !chunks.is_empty() {
                // the masses of the first eight cells and their ratios eight cells on
                let mut mass = [0.0f32; LANES];
                let mut ratio = [0.0f32; LANES];
                for l in 0..LANES {
                    let z = z0 + l as f32 * d;
                    mass[l] = self.scale * exp_neg_f32(-0.5 * z * z);
                    ratio[l] = exp_f32(-8.0 * d * z - 32.0 * d2);
                }
                for chunk in chunks.iter_mut() {
                    *chunk = mass;
                    for l in 0..LANES {
                        mass[l] *= ratio[l];
                        ratio[l] *= self.step;
                    }
                }
            }
            for (i, m) in tail.iter_mut().enumerate() {
                let z = z0 + (done + i) as f32 * d;
                *m = self.scale * exp_neg_f32(-0.5 * z * z);
            }
            return;
        }
        let table = phi_table();
        let scale = PHI_CELLS as f32 / (2.0 * PHI_RANGE);
        let cdf = |edge: f32| -> f32 {
            let z = ((edge - mu) * inv).clamp(-PHI_RANGE, PHI_RANGE);
            let u = (z + PHI_RANGE) * scale;
            let i = (u as usize).min(PHI_CELLS - 1);
            let f = u - i as f32;
            table[i] + (table[i + 1] - table[i]) * f
        };
        let mut lo = cdf(origin + first as f32 * resolution);
        for (i, m) in out.iter_mut().enumerate() {
            let hi = cdf(origin + (first + i + 1) as f32 * resolution);
            *m = hi - lo;
            lo = hi;
        }
    }
}

/// The cells `[first, last]` (inclusive) along an axis of `cells` cells that the kernel
/// of mean `mu` reaches within `reach` metres, or `None` when it misses the grid.
#[inline(always)]
pub(super) fn axis_box(
    mu: f32,
    reach: f32,
    origin: f32,
    resolution: f32,
    cells: usize,
) -> Option<(usize, usize)> {
    axis_span(mu, mu, reach, origin, resolution, cells)
}

/// The cells along an axis that kernels of means between `lo` and `hi` reach within
/// `reach` metres: the union of their [`axis_box`]es (the same expressions, monotone in
/// the mean), or `None` when all miss the grid.
#[inline(always)]
pub(super) fn axis_span(
    lo: f32,
    hi: f32,
    reach: f32,
    origin: f32,
    resolution: f32,
    cells: usize,
) -> Option<(usize, usize)> {
    // (by the reciprocal: a division per edge would cost more than the rest of it)
    let inv = 1.0 / resolution;
    let first = ((lo - reach - origin) * inv).floor();
    let last = ((hi + reach - origin) * inv).floor();
    if !(last >= 0.0 && first < cells as f32) {
        return None;
    }
    Some((first.max(0.0) as usize, (last as usize).min(cells - 1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_cdf_matches_known_values() {
        // values from the normal table
        for (z, p) in [
            (0.0, 0.5),
            (1.0, 0.841_344_746),
            (-1.96, 0.024_997_895),
            (3.0, 0.998_650_102),
            (-5.0, 2.866_515_7e-7),
        ] {
            assert!(
                (normal_cdf(z) - p).abs() < 2e-7 * p.max(1e-3),
                "{z}: {}",
                normal_cdf(z)
            );
        }
    }

    #[test]
    fn axis_masses_integrate_the_density_over_each_cell() {
        // narrow cells (the series: eight cells from the exponential, each later eight
        // from the eight before, and a tail of cells on their own) and wide ones (the
        // table)
        for (mu, sigma, origin, res) in [
            (0.37, 0.45, -2.0, 0.1),
            (-1.9, 0.3, -2.0, 0.05),
            (0.21, 0.3, -1.3, 0.05),
            (0.37, 0.3, -4.0, 0.25),
            (1.1, 0.3, -5.0, 0.5),
        ] {
            let cells = (2.0 * -origin / res) as usize;
            let mut out = vec![0.0f32; cells];
            axis_mass(
                mu as f32,
                sigma as f32,
                origin as f32,
                res as f32,
                0,
                &mut out,
            );
            for (i, m) in out.iter().enumerate() {
                // midpoint rule over 1000 sub-intervals of the cell
                let (a, b) = (origin + i as f64 * res, origin + (i + 1) as f64 * res);
                let h = (b - a) / 1000.0;
                let want: f64 = (0..1000)
                    .map(|j| {
                        let x = a + (j as f64 + 0.5) * h;
                        let z = (x - mu) / sigma;
                        (-0.5 * z * z).exp() / (sigma * (2.0 * std::f64::consts::PI).sqrt()) * h
                    })
                    .sum();
                assert!(
                    (*m as f64 - want).abs() < 2e-6 + 1e-5 * want,
                    "sigma {sigma} res {res} cell {i}: {m} vs {want}"
                );
            }
        }
    }

    #[test]
    fn the_kernel_widens_with_the_spread_and_never_below_the_person() {
        let s = Settings::default();
        assert!((s.sigma(0.0, 20) - 0.3).abs() < 1e-12);
        let wide = s.sigma(2.0, 20);
        let want = (0.09f64 + (2.0 * 20f64.powf(-1.0 / 6.0)).powi(2)).sqrt();
        assert!((wide - want).abs() < 1e-12);
        let pts = [[1.0f32, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]];
        assert!((spread(&pts) - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-9);
        assert_eq!(axis_box(0.0, 1.0, -5.0, 0.5, 20), Some((8, 12)));
        assert_eq!(axis_box(-7.0, 1.0, -5.0, 0.5, 20), None);
        assert_eq!(axis_box(4.6, 1.0, -5.0, 0.5, 20), Some((17, 19)));
    }

    #[test]
    fn unusable_settings_are_named() {
        for (s, name) in [
            (
                Settings {
                    person_radius: 0.0,
                    ..Settings::default()
                },
                "person_radius",
            ),
            (
                Settings {
                    bandwidth_scale: -1.0,
                    ..Settings::default()
                },
                "bandwidth_scale",
            ),
            (
                Settings {
                    min_bandwidth: f64::NAN,
                    ..Settings::default()
                },
                "min_bandwidth",
            ),
            (
                Settings {
                    truncate: 0.5,
                    ..Settings::default()
                },
                "truncate",
            ),
        ] {
            match s.validate() {
                Err(OccupancyError::Setting { name: n, .. }) => assert_eq!(n, name),
                other => panic!("{name}: {other:?}"),
            }
        }
        Settings::default().validate().unwrap();
    }
}
