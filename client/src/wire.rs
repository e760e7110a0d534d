//! The byte encoding of the protocol for transports other than iceoryx2 (zenoh): the
//! same messages as [`crate::protocol`], written field by field in little-endian order,
//! so that a client in any language can speak it. The full table of offsets is in
//! `docs/zenoh-protocol.md`; this module is its one implementation, used by the daemon
//! and by the Rust client.
//!
//! * request = [`RequestHeader`] ([`REQUEST_HEADER_BYTES`]) followed by the rows, each
//!   an [`Observation`] of [`ROW_BYTES`]; the number of rows is the remaining length
//!   divided by [`ROW_BYTES`] (it must divide exactly);
//! * response = [`ResponseHeader`] ([`RESPONSE_HEADER_BYTES`]) followed by the payload,
//!   `u32` words: the `agents x k x steps` points as two `f32` bit patterns (x, y), then
//!   the `agents x k` valid lengths, then (when [`ResponseHeader::flags`] has
//!   [`FLAG_SCORES`](crate::protocol::FLAG_SCORES)) the `agents x k` scores as `f32` bit
//!   patterns. A rejection has no payload.
//! * a request of another protocol version is answered with the first
//!   [`COMMON_RESPONSE_BYTES`] of a response only (the fields every version shares):
//!   status `bad-version`, `limit` and `version` the daemon's version
//!   ([`encode_bad_version`]), which a client of any version can read.
//!
//! Offsets are those of the `#[repr(C)]` structs (no padding anywhere), so on a
//! little-endian host the bytes equal the structs' memory; the encoding never relies on
//! that.
//!
//! ```
//! use cliff_client::protocol::{Observation, RequestHeader};
//! use cliff_client::wire;
//!
//! let mut h = RequestHeader::default();
//! h.set_map_name("demo").unwrap();
//! h.agents = 1;
//! let rows = [Observation::position(0.0, 1.0, 2.0), Observation::position(0.4, 1.5, 2.0)];
//! let mut bytes = Vec::new();
//! wire::encode_request(&h, &rows, &mut bytes);
//! assert_eq!(bytes.len(), wire::REQUEST_HEADER_BYTES + 2 * wire::ROW_BYTES);
//!
//! let mut back = Vec::with_capacity(8);
//! let h2 = wire::decode_request(&bytes, 8, &mut back).unwrap();
//! assert_eq!((h2, &back[..]), (h, &rows[..]));
//! ```

use std::fmt;

use crate::protocol::{
    Field, MAP_NAME_BYTES, Observation, PROTOCOL_VERSION, Rejection, RequestHeader, ResponseHeader,
    Status,
};

/// Bytes of an encoded [`RequestHeader`].
pub const REQUEST_HEADER_BYTES: usize = 184;
/// Bytes of an encoded [`Observation`] row.
pub const ROW_BYTES: usize = 48;
/// Bytes of an encoded [`ResponseHeader`].
pub const RESPONSE_HEADER_BYTES: usize = 56;
/// Bytes of the response fields every protocol version shares (version 1's whole
/// header): what a `bad-version` answer holds.
pub const COMMON_RESPONSE_BYTES: usize = 48;

/// Why a byte message is not a well-formed request or response.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WireError {
    /// Shorter than the fixed header.
    TooShort {
        /// Bytes received.
        len: usize,
        /// Bytes the header needs.
        need: usize,
    },
    /// The protocol version (first 4 bytes) is not [`PROTOCOL_VERSION`]; the rest was
    /// not read (for a response: the other side speaks that version).
    Version {
        /// The version found.
        found: u32,
    },
    /// What follows the header is not a whole number of rows (or payload words).
    Ragged {
        /// Bytes after the header.
        len: usize,
        /// The unit they must be a multiple of.
        unit: usize,
    },
    /// More rows (or payload words) than the receiver accepts.
    TooMany {
        /// How many were sent.
        count: usize,
        /// The most accepted.
        max: usize,
    },
    /// A response's payload does not match the shape in its header.
    Shape {
        /// Words received.
        words: usize,
        /// Words the header's shape needs.
        need: usize,
    },
}

impl fmt::Display for WireError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            WireError::TooShort { len, need } => {
                write!(
                    f,
                    "message of {len} bytes is shorter than its {need}-byte header"
                )
            }
            WireError::Version { found } => {
                write!(f, "protocol version {found}, expected {PROTOCOL_VERSION}")
            }
            WireError::Ragged { len, unit } => write!(
                f,
                "{len} bytes after the header are not a multiple of {unit}"
            ),
            WireError::TooMany { count, max } => {
                write!(f, "{count} rows or words, at most {max} are accepted")
            }
            WireError::Shape { words, need } => {
                write!(
                    f,
                    "payload of {words} words, the header's shape needs {need}"
                )
            }
        }
    }
}

impl std::error::Error for WireError {}

impl WireError {
    /// The rejection a daemon answers a malformed request with: [`Status::BadVersion`]
    /// for another version (`limit`: [`PROTOCOL_VERSION`]; send it with
    /// [`encode_bad_version`]), else [`Status::BadLayout`] (`limit`: the most rows
    /// accepted, for too many rows).
    pub fn rejection(&self) -> Rejection {
        match *self {
            WireError::Version { .. } => {
                Rejection::over(Status::BadVersion, Field::Version, PROTOCOL_VERSION)
            }
            WireError::TooMany { max, .. } => Rejection::over(
                Status::BadLayout,
                Field::None,
                max.min(u32::MAX as usize) as u32,
            ),
            _ => Rejection::new(Status::BadLayout, Field::None),
        }
    }
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_u64(out: &mut Vec<u8>, v: u64) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_f64(out: &mut Vec<u8>, v: f64) {
    out.extend_from_slice(&v.to_bits().to_le_bytes());
}

/// Little-endian reader over a slice whose length was checked by the caller.
struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn array<const N: usize>(&mut self) -> [u8; N] {
        let mut a = [0u8; N];
        a.copy_from_slice(&self.b[self.at..self.at + N]);
        self.at += N;
        a
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.array())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.array())
    }
    fn f64(&mut self) -> f64 {
        f64::from_bits(self.u64())
    }
}

/// Append the encoded request (header, then rows) to `out` after clearing it.
/// `listener_id` is written as zeros: it means nothing outside one host.
pub fn encode_request(h: &RequestHeader, rows: &[Observation], out: &mut Vec<u8>) {
    out.clear();
    out.reserve(REQUEST_HEADER_BYTES + rows.len() * ROW_BYTES);
    put_u32(out, h.version);
    put_u32(out, h.kind);
    put_u64(out, h.request_id);
    put_u64(out, 0);
    put_u64(out, 0);
    out.extend_from_slice(&h.map);
    put_u32(out, h.method);
    put_u32(out, h.heading_rule);
    put_u32(out, h.k);
    put_u32(out, h.agents);
    put_f64(out, h.dt);
    put_f64(out, h.horizon);
    put_f64(out, h.beta);
    put_f64(out, h.radius);
    put_u64(out, h.seed);
    put_f64(out, h.speed_beta);
    put_f64(out, h.coast);
    put_u32(out, h.flags);
    put_u32(out, h.time_mode);
    put_f64(out, h.time);
    for o in rows {
        put_u32(out, o.agent);
        put_u32(out, o.flags);
        put_f64(out, o.t);
        put_f64(out, o.x);
        put_f64(out, o.y);
        put_f64(out, o.speed);
        put_f64(out, o.heading);
    }
}

/// The request id of a request message, read before anything is validated (0 when the
/// message is too short to hold one), so that even a malformed request gets an answer
/// its sender can match.
pub fn peek_request_id(bytes: &[u8]) -> u64 {
    bytes
        .get(8..16)
        .map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")))
        .unwrap_or(0)
}

/// Decode a request: checks the version first, then that the length is the header plus
/// a whole number of rows, at most `max_rows` of them, all before `rows` is touched;
/// `rows` is cleared and filled (it allocates only when its capacity is below the
/// number of rows, so give it `max_rows` once). The values are validated later by
/// [`crate::protocol::decode_request`], exactly as for iceoryx2 requests.
pub fn decode_request(
    bytes: &[u8],
    max_rows: usize,
    rows: &mut Vec<Observation>,
) -> Result<RequestHeader, WireError> {
    if bytes.len() < 4 {
        return Err(WireError::TooShort {
            len: bytes.len(),
            need: REQUEST_HEADER_BYTES,
        });
    }
    let version = u32::from_le_bytes(bytes[..4].try_into().expect("4 bytes"));
    if version != PROTOCOL_VERSION {
        return Err(WireError::Version { found: version });
    }
    if bytes.len() < REQUEST_HEADER_BYTES {
        return Err(WireError::TooShort {
            len: bytes.len(),
            need: REQUEST_HEADER_BYTES,
        });
    }
    let body = bytes.len() - REQUEST_HEADER_BYTES;
    if !body.is_multiple_of(ROW_BYTES) {
        return Err(WireError::Ragged {
            len: body,
            unit: ROW_BYTES,
        });
    }
    let count = body / ROW_BYTES;
    if count > max_rows {
        return Err(WireError::TooMany {
            count,
            max: max_rows,
        });
    }
    let mut r = Reader { b: bytes, at: 0 };
    let mut h = RequestHeader {
        version: r.u32(),
        kind: r.u32(),
        request_id: r.u64(),
        listener_id: [r.u64(), r.u64()],
        map: r.array::<MAP_NAME_BYTES>(),
        method: r.u32(),
        heading_rule: r.u32(),
        k: r.u32(),
        agents: r.u32(),
        dt: r.f64(),
        horizon: r.f64(),
        beta: r.f64(),
        radius: r.f64(),
        seed: r.u64(),
        speed_beta: r.f64(),
        coast: r.f64(),
        flags: r.u32(),
        time_mode: r.u32(),
        time: r.f64(),
    };
    // the listener id is an iceoryx2 port id: meaningless from another host
    h.listener_id = [0, 0];
    debug_assert_eq!(r.at, REQUEST_HEADER_BYTES);
    rows.clear();
    for _ in 0..count {
        rows.push(Observation {
            agent: r.u32(),
            flags: r.u32(),
            t: r.f64(),
            x: r.f64(),
            y: r.f64(),
            speed: r.f64(),
            heading: r.f64(),
        });
    }
    Ok(h)
}

/// The response fields every protocol version shares, in version 1's layout.
fn put_common(out: &mut Vec<u8>, h: &ResponseHeader) {
    put_u32(out, h.version);
    put_u32(out, h.status);
    put_u64(out, h.request_id);
    for v in [
        h.agents, h.k, h.steps, h.agent, h.row, h.field, h.limit, h.awake_us,
    ] {
        put_u32(out, v);
    }
}

/// Append the encoded response (header, then payload words) to `out` after clearing it.
pub fn encode_response(h: &ResponseHeader, payload: &[u32], out: &mut Vec<u8>) {
    out.clear();
    out.reserve(RESPONSE_HEADER_BYTES + payload.len() * 4);
    put_common(out, h);
    put_u32(out, h.flags);
    put_u32(out, h.map_version);
    for &w in payload {
        put_u32(out, w);
    }
}

/// The answer to a request of another protocol version, in the layout every version
/// reads ([`COMMON_RESPONSE_BYTES`]): status `bad-version` for the version field, the
/// daemon's [`PROTOCOL_VERSION`] as `version` and `limit`, the request's id.
pub fn encode_bad_version(request_id: u64, out: &mut Vec<u8>) {
    let mut h = ResponseHeader {
        version: PROTOCOL_VERSION,
        request_id,
        ..ResponseHeader::default()
    };
    WireError::Version { found: 0 }.rejection().write_to(&mut h);
    out.clear();
    put_common(out, &h);
}

/// Decode a response: the version first (another one is [`WireError::Version`]: the
/// daemon speaks it, and nothing else is read), then the header, then the payload words
/// into `payload` (cleared). The number of words must be the one the header's shape
/// and flags need (none for a rejection) and at most `max_words`. A rejection of
/// [`COMMON_RESPONSE_BYTES`] (as [`encode_bad_version`] writes it) is read as well.
pub fn decode_response(
    bytes: &[u8],
    max_words: usize,
    payload: &mut Vec<u32>,
) -> Result<ResponseHeader, WireError> {
    if bytes.len() < 4 {
        return Err(WireError::TooShort {
            len: bytes.len(),
            need: RESPONSE_HEADER_BYTES,
        });
    }
    let version = u32::from_le_bytes(bytes[..4].try_into().expect("4 bytes"));
    if version != PROTOCOL_VERSION {
        return Err(WireError::Version { found: version });
    }
    let mut r = Reader { b: bytes, at: 0 };
    let read_common = |r: &mut Reader<'_>| ResponseHeader {
        version: r.u32(),
        status: r.u32(),
        request_id: r.u64(),
        agents: r.u32(),
        k: r.u32(),
        steps: r.u32(),
        agent: r.u32(),
        row: r.u32(),
        field: r.u32(),
        limit: r.u32(),
        awake_us: r.u32(),
        flags: 0,
        map_version: 0,
    };
    if bytes.len() == COMMON_RESPONSE_BYTES {
        // a rejection in the layout every version reads (what a request of another
        // version gets, [`encode_bad_version`])
        let h = read_common(&mut r);
        if h.status != Status::Ok.code() {
            payload.clear();
            return Ok(h);
        }
    }
    if bytes.len() < RESPONSE_HEADER_BYTES {
        return Err(WireError::TooShort {
            len: bytes.len(),
            need: RESPONSE_HEADER_BYTES,
        });
    }
    let body = bytes.len() - RESPONSE_HEADER_BYTES;
    if !body.is_multiple_of(4) {
        return Err(WireError::Ragged { len: body, unit: 4 });
    }
    let words = body / 4;
    if words > max_words {
        return Err(WireError::TooMany {
            count: words,
            max: max_words,
        });
    }
    let mut r = Reader { b: bytes, at: 0 };
    let mut h = read_common(&mut r);
    h.flags = r.u32();
    h.map_version = r.u32();
    // a hostile header's shape saturates to usize::MAX (checked arithmetic), which no
    // payload matches
    let need = if h.status == Status::Ok.code() {
        h.payload_words()
    } else {
        0
    };
    if words != need {
        return Err(WireError::Shape { words, need });
    }
    payload.clear();
    payload.extend(
        bytes[RESPONSE_HEADER_BYTES..]
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes"))),
    );
    Ok(h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::{FLAG_VELOCITY, KIND_RELOAD, payload_words};

    fn header() -> RequestHeader {
        let mut h = RequestHeader {
            kind: KIND_RELOAD,
            request_id: 0x0102_0304_0506_0708,
            listener_id: [9, 10],
            method: 1,
            heading_rule: 1,
            k: 7,
            agents: 2,
            dt: 0.25,
            horizon: -3.5,
            beta: f64::NAN,
            radius: 1e-300,
            seed: u64::MAX - 5,
            speed_beta: 2.5,
            coast: f64::from_bits(0x7ff8_0000_0000_0001), // a NaN payload travels too
            flags: 0x8000_0001,
            time_mode: 1,
            time: 1_351_700_000.25,
            ..RequestHeader::default()
        };
        h.set_map_name("thor1").unwrap();
        h
    }

    #[test]
    fn the_wire_sizes_are_those_of_the_repr_c_structs() {
        assert_eq!(std::mem::size_of::<RequestHeader>(), REQUEST_HEADER_BYTES);
        assert_eq!(std::mem::size_of::<Observation>(), ROW_BYTES);
        assert_eq!(std::mem::size_of::<ResponseHeader>(), RESPONSE_HEADER_BYTES);
    }

    #[test]
    fn requests_round_trip_bit_for_bit_at_the_documented_offsets() {
        let h = header();
        let rows = [
            Observation {
                agent: 0,
                ..Observation::position(1.0, -2.0, 3.0)
            },
            Observation {
                agent: 1,
                ..Observation::with_velocity(4.0, 5.0, 6.0, 0.5, -1.25)
            },
        ];
        let mut b = Vec::new();
        encode_request(&h, &rows, &mut b);
        assert_eq!(b.len(), 184 + 2 * 48);
        // offsets from docs/zenoh-protocol.md
        assert_eq!(&b[0..4], &2u32.to_le_bytes());
        assert_eq!(&b[4..8], &KIND_RELOAD.to_le_bytes());
        assert_eq!(&b[8..16], &0x0102_0304_0506_0708u64.to_le_bytes());
        assert_eq!(&b[16..32], &[0u8; 16]); // the listener id is not sent
        assert_eq!(&b[32..37], b"thor1");
        assert_eq!(b[37], 0);
        assert_eq!(&b[104..108], &7u32.to_le_bytes());
        assert_eq!(&b[108..112], &2u32.to_le_bytes());
        assert_eq!(&b[112..120], &0.25f64.to_le_bytes());
        assert_eq!(&b[144..152], &(u64::MAX - 5).to_le_bytes());
        assert_eq!(&b[152..160], &2.5f64.to_le_bytes());
        assert_eq!(&b[160..168], &0x7ff8_0000_0000_0001u64.to_le_bytes());
        assert_eq!(&b[168..172], &0x8000_0001u32.to_le_bytes());
        assert_eq!(&b[172..176], &1u32.to_le_bytes());
        assert_eq!(&b[176..184], &1_351_700_000.25f64.to_le_bytes());
        assert_eq!(&b[184 + 48..184 + 52], &1u32.to_le_bytes()); // row 1 agent
        assert_eq!(&b[184 + 52..184 + 56], &FLAG_VELOCITY.to_le_bytes());
        assert_eq!(&b[184 + 88..184 + 96], &(-1.25f64).to_le_bytes()); // row 1 heading
        let mut back = Vec::new();
        let d = decode_request(&b, 2, &mut back).unwrap();
        assert_eq!(d.listener_id, [0, 0]);
        assert_eq!(d.beta.to_bits(), h.beta.to_bits());
        assert_eq!(d.coast.to_bits(), h.coast.to_bits());
        let same = RequestHeader {
            listener_id: [0, 0],
            beta: 0.0,
            coast: 0.0,
            ..h
        };
        assert_eq!(
            RequestHeader {
                beta: 0.0,
                coast: 0.0,
                ..d
            },
            same
        );
        assert_eq!(back, rows);
    }

    #[test]
    fn malformed_requests_are_refused_before_any_row_is_read() {
        let h = header();
        let mut b = Vec::new();
        encode_request(&h, &[Observation::default(); 3], &mut b);
        let mut rows = Vec::new();
        assert_eq!(
            decode_request(&b[..2], 8, &mut rows),
            Err(WireError::TooShort { len: 2, need: 184 })
        );
        assert_eq!(
            decode_request(&b[..152], 8, &mut rows),
            Err(WireError::TooShort {
                len: 152,
                need: 184
            })
        );
        assert_eq!(
            decode_request(&b[..b.len() - 1], 8, &mut rows),
            Err(WireError::Ragged {
                len: 3 * 48 - 1,
                unit: 48
            })
        );
        let e = decode_request(&b, 2, &mut rows).unwrap_err();
        assert_eq!(e, WireError::TooMany { count: 3, max: 2 });
        assert!(
            rows.capacity() == 0,
            "nothing allocated for a refused request"
        );
        let r = e.rejection();
        assert_eq!((r.status, r.limit), (Status::BadLayout, 2));
        let mut v = b.clone();
        v[0] = 3;
        let e = decode_request(&v[..20], 8, &mut rows).unwrap_err();
        assert_eq!(e, WireError::Version { found: 3 });
        let r = e.rejection();
        assert_eq!((r.status, r.limit), (Status::BadVersion, PROTOCOL_VERSION));
        assert_eq!(peek_request_id(&v), h.request_id);
        assert_eq!(peek_request_id(&v[..15]), 0);
    }

    /// A version 1 request, encoded as version 1 did (its 152-byte header), gets the
    /// answer version 1's decoder reads: 48 bytes, bad-version, the daemon's version.
    #[test]
    fn a_version_1_request_gets_a_bad_version_answer_version_1_can_read() {
        let v1 = crate::legacy::RequestHeader {
            request_id: 0x0a0b_0c0d,
            agents: 1,
            ..Default::default()
        };
        let mut b = Vec::new();
        put_u32(&mut b, v1.version);
        put_u32(&mut b, v1.kind);
        put_u64(&mut b, v1.request_id);
        b.resize(152, 0);
        b.resize(152 + 2 * 48, 0); // two rows
        let mut rows = Vec::new();
        let e = decode_request(&b, 8, &mut rows).unwrap_err();
        assert_eq!(e, WireError::Version { found: 1 });
        let mut reply = Vec::new();
        encode_bad_version(peek_request_id(&b), &mut reply);
        assert_eq!(reply.len(), COMMON_RESPONSE_BYTES);
        // version 1's reading: version, status, request id, then 8 u32 words
        let u32_at = |i: usize| u32::from_le_bytes(reply[i..i + 4].try_into().unwrap());
        assert_eq!(u32_at(0), PROTOCOL_VERSION);
        assert_eq!(u32_at(4), Status::BadVersion.code());
        assert_eq!(&reply[8..16], &0x0a0b_0c0du64.to_le_bytes());
        assert_eq!((u32_at(16), u32_at(20), u32_at(24)), (0, 0, 0)); // no batch
        assert_eq!(u32_at(36), Field::Version as u32);
        assert_eq!(u32_at(40), PROTOCOL_VERSION); // limit
        // this version reads it as the rejection it is
        let mut payload = vec![7];
        let h = decode_response(&reply, 8, &mut payload).unwrap();
        assert!(payload.is_empty());
        let r = Rejection::from_header(&h).unwrap();
        assert_eq!(
            (r.status, r.field, r.limit, h.request_id),
            (
                Status::BadVersion,
                Field::Version,
                PROTOCOL_VERSION,
                0x0a0b_0c0d
            )
        );
        // but 48 bytes that claim a batch are too short
        let mut ok = reply.clone();
        ok[4..8].copy_from_slice(&0u32.to_le_bytes());
        assert_eq!(
            decode_response(&ok, 8, &mut payload),
            Err(WireError::TooShort { len: 48, need: 56 })
        );
        // and a daemon of another version is named by its version
        let mut payload = Vec::new();
        let mut old = reply.clone();
        old[0..4].copy_from_slice(&1u32.to_le_bytes());
        assert_eq!(
            decode_response(&old, 8, &mut payload),
            Err(WireError::Version { found: 1 })
        );
    }

    #[test]
    fn responses_round_trip_and_their_shape_is_checked() {
        let h = ResponseHeader {
            version: PROTOCOL_VERSION,
            status: 0,
            request_id: 77,
            agents: 2,
            k: 3,
            steps: 4,
            agent: u32::MAX,
            row: u32::MAX,
            field: 0,
            limit: 0,
            awake_us: 5,
            flags: 0,
            map_version: 0,
        };
        let words = payload_words(2, 3, 4, false);
        let payload: Vec<u32> = (0..words as u32)
            .map(|i| i.wrapping_mul(2654435761))
            .collect();
        let mut b = Vec::new();
        encode_response(&h, &payload, &mut b);
        assert_eq!(b.len(), 56 + words * 4);
        assert_eq!(&b[8..16], &77u64.to_le_bytes());
        assert_eq!(&b[44..48], &5u32.to_le_bytes());
        assert_eq!(&b[48..56], &[0u8; 8]);
        assert_eq!(&b[56..60], &payload[0].to_le_bytes());
        let mut back = Vec::new();
        assert_eq!(decode_response(&b, words, &mut back), Ok(h));
        assert_eq!(back, payload);
        assert_eq!(
            decode_response(&b, words - 1, &mut back),
            Err(WireError::TooMany {
                count: words,
                max: words - 1
            })
        );
        // one word short, a ragged tail, and a payload on a rejection
        assert_eq!(
            decode_response(&b[..b.len() - 4], words, &mut back),
            Err(WireError::Shape {
                words: words - 1,
                need: words
            })
        );
        assert!(matches!(
            decode_response(&b[..b.len() - 1], words, &mut back),
            Err(WireError::Ragged { .. })
        ));
        let rej = ResponseHeader {
            status: Status::BadK.code(),
            agents: 0,
            k: 0,
            steps: 0,
            ..h
        };
        encode_response(&rej, &[1], &mut b);
        assert_eq!(
            decode_response(&b, words, &mut back),
            Err(WireError::Shape { words: 1, need: 0 })
        );
        // a hostile shape does not overflow
        let huge = ResponseHeader {
            agents: u32::MAX,
            k: u32::MAX,
            steps: u32::MAX,
            ..h
        };
        encode_response(&huge, &[], &mut b);
        assert!(matches!(
            decode_response(&b, words, &mut back),
            Err(WireError::Shape { words: 0, .. })
        ));
        let huge = ResponseHeader {
            flags: crate::protocol::FLAG_SCORES,
            ..huge
        };
        encode_response(&huge, &[], &mut b);
        assert!(matches!(
            decode_response(&b, words, &mut back),
            Err(WireError::Shape { words: 0, .. })
        ));
    }

    #[test]
    fn scores_follow_the_lengths_when_the_flag_says_so() {
        let h = ResponseHeader {
            version: PROTOCOL_VERSION,
            request_id: 5,
            agents: 2,
            k: 3,
            steps: 4,
            flags: crate::protocol::FLAG_SCORES,
            ..ResponseHeader::default()
        };
        let words = payload_words(2, 3, 4, true);
        assert_eq!(words, 2 * 3 * 4 * 2 + 2 * 3 + 2 * 3);
        assert_eq!(h.payload_words(), words);
        let mut payload: Vec<u32> = (0..words as u32).collect();
        // the scores: the last agents x k words, f32 bit patterns
        for (i, w) in payload[words - 6..].iter_mut().enumerate() {
            *w = (-(i as f32) - 0.5).to_bits();
        }
        let mut b = Vec::new();
        encode_response(&h, &payload, &mut b);
        assert_eq!(&b[48..52], &1u32.to_le_bytes()); // flags
        assert_eq!(b.len(), 56 + 4 * words);
        let mut back = Vec::new();
        assert_eq!(decode_response(&b, words, &mut back), Ok(h));
        assert_eq!(back, payload);
        assert_eq!(f32::from_bits(back[words - 1]), -5.5);
        // without the scores the payload is 6 words too long for the header
        let plain = ResponseHeader { flags: 0, ..h };
        encode_response(&plain, &payload, &mut b);
        assert_eq!(
            decode_response(&b, words, &mut back),
            Err(WireError::Shape {
                words,
                need: words - 6
            })
        );
    }
}
