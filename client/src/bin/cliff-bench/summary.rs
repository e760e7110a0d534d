//! Latency percentiles of a run ([`Summary`]) and its distribution for the pictures
//! ([`cdf_points`]).

use serde_json::{Value, json};

/// Latency percentiles (microseconds), from every sample: the sorted samples read at
/// the nearest rank (`ceil(p x n)`), no histogram.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Summary {
    pub(crate) p50: f64,
    pub(crate) p90: f64,
    pub(crate) p99: f64,
    pub(crate) p999: f64,
    pub(crate) max: f64,
}

/// Sort `ns` (nanoseconds) and take its percentiles.
pub(crate) fn summarize(ns: &mut [u64]) -> Summary {
    ns.sort_unstable();
    Summary {
        p50: quantile(ns, 0.50),
        p90: quantile(ns, 0.90),
        p99: quantile(ns, 0.99),
        p999: quantile(ns, 0.999),
        max: quantile(ns, 1.0),
    }
}

/// The nearest-rank quantile `p` of sorted nanoseconds, in microseconds (NaN when empty).
fn quantile(sorted: &[u64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let rank = ((p * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[rank - 1] as f64 / 1000.0
}

impl Summary {
    /// The percentiles as JSON fields `{prefix}p50_us` ... `{prefix}max_us`.
    pub(crate) fn json_fields(&self, prefix: &str, out: &mut serde_json::Map<String, Value>) {
        for (name, v) in [
            ("p50", self.p50),
            ("p90", self.p90),
            ("p99", self.p99),
            ("p999", self.p999),
            ("max", self.max),
        ] {
            out.insert(format!("{prefix}{name}_us"), json!(v));
        }
    }
}

/// At most `points` points (microseconds, fraction of requests at or below it) of the
/// empirical distribution of sorted nanoseconds, evenly spaced in rank, with the
/// smallest and the largest sample always in.
pub(crate) fn cdf_points(sorted: &[u64], points: usize) -> Vec<(f64, f64)> {
    let n = sorted.len();
    if n == 0 || points < 2 {
        return Vec::new();
    }
    let m = points.min(n);
    (0..m)
        .map(|i| {
            let rank = 1 + i * (n - 1) / (m - 1); // 1 ..= n
            (sorted[rank - 1] as f64 / 1000.0, rank as f64 / n as f64)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_are_nearest_ranks_of_every_sample() {
        let mut ns: Vec<u64> = (1..=1000).rev().map(|i| i * 1000).collect();
        let s = summarize(&mut ns);
        assert_eq!(
            (s.p50, s.p90, s.p99, s.p999, s.max),
            (500.0, 900.0, 990.0, 999.0, 1000.0)
        );
        let mut one = [7000];
        let s = summarize(&mut one);
        assert_eq!((s.p50, s.max), (7.0, 7.0));
        assert!(summarize(&mut []).p50.is_nan());
    }

    #[test]
    fn the_distribution_runs_from_the_smallest_to_the_largest_sample() {
        let ns: Vec<u64> = (1..=10_000).map(|i| i * 10).collect();
        let pts = cdf_points(&ns, 200);
        assert_eq!(pts.len(), 200);
        assert_eq!(pts[0], (0.01, 1e-4));
        assert_eq!(*pts.last().unwrap(), (100.0, 1.0));
        assert!(pts.windows(2).all(|w| w[0].0 <= w[1].0 && w[0].1 < w[1].1));
        assert_eq!(cdf_points(&ns[..3], 200).len(), 3);
    }
}
