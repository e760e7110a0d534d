//! The track: [`Row`]s of one person in time order, the bounds every reader holds its
//! values to, and the error a reader gives with its place in the file.

use glam::DVec2;

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
    /// A bad message in a recording (a rosbag2 bag): the topic, the message's place
    /// among the topic's messages (1-based, in file order) and the field.
    #[error("{file}: topic {topic}, message {index}: {field}: {message}")]
    Message {
        /// The file.
        file: String,
        /// The topic.
        topic: String,
        /// The message's place among the topic's messages, from 1.
        index: u64,
        /// The field, as a path into the message (`people[2].position.x`).
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A recording that cannot be read as tracks: not MCAP, damaged, or without the
    /// topic asked for (the message lists the topics there are).
    #[error("{file}: {message}")]
    Recording {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A file whose format is not recognised from its start ([`Format::detect`]): it
    /// could be none of the formats, or several of them (`choices`).
    ///
    /// [`Format::detect`]: super::Format::detect
    #[error(
        "{file}: the format is not recognised: {reason}; name it: {}",
        super::Format::list(choices)
    )]
    Unrecognised {
        /// The file.
        file: String,
        /// Why it is not recognised.
        reason: String,
        /// The formats it could be read as.
        choices: Vec<super::Format>,
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

/// Largest trajectory file read, in bytes (1 GiB).
pub const MAX_TRACK_FILE_BYTES: u64 = 1 << 30;
/// Largest |time| (s) of a row: 1e11 s covers unix times for the next three millennia.
pub const MAX_TIME: f64 = 1e11;
/// Largest |x| and |y| (m) of a row, and of a map's coordinates
/// (`cliff::map::MAX_COORDINATE` is this bound).
pub const MAX_POSITION: f64 = 1e6;
/// Largest speed (m/s) of a row. Tracker glitches of hundreds of m/s occur in real
/// files (THÖR3 has one of 432 m/s) and are read, for the evaluation's filters to judge;
/// this bound only refuses the absurd.
pub const MAX_SPEED: f64 = 1e6;
/// Largest |motion angle| (rad) of a row: the files hold (-pi, pi]; other conventions
/// ([0, 2pi), degrees-free unwrapped angles) stay well within.
pub const MAX_ANGLE: f64 = 1e3;

/// Keep only the rows with `from <= t < until` (times as in the file), and drop the
/// tracks left empty: for building a map from one part of a recording and evaluating on
/// another.
///
/// ```
/// use cliff::tracks::{parse_tracks, keep_time_range, Format};
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
