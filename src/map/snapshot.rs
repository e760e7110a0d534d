//! Our binary map snapshot: postcard with a header.
//!
//! Layout: 8 bytes magic `CLIFFMAP`, format version (u32 LE), payload length (u64 LE),
//! CRC-32 of the payload (u32 LE), then the postcard payload. A file whose magic,
//! version, length or checksum does not match is refused whole.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{CliffMap, Location, MAX_MAP_FILE_BYTES, MapError};
use crate::bounded_read::read_at_most;

/// The first eight bytes of every snapshot.
pub const SNAPSHOT_MAGIC: [u8; 8] = *b"CLIFFMAP";
/// The snapshot format version this build writes and reads.
pub const SNAPSHOT_VERSION: u32 = 1;
const HEADER: usize = 8 + 4 + 8 + 4;

#[derive(Serialize, Deserialize)]
struct Payload {
    grid_step: f64,
    locations: Vec<Location>,
}

/// Encode a map as snapshot bytes.
pub fn encode(map: &CliffMap) -> Vec<u8> {
    let payload = Payload {
        grid_step: map.grid().step(),
        locations: map.locations().to_vec(),
    };
    let body = postcard::to_stdvec(&payload).expect("serialising plain data to memory cannot fail");
    let mut out = Vec::with_capacity(HEADER + body.len());
    out.extend_from_slice(&SNAPSHOT_MAGIC);
    out.extend_from_slice(&SNAPSHOT_VERSION.to_le_bytes());
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
    out.extend_from_slice(&body);
    out
}

/// Decode snapshot bytes; `file` names the source in errors.
pub fn decode(bytes: &[u8], file: &str) -> Result<CliffMap, MapError> {
    let bad = |message: String| MapError::Snapshot {
        file: file.to_string(),
        message,
    };
    if bytes.len() < HEADER {
        return Err(bad(format!(
            "{} bytes is shorter than the {HEADER}-byte header",
            bytes.len()
        )));
    }
    if bytes[..8] != SNAPSHOT_MAGIC {
        return Err(bad("wrong magic number (not a cliff snapshot)".into()));
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
    if version != SNAPSHOT_VERSION {
        return Err(bad(format!(
            "format version {version}, this build reads version {SNAPSHOT_VERSION}"
        )));
    }
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap());
    let crc = u32::from_le_bytes(bytes[20..24].try_into().unwrap());
    let body = &bytes[HEADER..];
    if body.len() as u64 != len {
        return Err(bad(format!(
            "payload is {} bytes, header says {len} (truncated or padded)",
            body.len()
        )));
    }
    if crc32fast::hash(body) != crc {
        return Err(bad("checksum mismatch (corrupted)".into()));
    }
    let (payload, rest): (Payload, &[u8]) =
        postcard::take_from_bytes(body).map_err(|e| bad(format!("payload: {e}")))?;
    if !rest.is_empty() {
        return Err(bad(format!(
            "{} trailing bytes after the payload",
            rest.len()
        )));
    }
    CliffMap::with_grid_step(payload.locations, Some(payload.grid_step))
        .map_err(|e| bad(e.to_string()))
}

/// Read a snapshot file (at most [`MAX_MAP_FILE_BYTES`]; see [`read_snapshot_bytes`]).
pub fn read_snapshot(path: &Path) -> Result<CliffMap, MapError> {
    let name = path.display().to_string();
    let bytes = read_at_most(path, MAX_MAP_FILE_BYTES).map_err(|source| MapError::Io {
        file: name.clone(),
        source,
    })?;
    decode(&bytes, &name)
}

/// Read a map from snapshot bytes; `file` names the source in errors.
///
/// The header is checked before the payload is decoded (magic, version, the payload
/// length against the bytes present, the checksum); decoding allocates at most in
/// proportion to the payload (a length prefix is never trusted for an allocation), and
/// the map gets the checks of [`CliffMap::with_grid_step`].
pub fn read_snapshot_bytes(bytes: &[u8], file: &str) -> Result<CliffMap, MapError> {
    decode(bytes, file)
}

/// Write a snapshot file.
pub fn write_snapshot(map: &CliffMap, path: &Path) -> Result<(), MapError> {
    std::fs::write(path, encode(map)).map_err(|source| MapError::Io {
        file: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_exact() {
        let m = CliffMap::demo();
        let back = decode(&encode(&m), "x").unwrap();
        assert_eq!(back.locations(), m.locations());
        assert_eq!(back.grid().step(), m.grid().step());
    }

    /// A snapshot file around `body`, with a correct header.
    fn wrap(body: &[u8]) -> Vec<u8> {
        let mut out = SNAPSHOT_MAGIC.to_vec();
        out.extend_from_slice(&SNAPSHOT_VERSION.to_le_bytes());
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
        out.extend_from_slice(&crc32fast::hash(body).to_le_bytes());
        out.extend_from_slice(body);
        out
    }

    #[test]
    fn refuses_absurd_steps_and_positions() {
        let one = CliffMap::demo().locations()[0].clone();
        let payload = |grid_step: f64, locations: Vec<Location>| {
            postcard::to_stdvec(&Payload {
                grid_step,
                locations,
            })
            .unwrap()
        };
        // The known case: a one-location snapshot with a grid step of 1e300 was accepted.
        let e = decode(&wrap(&payload(1e300, vec![one.clone()])), "s.cliff")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.cliff") && e.contains("grid step 1e300 m is not in [0.001, 1000] m"),
            "{e}"
        );
        assert!(decode(&wrap(&payload(1.0, vec![one.clone()])), "s").is_ok());
        let mut far = one.clone();
        far.position.x = 1e20;
        let e = decode(&wrap(&payload(1.0, vec![one.clone(), far])), "s")
            .unwrap_err()
            .to_string();
        assert!(e.contains("location 1") && e.contains("beyond"), "{e}");
        let mut wide = one;
        wide.components = vec![wide.components[0]; crate::map::MAX_COMPONENTS + 1];
        let e = decode(&wrap(&payload(1.0, vec![wide])), "s")
            .unwrap_err()
            .to_string();
        assert!(e.contains("65 components, at most 64"), "{e}");
    }

    #[test]
    fn huge_length_prefixes_do_not_allocate() {
        // A location list claiming 2^60 entries (and then one claiming 2^32 components):
        // the decoder runs out of bytes long before it could allocate that much.
        let body = postcard::to_stdvec(&(1.0f64, 1u64 << 60)).unwrap();
        let e = decode(&wrap(&body), "s").unwrap_err().to_string();
        assert!(e.contains("payload"), "{e}");
        let mut body = postcard::to_stdvec(&(1.0f64, 1u64, 0.0f64, 0.0f64)).unwrap();
        body.extend(postcard::to_stdvec(&(1u64 << 32)).unwrap());
        let e = decode(&wrap(&body), "s").unwrap_err().to_string();
        assert!(e.contains("payload"), "{e}");
    }

    #[test]
    fn refuses_damaged_files_whole() {
        let bytes = encode(&CliffMap::demo());
        let e = decode(&bytes[..bytes.len() - 3], "f.cliff")
            .unwrap_err()
            .to_string();
        assert!(e.contains("f.cliff") && e.contains("truncated"), "{e}");
        let e = decode(&bytes[..10], "f").unwrap_err().to_string();
        assert!(e.contains("header"), "{e}");
        let mut b = bytes.clone();
        let mid = b.len() / 2;
        b[mid] ^= 0x40;
        assert!(
            decode(&b, "f")
                .unwrap_err()
                .to_string()
                .contains("checksum")
        );
        let mut b = bytes.clone();
        b[0] = b'X';
        assert!(decode(&b, "f").unwrap_err().to_string().contains("magic"));
        let mut b = bytes.clone();
        b[8] = 9;
        assert!(
            decode(&b, "f")
                .unwrap_err()
                .to_string()
                .contains("version 9")
        );
    }
}
