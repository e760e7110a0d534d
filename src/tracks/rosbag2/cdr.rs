//! A reader of CDR, the encoding of ROS 2 messages (OMG CDR as DDS-XTypes version 1
//! calls it, "XCDR1"): a 4-byte encapsulation header (`00 00`: big-endian, `00 01`:
//! little-endian, then two option bytes), then the fields in order, each primitive
//! aligned to its own size counted from the end of the header; a string is a `u32`
//! length (its bytes and a terminating NUL) and the bytes; a sequence is a `u32` count
//! and its elements.
//!
//! Every read checks that the bytes are there, and a length or count is checked against
//! the bytes left before anything is allocated: a count of four billion in a 100-byte
//! message is an error, not a 4 GB allocation.

use std::fmt;

/// What is wrong with a CDR message (the caller adds which field was read).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum CdrError {
    /// Fewer than four bytes: no encapsulation header.
    NoHeader(usize),
    /// An encapsulation this reader does not read (parameter lists, XCDR2).
    Encapsulation([u8; 2]),
    /// A value runs past the end of the message.
    Truncated {
        /// Byte offset of the value (from the start of the message).
        offset: usize,
        /// Its size in bytes.
        size: usize,
        /// The message's size.
        len: usize,
    },
    /// A string or sequence length that the bytes left cannot hold.
    Length {
        /// Byte offset of the length field.
        offset: usize,
        /// The length read.
        count: u32,
        /// Bytes of each element at least.
        element: usize,
        /// Bytes left after the length field.
        left: usize,
    },
    /// A string of length 0 (CDR counts the terminating NUL) or without its NUL.
    Unterminated {
        /// Byte offset of the length field.
        offset: usize,
    },
    /// A string that is not UTF-8.
    NotUtf8 {
        /// Byte offset of the length field.
        offset: usize,
    },
}

impl fmt::Display for CdrError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CdrError::NoHeader(n) => write!(
                f,
                "{n} bytes: too short for the 4-byte CDR encapsulation header"
            ),
            CdrError::Encapsulation(b) => write!(
                f,
                "encapsulation {:02x} {:02x} is not plain CDR (00 00 big-endian or 00 01 little-endian)",
                b[0], b[1]
            ),
            CdrError::Truncated { offset, size, len } => write!(
                f,
                "{size} bytes at byte {offset} run past the end of the message ({len} bytes)"
            ),
            CdrError::Length {
                offset,
                count,
                element,
                left,
            } => write!(
                f,
                "length {count} at byte {offset} runs past the end of the message \
                 ({left} bytes left, {element} or more per element)"
            ),
            CdrError::Unterminated { offset } => {
                write!(f, "the string at byte {offset} has no terminating NUL")
            }
            CdrError::NotUtf8 { offset } => {
                write!(f, "the string at byte {offset} is not UTF-8")
            }
        }
    }
}

/// Size of the encapsulation header.
const HEADER: usize = 4;

/// Reads the fields of one CDR message in order.
pub(crate) struct Cdr<'a> {
    bytes: &'a [u8],
    /// Offset of the next byte, from the start of the message (header included).
    pos: usize,
    little: bool,
}

impl<'a> Cdr<'a> {
    /// A reader after the encapsulation header of `bytes`.
    pub(crate) fn new(bytes: &'a [u8]) -> Result<Self, CdrError> {
        if bytes.len() < HEADER {
            return Err(CdrError::NoHeader(bytes.len()));
        }
        let little = match [bytes[0], bytes[1]] {
            [0, 0] => false,
            [0, 1] => true,
            other => return Err(CdrError::Encapsulation(other)),
        };
        Ok(Self {
            bytes,
            pos: HEADER,
            little,
        })
    }

    /// Bytes after the next read position.
    fn left(&self) -> usize {
        self.bytes.len().saturating_sub(self.pos)
    }

    /// The next `N` bytes, aligned to `N` (from the end of the header).
    fn take<const N: usize>(&mut self) -> Result<[u8; N], CdrError> {
        let body = self.pos - HEADER;
        let at = HEADER + body.div_ceil(N) * N;
        let out = self
            .bytes
            .get(at..at + N)
            .ok_or(CdrError::Truncated {
                offset: at,
                size: N,
                len: self.bytes.len(),
            })?
            .try_into()
            .expect("N bytes");
        self.pos = at + N;
        Ok(out)
    }

    /// An `int32`.
    pub(crate) fn i32(&mut self) -> Result<i32, CdrError> {
        let b = self.take::<4>()?;
        Ok(if self.little {
            i32::from_le_bytes(b)
        } else {
            i32::from_be_bytes(b)
        })
    }

    /// A `uint32`.
    pub(crate) fn u32(&mut self) -> Result<u32, CdrError> {
        let b = self.take::<4>()?;
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    /// A `float64`.
    pub(crate) fn f64(&mut self) -> Result<f64, CdrError> {
        let b = self.take::<8>()?;
        Ok(if self.little {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        })
    }

    /// A `float32`.
    pub(crate) fn f32(&mut self) -> Result<f32, CdrError> {
        let b = self.take::<4>()?;
        Ok(if self.little {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        })
    }

    /// `N` bytes of a fixed-size `uint8[N]` array (no alignment, no length).
    pub(crate) fn bytes<const N: usize>(&mut self) -> Result<[u8; N], CdrError> {
        let out = self
            .bytes
            .get(self.pos..self.pos + N)
            .ok_or(CdrError::Truncated {
                offset: self.pos,
                size: N,
                len: self.bytes.len(),
            })?
            .try_into()
            .expect("N bytes");
        self.pos += N;
        Ok(out)
    }

    /// A `uint8` (and `bool`, `byte`, `char`).
    pub(crate) fn u8(&mut self) -> Result<u8, CdrError> {
        Ok(self.take::<1>()?[0])
    }

    /// A sequence's element count, checked against the bytes left: every element takes
    /// at least `element` bytes (at least 1 is assumed).
    pub(crate) fn count(&mut self, element: usize) -> Result<usize, CdrError> {
        let n = self.u32()?;
        let left = self.left();
        if (n as u64).saturating_mul(element.max(1) as u64) > left as u64 {
            return Err(CdrError::Length {
                offset: self.pos - 4,
                count: n,
                element: element.max(1),
                left,
            });
        }
        Ok(n as usize)
    }

    /// A `string` (UTF-8, without its NUL).
    pub(crate) fn string(&mut self) -> Result<&'a str, CdrError> {
        let n = self.count(1)?;
        let offset = self.pos - 4;
        if n == 0 || self.bytes[self.pos + n - 1] != 0 {
            return Err(CdrError::Unterminated { offset });
        }
        let text = &self.bytes[self.pos..self.pos + n - 1];
        self.pos += n;
        std::str::from_utf8(text).map_err(|_| CdrError::NotUtf8 { offset })
    }

    /// Bytes not read yet.
    #[cfg(test)]
    pub(crate) fn left_over(&self) -> usize {
        self.left()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same fields in both byte orders, laid out by hand: a u8 (then 3 bytes of
    /// padding), a u32, a string "ab" (length 3 with its NUL, then 1 byte of padding to
    /// the f64's 8-byte alignment, counted from the end of the header), 1.5.
    #[test]
    fn reads_little_and_big_endian_with_alignment() {
        // body offsets: u8 at 0, u32 at 4, string length at 8, bytes 12..15, f64 aligned to 16
        let le: Vec<u8> = [
            &[0u8, 1, 0, 0][..],
            &[9, 0, 0, 0],
            &[0x78, 0x56, 0x34, 0x12],
            &[3, 0, 0, 0, b'a', b'b', 0, 0],
            &[0, 0, 0, 0, 0, 0, 0xf8, 0x3f],
        ]
        .concat();
        let be: Vec<u8> = [
            &[0u8, 0, 0, 0][..],
            &[9, 0, 0, 0],
            &[0x12, 0x34, 0x56, 0x78],
            &[0, 0, 0, 3, b'a', b'b', 0, 0],
            &[0x3f, 0xf8, 0, 0, 0, 0, 0, 0],
        ]
        .concat();
        for bytes in [&le, &be] {
            let mut r = Cdr::new(bytes).unwrap();
            assert_eq!(r.u8().unwrap(), 9);
            assert_eq!(r.u32().unwrap(), 0x1234_5678);
            assert_eq!(r.string().unwrap(), "ab");
            assert_eq!(r.f64().unwrap(), 1.5);
            assert_eq!(r.left_over(), 0);
        }
    }

    #[test]
    fn lengths_beyond_the_message_are_errors_before_allocating() {
        let huge = [0u8, 1, 0, 0, 0xff, 0xff, 0xff, 0xff, b'x', 0];
        let e = Cdr::new(&huge).unwrap().string().unwrap_err();
        assert_eq!(
            e.to_string(),
            "length 4294967295 at byte 4 runs past the end of the message (2 bytes left, 1 or more per element)"
        );
        // a sequence of 2^32-1 elements of 24 bytes each in a tiny message
        let e = Cdr::new(&huge).unwrap().count(24).unwrap_err();
        assert!(matches!(
            e,
            CdrError::Length {
                count: u32::MAX,
                element: 24,
                left: 2,
                ..
            }
        ));
        // a count that fits exactly is read
        let two = [0u8, 1, 0, 0, 2, 0, 0, 0, 1, 2];
        assert_eq!(Cdr::new(&two).unwrap().count(1).unwrap(), 2);
    }

    #[test]
    fn bad_strings_headers_and_short_values_are_errors() {
        let no_nul = [0u8, 1, 0, 0, 2, 0, 0, 0, b'a', b'b'];
        assert_eq!(
            Cdr::new(&no_nul).unwrap().string().unwrap_err(),
            CdrError::Unterminated { offset: 4 }
        );
        let empty = [0u8, 1, 0, 0, 0, 0, 0, 0];
        assert_eq!(
            Cdr::new(&empty).unwrap().string().unwrap_err(),
            CdrError::Unterminated { offset: 4 }
        );
        let latin1 = [0u8, 1, 0, 0, 2, 0, 0, 0, 0xe9, 0];
        assert_eq!(
            Cdr::new(&latin1).unwrap().string().unwrap_err(),
            CdrError::NotUtf8 { offset: 4 }
        );
        assert_eq!(Cdr::new(&[0, 1]).err(), Some(CdrError::NoHeader(2)));
        assert_eq!(
            Cdr::new(&[0, 3, 0, 0]).err(),
            Some(CdrError::Encapsulation([0, 3]))
        );
        // an f64 needs 8 aligned bytes: after a u32 at body offset 0, it starts at 8
        let short = [0u8, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 1, 2, 3];
        let mut r = Cdr::new(&short).unwrap();
        r.u32().unwrap();
        assert_eq!(
            r.f64().unwrap_err().to_string(),
            "8 bytes at byte 12 run past the end of the message (15 bytes)"
        );
    }
}
