//! What the numbers were measured on ([`Machine`]: cores, CPU model, load average at
//! the start and the end) and whether the run's spinning clients fit the free cores
//! ([`CoreBudget`]).

use cliff_client::WaitMode;
use serde_json::{Value, json};

/// cliffd splits a round of requests over its workers only when the round holds at least
/// this many positions (its scheduler's threshold; below it the serving thread predicts
/// alone, since waking a worker costs more than it saves).
const DAEMON_SPLIT_POSITIONS: usize = 4000;

/// The machine's facts, read when the run starts (and the load again at its end).
#[derive(Debug, Clone)]
pub(crate) struct Machine {
    /// Cores this process may run on (`available_parallelism`: affinity and cgroup
    /// quotas included).
    pub(crate) cores: usize,
    /// Processors listed in /proc/cpuinfo.
    pub(crate) processors: usize,
    /// The first `model name` of /proc/cpuinfo.
    pub(crate) cpu_model: String,
    /// /proc/loadavg's 1, 5 and 15 minute averages when the run started.
    pub(crate) load_start: Option<[f64; 3]>,
    /// The same when it ended.
    pub(crate) load_end: Option<[f64; 3]>,
    /// When the run started (UTC, ISO 8601).
    pub(crate) started_utc: String,
}

impl Machine {
    /// The facts now (the end's load is read by [`Machine::finish`]).
    pub(crate) fn now() -> Machine {
        let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        let (processors, cpu_model) = parse_cpuinfo(&cpuinfo);
        Machine {
            cores: available_cores(),
            processors,
            cpu_model,
            load_start: load_average(),
            load_end: None,
            started_utc: utc_now(),
        }
    }

    /// Read the load average at the end of the run.
    pub(crate) fn finish(&mut self) {
        self.load_end = load_average();
    }

    pub(crate) fn json(&self) -> Value {
        json!({
            "cores": self.cores,
            "processors": self.processors,
            "cpu_model": self.cpu_model,
            "load_average_start": self.load_start,
            "load_average_end": self.load_end,
            "started_utc": self.started_utc,
        })
    }

    /// One line: `2 cores (AMD EPYC ...), load average 0.52 at the start, 0.61 at the end`.
    pub(crate) fn describe(&self) -> String {
        let load =
            |l: Option<[f64; 3]>| l.map_or("unknown".to_string(), |l| format!("{:.2}", l[0]));
        format!(
            "{} cores ({}), load average {} at the start, {} at the end (1-minute)",
            self.cores,
            if self.cpu_model.is_empty() {
                "CPU model unknown"
            } else {
                &self.cpu_model
            },
            load(self.load_start),
            load(self.load_end)
        )
    }
}

/// Cores this process may run on.
pub(crate) fn available_cores() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

/// The processor count and first model name of /proc/cpuinfo's text.
fn parse_cpuinfo(text: &str) -> (usize, String) {
    let field = |line: &str, name: &str| {
        let (k, v) = line.split_once(':')?;
        (k.trim() == name).then(|| v.trim().to_string())
    };
    let processors = text
        .lines()
        .filter(|l| field(l, "processor").is_some())
        .count();
    let model = text
        .lines()
        .find_map(|l| field(l, "model name"))
        .unwrap_or_default();
    (processors, model)
}

/// /proc/loadavg's three averages.
fn load_average() -> Option<[f64; 3]> {
    let text = std::fs::read_to_string("/proc/loadavg").ok()?;
    let mut it = text.split_whitespace().map(|s| s.parse::<f64>().ok());
    Some([it.next()??, it.next()??, it.next()??])
}

/// The time now in UTC, `YYYY-MM-DDTHH:MM:SSZ`.
pub(crate) fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let (days, rem) = ((secs / 86_400) as i64, secs % 86_400);
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// The Gregorian date of a day count since 1970-01-01 (the well-known era algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = (if mp < 10 { mp + 3 } else { mp - 9 }) as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

/// Whether the clients that spin fit the cores the daemon leaves free.
///
/// Counting: the daemon's serving thread busy-polls while requests keep coming, so it
/// takes one core; its other workers (`--daemon-workers`, default cliffd's: the cores)
/// join only when one round of requests (clients x agents x k x steps positions) holds
/// at least [`DAEMON_SPLIT_POSITIONS`], and then take one core each. Spin clients spin
/// for the whole round trip, hybrid ones for up to `--spin-us` of it (back to back,
/// nearly all of it): both count as spinning; block clients do not.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct CoreBudget {
    pub(crate) cores: usize,
    /// Cores the daemon (or the floor's echo server) needs.
    pub(crate) daemon: usize,
    /// Cores left for the clients.
    pub(crate) free: usize,
    /// Clients that busy-poll.
    pub(crate) spinning: usize,
}

impl CoreBudget {
    /// The budget of `clients` clients waiting by `wait`, each sending requests of
    /// `positions` positions, against a daemon of `workers` workers on `cores` cores.
    /// `daemon`: false for the in-process run (no daemon, and the threads never wait).
    pub(crate) fn of(
        cores: usize,
        clients: usize,
        wait: WaitMode,
        positions: usize,
        workers: usize,
        daemon: bool,
    ) -> CoreBudget {
        let need = if !daemon {
            0
        } else if clients.saturating_mul(positions) >= DAEMON_SPLIT_POSITIONS {
            workers.clamp(1, cores.max(1))
        } else {
            1
        };
        let spinning = if daemon && wait != WaitMode::Block {
            clients
        } else {
            0
        };
        CoreBudget {
            cores,
            daemon: need,
            free: cores.saturating_sub(need),
            spinning,
        }
    }

    /// More spinning clients than free cores.
    pub(crate) fn oversubscribed(&self) -> bool {
        self.spinning > self.free
    }

    /// The warning for stderr, when oversubscribed.
    pub(crate) fn warning(&self, wait: WaitMode) -> Option<String> {
        self.oversubscribed().then(|| {
            format!(
                "warning: {} {wait} client(s) busy-poll, but only {} of {} cores are free ({} for the daemon: \
its serving thread{}): the latency measures the scheduler, not the daemon. Use fewer clients or --wait block.",
                self.spinning,
                self.free,
                self.cores,
                self.daemon,
                if self.daemon > 1 {
                    " and the workers that split large rounds"
                } else {
                    ""
                }
            )
        })
    }

    pub(crate) fn json(&self) -> Value {
        json!({
            "cores": self.cores,
            "daemon_needs": self.daemon,
            "free": self.free,
            "spinning_clients": self.spinning,
            "oversubscribed": self.oversubscribed(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpuinfo_gives_the_processors_and_the_model() {
        let text = "processor\t: 0\nmodel name\t: AMD EPYC 7B13\nflags\t: fpu\n\n\
                    processor\t: 1\nmodel name\t: AMD EPYC 7B13\n";
        assert_eq!(parse_cpuinfo(text), (2, "AMD EPYC 7B13".to_string()));
        assert_eq!(parse_cpuinfo(""), (0, String::new()));
    }

    #[test]
    fn dates_follow_the_gregorian_calendar() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
        assert_eq!(civil_from_days(20_788), (2026, 12, 1));
        assert!(utc_now().ends_with('Z'));
    }

    #[test]
    fn spinning_clients_beyond_the_free_cores_are_oversubscribed() {
        // one small-request client beside the daemon's serving thread fits two cores
        let one = CoreBudget::of(2, 1, WaitMode::Hybrid, 600, 2, true);
        assert_eq!((one.daemon, one.free, one.oversubscribed()), (1, 1, false));
        assert!(one.warning(WaitMode::Hybrid).is_none());
        // two do not
        let two = CoreBudget::of(2, 2, WaitMode::Spin, 600, 2, true);
        assert!(two.oversubscribed());
        assert!(
            two.warning(WaitMode::Spin)
                .unwrap()
                .contains("1 of 2 cores")
        );
        // rounds large enough to split take the workers' cores too
        let big = CoreBudget::of(4, 1, WaitMode::Hybrid, 32 * 50 * 100, 4, true);
        assert_eq!((big.daemon, big.free, big.oversubscribed()), (4, 0, true));
        // blocking clients and the in-process run never are
        assert!(!CoreBudget::of(2, 8, WaitMode::Block, 600, 2, true).oversubscribed());
        assert!(!CoreBudget::of(1, 8, WaitMode::Spin, 600, 1, false).oversubscribed());
    }
}
