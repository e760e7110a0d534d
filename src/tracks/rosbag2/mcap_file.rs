//! The messages of one MCAP file with their channels ([`for_each_message`]), read
//! record by record with the `mcap` crate's linear reader. Only the records that carry
//! messages are parsed (schemas, channels, messages); each length-prefixed string, byte
//! string and map inside a schema or channel is checked against its record's bytes
//! before the crate reads it (the crate reserves a string's claimed length, up to 4 GiB,
//! before reading it), and the other records (indexes, attachments, metadata,
//! statistics) are skipped unread, as is everything after the data section's end
//! (which the reader still reads through to check the file's end).

use std::collections::HashMap;
use std::io::{ErrorKind, Read};

use mcap::records::{Record, op};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

/// A channel of the file: its topic, message encoding and schema name (`None`: the
/// channel has no schema).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Channel {
    pub id: u16,
    pub topic: String,
    pub message_encoding: String,
    pub schema: Option<String>,
}

/// Why a file could not be read: the message for the error naming the file, and the
/// messages read before it.
#[derive(Debug)]
pub(crate) struct ReadError<E> {
    pub cause: Cause<E>,
    pub messages: usize,
}

/// What stopped the reading.
#[derive(Debug)]
pub(crate) enum Cause<E> {
    /// The file is not a readable MCAP file (the text says why).
    File(String),
    /// The caller's function failed on a message.
    Message(E),
}

/// Call `f` with each message of the MCAP file `source` in file order, with its channel
/// and its bytes, until the end of the data section or the first error. `options` are
/// the linear reader's (its record length limit bounds every record and chunk).
pub(crate) fn for_each_message<E>(
    mut source: impl Read,
    options: LinearReaderOptions,
    mut f: impl FnMut(&Channel, &[u8]) -> Result<(), E>,
) -> Result<(), ReadError<E>> {
    let mut reader = LinearReader::new_with_options(options.with_emit_chunks(false));
    let mut schemas: HashMap<u16, String> = HashMap::new();
    let mut channels: HashMap<u16, Channel> = HashMap::new();
    let mut messages = 0;
    let mut past_data_end = false;
    let fail = |messages: usize, text: String| ReadError {
        cause: Cause::File(text),
        messages,
    };
    while let Some(event) = reader.next_event() {
        let event = event.map_err(|e| fail(messages, e.to_string()))?;
        let (opcode, data) = match event {
            LinearReadEvent::ReadRequest(need) => {
                let got = loop {
                    match source.read(reader.insert(need)) {
                        Ok(n) => break n,
                        Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                        Err(e) => return Err(fail(messages, e.to_string())),
                    }
                };
                reader.notify_read(got);
                continue;
            }
            LinearReadEvent::Record { opcode, data } => (opcode, data),
        };
        match opcode {
            // the summary after the data repeats schemas and channels: read on (the
            // reader checks the file's end) without looking at them
            op::DATA_END => {
                past_data_end = true;
                continue;
            }
            _ if past_data_end => continue,
            op::SCHEMA | op::CHANNEL => {
                check_lengths(opcode, data).map_err(|e| fail(messages, e))?;
            }
            op::MESSAGE => {}
            _ => continue,
        }
        let record = mcap::parse_record(opcode, data).map_err(|e| fail(messages, e.to_string()))?;
        match record {
            Record::Schema { header, .. } => {
                if header.id == 0 {
                    return Err(fail(messages, "a schema with id 0".into()));
                }
                match schemas.get(&header.id) {
                    Some(name) if *name != header.name => {
                        return Err(fail(
                            messages,
                            format!("schema {} defined twice, differently", header.id),
                        ));
                    }
                    Some(_) => {}
                    None => {
                        schemas.insert(header.id, header.name);
                    }
                }
            }
            Record::Channel(c) => {
                let schema = match c.schema_id {
                    0 => None,
                    id => match schemas.get(&id) {
                        Some(name) => Some(name.clone()),
                        None => {
                            return Err(fail(
                                messages,
                                format!(
                                    "channel {} names schema {id}, not defined before it",
                                    c.id
                                ),
                            ));
                        }
                    },
                };
                let channel = Channel {
                    id: c.id,
                    topic: c.topic,
                    message_encoding: c.message_encoding,
                    schema,
                };
                match channels.get(&c.id) {
                    Some(old) if *old != channel => {
                        return Err(fail(
                            messages,
                            format!("channel {} defined twice, differently", c.id),
                        ));
                    }
                    Some(_) => {}
                    None => {
                        channels.insert(c.id, channel);
                    }
                }
            }
            Record::Message { header, data } => {
                let Some(channel) = channels.get(&header.channel_id) else {
                    return Err(fail(
                        messages,
                        format!(
                            "a message on channel {}, not defined before it",
                            header.channel_id
                        ),
                    ));
                };
                f(channel, &data).map_err(|e| ReadError {
                    cause: Cause::Message(e),
                    messages,
                })?;
                messages += 1;
            }
            _ => {}
        }
    }
    Ok(())
}

/// Check that each length-prefixed field of a schema or channel record fits in the
/// record's bytes `body` (a schema: id, name, encoding, data; a channel: id, schema id,
/// topic, message encoding, metadata map).
fn check_lengths(opcode: u8, body: &[u8]) -> Result<(), String> {
    let what = if opcode == op::SCHEMA {
        "schema"
    } else {
        "channel"
    };
    let mut at = if opcode == op::SCHEMA { 2 } else { 4 };
    let fields: &[&str] = if opcode == op::SCHEMA {
        &["name", "encoding", "data"]
    } else {
        &["topic", "message encoding", "metadata"]
    };
    for (i, field) in fields.iter().enumerate() {
        let end = prefixed(body, at).ok_or_else(|| {
            format!(
                "a {what} record's {field} is longer than the record ({} bytes)",
                body.len()
            )
        })?;
        if opcode == op::CHANNEL && i == 2 {
            // the map's entries: key and value strings within the map's bytes
            let mut entry = at + 4;
            while entry < end {
                for _ in 0..2 {
                    entry = prefixed(&body[..end], entry).ok_or_else(|| {
                        "a channel record's metadata entry is longer than its map".to_string()
                    })?;
                }
            }
        }
        at = end;
    }
    Ok(())
}

/// The end of the field at `at` in `body` that a little-endian u32 length prefixes, or
/// `None` when the prefix or the field runs past `body`.
fn prefixed(body: &[u8], at: usize) -> Option<usize> {
    let len = body.get(at..at.checked_add(4)?)?;
    let len = u32::from_le_bytes(len.try_into().ok()?) as usize;
    let end = (at + 4).checked_add(len)?;
    (end <= body.len()).then_some(end)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A channel record's body: id 1, schema 0, the topic, encoding and metadata given.
    fn channel_body(topic: &[u8], claimed_topic_len: u32, metadata: &[(&str, &str)]) -> Vec<u8> {
        let mut b = vec![1, 0, 0, 0];
        b.extend(claimed_topic_len.to_le_bytes());
        b.extend(topic);
        b.extend(3u32.to_le_bytes());
        b.extend(b"cdr");
        let mut map = Vec::new();
        for (k, v) in metadata {
            for s in [k, v] {
                map.extend((s.len() as u32).to_le_bytes());
                map.extend(s.as_bytes());
            }
        }
        b.extend((map.len() as u32).to_le_bytes());
        b.extend(map);
        b
    }

    #[test]
    fn lengths_past_their_record_are_refused_before_parsing() {
        let good = channel_body(b"/people", 7, &[("a", "b")]);
        assert_eq!(check_lengths(op::CHANNEL, &good), Ok(()));
        assert!(mcap::parse_record(op::CHANNEL, &good).is_ok());
        // a topic that claims 4 GiB in a record of a few bytes
        let huge = channel_body(b"/people", u32::MAX, &[]);
        let e = check_lengths(op::CHANNEL, &huge).unwrap_err();
        assert!(e.contains("topic is longer than the record"), "{e}");
        // a metadata value longer than the map that holds it
        let mut bad_map = channel_body(b"/people", 7, &[("a", "b")]);
        let n = bad_map.len();
        bad_map[n - 5..n - 1].copy_from_slice(&1000u32.to_le_bytes());
        let e = check_lengths(op::CHANNEL, &bad_map).unwrap_err();
        assert!(e.contains("metadata entry"), "{e}");
        // a schema whose data claims more than there is
        let mut schema = vec![1, 0];
        for s in [&b"people_msgs/msg/People"[..], b"ros2msg"] {
            schema.extend((s.len() as u32).to_le_bytes());
            schema.extend(s);
        }
        schema.extend(10u32.to_le_bytes());
        schema.extend(b"short");
        let e = check_lengths(op::SCHEMA, &schema).unwrap_err();
        assert!(e.contains("schema record's data"), "{e}");
        // cut anywhere, a record never passes with a length running past it
        for cut in 0..good.len() {
            assert!(
                check_lengths(op::CHANNEL, &good[..cut]).is_err(),
                "cut at {cut}"
            );
        }
    }
}
