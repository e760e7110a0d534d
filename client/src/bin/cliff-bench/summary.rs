//! Latency percentiles of a run ([`Summary`]).

/// Latency percentiles (microseconds).
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
    let q = |p: f64| {
        if ns.is_empty() {
            return f64::NAN;
        }
        let rank = ((p * ns.len() as f64).ceil() as usize).clamp(1, ns.len());
        ns[rank - 1] as f64 / 1000.0
    };
    Summary {
        p50: q(0.50),
        p90: q(0.90),
        p99: q(0.99),
        p999: q(0.999),
        max: q(1.0),
    }
}
