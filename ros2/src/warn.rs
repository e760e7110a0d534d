//! Rate-limited warnings: at most one line per kind per period, telling how many
//! were held back since the last one.

use std::time::{Duration, Instant};

/// One kind of warning.
#[derive(Debug, Clone)]
pub struct RateLimit {
    period: Duration,
    last: Option<Instant>,
    held: u64,
}

impl RateLimit {
    /// At most one warning per `period`.
    pub fn new(period: Duration) -> Self {
        RateLimit {
            period,
            last: None,
            held: 0,
        }
    }

    /// Whether to warn now; `Some(n)`: yes, and `n` occurrences since the last warning
    /// were held back.
    pub fn check(&mut self, now: Instant) -> Option<u64> {
        match self.last {
            Some(t) if now.saturating_duration_since(t) < self.period => {
                self.held += 1;
                None
            }
            _ => {
                self.last = Some(now);
                Some(std::mem::take(&mut self.held))
            }
        }
    }

    /// Forget the last warning (the condition ended: warn at once when it recurs).
    pub fn reset(&mut self) {
        self.last = None;
        self.held = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_warning_per_period_with_the_count_held_back() {
        let mut r = RateLimit::new(Duration::from_secs(5));
        let t0 = Instant::now();
        assert_eq!(r.check(t0), Some(0));
        assert_eq!(r.check(t0 + Duration::from_secs(1)), None);
        assert_eq!(r.check(t0 + Duration::from_secs(2)), None);
        assert_eq!(r.check(t0 + Duration::from_secs(6)), Some(2));
        r.reset();
        assert_eq!(r.check(t0 + Duration::from_secs(7)), Some(0));
    }
}
