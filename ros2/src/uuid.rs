//! The UUID of a track on `cliff/objects`: a TrackedObjects track keeps its own (its id
//! is the UUID's 32 hex digits), any other track id gets the name-based UUID (version
//! 5, RFC 9562: SHA-1 of [`PEOPLE_NAMESPACE`] and the id's bytes), so that a People
//! track keeps one UUID for as long as the tracker keeps its name. SHA-1 is written
//! here (no allocation, no dependency); it serves as a name hash only.

/// The namespace of the People tracks' UUIDs: itself the version-5 UUID of the URL
/// `urn:cliff-ros2:people` in the URL namespace (`5af8f214-371b-55be-a675-005c5cafff88`).
/// Python: `uuid.uuid5(uuid.uuid5(uuid.NAMESPACE_URL, "urn:cliff-ros2:people"), name)`.
pub const PEOPLE_NAMESPACE: [u8; 16] = [
    0x5a, 0xf8, 0xf2, 0x14, 0x37, 0x1b, 0x55, 0xbe, 0xa6, 0x75, 0x00, 0x5c, 0x5c, 0xaf, 0xff, 0x88,
];

/// The URL namespace of RFC 9562 (`6ba7b811-9dad-11d1-80b4-00c04fd430c8`).
pub const URL_NAMESPACE: [u8; 16] = [
    0x6b, 0xa7, 0xb8, 0x11, 0x9d, 0xad, 0x11, 0xd1, 0x80, 0xb4, 0x00, 0xc0, 0x4f, 0xd4, 0x30, 0xc8,
];

/// The UUID of track `id`: the 16 bytes its 32 lowercase hex digits spell (the ids of
/// TrackedObjects tracks), else [`uuid_v5`] of the id in [`PEOPLE_NAMESPACE`].
pub fn track_uuid(id: &str) -> [u8; 16] {
    parse_hex(id).unwrap_or_else(|| uuid_v5(&PEOPLE_NAMESPACE, id.as_bytes()))
}

/// The 16 bytes of 32 lowercase hex digits (the form [`crate::msg::Uuid::hex`] writes),
/// or `None`.
pub fn parse_hex(id: &str) -> Option<[u8; 16]> {
    let b = id.as_bytes();
    if b.len() != 32 {
        return None;
    }
    let digit = |c: u8| match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'a'..=b'f' => Some(c - b'a' + 10),
        _ => None,
    };
    let mut out = [0u8; 16];
    for (i, o) in out.iter_mut().enumerate() {
        *o = (digit(b[2 * i])? << 4) | digit(b[2 * i + 1])?;
    }
    Some(out)
}

/// The name-based UUID (version 5) of `name` in `namespace`.
pub fn uuid_v5(namespace: &[u8; 16], name: &[u8]) -> [u8; 16] {
    let mut h = Sha1::new();
    h.update(namespace);
    h.update(name);
    let d = h.finish();
    let mut u = [0u8; 16];
    u.copy_from_slice(&d[..16]);
    u[6] = (u[6] & 0x0f) | 0x50;
    u[8] = (u[8] & 0x3f) | 0x80;
    u
}

/// SHA-1 (FIPS 180-4), streaming, on the stack.
pub struct Sha1 {
    state: [u32; 5],
    block: [u8; 64],
    filled: usize,
    length: u64,
}

impl Default for Sha1 {
    fn default() -> Self {
        Self::new()
    }
}

impl Sha1 {
    /// An empty hash.
    pub fn new() -> Self {
        Sha1 {
            state: [
                0x6745_2301,
                0xefcd_ab89,
                0x98ba_dcfe,
                0x1032_5476,
                0xc3d2_e1f0,
            ],
            block: [0; 64],
            filled: 0,
            length: 0,
        }
    }

    /// Hash `data` after what came before.
    pub fn update(&mut self, mut data: &[u8]) {
        self.length = self.length.wrapping_add(data.len() as u64);
        while !data.is_empty() {
            let n = (64 - self.filled).min(data.len());
            self.block[self.filled..self.filled + n].copy_from_slice(&data[..n]);
            self.filled += n;
            data = &data[n..];
            if self.filled == 64 {
                let block = self.block;
                self.compress(&block);
                self.filled = 0;
            }
        }
    }

    /// The 20-byte digest.
    pub fn finish(mut self) -> [u8; 20] {
        let bits = self.length.wrapping_mul(8);
        self.update(&[0x80]);
        while self.filled != 56 {
            self.update(&[0]);
        }
        self.update(&bits.to_be_bytes());
        let mut out = [0u8; 20];
        for (o, s) in out.chunks_exact_mut(4).zip(self.state) {
            o.copy_from_slice(&s.to_be_bytes());
        }
        out
    }

    fn compress(&mut self, block: &[u8; 64]) {
        let mut w = [0u32; 80];
        for (i, c) in block.chunks_exact(4).enumerate() {
            w[i] = u32::from_be_bytes([c[0], c[1], c[2], c[3]]);
        }
        for i in 16..80 {
            w[i] = (w[i - 3] ^ w[i - 8] ^ w[i - 14] ^ w[i - 16]).rotate_left(1);
        }
        let [mut a, mut b, mut c, mut d, mut e] = self.state;
        for (i, wi) in w.iter().enumerate() {
            let (f, k) = match i {
                0..=19 => ((b & c) | (!b & d), 0x5a82_7999),
                20..=39 => (b ^ c ^ d, 0x6ed9_eba1),
                40..=59 => ((b & c) | (b & d) | (c & d), 0x8f1b_bcdc),
                _ => (b ^ c ^ d, 0xca62_c1d6),
            };
            let t = a
                .rotate_left(5)
                .wrapping_add(f)
                .wrapping_add(e)
                .wrapping_add(k)
                .wrapping_add(*wi);
            e = d;
            d = c;
            c = b.rotate_left(30);
            b = a;
            a = t;
        }
        for (s, v) in self.state.iter_mut().zip([a, b, c, d, e]) {
            *s = s.wrapping_add(v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hex(b: &[u8]) -> String {
        b.iter().map(|x| format!("{x:02x}")).collect()
    }

    fn sha1(data: &[u8]) -> String {
        let mut h = Sha1::new();
        h.update(data);
        hex(&h.finish())
    }

    // digests from Python's hashlib (OpenSSL), an implementation independent of ours
    #[test]
    fn sha1_equals_hashlib_across_block_edges() {
        assert_eq!(sha1(b""), "da39a3ee5e6b4b0d3255bfef95601890afd80709");
        assert_eq!(sha1(b"abc"), "a9993e364706816aba3e25717850c26c9cd0d89d");
        assert_eq!(
            sha1(&[b'x'; 55]),
            "cef734ba81a024479e09eb5a75b6ddae62e6abf1"
        );
        assert_eq!(
            sha1(&[b'x'; 56]),
            "901305367c259952f4e7af8323f480d59f81335b"
        );
        assert_eq!(
            sha1(&[b'x'; 64]),
            "bb2fa3ee7afb9f54c6dfb5d021f14b1ffe40c163"
        );
        assert_eq!(
            sha1(&[b'a'; 1000]),
            "291e9a6c66994949b57ba5e650361e98fc36b1ba"
        );
        // fed in pieces: the same digest
        let mut h = Sha1::new();
        for chunk in [b'a'; 1000].chunks(7) {
            h.update(chunk);
        }
        assert_eq!(hex(&h.finish()), "291e9a6c66994949b57ba5e650361e98fc36b1ba");
    }

    // UUIDs from Python's uuid.uuid5
    #[test]
    fn people_uuids_equal_python_uuid5() {
        assert_eq!(
            uuid_v5(&URL_NAMESPACE, b"urn:cliff-ros2:people"),
            PEOPLE_NAMESPACE
        );
        assert_eq!(hex(&track_uuid("3")), "168b870a65fe522f96e23c7cfdbfc0d7");
        assert_eq!(hex(&track_uuid("")), "b2501c5412e05cf6a9708dae46cce263");
        assert_eq!(
            hex(&track_uuid("person_12")),
            "e1cb631cb81c51d09d1b6f0d0c985b93"
        );
    }

    #[test]
    fn tracked_object_ids_keep_their_uuid() {
        let u = track_uuid("00112233445566778899aabbccddeeff");
        assert_eq!(hex(&u), "00112233445566778899aabbccddeeff");
        let m = crate::msg::Uuid {
            uuid: [7, 200, 0, 255, 16, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11],
        };
        assert_eq!(track_uuid(std::str::from_utf8(&m.hex()).unwrap()), m.uuid);
        // not 32 lowercase hex digits: a name
        for id in [
            "00112233445566778899AABBCCDDEEFF",
            "0011223344556677",
            "zz112233445566778899aabbccddeeff",
        ] {
            assert_eq!(parse_hex(id), None, "{id}");
            assert_eq!(track_uuid(id), uuid_v5(&PEOPLE_NAMESPACE, id.as_bytes()));
        }
    }
}
