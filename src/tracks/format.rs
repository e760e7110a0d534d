//! The trajectory file formats: [`Format`], parsed from and shown as the names the
//! command line takes (`thor`, `atc`, `magni`, `csv`, `rosbag2`); [`super::detect`]
//! recognises them from a file's start ([`Format::detect`]).

use std::fmt;
use std::str::FromStr;

/// Trajectory file formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// THÖR: `time, person_id, x, y, speed, motion_angle`, 2.5 Hz.
    Thor,
    /// ATC: `unix_time, person_id, x, y, speed, motion_angle`, 1 Hz.
    Atc,
    /// THÖR-MAGNI: a header row, columns by name
    /// ([`Columns::magni`](super::columns::Columns::magni)).
    Magni,
    /// A CSV with a header row and named columns; without a mapping
    /// ([`super::columns`]) the columns `t, id, x, y`.
    Csv,
    /// A rosbag2 recording (MCAP) of a people tracker ([`super::rosbag2`]). A file that
    /// begins with the MCAP magic is read as one whatever format is named.
    Rosbag2,
}

impl Format {
    /// Every format, in the order the command line lists them.
    pub const ALL: [Format; 5] = [
        Format::Thor,
        Format::Atc,
        Format::Magni,
        Format::Csv,
        Format::Rosbag2,
    ];

    /// `choices` as a sentence's list: `thor or atc`, `thor, atc, magni, csv or rosbag2`.
    pub fn list(choices: &[Format]) -> String {
        match choices {
            [] => String::new(),
            [one] => one.to_string(),
            [init @ .., last] => {
                let init: Vec<String> = init.iter().map(Format::to_string).collect();
                format!("{} or {last}", init.join(", "))
            }
        }
    }
}

impl FromStr for Format {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "thor" => Ok(Format::Thor),
            "atc" => Ok(Format::Atc),
            "magni" | "thor-magni" => Ok(Format::Magni),
            "csv" => Ok(Format::Csv),
            "rosbag2" | "mcap" => Ok(Format::Rosbag2),
            other => Err(format!(
                "unknown track format '{other}' (expected thor, atc, magni, csv or rosbag2)"
            )),
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Format::Thor => "thor",
            Format::Atc => "atc",
            Format::Magni => "magni",
            Format::Csv => "csv",
            Format::Rosbag2 => "rosbag2",
        })
    }
}
