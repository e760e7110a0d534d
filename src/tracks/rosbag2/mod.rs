//! rosbag2 recordings: the tracks of a robot's people tracker, read from the MCAP files
//! `ros2 bag record` writes (zstd-compressed chunks or none): one file, or a bag's
//! folder whose files are read in order as one recording.
//!
//! One topic is read: the one named, or, when none is, the one topic whose type cliff
//! reads. Its messages must be CDR of one of these types (the schema name in the
//! recording says which):
//!
//! - `people_msgs/msg/People` ([`people`]): every person of a message is a row at
//!   the header's stamp, of the track of its `name`; its velocity gives the row's speed
//!   (`|v|`) and motion angle (`atan2(vy, vx)`, 0 standing).
//! - `autoware_perception_msgs/msg/TrackedObjects` ([`tracked_objects`]): the objects
//!   whose most probable class is a pedestrian, each a row at the header's stamp of the
//!   track of its uuid (in hex); speeds and motion angles from the positions.
//!
//! Tracks are numbered from the tracker's ids as a named-column file's agents are
//! ([`columns`](super::columns)): the ids themselves when they are distinct whole numbers,
//! else their trailing numbers, else 1, 2, ... in order of first appearance. A person's
//! times must increase; values are bounded as in every reader ([`super::track`]).
//!
//! Errors name the file, the topic, the message (1-based among the topic's messages)
//! and the field (`people[3].position.x`); a damaged file (a truncated chunk, a bad CRC)
//! is an error naming the file and how far it was read. Costs are bounded: a record is
//! at most [`MAX_RECORD_BYTES`], a length inside a schema or channel record and a length
//! or count in a message are checked against their record's or message's bytes before
//! anything is allocated, records that hold no messages are skipped unread, and memory
//! otherwise grows with the rows read.
//!
//! | file | what it holds |
//! |---|---|
//! | `recording` | the recording's reading: topics, types, rows into tracks; [`MAX_RECORD_BYTES`] |
//! | `mcap_file` | one MCAP file's messages with their channels, every length inside a record checked before it is read |
//! | `cdr` | the CDR reader (little- and big-endian) |
//! | `header` | what the message types share: the header's stamp, points, value checks |
//! | [`people`] | `people_msgs/msg/People` |
//! | [`tracked_objects`] | `autoware_perception_msgs/msg/TrackedObjects` (pedestrians) |

mod cdr;
mod header;
mod mcap_file;
pub mod people;
mod recording;
pub mod tracked_objects;

use std::io::Read;
use std::path::Path;

pub use recording::MAX_RECORD_BYTES;

use super::track::{DatasetError, Track};

/// The first bytes of every MCAP file.
pub const MCAP_MAGIC: &[u8] = mcap::MAGIC;

/// Whether `bytes` begin as an MCAP file does.
pub fn is_mcap(bytes: &[u8]) -> bool {
    bytes.starts_with(MCAP_MAGIC)
}

/// Whether the file at `path` begins as an MCAP file does (false if it cannot be read).
pub fn is_mcap_file(path: &Path) -> bool {
    let mut head = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok()
        && is_mcap(&head)
}

/// Whether `path` is a rosbag2 recording: an MCAP file, or a bag's folder (holding
/// `.mcap` files).
pub fn is_recording(path: &Path) -> bool {
    if path.is_dir() {
        mcap_files(path).is_ok_and(|f| !f.is_empty())
    } else {
        is_mcap_file(path)
    }
}

/// The `.mcap` files of a bag's folder in recording order (`run_0.mcap`, `run_1.mcap`,
/// ..., `run_10.mcap`: by length, then name).
fn mcap_files(folder: &Path) -> std::io::Result<Vec<std::path::PathBuf>> {
    let mut files: Vec<_> = std::fs::read_dir(folder)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .is_some_and(|x| x.eq_ignore_ascii_case("mcap"))
        })
        .collect();
    files.sort_by_key(|p| {
        let name = p
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        (name.len(), name)
    });
    Ok(files)
}

/// Read the tracks of a rosbag2 MCAP recording: the messages of `topic`, or without
/// one, of the one topic whose type cliff reads (see the [module](self) documentation).
/// `path` is an MCAP file or a bag's folder, whose `.mcap` files (a recording split by
/// size or time) are read in order as one recording.
pub fn read_recording(path: &Path, topic: Option<&str>) -> Result<Vec<Track>, DatasetError> {
    let name = path.display().to_string();
    let io = |file: &str, source| DatasetError::Io {
        file: file.to_string(),
        source,
    };
    let files = if path.is_dir() {
        let files = mcap_files(path).map_err(|e| io(&name, e))?;
        if files.is_empty() {
            return Err(DatasetError::Recording {
                file: name,
                message: "a folder without .mcap files (a rosbag2 recording holds them)".into(),
            });
        }
        files
    } else {
        vec![path.to_path_buf()]
    };
    let mut reading = recording::Reading::default();
    for f in &files {
        let file = f.display().to_string();
        let source = std::fs::File::open(f).map_err(|e| io(&file, e))?;
        reading.read_file(std::io::BufReader::new(source), &file, topic)?;
    }
    reading.finish(&name, topic)
}

/// [`read_recording`] of bytes in memory; `file` names them in errors.
pub fn parse_recording(
    bytes: &[u8],
    file: &str,
    topic: Option<&str>,
) -> Result<Vec<Track>, DatasetError> {
    recording::read_recording(bytes, file, topic)
}
