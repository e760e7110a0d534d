//! Reading a rosbag2 recording (an MCAP file) as tracks: the messages of one topic, of
//! a type cliff reads, each decoded into rows of the tracks of its people.

use std::collections::{BTreeMap, HashMap};
use std::io::Read;

use mcap::sans_io::LinearReaderOptions;

use super::header::{FieldError, Seen};
use super::mcap_file::{Cause, for_each_message};
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
    let mut reading = Reading::default();
    reading.read_file(source, file, topic)?;
    reading.finish(file, topic)
}

/// What has been read of a recording so far, over its files (a bag split into several
/// MCAP files continues the tracks of the one before).
#[derive(Default)]
pub(crate) struct Reading {
    /// Every topic seen, with its type (for the error when the topic asked for is
    /// missing).
    topics: BTreeMap<String, String>,
    decoded: BTreeMap<String, TopicTracks>,
}

impl Reading {
    /// Read one MCAP file of the recording (`file` names it in errors; the messages are
    /// counted from 1 in each file).
    pub(crate) fn read_file(
        &mut self,
        source: impl Read,
        file: &str,
        topic: Option<&str>,
    ) -> Result<(), DatasetError> {
        let recording = |message: String| DatasetError::Recording {
            file: file.to_string(),
            message,
        };
        let options = LinearReaderOptions::default()
            .with_record_length_limit(MAX_RECORD_BYTES)
            .with_validate_chunk_crcs(true);
        let Reading { topics, decoded } = self;
        for t in decoded.values_mut() {
            t.messages = 0;
        }
        let mut channels: HashMap<u16, Use> = HashMap::new();
        let read = for_each_message(source, options, |ch, data| {
            let usage = match channels.get(&ch.id) {
                Some(u) => u,
                None => {
                    let type_name = ch.schema.clone();
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
                return Ok(());
            };
            let tracks = decoded.get_mut(name).expect("registered with its channel");
            if tracks.kind.name != ch.schema.as_deref().unwrap_or("") {
                return Err(recording(format!(
                    "topic {name} carries two types: {} and {}",
                    tracks.kind.name,
                    ch.schema.as_deref().unwrap_or("no schema")
                )));
            }
            tracks.add(data).map_err(|e| DatasetError::Message {
                file: file.to_string(),
                topic: name.clone(),
                index: tracks.messages,
                field: e.field,
                message: e.message,
            })
        });
        read.map_err(|e| match e.cause {
            Cause::File(text) => recording(format!(
                "not a readable rosbag2 MCAP recording: {text} (after {} messages)",
                e.messages
            )),
            Cause::Message(e) => e,
        })
    }

    /// The tracks read; `file` names the recording in errors.
    pub(crate) fn finish(
        self,
        file: &str,
        topic: Option<&str>,
    ) -> Result<Vec<Track>, DatasetError> {
        let recording = |message: String| DatasetError::Recording {
            file: file.to_string(),
            message,
        };
        let Reading {
            topics,
            mut decoded,
        } = self;
        let listing = || {
            if topics.is_empty() {
                "it holds no messages".to_string()
            } else {
                let list: Vec<String> =
                    topics.iter().map(|(t, ty)| format!("{t} ({ty})")).collect();
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
                None => Err(recording(format!(
                    "no messages on topic {t}; {}",
                    listing()
                ))),
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
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::io::Cursor;

    use super::*;

    /// A People message (little-endian): stamp `t` s, the people `(name, x, y, vx, vy)`.
    fn people(t: f64, who: &[(&str, f64, f64, f64, f64)]) -> Vec<u8> {
        let mut b = vec![0u8, 1, 0, 0];
        let pad = |b: &mut Vec<u8>, n: usize| {
            while !(b.len() - 4).is_multiple_of(n) {
                b.push(0);
            }
        };
        b.extend((t.floor() as i32).to_le_bytes());
        b.extend((((t - t.floor()) * 1e9).round() as u32).to_le_bytes());
        b.extend(1u32.to_le_bytes());
        b.push(0); // frame ""
        pad(&mut b, 4);
        b.extend((who.len() as u32).to_le_bytes());
        for (name, x, y, vx, vy) in who {
            pad(&mut b, 4);
            b.extend((name.len() as u32 + 1).to_le_bytes());
            b.extend(name.as_bytes());
            b.push(0);
            pad(&mut b, 8);
            for v in [*x, *y, 0.0, *vx, *vy, 0.0, 1.0] {
                b.extend(v.to_le_bytes());
            }
            b.extend([0u8; 8]); // two empty arrays
        }
        b
    }

    /// How an MCAP file holds its records.
    #[derive(Clone, Copy, PartialEq)]
    enum Layout {
        NoChunks,
        Chunks,
        Zstd,
    }

    /// An MCAP file of `messages` (topic, schema name, CDR bytes).
    fn mcap(messages: &[(&str, &str, Vec<u8>)], layout: Layout) -> Vec<u8> {
        let options = mcap::write::WriteOptions::new()
            .use_chunks(layout != Layout::NoChunks)
            .compression((layout == Layout::Zstd).then_some(mcap::Compression::Zstd));
        let mut w = options.create(Cursor::new(Vec::new())).unwrap();
        let mut channels = BTreeMap::new();
        for (i, (topic, schema, data)) in messages.iter().enumerate() {
            let id = *channels.entry((*topic, *schema)).or_insert_with(|| {
                let s = w.add_schema(schema, "ros2msg", b"").unwrap();
                w.add_channel(s, topic, "cdr", &BTreeMap::new()).unwrap()
            });
            let header = mcap::records::MessageHeader {
                channel_id: id,
                sequence: i as u32,
                log_time: i as u64,
                publish_time: i as u64,
            };
            w.write_to_known_channel(&header, data).unwrap();
        }
        w.finish().unwrap();
        w.into_inner().into_inner()
    }

    fn read(bytes: &[u8], topic: Option<&str>) -> Result<Vec<Track>, String> {
        read_recording(bytes, "r.mcap", topic).map_err(|e| e.to_string())
    }

    #[test]
    fn reads_people_into_tracks_with_speed_and_heading_from_velocity() {
        let msgs = [
            (
                "/people",
                people::NAME,
                people(0.5, &[("7", 1.0, 2.0, 0.0, 1.0), ("9", 0.0, 0.0, 0.0, 0.0)]),
            ),
            ("/scan", "sensor_msgs/msg/LaserScan", vec![1, 2, 3]),
            (
                "/people",
                people::NAME,
                people(0.9, &[("7", 1.0, 2.4, -1.0, 0.0)]),
            ),
        ];
        for layout in [Layout::NoChunks, Layout::Chunks, Layout::Zstd] {
            let bytes = mcap(&msgs, layout);
            let t = read(&bytes, Some("/people")).unwrap();
            assert_eq!(t, read(&bytes, None).unwrap());
            assert_eq!(t.len(), 2);
            assert_eq!((t[0].id, t[0].rows.len(), t[1].id), (7, 2, 9));
            let r = t[0].rows[1];
            assert_eq!((r.t, r.position.y, r.speed), (0.9, 2.4, 1.0));
            assert_eq!(r.angle, std::f64::consts::PI);
            assert_eq!(t[0].rows[0].angle, std::f64::consts::FRAC_PI_2);
            assert_eq!((t[1].rows[0].speed, t[1].rows[0].angle), (0.0, 0.0));
        }
    }

    #[test]
    fn topics_types_and_damage_are_errors_naming_them() {
        let msgs = [
            (
                "/people",
                people::NAME,
                people(0.5, &[("a", 1.0, 2.0, 0.0, 1.0)]),
            ),
            ("/poses", "geometry_msgs/msg/PoseArray", vec![0, 1, 0, 0]),
            (
                "/people",
                people::NAME,
                people(0.1, &[("a", 1.0, 2.0, 0.0, 1.0)]),
            ),
        ];
        let bytes = mcap(&msgs, Layout::Zstd);
        assert_eq!(
            read(&bytes, Some("/poses")).unwrap_err(),
            "r.mcap: topic /poses carries geometry_msgs/msg/PoseArray, not a type cliff reads \
             (people_msgs/msg/People, autoware_perception_msgs/msg/TrackedObjects)"
        );
        assert_eq!(
            read(&bytes, Some("/tracks")).unwrap_err(),
            "r.mcap: no messages on topic /tracks; its topics: \
             /people (people_msgs/msg/People), /poses (geometry_msgs/msg/PoseArray)"
        );
        assert_eq!(
            read(&bytes, None).unwrap_err(),
            "r.mcap: topic /people, message 2: header.stamp: time 0.1 of person \"a\" \
             (person 0 of the message) is not after its previous row's (0.5)"
        );
        // every cut of a good file is an error, never a panic
        let bytes = mcap(&msgs[..2], Layout::Zstd);
        assert_eq!(read(&bytes, None).unwrap().len(), 1);
        for n in (0..bytes.len()).step_by(7) {
            assert!(read(&bytes[..n], None).is_err(), "cut at {n}");
        }
        let e = read(&bytes[..bytes.len() / 2], None).unwrap_err();
        assert!(
            e.starts_with("r.mcap: not a readable rosbag2 MCAP recording: "),
            "{e}"
        );
        // two topics of people: one must be named
        let two = mcap(
            &[
                ("/a", people::NAME, people(0.5, &[])),
                ("/b", people::NAME, people(0.5, &[])),
            ],
            Layout::Chunks,
        );
        assert!(
            read(&two, None)
                .unwrap_err()
                .contains("several topics hold people (/a, /b)")
        );
        assert_eq!(read(&two, Some("/b")).unwrap(), Vec::new());
    }

    #[test]
    fn a_record_length_of_four_billion_is_refused_not_allocated() {
        // a file without chunks: the first record after the magic and the header record
        // is a schema; its length field (8 bytes after its opcode) claims 2^32 bytes
        let mut bytes = mcap(
            &[("/people", people::NAME, people(0.5, &[]))],
            Layout::NoChunks,
        );
        let header_len = u64::from_le_bytes(bytes[9..17].try_into().unwrap()) as usize;
        let at = 8 + 9 + header_len;
        assert_eq!(bytes[at], 0x03, "a schema record");
        bytes[at + 1..at + 9].copy_from_slice(&(1u64 << 32).to_le_bytes());
        let e = read(&bytes, None).unwrap_err();
        assert!(e.contains("length exceeds limit"), "{e}");
        // and inside a chunk: a message record claiming 2^32 bytes
        let msg = people(0.5, &[("a", 1.0, 2.0, 0.0, 1.0)]);
        let plain = mcap(&[("/people", people::NAME, msg.clone())], Layout::Chunks);
        let at = plain
            .windows(msg.len())
            .position(|w| w == msg.as_slice())
            .unwrap();
        // the message record: opcode, length, channel id, sequence, two times, data
        let record = at - (1 + 8 + 2 + 4 + 8 + 8);
        assert_eq!(plain[record], 0x05);
        let mut bad = plain.clone();
        bad[record + 1..record + 9].copy_from_slice(&(1u64 << 32).to_le_bytes());
        let e = read(&bad, None).unwrap_err();
        assert!(e.contains("not a readable rosbag2 MCAP recording"), "{e}");
    }

    #[test]
    fn a_string_claiming_four_gigabytes_inside_a_record_is_refused_not_reserved() {
        // the schema record's name: its u32 length (after opcode, record length and the
        // schema id) claims nearly 4 GiB in a record of a few dozen bytes
        let mut bytes = mcap(
            &[("/people", people::NAME, people(0.5, &[]))],
            Layout::NoChunks,
        );
        let header_len = u64::from_le_bytes(bytes[9..17].try_into().unwrap()) as usize;
        let at = 8 + 9 + header_len;
        assert_eq!(bytes[at], 0x03, "a schema record");
        let name = at + 9 + 2;
        assert_eq!(
            u32::from_le_bytes(bytes[name..name + 4].try_into().unwrap()) as usize,
            people::NAME.len()
        );
        bytes[name..name + 4].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
        let e = read(&bytes, None).unwrap_err();
        assert!(e.contains("name is longer than the record"), "{e}");
        assert!(e.contains("not a readable rosbag2 MCAP recording"), "{e}");
    }
}
