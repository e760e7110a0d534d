//! Checksummed binary files: a header around a postcard payload, shared by map snapshots
//! (`CLIFFMAP`) and motion models (`CLIFFMOT`).
//!
//! Layout: 8 bytes magic, format version (u32 LE), payload length (u64 LE), CRC-32 of
//! the payload (u32 LE), then the payload. A file whose magic, version, length or
//! checksum does not match is refused whole, before its payload is decoded.

use serde::de::DeserializeOwned;

/// Bytes before the payload.
pub(crate) const HEADER: usize = 8 + 4 + 8 + 4;

/// `body` behind a header of `magic` and `version`.
pub(crate) fn frame(magic: &[u8; 8], version: u32, body: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER + body.len());
    out.extend_from_slice(magic);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(body).to_le_bytes());
    out.extend_from_slice(body);
    out
}

/// The version and the payload of `bytes`, checked against `magic` (`kind` names what
/// it is in the error, "a cliff snapshot"), the versions this build reads, the length
/// and the checksum. The error says what does not match.
pub(crate) fn unframe<'a>(
    bytes: &'a [u8],
    magic: &[u8; 8],
    kind: &str,
    versions: &[u32],
) -> Result<(u32, &'a [u8]), String> {
    if bytes.len() < HEADER {
        return Err(format!(
            "{} bytes is shorter than the {HEADER}-byte header",
            bytes.len()
        ));
    }
    if bytes[..8] != magic[..] {
        return Err(format!("wrong magic number (not {kind})"));
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if !versions.contains(&version) {
        let known: Vec<String> = versions.iter().map(u32::to_string).collect();
        let known = match known.as_slice() {
            [one] => format!("version {one}"),
            [rest @ .., last] => format!("versions {} and {last}", rest.join(", ")),
            [] => "no version".to_string(),
        };
        return Err(format!(
            "format version {version}, this build reads {known}"
        ));
    }
    let len = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes"));
    let crc = u32::from_le_bytes(bytes[20..24].try_into().expect("4 bytes"));
    let body = &bytes[HEADER..];
    if body.len() as u64 != len {
        return Err(format!(
            "payload is {} bytes, header says {len} (truncated or padded)",
            body.len()
        ));
    }
    if crc32fast::hash(body) != crc {
        return Err("checksum mismatch (corrupted)".into());
    }
    Ok((version, body))
}

/// Decode a whole payload: postcard, with nothing left over (`what` names the payload
/// in the error).
pub(crate) fn decode_all<T: DeserializeOwned>(body: &[u8], what: &str) -> Result<T, String> {
    let (value, rest): (T, &[u8]) =
        postcard::take_from_bytes(body).map_err(|e| format!("{what}: {e}"))?;
    if rest.is_empty() {
        Ok(value)
    } else {
        Err(format!("{} trailing bytes after the payload", rest.len()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_round_trips_and_every_damage_is_named() {
        let body = postcard::to_stdvec(&(7u32, 2.5f64)).unwrap();
        let bytes = frame(b"TESTTEST", 3, &body);
        let (v, b) = unframe(&bytes, b"TESTTEST", "a test file", &[2, 3]).unwrap();
        assert_eq!(
            (v, decode_all::<(u32, f64)>(b, "p").unwrap()),
            (3, (7, 2.5))
        );
        let err = |bytes: &[u8]| unframe(bytes, b"TESTTEST", "a test file", &[1, 2]).unwrap_err();
        assert!(err(&bytes[..10]).contains("shorter than the 24-byte header"));
        assert!(err(&frame(b"OTHEROTH", 1, &body)).contains("not a test file"));
        assert!(err(&bytes).contains("format version 3, this build reads versions 1 and 2"));
        let one = unframe(&bytes, b"TESTTEST", "x", &[1]).unwrap_err();
        assert!(one.contains("reads version 1"), "{one}");
        let ok = frame(b"TESTTEST", 1, &body);
        assert!(err(&ok[..ok.len() - 1]).contains("truncated or padded"));
        let mut flipped = ok.clone();
        *flipped.last_mut().unwrap() ^= 1;
        assert!(err(&flipped).contains("checksum mismatch"));
        let mut long = body.clone();
        long.push(0);
        let padded = frame(b"TESTTEST", 1, &long);
        let (_, b) = unframe(&padded, b"TESTTEST", "x", &[1]).unwrap();
        assert!(
            decode_all::<(u32, f64)>(b, "p")
                .unwrap_err()
                .contains("1 trailing bytes")
        );
    }
}
