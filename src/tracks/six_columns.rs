//! The THÖR and ATC files: CSV without a header, one row per tracked position,
//! `time, person_id, x, y, speed, motion_angle` (s, -, m, m, m/s, rad in (-pi, pi]).
//! THÖR runs at 2.5 Hz with times from the start of the recording; ATC at 1 Hz with
//! unix times. Rows are grouped into [`Track`]s by person, in order of first appearance.

use std::collections::HashMap;

use glam::DVec2;

use super::track::{DatasetError, MAX_ANGLE, MAX_POSITION, MAX_SPEED, MAX_TIME, Row, Track};

const COLUMNS: usize = 6;

/// Parse six-column text (the bounds and rules of [`parse_tracks`](super::read::parse_tracks)).
pub(crate) fn parse_six_columns(text: &str, file: &str) -> Result<Vec<Track>, DatasetError> {
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
