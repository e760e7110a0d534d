//! Reading trajectory files of every [`Format`]: one entry point per source (a path,
//! bytes, text, several paths) that hands each format to its reader.
//!
//! ```
//! use cliff::tracks::{parse_tracks, Format};
//! let text = "0.0,7,1.0,2.0,1.2,0.5\n0.4,7,1.4,2.2,1.1,0.4\n";
//! let tracks = parse_tracks(text, "inline.csv", Format::Thor).unwrap();
//! assert_eq!(tracks[0].id, 7);
//! assert_eq!(tracks[0].rows.len(), 2);
//! ```

use std::path::Path;

use super::columns::{Columns, parse_named, read_named};
use super::format::Format;
use super::rosbag2::{is_mcap, is_recording, parse_recording, read_recording};
use super::six_columns::parse_six_columns;
use super::track::{DatasetError, MAX_TRACK_FILE_BYTES, Track};
use crate::bounded_read::{line_column, read_at_most};

/// Read the tracks of one file.
///
/// Files larger than [`MAX_TRACK_FILE_BYTES`] are refused before they are read; the
/// rows are then checked as [`parse_tracks`] describes. A rosbag2 recording (a file that
/// begins with the MCAP magic, a bag's folder of `.mcap` files, or any file with
/// [`Format::Rosbag2`]) is read as
/// [`read_recording`] reads it without a topic: its one topic of people; its size is
/// not limited, as it streams.
pub fn read_tracks(path: &Path, format: Format) -> Result<Vec<Track>, DatasetError> {
    if format == Format::Rosbag2 || is_recording(path) {
        return read_recording(path, None);
    }
    let file = path.display().to_string();
    let bytes = read_at_most(path, MAX_TRACK_FILE_BYTES).map_err(|source| DatasetError::Io {
        file: file.clone(),
        source,
    })?;
    parse_track_bytes(&bytes, &file, format)
}

/// Parse trajectory bytes (UTF-8 text; anything else is an error at its line and
/// column; a rosbag2 recording, as [`read_tracks`] says); `file` names the source in
/// errors.
pub fn parse_track_bytes(
    bytes: &[u8],
    file: &str,
    format: Format,
) -> Result<Vec<Track>, DatasetError> {
    if format == Format::Rosbag2 || is_mcap(bytes) {
        return parse_recording(bytes, file, None);
    }
    match std::str::from_utf8(bytes) {
        Ok(text) => parse_tracks(text, file, format),
        Err(e) => {
            let (line, column) = line_column(bytes, e.valid_up_to());
            Err(DatasetError::Parse {
                file: file.to_string(),
                line,
                column,
                message: "not UTF-8 text".into(),
            })
        }
    }
}

/// Read and concatenate the tracks of several files (a person id seen in two files
/// becomes two tracks).
pub fn read_many(paths: &[impl AsRef<Path>], format: Format) -> Result<Vec<Track>, DatasetError> {
    let mut all = Vec::new();
    for p in paths {
        all.extend(read_tracks(p.as_ref(), format)?);
    }
    Ok(all)
}

/// Parse trajectory text; `file` names the source in errors.
///
/// Every value must be a finite number within its bound: |time| <= [`MAX_TIME`],
/// |x|, |y| <= [`MAX_POSITION`], 0 <= speed <= [`MAX_SPEED`],
/// |angle| <= [`MAX_ANGLE`]; a person id is a whole number in `0..2^64`; a person's
/// times strictly increase. Memory grows with the rows read, never with a value.
/// ([`Format::Rosbag2`] is binary: text given as one is read as bytes.)
pub fn parse_tracks(text: &str, file: &str, format: Format) -> Result<Vec<Track>, DatasetError> {
    match format {
        Format::Rosbag2 => parse_recording(text.as_bytes(), file, None),
        Format::Thor | Format::Atc => parse_six_columns(text, file),
        Format::Magni => Ok(parse_named(text, file, &Columns::magni())?.tracks),
        Format::Csv => Ok(parse_named(text, file, &Columns::default())?.tracks),
    }
}

/// Read and concatenate the tracks of several files, each in `format` or, when it is
/// `None`, in the format recognised from the file itself ([`Format::detect`]: files of
/// different formats are each read in their own). `columns`, when given, names the
/// columns of a [`Format::Csv`] or [`Format::Magni`] file (and is an error with the
/// headerless formats); `topic`, when given, the topic of rosbag2 recordings (and is an
/// error with a text file). Files that begin with the MCAP magic, and bag folders, are
/// read as recordings whatever `format` says; recordings and text files are not read
/// together.
pub fn read_many_as(
    paths: &[impl AsRef<Path>],
    format: Option<Format>,
    columns: Option<&Columns>,
    topic: Option<&str>,
) -> Result<Vec<Track>, ReadError> {
    let formats = paths
        .iter()
        .map(|p| format.map_or_else(|| Format::detect(p.as_ref()), Ok))
        .collect::<Result<Vec<Format>, DatasetError>>()?;
    let bags: Vec<bool> = paths
        .iter()
        .zip(&formats)
        .map(|(p, &f)| f == Format::Rosbag2 || is_recording(p.as_ref()))
        .collect();
    if bags.iter().any(|&b| b) {
        let mut all = Vec::new();
        for (p, bag) in paths.iter().zip(bags) {
            let p = p.as_ref();
            if !bag {
                return Err(ReadError::Mixed(p.display().to_string()));
            }
            if columns.is_some() {
                return Err(ReadError::ColumnsWithRecording);
            }
            all.extend(read_recording(p, topic)?);
        }
        return Ok(all);
    }
    if topic.is_some() {
        return Err(ReadError::TopicWithoutRecording(
            formats.first().copied().unwrap_or(Format::Csv),
        ));
    }
    let mut all = Vec::new();
    for (p, format) in paths.iter().zip(formats) {
        let p = p.as_ref();
        match (format, columns) {
            (Format::Csv | Format::Magni, Some(c)) => all.extend(read_named(p, c)?.tracks),
            (Format::Thor | Format::Atc | Format::Rosbag2, Some(_)) => {
                return Err(ReadError::ColumnsWithoutHeader(format));
            }
            (_, None) => all.extend(read_tracks(p, format)?),
        }
    }
    Ok(all)
}

/// Errors of [`read_many_as`].
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be read or parsed.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// A column mapping was given for a format without a header row.
    #[error("a column mapping needs a file with a header row (format csv or magni), not {0}")]
    ColumnsWithoutHeader(Format),
    /// A column mapping was given for rosbag2 recordings.
    #[error("a column mapping is for CSV files with a header row, not rosbag2 recordings")]
    ColumnsWithRecording,
    /// A topic was given for text files.
    #[error("a topic is for rosbag2 recordings (MCAP files), not {0} text files")]
    TopicWithoutRecording(Format),
    /// Recordings and text files were given together.
    #[error(
        "{0} is not a rosbag2 recording (MCAP) like the other files given: read recordings and text files separately"
    )]
    Mixed(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(text: &str) -> String {
        parse_tracks(text, "t.csv", Format::Thor)
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn groups_by_person_in_order() {
        let t = parse_tracks("0,2,0,0,1,0\n0,1,5,5,1,0\n1,2,1,0,1,0\n", "t", Format::Atc).unwrap();
        assert_eq!(
            t.iter().map(|t| (t.id, t.rows.len())).collect::<Vec<_>>(),
            vec![(2, 2), (1, 1)]
        );
    }

    #[test]
    fn errors_name_file_line_column() {
        assert!(e("0,1,0,0,1\n").contains("t.csv:1: column 0: expected 6 columns"));
        assert!(e("0,1,0,0,1,0\n1,1,x,0,1,0\n").contains("t.csv:2: column 3: 'x' is not a number"));
        assert!(e("0,1,0,inf,1,0\n").contains("column 4: 'inf' is not finite"));
        assert!(e("0,1,0,0,-1,0\n").contains("column 5: negative speed"));
        assert!(e("0,-3,0,0,1,0\n").contains("column 2: person id"));
        assert!(
            e("1,1,0,0,1,0\n1,1,0,0,1,0\n")
                .contains("t.csv:2: column 1: time 1 of person 1 does not increase")
        );
    }

    #[test]
    fn absurd_values_lines_and_bytes_are_errors_with_line_and_column() {
        assert!(e("1e300,1,0,0,1,0\n").contains("t.csv:1: column 1: time 1e300 is beyond"));
        assert!(e("0,1,0,0,1,0\n1,1,1e7,0,1,0\n").contains("t.csv:2: column 3: coordinate"));
        assert!(e("0,1,0,-2e6,1,0\n").contains("column 4: coordinate"));
        assert!(e("0,1,0,0,2e6,0\n").contains("column 5: speed 2000000.0 is beyond 1000000"));
        assert!(e("0,1,0,0,1,-1e4\n").contains("column 6: motion angle"));
        assert!(e("0,1.5,0,0,1,0\n").contains("column 2: person id '1.5'"));
        assert!(e("0,1e300,0,0,1,0\n").contains("column 2: person id"));
        // a line of a million columns: counted, not collected
        let long = format!("0,1,0,0,1,0{}\n", ",".repeat(1_000_000));
        assert!(e(&long).contains(
            "expected 6 columns (time, person_id, x, y, speed, motion_angle), found 1000006"
        ));
        let err = parse_track_bytes(b"0,1,0,0,1,0\n1,1,\xc3(,0,1,0\n", "t.csv", Format::Atc)
            .unwrap_err()
            .to_string();
        assert!(err.contains("t.csv:2: column 5: not UTF-8"), "{err}");
        // the bounds themselves are accepted; an id as a whole float is read
        let t = parse_tracks(
            "-1e11,7e0,1e6,-1e6,1e6,1000\n1e11,7,0,0,0,-1000\n",
            "t",
            Format::Thor,
        )
        .unwrap();
        assert_eq!((t.len(), t[0].id, t[0].rows.len()), (1, 7, 2));
    }

    #[test]
    fn bytes_with_the_mcap_magic_are_a_recording_whatever_the_text_format() {
        // inputs of the fuzz targets tracks_thor and tracks_named: the MCAP magic, then
        // text; read as a recording (its error names the file, no line), not as rows
        for (bytes, format) in [
            (&b"\x89MCAP0\r\n01,.=46,-3443.,.010.41"[..], Format::Thor),
            (
                &b"\x89MCAP0\r\nTime0Time,ag_id,x,y,speed"[..],
                Format::Magni,
            ),
        ] {
            match parse_track_bytes(bytes, "fuzz.csv", format) {
                Err(DatasetError::Recording { file, message }) => {
                    assert_eq!(file, "fuzz.csv");
                    assert!(
                        message.contains("not a readable rosbag2 MCAP recording"),
                        "{message}"
                    );
                }
                other => panic!("{format:?}: {other:?}"),
            }
        }
    }

    #[test]
    fn refuses_files_over_the_size_limit_before_reading() {
        // a sparse file of 1 GiB + 1 byte costs no disk
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("huge.csv");
        let f = std::fs::File::create(&path).unwrap();
        f.set_len(MAX_TRACK_FILE_BYTES + 1).unwrap();
        let err = read_tracks(&path, Format::Atc).unwrap_err().to_string();
        assert!(
            err.contains("huge.csv") && err.contains("larger than 1073741824 bytes"),
            "{err}"
        );
    }

    #[test]
    fn reads_the_shipped_files() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data");
        let t = read_tracks(&Path::new(dir).join("thor1/exp-1-run-2.csv"), Format::Thor).unwrap();
        assert_eq!(t.len(), 87);
        let t = read_tracks(&Path::new(dir).join("thor3/exp-3-run-2.csv"), Format::Thor).unwrap();
        assert_eq!(t.len(), 126);
        let t = read_tracks(
            &Path::new(dir).join("atc/dev/atc-1024-13_test.csv"),
            Format::Atc,
        )
        .unwrap();
        assert_eq!(t.iter().map(|t| t.rows.len()).sum::<usize>(), 7973);
    }
}
