//! A trajectory file's [`Format`] recognised from the file itself: [`Format::detect`]
//! (a path, reading at most [`DETECT_BYTES`] of it) and [`Format::detect_bytes`].
//!
//! A file is recognised by, in this order:
//!
//! | what the file holds | format |
//! |---|---|
//! | a bag's folder of `.mcap` files, a file beginning with the MCAP magic or named `*.mcap` | `rosbag2` |
//! | a header row beginning `Time,ag_id,x,y` | `magni` |
//! | any other header row (a first row without a number) | `csv` |
//! | no header, 6 numbers a row, the first time below 1e6 s (seconds from a recording's start) | `thor` |
//! | no header, 6 numbers a row, the first time from 1e8 s on (unix time, 1973 on) | `atc` |
//!
//! THÖR and ATC files are read by the same reader with the same rules (six columns,
//! `time, person_id, x, y, speed, motion_angle`): the two names differ only in the time
//! scale, which names the one recognised. A headerless file whose first time is neither
//! (from 1e6 to 1e8 s in magnitude), an empty file, a headerless row of another column
//! count or bytes that are not text are not recognised: [`DatasetError::Unrecognised`]
//! names the file and the formats to choose from.
//!
//! ```
//! use cliff::tracks::{Format, DatasetError};
//! assert_eq!(Format::detect_bytes(b"0.02,12001,-0.04,-3.4,0.1,2.3\n", "t.csv")?, Format::Thor);
//! assert_eq!(Format::detect_bytes(b"1351044035.976,11003500,-28.0,3.5,1.4,0.06\n", "a.csv")?, Format::Atc);
//! assert_eq!(Format::detect_bytes(b"Time,ag_id,x,y,speed,x_speed,y_speed\n", "m.csv")?, Format::Magni);
//! assert_eq!(Format::detect_bytes(b"t,id,x,y\n0,1,2,3\n", "p.csv")?, Format::Csv);
//! let e = Format::detect_bytes(b"5000000,1,0,0,1,0\n", "q.csv").unwrap_err();
//! assert!(matches!(&e, DatasetError::Unrecognised { choices, .. } if choices == &[Format::Thor, Format::Atc]));
//! # Ok::<(), DatasetError>(())
//! ```

use std::path::Path;

use super::format::Format;
use super::rosbag2::{is_mcap, is_recording};
use super::track::DatasetError;
use crate::bounded_read::read_start;

/// Bytes of a file's start [`Format::detect`] reads.
pub const DETECT_BYTES: u64 = 64 * 1024;

/// Below this magnitude (s) a headerless file's first time is seconds from the start of
/// a recording: [`Format::Thor`] (about 11.6 days).
pub const RECORDING_TIME_BELOW: f64 = 1e6;

/// From this time (s) on a headerless file's first time is unix time: [`Format::Atc`]
/// (March 1973 on).
pub const UNIX_TIME_FROM: f64 = 1e8;

impl Format {
    /// The format of the file (or bag folder) at `path`, recognised from its name and
    /// its first [`DETECT_BYTES`] bytes as the [module documentation](self) describes;
    /// [`DatasetError::Unrecognised`] when the file could be none or several of them.
    pub fn detect(path: &Path) -> Result<Format, DatasetError> {
        let file = path.display().to_string();
        if is_recording(path)
            || path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
        {
            return Ok(Format::Rosbag2);
        }
        if path.is_dir() {
            return Err(unrecognised(
                &file,
                "a folder without .mcap files (a rosbag2 bag's folder holds them)".into(),
                &Format::ALL,
            ));
        }
        let start = read_start(path, DETECT_BYTES).map_err(|source| DatasetError::Io {
            file: file.clone(),
            source,
        })?;
        Format::detect_bytes(&start, &file)
    }

    /// The format of a file that begins with `start` (its first bytes or all of it);
    /// `file` names it in errors. See [`Format::detect`].
    pub fn detect_bytes(start: &[u8], file: &str) -> Result<Format, DatasetError> {
        if is_mcap(start) {
            return Ok(Format::Rosbag2);
        }
        // a character cut at the end of the window is not an error; a byte that is not
        // UTF-8 before it is
        let text = match std::str::from_utf8(start) {
            Ok(t) => t,
            Err(e) if e.error_len().is_none() => {
                std::str::from_utf8(&start[..e.valid_up_to()]).unwrap_or_default()
            }
            Err(_) => {
                return Err(unrecognised(
                    file,
                    "not UTF-8 text nor a rosbag2 recording (MCAP)".into(),
                    &Format::ALL,
                ));
            }
        };
        let complete = start.len() < DETECT_BYTES as usize;
        let Some((i, first)) = text
            .split('\n')
            .map(str::trim)
            .enumerate()
            .find(|(_, l)| !l.is_empty())
        else {
            return Err(unrecognised(
                file,
                "no rows to recognise the format by".into(),
                &Format::ALL,
            ));
        };
        // the line is whole when a newline follows it or the file ends within the window
        let whole = complete || text.split('\n').nth(i + 1).is_some();
        let fields: Vec<&str> = first.split(',').map(str::trim).collect();
        let number = |f: &str| f.parse::<f64>().is_ok();
        if !fields.iter().copied().any(number) {
            return Ok(
                if fields.len() >= 4 && fields[..4] == ["Time", "ag_id", "x", "y"] {
                    Format::Magni
                } else {
                    Format::Csv
                },
            );
        }
        if !whole && fields.len() <= 6 {
            return Err(unrecognised(
                file,
                format!("its first row is longer than {DETECT_BYTES} bytes"),
                &Format::ALL,
            ));
        }
        if fields.len() != 6 {
            return Err(unrecognised(
                file,
                format!(
                    "its first row holds {}{} values and no header (thor and atc files have 6 columns: \
                     time, person_id, x, y, speed, motion_angle; magni and csv files a header row)",
                    fields.len(),
                    if whole { "" } else { " or more" },
                ),
                &Format::ALL,
            ));
        }
        let time = fields[0];
        match time.parse::<f64>() {
            Ok(t) if t.abs() < RECORDING_TIME_BELOW => Ok(Format::Thor),
            Ok(t) if t >= UNIX_TIME_FROM && t.is_finite() => Ok(Format::Atc),
            Ok(t) if t.is_finite() => Err(unrecognised(
                file,
                format!(
                    "a headerless file of 6 columns whose first time {time} could be seconds \
                     from a recording's start (thor, below {RECORDING_TIME_BELOW:e}) or unix time \
                     (atc, from {UNIX_TIME_FROM:e})"
                ),
                &[Format::Thor, Format::Atc],
            )),
            _ => Err(unrecognised(
                file,
                format!(
                    "a headerless file of 6 columns whose first time '{time}' is not a finite number"
                ),
                &[Format::Thor, Format::Atc],
            )),
        }
    }
}

fn unrecognised(file: &str, reason: String, choices: &[Format]) -> DatasetError {
    DatasetError::Unrecognised {
        file: file.to_string(),
        reason,
        choices: choices.to_vec(),
    }
}
