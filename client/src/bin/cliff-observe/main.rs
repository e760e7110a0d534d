//! `cliff-observe` (also run as `cliff observe`): streams recorded trajectory files to a
//! learning `cliffd` as observations. One part per file: `main.rs` (the command line and
//! the sending loop), `feed.rs` (the files as a time-ordered stream of requests).

mod feed;

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Parser;
use cliff::tracks::{DatasetError, Format, read_tracks};
use cliff_client::protocol::{MAX_OBSERVE_ROWS, Observation};
use cliff_client::{Client, ClientOptions, Error, Field, ObserveRequest, Status};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use feed::Feed;

/// cliff-observe: streams recorded trajectories to a learning cliffd as observations.
///
/// Reads the trajectory files, merges their rows in time order (as a live tracker would
/// see them) and sends them to the daemon in observe requests for the map --map, which
/// the daemon must learn (cliffd --learn NAME). As fast as the daemon accepts (a request
/// over the client's budget is sent again a little later), or at --rate rows per second,
/// or as a robot streams what it sees: with --every-s, each request holds the rows of
/// one window of that many seconds of recording time, and with --speed each window is
/// sent once its time has come (the recording replayed that many times faster than it
/// was recorded). Each file's people are tracks of their own; a track's last row tells
/// the daemon the person left.
///
/// Example (cliffd --map thor1=../shared/data/thor1/cliffmap.csv --learn thor1):
///
///   cliff-observe --map thor1 --tracks ../shared/data/thor1/exp-1-run-2.csv --format thor
#[derive(Parser, Debug)]
#[command(name = "cliff-observe", version, about, long_about)]
struct Args {
    /// The learned map's name.
    #[arg(long)]
    map: String,

    /// Trajectory files.
    #[arg(long, num_args = 1.., required = true, value_name = "FILE")]
    tracks: Vec<PathBuf>,

    /// Trajectory file format: thor, atc, magni or csv [default: recognised from each
    /// file].
    #[arg(long, value_parser = |s: &str| s.parse::<Format>())]
    format: Option<Format>,

    /// Rows per second (default: as fast as the daemon accepts).
    #[arg(long, value_name = "ROWS")]
    rate: Option<f64>,

    /// Rows per request (at most 4096; the daemon's --max-observe-rows may be lower).
    #[arg(long, default_value_t = 512)]
    rows_per_request: usize,

    /// Send the rows of each window of this many seconds of recording time together (a
    /// window of more than --rows-per-request rows in several requests), as a tracker's
    /// rows come.
    #[arg(long, value_name = "S", conflicts_with = "rate")]
    every_s: Option<f64>,

    /// Replay the recording this many times faster than real time: each window of
    /// --every-s is sent once its end has come (1: as recorded). The last line says how
    /// late the requests went out.
    #[arg(long, value_name = "X", requires = "every_s", conflicts_with = "rate")]
    speed: Option<f64>,

    /// iceoryx2 service name of the daemon.
    #[arg(long, default_value = cliff_client::DEFAULT_SERVICE)]
    service: String,

    /// iceoryx2 prefix (namespace) of the daemon. Default: the CLIFF_IPC_PREFIX
    /// environment variable, else iceoryx2's default.
    #[arg(long, env = "CLIFF_IPC_PREFIX")]
    prefix: Option<String>,

    /// Give up when the daemon has taken nothing for this long (s).
    #[arg(long, default_value_t = 30.0)]
    give_up_s: f64,

    /// No progress bar.
    #[arg(long)]
    quiet: bool,

    /// Reach the daemon over zenoh at this endpoint (e.g. tcp/127.0.0.1:7447) instead
    /// of iceoryx2 shared memory; repeatable.
    #[cfg(feature = "zenoh")]
    #[arg(long = "zenoh", value_name = "ENDPOINT")]
    zenoh: Vec<String>,

    /// A zenoh configuration file for the client (TLS certificates, ...); implies zenoh.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "FILE")]
    zenoh_config: Option<PathBuf>,
}

impl Args {
    fn connect(&self) -> Result<Client, Error> {
        let options = ClientOptions {
            prefix: self.prefix.clone().filter(|p| !p.is_empty()),
            ..ClientOptions::default()
        };
        #[cfg(feature = "zenoh")]
        if !self.zenoh.is_empty() || self.zenoh_config.is_some() {
            return Client::connect_zenoh_with(
                &self.zenoh,
                self.zenoh_config.as_deref(),
                &self.service,
                options,
            );
        }
        Client::connect_with(&self.service, options)
    }
}

/// What the run counted.
#[derive(Debug, Default)]
struct Counts {
    accepted: u64,
    duplicates: u64,
    retries: u64,
    version: u32,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(a: Args) -> Result<(), String> {
    if a.rows_per_request == 0 || a.rows_per_request > MAX_OBSERVE_ROWS as usize {
        return Err(format!(
            "--rows-per-request {}: must be between 1 and {MAX_OBSERVE_ROWS}",
            a.rows_per_request
        ));
    }
    if let Some(r) = a.rate
        && !(r.is_finite() && r > 0.0)
    {
        return Err(format!(
            "--rate {r}: must be a positive number of rows per second"
        ));
    }
    for (name, v) in [("--every-s", a.every_s), ("--speed", a.speed)] {
        if let Some(v) = v
            && !(v.is_finite() && v > 0.0)
        {
            return Err(format!("{name} {v}: must be a positive number"));
        }
    }
    if !(a.give_up_s.is_finite() && a.give_up_s > 0.0) {
        return Err(format!("--give-up-s {}: must be positive", a.give_up_s));
    }
    let files = a
        .tracks
        .iter()
        .map(|p| {
            let format = a.format.map_or_else(|| Format::detect(p), Ok);
            format
                .and_then(|f| read_tracks(p, f))
                .map_err(|e| match &e {
                    DatasetError::Unrecognised {
                        file,
                        reason,
                        choices,
                    } => {
                        let give: Vec<String> =
                            choices.iter().map(|c| format!("--format {c}")).collect();
                        format!(
                            "{file}: the format is not recognised: {reason}; give {}",
                            give.join(" or ")
                        )
                    }
                    _ => e.to_string(),
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let feed = Feed::new(&files)?;
    let mut request = ObserveRequest::new(&a.map).map_err(|e| e.to_string())?;
    let mut client = a.connect().map_err(|e| e.to_string())?;

    let bar = if a.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::with_draw_target(Some(feed.len() as u64), ProgressDrawTarget::stderr())
    };
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} rows ({per_sec}, {eta} left)")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_message(format!("observing {}", a.map));

    let start = Instant::now();
    let give_up = Duration::from_secs_f64(a.give_up_s);
    let mut counts = Counts::default();
    let mut rows: Vec<Observation> = Vec::with_capacity(a.rows_per_request);
    let mut sent = 0usize;
    let mut last_progress = Instant::now();
    // lowered when a request holds more rows than the daemon's budget lets through at once
    let mut per_request = a.rows_per_request;
    // how late each window went out after its time had come (s), with --speed
    let mut late: Vec<f64> = Vec::new();
    let t0 = feed.span().map_or(0.0, |(a, _)| a);
    while sent < feed.len() {
        let mut due = None;
        if let Some(rate) = a.rate {
            // the rows sent so far may not run ahead of the rate
            due = Some(start + Duration::from_secs_f64(sent as f64 / rate));
        }
        let n = match (a.rate, a.every_s) {
            // at low rates, requests of about a tenth of a second's rows
            (Some(rate), _) => per_request.min(((rate / 10.0).ceil() as usize).max(1)),
            (None, Some(every)) => {
                let (end, close) = feed.window(sent, every);
                if let Some(speed) = a.speed {
                    due = Some(start + Duration::from_secs_f64((close - t0) / speed));
                }
                per_request.min(end - sent)
            }
            (None, None) => per_request,
        };
        if let Some(due) = due {
            let now = Instant::now();
            if let Some(wait) = due.checked_duration_since(now) {
                std::thread::sleep(wait);
            }
            if a.speed.is_some() {
                late.push(now.saturating_duration_since(due).as_secs_f64());
            }
        }
        feed.request(sent, n, &mut rows);
        request.clear();
        fill(&mut request, &rows);
        match client.observe(&request) {
            Ok(r) => {
                counts.accepted += r.accepted as u64;
                counts.duplicates += r.duplicates as u64;
                counts.version = r.map_version;
                sent += rows.len();
                bar.inc(rows.len() as u64);
                bar.set_message(format!(
                    "observing {} (map version {})",
                    a.map, r.map_version
                ));
                last_progress = Instant::now();
            }
            Err(Error::Rejected(rej)) if rej.status == Status::OverBudget => {
                counts.retries += 1;
                if last_progress.elapsed() > give_up {
                    return Err(format!(
                        "the daemon has taken nothing for {} s: {rej}",
                        a.give_up_s
                    ));
                }
                if rej.field == Field::Rows && rej.limit > 0 {
                    // at most half of what the budget lets through in a second
                    per_request = per_request.min((rej.limit as usize / 2).max(1));
                }
                // rows come back as the budget refills; tracks and memory as they end
                let pause = if rej.field == Field::Rows { 10 } else { 100 };
                std::thread::sleep(Duration::from_millis(pause));
            }
            Err(e) => return Err(format!("observing '{}': {e}", a.map)),
        }
    }
    bar.finish_and_clear();
    let took = start.elapsed().as_secs_f64();
    let span = feed.span().map_or(0.0, |(a, b)| b - a);
    println!(
        "observed {} rows ({:.0} s of tracks) in {took:.1} s ({:.0} rows/s, {:.0}x real time): {} taken, {} duplicates, {} retries over budget; map '{}' at version {}",
        feed.len(),
        span,
        feed.len() as f64 / took.max(1e-9),
        span / took.max(1e-9),
        counts.accepted,
        counts.duplicates,
        counts.retries,
        a.map,
        counts.version
    );
    if let (Some(every), Some(speed)) = (a.every_s, a.speed) {
        late.sort_by(f64::total_cmp);
        let ms = |q: f64| {
            1e3 * late
                .get(((late.len() as f64 - 1.0) * q) as usize)
                .unwrap_or(&0.0)
        };
        println!(
            "streamed in windows of {every} s of recording time at {speed}x: {} requests, sent after their time by {:.1} ms median, {:.1} ms p99, {:.1} ms at most",
            late.len(),
            ms(0.5),
            ms(0.99),
            ms(1.0)
        );
    }
    Ok(())
}

/// The request's rows: `rows`, which are grouped by track already.
fn fill(request: &mut ObserveRequest, rows: &[Observation]) {
    let mut i = 0;
    while i < rows.len() {
        let id = rows[i].agent;
        let end = i + rows[i..].iter().take_while(|o| o.agent == id).count();
        request.add_track(id, rows[i..end].iter().copied());
        i = end;
    }
}
