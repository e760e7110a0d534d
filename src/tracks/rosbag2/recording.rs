//! Reading a rosbag2 recording (an MCAP file) as tracks: the messages of one topic, of
//! a type cliff reads, each decoded into rows of the tracks of its people.

use std::collections::{BTreeMap, HashMap};
use std::io::Read;

use mcap::sans_io::LinearReaderOptions;

use super::header::{FieldError, Seen};
use super::{people, tracked_objects};
use crate::tracks::columns::{heading_of, number_ids, velocities_from_positions};
use crate::tracks::track::MAX_SPEED;
use crate::tracks::track::{DatasetError, Row, Track};

/// Largest MCAP record read (64 MiB): a damaged length field is refused rather than
/// allocated; chunks stream through in pieces of at most this size.
pub const MAX_RECORD_BYTES: usize = 64 << 20;

/// A message type cliff reads: its name in the recording and its decoder (the time of
/// the message; its people appended to the buffer).
struct MessageType {
    name: &'static str,
    decode: for<'a> fn(&'a [u8], &mut Vec<Seen<'a>>) -> Result<f64, FieldError>,
    /// Whether speeds come from the positions rather than the messages' velocities.
    speed_from_positions: bool,
}

/// The message types cliff reads.
const TYPES: &[MessageType] = &[
    MessageType {
        name: people::NAME,
        decode: people::decode,
        speed_from_positions: false,
    },
    MessageType {
        name: tracked_objects::NAME,
        decode: tracked_objects::decode,
        speed_from_positions: true,
    },
];

/// The names of the types cliff reads, for messages: `a, b`.
fn type_names() -> String {
    TYPES.iter().map(|t| t.name).collect::<Vec<_>>().join(", ")
}

/// The tracks of one topic as its messages come.
struct TopicTracks {
    kind: &'static MessageType,
    /// Messages read so far.
    messages: u64,
    tracks: Vec<Track>,
    names: Vec<String>,
    index: HashMap<String, usize>,
}

impl TopicTracks {
    fn new(kind: &'static MessageType) -> Self {
        Self {
            kind,
            messages: 0,
            tracks: Vec::new(),
            names: Vec::new(),
            index: HashMap::new(),
        }
    }

    /// Decode one message (the topic's next) into rows.
    fn add(&mut self, data: &[u8]) -> Result<(), FieldError> {
        self.messages += 1;
        let mut buf = Vec::new();
        let t = (self.kind.decode)(data, &mut buf)?;
        for (i, p) in buf.iter().enumerate() {
            let k = match self.index.get(p.id.as_ref()) {
                Some(&k) => k,
                None => {
                    self.index.insert(p.id.to_string(), self.tracks.len());
                    self.names.push(p.id.to_string());
                    self.tracks.push(Track {
                        id: 0,
                        rows: Vec::new(),
                    });
                    self.tracks.len() - 1
                }
            };
            let rows = &mut self.tracks[k].rows;
            if let Some(prev) = rows.last()
                && t <= prev.t
            {
                return Err(FieldError::new(
                    "header.stamp",
                    format!(
                        "time {t} of person {:?} (person {i} of the message) is not after its previous row's ({})",
                        p.id, prev.t
                    ),
                ));
            }
            rows.push(Row {
                t,
                position: p.position,
                speed: p.velocity.length(),
                angle: heading_of(p.velocity),
            });
        }
        Ok(())
    }

    /// The tracks, numbered from the tracker's ids as a named-column file's are (and
    /// their speeds from the positions if the type has no velocity); an error names the
    /// person and the two rows of a speed beyond [`MAX_SPEED`].
    fn finish(mut self) -> Result<Vec<Track>, String> {
        for ((t, id), name) in self
            .tracks
            .iter_mut()
            .zip(number_ids(&self.names))
            .zip(&self.names)
        {
            t.id = id;
            if self.kind.speed_from_positions
                && let Err((a, b, speed)) = velocities_from_positions(&mut t.rows)
            {
                return Err(format!(
                    "person {name:?}: its positions at {} s and {} s give a speed of {speed:?} m/s, beyond {MAX_SPEED}",
                    t.rows[a].t, t.rows[b].t
                ));
            }
        }
        Ok(self.tracks)
    }
}

/// What a channel's messages are to this read.
enum Use {
    /// Decoded into the tracks of this topic.
    Decode(String),
    /// Not read (another topic, or a type cliff does not read when no topic was asked for).
    Skip,
}

/// Read the recording from `source`; `file` names it in errors. With `topic`, that
/// topic's messages (an error if it is missing or of another type); without, the one
/// topic of a type cliff reads.
pub(crate) fn read_recording(
    source: impl Read,
    file: &str,
    topic: Option<&str>,
) -> Result<Vec<Track>, DatasetError> {
    let recording = |message: String| DatasetError::Recording {
        file: file.to_string(),
        message,
    };
    let options = LinearReaderOptions::default()
        .with_record_length_limit(MAX_RECORD_BYTES)
        .with_validate_chunk_crcs(true);
    let reader = mcap::io::MessageReader::new_with_options(source, options);
    // every topic seen, with its type (for the error when the topic asked for is missing)
    let mut topics: BTreeMap<String, String> = BTreeMap::new();
    let mut channels: HashMap<u16, Use> = HashMap::new();
    let mut decoded: BTreeMap<String, TopicTracks> = BTreeMap::new();
    let mut total = 0u64;
    for message in reader {
        let message = message.map_err(|e| {
            recording(format!(
                "not a readable rosbag2 MCAP recording: {e} (after {total} messages)"
            ))
        })?;
        total += 1;
        let ch = &message.channel;
        let usage = match channels.get(&ch.id) {
            Some(u) => u,
            None => {
                let type_name = ch.schema.as_ref().map(|s| s.name.clone());
                topics.insert(
                    ch.topic.clone(),
                    type_name.clone().unwrap_or_else(|| "no schema".into()),
                );
                let kind = type_name
                    .as_deref()
                    .and_then(|n| TYPES.iter().find(|t| t.name == n));
                let wanted = topic.is_none_or(|t| t == ch.topic);
                let usage = match kind {
                    Some(kind) if wanted && ch.message_encoding == "cdr" => {
                        decoded
                            .entry(ch.topic.clone())
                            .or_insert_with(|| TopicTracks::new(kind));
                        Use::Decode(ch.topic.clone())
                    }
                    Some(_) if wanted && topic.is_some() => {
                        return Err(recording(format!(
                            "topic {} holds {} messages, not cdr",
                            ch.topic, ch.message_encoding
                        )));
                    }
                    None if topic == Some(ch.topic.as_str()) => {
                        return Err(recording(format!(
                            "topic {} carries {}, not a type cliff reads ({})",
                            ch.topic,
                            type_name.as_deref().unwrap_or("messages without a schema"),
                            type_names()
                        )));
                    }
                    _ => Use::Skip,
                };
                channels.entry(ch.id).or_insert(usage)
            }
        };
        let Use::Decode(name) = usage else {
            continue;
        };
        let tracks = decoded.get_mut(name).expect("registered with its channel");
        if tracks.kind.name != ch.schema.as_ref().map_or("", |s| s.name.as_str()) {
            return Err(recording(format!(
                "topic {name} carries two types: {} and {}",
                tracks.kind.name,
                ch.schema.as_ref().map_or("no schema", |s| s.name.as_str())
            )));
        }
        tracks
            .add(&message.data)
            .map_err(|e| DatasetError::Message {
                file: file.to_string(),
                topic: name.clone(),
                index: tracks.messages,
                field: e.field,
                message: e.message,
            })?;
    }
    let listing = || {
        if topics.is_empty() {
            "it holds no messages".to_string()
        } else {
            let list: Vec<String> = topics.iter().map(|(t, ty)| format!("{t} ({ty})")).collect();
            format!("its topics: {}", list.join(", "))
        }
    };
    let finish = |topic: &str, tracks: TopicTracks| {
        tracks
            .finish()
            .map_err(|e| recording(format!("topic {topic}: {e}")))
    };
    match topic {
        Some(t) => match decoded.remove(t) {
            Some(tracks) => finish(t, tracks),
            None => Err(recording(format!("no messages on topic {t}; {}", listing()))),
        },
        None => {
            let mut all = decoded.into_iter();
            match (all.next(), all.next()) {
                (Some((t, tracks)), None) => finish(&t, tracks),
                (None, _) => Err(recording(format!(
                    "no topic of a type cliff reads ({}); {}",
                    type_names(),
                    listing()
                ))),
                (Some((a, _)), Some((b, _))) => Err(recording(format!(
                    "several topics hold people ({a}, {b}{}): name the one to read",
                    if all.next().is_some() { ", ..." } else { "" }
                ))),
            }
        }
    }
}
