//! Evaluation: protocols, metrics and reports, and whether occupancy is calibrated
//! ([`calibration`]).
//!
//! ```no_run
//! use cliff::eval::{evaluate, protocol::Settings, EvalConfig};
//! use cliff::tracks::{read_tracks, Format};
//! use cliff::map::CliffMap;
//! use cliff::predict::{Method, Params};
//!
//! let map = CliffMap::load("../shared/data/thor1/cliffmap.csv")?;
//! let tracks = read_tracks("../shared/data/thor1/exp-1-run-2.csv".as_ref(), Format::Thor)?;
//! let cfg = EvalConfig {
//!     settings: Settings::default(), // reference protocol, 3.2 s observed, dt 0.4, 12 s
//!     params: Params::default(),     // k 20, beta 1, radius 0.7071
//!     seeds: 20,
//!     methods: vec![Method::Cliff, Method::Cvm],
//!     options: Default::default(),   // the paper's method
//!     motion_model: None,            // the built-in motion model (for `motion`)
//! };
//! let report = evaluate(&map, &tracks, &cfg, &|| {})?;
//! print!("{}", cliff::eval::summary_table(&report.summary, &[2.0, 4.0, 6.0, 8.0, 10.0, 12.0]));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod calibration;
pub mod metrics;
pub mod protocol;
mod report;
pub mod speed_prior_fit;
pub mod windows;

pub use report::{
    EvalConfig, EvalReport, PersonRow, SUMMARY_HEADER, SummaryRow, evaluate, per_person_csv,
    person_seed, summary_csv, summary_table, table_horizons, write_reports,
};
