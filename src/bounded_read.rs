//! Reading input files with a size limit, so that no file can make a reader allocate
//! more than the limit it documents.

use std::io::Read;
use std::path::Path;

/// The contents of `path`, refused with an [`std::io::ErrorKind::InvalidData`] error
/// (naming the limit) when the file holds more than `max_bytes` bytes.
pub(crate) fn read_at_most(path: &Path, max_bytes: u64) -> std::io::Result<Vec<u8>> {
    let too_large = || {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("file is larger than {max_bytes} bytes, the most this reader accepts"),
        )
    };
    let file = std::fs::File::open(path)?;
    // The size the file claims refuses it early and sizes the buffer; the read itself
    // stops after `max_bytes + 1` bytes whatever the file claimed (pipes, growing files).
    let claimed = file.metadata().map(|m| m.len()).unwrap_or(0);
    if claimed > max_bytes {
        return Err(too_large());
    }
    let mut bytes = Vec::with_capacity(claimed as usize + 1);
    file.take(max_bytes + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_large());
    }
    Ok(bytes)
}

/// The first `max_bytes` bytes of `path` (all of it when shorter): what a reader looks
/// at to recognise a file, whatever its size.
pub(crate) fn read_start(path: &Path, max_bytes: u64) -> std::io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(max_bytes)
        .read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// The 1-based line and column (in characters) of byte `offset` of `bytes`, for
/// errors in text that is not valid UTF-8.
pub(crate) fn line_column(bytes: &[u8], offset: usize) -> (usize, usize) {
    let before = &bytes[..offset.min(bytes.len())];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |i| i + 1);
    let column = String::from_utf8_lossy(&before[start..]).chars().count() + 1;
    (line, column)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_files_over_the_limit() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("f.csv");
        std::fs::write(&f, b"0123456789").unwrap();
        assert_eq!(read_at_most(&f, 10).unwrap().len(), 10);
        let e = read_at_most(&f, 9).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidData);
        assert!(e.to_string().contains("larger than 9 bytes"), "{e}");
    }

    #[test]
    fn reads_only_the_start() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("f.csv");
        std::fs::write(&f, b"0123456789").unwrap();
        assert_eq!(read_start(&f, 4).unwrap(), b"0123");
        assert_eq!(read_start(&f, 40).unwrap().len(), 10);
    }

    #[test]
    fn line_column_counts_from_one() {
        let b = b"ab\ncd\xffe";
        assert_eq!(line_column(b, 0), (1, 1));
        assert_eq!(line_column(b, 5), (2, 3));
    }
}
