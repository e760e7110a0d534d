//! The report of `--compare` ([`write_report`]): report.md (the tables), report.json
//! (everything, with every run's percentiles and the machine), latency-cdf.png (the
//! latency distribution of every way in at the first client count) and throughput.png
//! (requests per second against clients).

use std::fmt::Write as _;
use std::path::Path;

use cliff::plot::{Line, LineChart, plot_lines};
use serde_json::{Value, json};

use crate::args::Args;
use crate::floor::Shape;
use crate::machine::{CoreBudget, Machine};
use crate::runs::{Run, Way};
use crate::summary::cdf_points;

/// One way in at one client count.
pub(crate) struct Measured {
    pub(crate) way: Way,
    pub(crate) clients: usize,
    pub(crate) budget: CoreBudget,
    pub(crate) run: Run,
}

/// Everything the report shows.
pub(crate) struct Report<'a> {
    pub(crate) args: &'a Args,
    pub(crate) machine: &'a Machine,
    pub(crate) shape: Shape,
    pub(crate) measured: &'a [Measured],
    /// The command line of the run.
    pub(crate) command: String,
}

/// What cliffd adds over one transport at one client count, at p50 (us): the full
/// round trip less the floor less the prediction. Derived from three runs (responses
/// carry no daemon timing), so it holds the noise of all three.
struct Breakdown {
    transport: &'static str,
    clients: usize,
    floor: f64,
    full: f64,
    prediction: f64,
}

impl Breakdown {
    fn daemon_adds(&self) -> f64 {
        self.full - self.floor - self.prediction
    }
}

impl Report<'_> {
    fn find(&self, kind: &str, transport: &str, clients: usize) -> Option<&Measured> {
        self.measured.iter().find(|m| {
            m.way.kind() == kind && m.way.transport() == transport && m.clients == clients
        })
    }

    fn breakdowns(&self) -> Vec<Breakdown> {
        let mut out = Vec::new();
        for m in self.measured.iter().filter(|m| m.way.kind() == "full") {
            let t = m.way.transport();
            let (Some(floor), Some(local)) = (
                self.find("floor", t, m.clients),
                self.find("prediction", "none", m.clients),
            ) else {
                continue;
            };
            out.push(Breakdown {
                transport: t,
                clients: m.clients,
                floor: floor.run.summary.p50,
                full: m.run.summary.p50,
                prediction: local.run.summary.p50,
            });
        }
        out
    }

    fn settings_line(&self) -> String {
        let a = self.args;
        format!(
            "{} agent(s) x k {} x {} steps (dt {} s), method {}{}, map {}; response {} x {} x {} ({} words); \
{} timed requests per client after {} warm-up requests (not counted); wait {} (spin {} us); {}; verify {}",
            a.agents,
            a.k,
            a.steps,
            a.dt,
            a.method,
            if a.scores { " with scores" } else { "" },
            a.map,
            self.shape.agents,
            self.shape.k,
            self.shape.steps,
            cliff_client::protocol::payload_words(
                self.shape.agents,
                self.shape.k,
                self.shape.steps,
                self.shape.scores
            ),
            a.requests,
            a.warmup,
            a.wait,
            a.spin_us,
            match a.rate {
                Some(r) => format!("each client paced at {r} requests/s"),
                None => "back to back".into(),
            },
            if a.verify() { "on" } else { "off" }
        )
    }

    fn markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# cliff-bench --compare\n");
        let _ = writeln!(s, "`{}`\n", self.command);
        let _ = writeln!(s, "* date: {} (UTC, start)", self.machine.started_utc);
        let _ = writeln!(s, "* machine: {}", self.machine.describe());
        let _ = writeln!(s, "* requests: {}", self.settings_line());
        let _ = writeln!(
            s,
            "* percentiles: from every timed request of the run (all clients), sorted, nearest rank; microseconds\n"
        );
        let _ = writeln!(
            s,
            "| way in | clients | p50 | p90 | p99 | p99.9 | max | requests/s | checked |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
        for m in self.measured {
            let x = &m.run.summary;
            let checked = match m.run.mismatches {
                Some(0) => format!("{} identical", m.run.completed()),
                Some(n) => format!("**{n} differ**"),
                None => "-".into(),
            };
            let _ = writeln!(
                s,
                "| {}{} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.0} | {} |",
                m.way.name(),
                if m.budget.oversubscribed() {
                    " (!)"
                } else {
                    ""
                },
                m.clients,
                x.p50,
                x.p90,
                x.p99,
                x.p999,
                x.max,
                m.run.requests_per_s(),
                checked
            );
        }
        let b = self.breakdowns();
        if !b.is_empty() {
            let _ = writeln!(
                s,
                "\nWhere a round trip's time goes, at p50 (us): the transport is the floor (the same \
request and response through the same client, answered by an echo server), the prediction is \
the in-process time, and cliffd's own work (decoding, validation, scheduling, writing the \
response, waking) is what is left of the round trip through cliffd. Derived from three runs \
(the responses carry no timing of the daemon), so each figure holds the noise of three.\n"
            );
            let _ = writeln!(
                s,
                "| transport | clients | transport (floor) | prediction (in-process) | cliffd adds | round trip via cliffd |"
            );
            let _ = writeln!(s, "|---|---|---|---|---|---|");
            for x in &b {
                let _ = writeln!(
                    s,
                    "| {} | {} | {:.1} | {:.1} | {:+.1} | {:.1} |",
                    x.transport,
                    x.clients,
                    x.floor,
                    x.prediction,
                    x.daemon_adds(),
                    x.full
                );
            }
        }
        if self.measured.iter().any(|m| m.budget.oversubscribed()) {
            let _ = writeln!(
                s,
                "\n(!) more spinning clients than free cores (the cores less what the daemon needs: \
one for its serving thread, and its other workers when a round of requests is large enough \
to split): those rows measure the scheduler as much as the transport."
            );
        }
        let _ = writeln!(
            s,
            "\n![latency distribution](latency-cdf.png)\n\n![throughput against clients](throughput.png)"
        );
        s
    }

    fn json(&self) -> Value {
        let runs: Vec<Value> = self
            .measured
            .iter()
            .map(|m| {
                let mut o = serde_json::Map::new();
                o.insert("way".into(), json!(m.way.name()));
                o.insert("transport".into(), json!(m.way.transport()));
                o.insert("kind".into(), json!(m.way.kind()));
                o.insert("clients".into(), json!(m.clients));
                o.insert("completed".into(), json!(m.run.completed()));
                m.run.summary.json_fields("", &mut o);
                o.insert("requests_per_s".into(), json!(m.run.requests_per_s()));
                o.insert(
                    "agent_predictions_per_s".into(),
                    json!(m.run.requests_per_s() * self.args.agents as f64),
                );
                o.insert("wall_s".into(), json!(m.run.wall_s));
                o.insert("errors".into(), json!(m.run.errors.len()));
                o.insert("first_error".into(), json!(m.run.errors.first()));
                o.insert("mismatches".into(), json!(m.run.mismatches));
                o.insert("cores".into(), m.budget.json());
                Value::Object(o)
            })
            .collect();
        let breakdown: Vec<Value> = self
            .breakdowns()
            .iter()
            .map(|b| {
                json!({
                    "transport": b.transport,
                    "clients": b.clients,
                    "floor_p50_us": b.floor,
                    "prediction_p50_us": b.prediction,
                    "cliffd_adds_p50_us": b.daemon_adds(),
                    "full_p50_us": b.full,
                })
            })
            .collect();
        let a = self.args;
        json!({
            "command": self.command,
            "machine": self.machine.json(),
            "settings": {
                "service": a.service,
                "agents": a.agents,
                "k": a.k,
                "steps": a.steps,
                "dt": a.dt,
                "method": a.method.name(),
                "scores": a.scores,
                "map": a.map,
                "wait": a.wait.to_string(),
                "spin_us": a.spin_us,
                "rate_hz": a.rate,
                "requests_per_client": a.requests,
                "warmup_per_client": a.warmup,
                "verify": a.verify(),
                "response_words": cliff_client::protocol::payload_words(
                    self.shape.agents, self.shape.k, self.shape.steps, self.shape.scores),
            },
            "warmup_excluded": true,
            "percentiles": "nearest rank over every timed request of a run (all clients), microseconds",
            "breakdown_source": "derived: round trip via cliffd less the floor less the in-process prediction, at p50 (responses carry no daemon timing)",
            "runs": runs,
            "breakdown": breakdown,
        })
    }

    fn cdf_chart(&self) -> LineChart {
        let first = self.measured.first().map_or(1, |m| m.clients);
        let lines = self
            .measured
            .iter()
            .filter(|m| m.clients == first)
            .map(|m| Line {
                label: m.way.name(),
                points: cdf_points(&m.run.latencies_ns, 400),
                markers: false,
                faint: m.way.kind() == "floor",
            })
            .collect();
        LineChart {
            title: format!(
                "Latency of every way in, {first} client(s), {} agent(s) x k {} x {} steps",
                self.args.agents, self.args.k, self.args.steps
            ),
            x_label: "latency per request (us, log scale)".into(),
            y_label: "fraction of requests at or below".into(),
            log_x: true,
            lines,
            ..LineChart::default()
        }
    }

    fn throughput_chart(&self) -> LineChart {
        let mut names: Vec<String> = Vec::new();
        for m in self.measured {
            if !names.contains(&m.way.name()) {
                names.push(m.way.name());
            }
        }
        let lines = names
            .into_iter()
            .map(|name| {
                let of_way: Vec<&Measured> = self
                    .measured
                    .iter()
                    .filter(|m| m.way.name() == name)
                    .collect();
                Line {
                    faint: of_way.iter().any(|m| m.way.kind() == "floor"),
                    points: of_way
                        .iter()
                        .map(|m| (m.clients as f64, m.run.requests_per_s()))
                        .collect(),
                    label: name,
                    markers: true,
                }
            })
            .collect();
        LineChart {
            title: format!(
                "Requests per second against clients, {} cores",
                self.machine.cores
            ),
            x_label: "clients".into(),
            y_label: "requests per second".into(),
            integer_x: true,
            legend_upper_left: true,
            lines,
            ..LineChart::default()
        }
    }
}

/// Write the report into `dir` (created if missing); returns the Markdown.
pub(crate) fn write_report(r: &Report<'_>, dir: &Path) -> Result<String, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.join(name);
        std::fs::write(&p, bytes).map_err(|e| format!("{}: {e}", p.display()))
    };
    let md = r.markdown();
    write("report.md", md.as_bytes())?;
    let json = serde_json::to_string_pretty(&r.json()).map_err(|e| e.to_string())?;
    write("report.json", json.as_bytes())?;
    for (name, chart) in [
        ("latency-cdf.png", r.cdf_chart()),
        ("throughput.png", r.throughput_chart()),
    ] {
        plot_lines(&chart, &dir.join(name)).map_err(|e| format!("{name}: {e}"))?;
    }
    Ok(md)
}
