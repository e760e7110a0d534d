//! Readers for the THÖR and ATC trajectory files.
//!
//! Both are CSV without a header, one row per tracked position:
//! `time, person_id, x, y, speed, motion_angle` (s, -, m, m, m/s, rad in (-pi, pi]).
//! THÖR runs at 2.5 Hz with times from the start of the recording; ATC at 1 Hz with
//! unix times. Rows are grouped into [`Track`]s by person, in order of first appearance.
//! Files with a header row and named columns (THÖR-MAGNI, [`Format::Magni`], or any
//! CSV, [`Format::Csv`]) are read by [`super::columns`].
//!
//! ```
//! use cliff::eval::dataset::{parse_tracks, Format};
//! let text = "0.0,7,1.0,2.0,1.2,0.5\n0.4,7,1.4,2.2,1.1,0.4\n";
//! let tracks = parse_tracks(text, "inline.csv", Format::Thor).unwrap();
//! assert_eq!(tracks[0].id, 7);
//! assert_eq!(tracks[0].rows.len(), 2);
//! ```

use std::collections::HashMap;
use std::fmt;
use std::path::Path;
use std::str::FromStr;

use glam::DVec2;

use super::columns::{Columns, parse_named};
use crate::bounded_read::{line_column, read_at_most};

/// Trajectory file formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// THÖR: `time, person_id, x, y, speed, motion_angle`, 2.5 Hz.
    Thor,
    /// ATC: `unix_time, person_id, x, y, speed, motion_angle`, 1 Hz.
    Atc,
    /// THÖR-MAGNI: a header row, columns by name
    /// ([`Columns::magni`](super::columns::Columns::magni)).
    Magni,
    /// A CSV with a header row and named columns; without a mapping
    /// ([`super::columns`]) the columns `t, id, x, y`.
    Csv,
}

impl FromStr for Format {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "thor" => Ok(Format::Thor),
            "atc" => Ok(Format::Atc),
            "magni" | "thor-magni" => Ok(Format::Magni),
            "csv" => Ok(Format::Csv),
            other => Err(format!(
                "unknown track format '{other}' (expected thor, atc, magni or csv)"
            )),
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Format::Thor => "thor",
            Format::Atc => "atc",
            Format::Magni => "magni",
            Format::Csv => "csv",
        })
    }
}

/// One tracked position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Time (s).
    pub t: f64,
    /// Position (m).
    pub position: DVec2,
    /// Speed (m/s); 0 with angle 0 means standing still.
    pub speed: f64,
    /// Motion angle (rad, as in the file: (-pi, pi]).
    pub angle: f64,
}

/// All rows of one person, in time order.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// Person id.
    pub id: u64,
    /// Rows, strictly increasing in time.
    pub rows: Vec<Row>,
}

/// A problem in a trajectory file, with its place.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// A bad value; line and column are 1-based (column 0: the whole line).
    #[error("{file}:{line}: column {column}: {message}")]
    Parse {
        /// The file.
        file: String,
        /// Line.
        line: usize,
        /// Column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// Reading failed.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// The underlying error.
        source: std::io::Error,
    },
}

const COLUMNS: usize = 6;

/// Largest trajectory file read, in bytes (1 GiB).
pub const MAX_TRACK_FILE_BYTES: u64 = 1 << 30;
/// Largest |time| (s) of a row: 1e11 s covers unix times for the next three millennia.
pub const MAX_TIME: f64 = 1e11;
/// Largest |x| and |y| (m) of a row (the bound of map coordinates,
/// [`MAX_COORDINATE`](crate::map::MAX_COORDINATE)).
pub const MAX_POSITION: f64 = crate::map::MAX_COORDINATE;
/// Largest speed (m/s) of a row. Tracker glitches of hundreds of m/s occur in real
/// files (THÖR3 has one of 432 m/s) and are read, for the evaluation's filters to judge;
/// this bound only refuses the absurd.
pub const MAX_SPEED: f64 = 1e6;
/// Largest |motion angle| (rad) of a row: the files hold (-pi, pi]; other conventions
/// ([0, 2pi), degrees-free unwrapped angles) stay well within.
pub const MAX_ANGLE: f64 = 1e3;

/// Read the tracks of one file.
///
/// Files larger than [`MAX_TRACK_FILE_BYTES`] are refused before they are read; the
/// rows are then checked as [`parse_tracks`] describes.
pub fn read_tracks(path: &Path, format: Format) -> Result<Vec<Track>, DatasetError> {
    let file = path.display().to_string();
    let bytes = read_at_most(path, MAX_TRACK_FILE_BYTES).map_err(|source| DatasetError::Io {
        file: file.clone(),
        source,
    })?;
    parse_track_bytes(&bytes, &file, format)
}

/// Parse trajectory bytes (UTF-8 text; anything else is an error at its line and
/// column); `file` names the source in errors.
pub fn parse_track_bytes(
    bytes: &[u8],
    file: &str,
    format: Format,
) -> Result<Vec<Track>, DatasetError> {
    match std::str::from_utf8(bytes) {
        Ok(text) => parse_tracks(text, file, format),
        Err(e) => {
            let (line, column) = line_column(bytes, e.valid_up_to());
            Err(DatasetError::Parse {
                file: file.to_string(),
                line,
                column,
                message: "not UTF-8 text".into(),
            })
        }
    }
}

/// Read and concatenate the tracks of several files (a person id seen in two files
/// becomes two tracks).
pub fn read_many(paths: &[impl AsRef<Path>], format: Format) -> Result<Vec<Track>, DatasetError> {
    let mut all = Vec::new();
    for p in paths {
        all.extend(read_tracks(p.as_ref(), format)?);
    }
    Ok(all)
}

/// Parse trajectory text; `file` names the source in errors.
///
/// Every value must be a finite number within its bound: |time| <= [`MAX_TIME`],
/// |x|, |y| <= [`MAX_POSITION`], 0 <= speed <= [`MAX_SPEED`],
/// |angle| <= [`MAX_ANGLE`]; a person id is a whole number in `0..2^64`; a person's
/// times strictly increase. Memory grows with the rows read, never with a value.
pub fn parse_tracks(text: &str, file: &str, format: Format) -> Result<Vec<Track>, DatasetError> {
    match format {
        Format::Thor | Format::Atc => {}
        Format::Magni => return Ok(parse_named(text, file, &Columns::magni())?.tracks),
        Format::Csv => return Ok(parse_named(text, file, &Columns::default())?.tracks),
    }
    let err = |line: usize, column: usize, message: String| DatasetError::Parse {
        file: file.to_string(),
        line,
        column,
        message,
    };
    let mut tracks: Vec<Track> = Vec::new();
    let mut index: HashMap<u64, usize> = HashMap::new();
    for (ln, raw) in text.lines().enumerate() {
        let line = ln + 1;
        let raw = raw.trim();
        if raw.is_empty() {
            continue;
        }
        let mut fields = [""; COLUMNS];
        let mut n = 0;
        for f in raw.split(',') {
            if n < COLUMNS {
                fields[n] = f.trim();
            }
            n += 1;
        }
        if n != COLUMNS {
            return Err(err(
                line,
                0,
                format!(
                    "expected {COLUMNS} columns (time, person_id, x, y, speed, motion_angle), found {n}"
                ),
            ));
        }
        let num = |c: usize, bound: f64, what: &str| -> Result<f64, DatasetError> {
            let v: f64 = fields[c]
                .parse()
                .map_err(|_| err(line, c + 1, format!("'{}' is not a number", fields[c])))?;
            if !v.is_finite() {
                Err(err(line, c + 1, format!("'{}' is not finite", fields[c])))
            } else if v.abs() > bound {
                Err(err(
                    line,
                    c + 1,
                    format!("{what} {v:?} is beyond {bound} in magnitude"),
                ))
            } else {
                Ok(v)
            }
        };
        let t = num(0, MAX_TIME, "time")?;
        let id: u64 = match fields[1].parse::<u64>() {
            Ok(id) => id,
            Err(_) => {
                let f = num(1, f64::MAX, "person id")?;
                if f >= 0.0 && f.fract() == 0.0 && f < 1.8e19 {
                    f as u64
                } else {
                    return Err(err(
                        line,
                        2,
                        format!(
                            "person id '{}' is not a non-negative whole number",
                            fields[1]
                        ),
                    ));
                }
            }
        };
        let row = Row {
            t,
            position: DVec2::new(
                num(2, MAX_POSITION, "coordinate")?,
                num(3, MAX_POSITION, "coordinate")?,
            ),
            speed: num(4, MAX_SPEED, "speed")?,
            angle: num(5, MAX_ANGLE, "motion angle")?,
        };
        if row.speed < 0.0 {
            return Err(err(line, 5, format!("negative speed {}", row.speed)));
        }
        let i = *index.entry(id).or_insert_with(|| {
            tracks.push(Track {
                id,
                rows: Vec::new(),
            });
            tracks.len() - 1
        });
        if let Some(prev) = tracks[i].rows.last()
            && row.t <= prev.t
        {
            return Err(err(
                line,
                1,
                format!(
                    "time {} of person {id} does not increase (previous row {})",
                    row.t, prev.t
                ),
            ));
        }
        tracks[i].rows.push(row);
    }
    Ok(tracks)
}

/// Keep only the rows with `from <= t < until` (times as in the file), and drop the
/// tracks left empty: for building a map from one part of a recording and evaluating on
/// another.
///
/// ```
/// use cliff::eval::dataset::{parse_tracks, keep_time_range, Format};
/// let mut t = parse_tracks("0,1,0,0,1,0\n1,1,1,0,1,0\n2,1,2,0,1,0\n0,2,5,5,1,0\n", "a", Format::Atc).unwrap();
/// keep_time_range(&mut t, 1.0, 3.0);
/// assert_eq!((t.len(), t[0].rows.len()), (1, 2));
/// ```
pub fn keep_time_range(tracks: &mut Vec<Track>, from: f64, until: f64) {
    for t in tracks.iter_mut() {
        t.rows.retain(|r| r.t >= from && r.t < until);
    }
    tracks.retain(|t| !t.rows.is_empty());
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(text: &str) -> String {
        parse_tracks(text, "t.csv", Format::Thor)
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn groups_by_person_in_order() {
        let t = parse_tracks("0,2,0,0,1,0\n0,1,5,5,1,0\n1,2,1,0,1,0\n", "t", Format::Atc).unwrap();
        assert_eq!(
            t.iter().map(|t| (t.id, t.rows.len())).collect::<Vec<_>>(),
            vec![(2, 2), (1, 1)]
        );
    }

    #[test]
    fn errors_name_file_line_column() {
        assert!(e("0,1,0,0,1\n").contains("t.csv:1: column 0: expected 6 columns"));
        assert!(e("0,1,0,0,1,0\n1,1,x,0,1,0\n").contains("t.csv:2: column 3: 'x' is not a number"));
        assert!(e("0,1,0,inf,1,0\n").contains("column 4: 'inf' is not finite"));
        assert!(e("0,1,0,0,-1,0\n").contains("column 5: negative speed"));
        assert!(e("0,-3,0,0,1,0\n").contains("column 2: person id"));
        assert!(
            e("1,1,0,0,1,0\n1,1,0,0,1,0\n")
                .contains("t.csv:2: column 1: time 1 of person 1 does not increase")
        );
    }

    #[test]
    fn absurd_values_lines_and_bytes_are_errors_with_line_and_column() {
        assert!(e("1e300,1,0,0,1,0\n").contains("t.csv:1: column 1: time 1e300 is beyond"));
        assert!(e("0,1,0,0,1,0\n1,1,1e7,0,1,0\n").contains("t.csv:2: column 3: coordinate"));
        assert!(e("0,1,0,-2e6,1,0\n").contains("column 4: coordinate"));
        assert!(e("0,1,0,0,2e6,0\n").contains("column 5: speed 2000000.0 is beyond 1000000"));
        assert!(e("0,1,0,0,1,-1e4\n").contains("column 6: motion angle"));
        assert!(e("0,1.5,0,0,1,0\n").contains("column 2: person id '1.5'"));
        assert!(e("0,1e300,0,0,1,0\n").contains("column 2: person id"));
        // a line of a million columns: counted, not collected
        let long = format!("0,1,0,0,1,0{}\n", ",".repeat(1_000_000));
        assert!(e(&long).contains(
            "expected 6 columns (time, person_id, x, y, speed, motion_angle), found 1000006"
        ));
        let err = parse_track_bytes(b"0,1,0,0,1,0\n1,1,\xc3(,0,1,0\n", "t.csv", Format::Atc)
            .unwrap_err()
            .to_string();
        assert!(err.contains("t.csv:2: column 5: not UTF-8"), "{err}");
        // the bounds themselves are accepted; an id as a whole float is read
        let t = parse_tracks(
            "-1e11,7e0,1e6,-1e6,1e6,1000\n1e11,7,0,0,0,-1000\n",
            "t",
            Format::Thor,
        )
        .unwrap();
        assert_eq!((t.len(), t[0].id, t[0].rows.len()), (1, 7, 2));
    }

    #[test]
    fn refuses_files_over_the_size_limit_before_reading() {
        // a sparse file of 1 GiB + 1 byte costs no disk
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("huge.csv");
        let f = std::fs::File::create(&path).unwrap();
        f.set_len(MAX_TRACK_FILE_BYTES + 1).unwrap();
        let err = read_tracks(&path, Format::Atc).unwrap_err().to_string();
        assert!(
            err.contains("huge.csv") && err.contains("larger than 1073741824 bytes"),
            "{err}"
        );
    }

    #[test]
    fn reads_the_shipped_files() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data");
        let t = read_tracks(&Path::new(dir).join("thor1/exp-1-run-2.csv"), Format::Thor).unwrap();
        assert_eq!(t.len(), 87);
        let t = read_tracks(&Path::new(dir).join("thor3/exp-3-run-2.csv"), Format::Thor).unwrap();
        assert_eq!(t.len(), 126);
        let t = read_tracks(
            &Path::new(dir).join("atc/dev/atc-1024-13_test.csv"),
            Format::Atc,
        )
        .unwrap();
        assert_eq!(t.iter().map(|t| t.rows.len()).sum::<usize>(), 7973);
    }
}
