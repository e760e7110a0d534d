//! The fixed schedule of `--rate` ([`Pace`]).

use std::time::{Duration, Instant};

/// A fixed schedule of requests (`--rate`): `wait` sleeps until the next slot.
pub(crate) struct Pace {
    period: Option<Duration>,
    next: Instant,
}

impl Pace {
    pub(crate) fn new(rate: Option<f64>) -> Pace {
        Pace {
            period: rate.map(|r| Duration::from_secs_f64(1.0 / r)),
            next: Instant::now(),
        }
    }

    pub(crate) fn wait(&mut self) {
        let Some(period) = self.period else {
            return;
        };
        let now = Instant::now();
        if let Some(pause) = self.next.checked_duration_since(now) {
            std::thread::sleep(pause);
        }
        // a late request does not make the next ones early
        self.next = self.next.max(now) + period;
    }
}
