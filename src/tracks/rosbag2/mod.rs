//! rosbag2 recordings: the tracks of a robot's people tracker, read from the MCAP file
//! `ros2 bag record` writes (zstd-compressed chunks or none).
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
//! at most [`MAX_RECORD_BYTES`], a length or count in a message is checked against the
//! message's bytes before anything is allocated, and memory otherwise grows with the
//! rows read.
//!
//! | file | what it holds |
//! |---|---|
//! | `recording` | the MCAP reading: topics, types, rows into tracks; [`MAX_RECORD_BYTES`] |
//! | `cdr` | the CDR reader (little- and big-endian) |
//! | `header` | what the message types share: the header's stamp, points, value checks |
//! | [`people`] | `people_msgs/msg/People` |
//! | [`tracked_objects`] | `autoware_perception_msgs/msg/TrackedObjects` (pedestrians) |

mod cdr;
mod header;
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

/// Read the tracks of a rosbag2 MCAP recording: the messages of `topic`, or without
/// one, of the one topic whose type cliff reads (see the [module](self) documentation).
pub fn read_recording(path: &Path, topic: Option<&str>) -> Result<Vec<Track>, DatasetError> {
    let file = path.display().to_string();
    let f = std::fs::File::open(path).map_err(|source| DatasetError::Io {
        file: file.clone(),
        source,
    })?;
    recording::read_recording(std::io::BufReader::new(f), &file, topic)
}

/// [`read_recording`] of bytes in memory; `file` names them in errors.
pub fn parse_recording(
    bytes: &[u8],
    file: &str,
    topic: Option<&str>,
) -> Result<Vec<Track>, DatasetError> {
    recording::read_recording(bytes, file, topic)
}
