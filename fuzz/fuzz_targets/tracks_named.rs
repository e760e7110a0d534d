//! The named-column trajectory readers (THÖR-MAGNI and CSV with a column mapping) on
//! arbitrary bytes: they read tracks whose rows keep their invariants, with one distinct
//! id per track, or name the file, line and column of what is wrong.
//!
//! The first byte picks the reader (its value modulo 4):
//!
//! - 0: `parse_track_bytes(.., Format::Magni)` on the rest (and `parse_named` with
//!   `Columns::magni()`, which must agree);
//! - 1: `parse_track_bytes(.., Format::Csv)` on the rest (columns `t, id, x, y`);
//! - 2: the first line of the rest is a column mapping (`t=Time,id=ag_id,x=x,y=y,...`)
//!   parsed as `--columns` is; it is refused with a message or it writes back to the same
//!   mapping, and the lines after it are the file;
//! - 3: the first line of the rest gives the header names of `t, id, x, y, speed, angle,
//!   vx, vy` in this order, put into a `Columns` directly (its fields are public), so also
//!   mappings `--columns` refuses (an angle without a speed, only one of vx and vy) reach
//!   the reader; the lines after it are the file.
#![no_main]

use std::collections::HashSet;

use cliff::tracks::rosbag2::is_mcap;
use cliff::tracks::{Columns, NamedTracks, parse_named};
use cliff::tracks::{
    DatasetError, Format, MAX_ANGLE, MAX_POSITION, MAX_SPEED, MAX_TIME, Track, parse_track_bytes,
};
use libfuzzer_sys::fuzz_target;

const FILE: &str = "fuzz.csv";

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    // bytes that begin with the MCAP magic are a rosbag2 recording whatever the format
    // asked for (`parse_track_bytes`): the target tracks_rosbag2 reads those
    if is_mcap(rest) {
        return;
    }
    match mode % 4 {
        0 => {
            let r = parse_track_bytes(rest, FILE, Format::Magni);
            check_tracks(&r, rest);
            if let (Ok(tracks), Ok(text)) = (&r, std::str::from_utf8(rest)) {
                let named = parse_named(text, FILE, &Columns::magni()).expect("read once");
                assert_eq!(&named.tracks, tracks);
                check_named(&named);
            }
        }
        1 => check_tracks(&parse_track_bytes(rest, FILE, Format::Csv), rest),
        2 => {
            let (spec, body) = first_line(rest);
            match String::from_utf8_lossy(spec).parse::<Columns>() {
                Ok(columns) => {
                    let back: Columns = columns.to_string().parse().expect("writes back");
                    assert_eq!(back, columns);
                    read(body, &columns);
                }
                Err(message) => assert!(!message.is_empty()),
            }
        }
        _ => {
            let (spec, body) = first_line(rest);
            let spec = String::from_utf8_lossy(spec);
            let mut names = spec.split(',').map(|s| s.trim().to_string());
            let mut next = || names.next().filter(|s| !s.is_empty());
            let columns = Columns {
                t: next().unwrap_or_default(),
                id: next().unwrap_or_default(),
                x: next().unwrap_or_default(),
                y: next().unwrap_or_default(),
                speed: next(),
                angle: next(),
                vx: next(),
                vy: next(),
            };
            read(body, &columns);
        }
    }
});

/// Split off the first line (without its newline).
fn first_line(bytes: &[u8]) -> (&[u8], &[u8]) {
    match bytes.iter().position(|&b| b == b'\n') {
        Some(i) => (&bytes[..i], &bytes[i + 1..]),
        None => (bytes, &[]),
    }
}

/// `parse_named` on `body` (as text: invalid UTF-8 becomes U+FFFD).
fn read(body: &[u8], columns: &Columns) {
    let text = String::from_utf8_lossy(body);
    let r = parse_named(&text, FILE, columns);
    if let Ok(named) = &r {
        check_named(named);
    }
    check_tracks(&r.map(|n| n.tracks), body);
}

/// Tracks keep their invariants; errors name the file, a line of the input and a column
/// no further right than its fields reach.
fn check_tracks(r: &Result<Vec<Track>, DatasetError>, bytes: &[u8]) {
    let lines = bytes.split(|&b| b == b'\n').count();
    match r {
        Ok(tracks) => {
            let mut ids = HashSet::new();
            let mut rows = 0;
            for t in tracks {
                assert!(ids.insert(t.id), "two tracks with id {}", t.id);
                assert!(!t.rows.is_empty());
                rows += t.rows.len();
                assert!(t.rows.windows(2).all(|w| w[0].t < w[1].t));
                for r in &t.rows {
                    assert!(r.t.is_finite() && r.t.abs() <= MAX_TIME, "{r:?}");
                    assert!(r.position.is_finite(), "{r:?}");
                    assert!(r.position.abs().max_element() <= MAX_POSITION, "{r:?}");
                    assert!((0.0..=MAX_SPEED).contains(&r.speed), "{r:?}");
                    assert!(r.angle.is_finite() && r.angle.abs() <= MAX_ANGLE, "{r:?}");
                }
            }
            // a header row and one row per data line at most
            assert!(rows < lines, "{rows} rows from {lines} lines");
        }
        Err(DatasetError::Parse {
            file,
            line,
            column,
            message,
        }) => {
            assert_eq!(file, FILE);
            assert!(
                *line >= 1 && *line <= lines,
                "line {line} of {lines}: {message}"
            );
            if !message.contains("UTF-8") {
                let fields = bytes
                    .split(|&b| b == b'\n')
                    .map(|l| l.iter().filter(|&&b| b == b',').count() + 1)
                    .max()
                    .unwrap_or(1);
                assert!(*column <= fields, "column {column} of {fields}: {message}");
            }
        }
        Err(e) => panic!("a track error without line and column: {e}"),
    }
}

/// One name per track, each a distinct id of the file.
fn check_named(n: &NamedTracks) {
    assert_eq!(n.names.len(), n.tracks.len());
    let mut seen = HashSet::new();
    for ((id, name), t) in n.names.iter().zip(&n.tracks) {
        assert_eq!(*id, t.id);
        assert!(!name.is_empty() && name.trim() == name && !name.contains(','));
        assert!(seen.insert(name), "agent {name} twice");
    }
}
