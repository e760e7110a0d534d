//! cliffd's configuration file (`cliffd --config FILE`): its command-line options, one
//! per line, so that a service manager starts the daemon with one file under `/etc`.
//!
//! ```text
//! # comment lines start with '#'; blank lines are skipped
//! map = thor1=/var/lib/cliff/thor1.csv     # --map thor1=/var/lib/cliff/thor1.csv
//! map = atc=/var/lib/cliff/atc.cliff       # options given twice add up, as on the command line
//! workers = 2                              # --workers 2
//! ```
//!
//! A line is `NAME = VALUE` (the option's long name without `--`; the value runs to the
//! end of the line, spaces around it trimmed, so it may hold `=` and spaces) or `NAME`
//! alone for an option without a value. A `#` starts a comment only at the start of a
//! line (a value may hold one). Whether NAME is one of the daemon's options is checked by
//! the caller, which knows them.

use std::fmt;

/// One line of a configuration file: `--name value` on the command line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileOption {
    /// The line it stands on, from 1.
    pub line: usize,
    /// The option's long name, without `--`.
    pub name: String,
    /// Its value; `None` for an option given by name alone.
    pub value: Option<String>,
}

impl FileOption {
    /// The option as command-line words: `--name` and, if there is one, the value.
    pub fn to_args(&self) -> Vec<String> {
        let mut words = vec![format!("--{}", self.name)];
        words.extend(self.value.clone());
        words
    }
}

/// A line of a configuration file that is not an option, with its line number.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OptionsFileError {
    /// The line, from 1.
    pub line: usize,
    /// What is wrong with it.
    pub message: String,
}

impl fmt::Display for OptionsFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for OptionsFileError {}

/// The options of a configuration file's text, in the file's order. Fails on the first
/// line that is neither blank, a comment nor `NAME [= VALUE]` with NAME made of lowercase
/// letters, digits and `-` (as the daemon's long options are), or that names `config`
/// (a file does not include another).
pub fn parse_options_file(text: &str) -> Result<Vec<FileOption>, OptionsFileError> {
    let mut options = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let trimmed = raw.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let (name, value) = match trimmed.split_once('=') {
            Some((n, v)) => (n.trim(), Some(v.trim())),
            None => (trimmed, None),
        };
        let name = name.strip_prefix("--").unwrap_or(name);
        let err = |message: String| OptionsFileError { line, message };
        if name.is_empty() {
            return Err(err(format!(
                "`{trimmed}` has no option name (write NAME = VALUE, e.g. workers = 2)"
            )));
        }
        if !name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')
        {
            return Err(err(format!(
                "`{name}` is not an option name (lowercase letters, digits and '-', as in \
                 max-agents; write NAME = VALUE)"
            )));
        }
        if name == "config" {
            return Err(err(
                "a configuration file cannot name another with `config`".to_string(),
            ));
        }
        if value == Some("") {
            return Err(err(format!(
                "`{name} =` has no value (write {name} = VALUE, or {name} alone for an \
                 option without one)"
            )));
        }
        options.push(FileOption {
            line,
            name: name.to_string(),
            value: value.map(str::to_string),
        });
    }
    Ok(options)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opt(line: usize, name: &str, value: Option<&str>) -> FileOption {
        FileOption {
            line,
            name: name.to_string(),
            value: value.map(str::to_string),
        }
    }

    #[test]
    fn lines_become_options_in_order_with_values_kept_whole() {
        let text = "# cliffd\n\n  map = thor1=/var/lib/cliff/thor 1.csv  \nworkers=2\n\
                    --log = info,cliff_service=debug\n\t# indented comment\nflag-alone\n\
                    map = atc=/srv/a#b.cliff\n";
        let got = parse_options_file(text).unwrap();
        assert_eq!(
            got,
            vec![
                opt(3, "map", Some("thor1=/var/lib/cliff/thor 1.csv")),
                opt(4, "workers", Some("2")),
                opt(5, "log", Some("info,cliff_service=debug")),
                opt(7, "flag-alone", None),
                opt(8, "map", Some("atc=/srv/a#b.cliff")),
            ]
        );
        let words: Vec<String> = got.iter().flat_map(FileOption::to_args).collect();
        assert_eq!(
            words,
            [
                "--map",
                "thor1=/var/lib/cliff/thor 1.csv",
                "--workers",
                "2",
                "--log",
                "info,cliff_service=debug",
                "--flag-alone",
                "--map",
                "atc=/srv/a#b.cliff"
            ]
        );
    }

    #[test]
    fn an_empty_or_comment_only_file_has_no_options() {
        assert_eq!(parse_options_file(""), Ok(vec![]));
        assert_eq!(
            parse_options_file("# nothing\n   \n#map = x=y\n"),
            Ok(vec![])
        );
    }

    #[test]
    fn bad_lines_are_refused_with_their_line_number() {
        let cases = [
            ("workers = 2\n= 3\n", 2, "no option name"),
            ("\n\nWorkers = 2\n", 3, "`Workers` is not an option name"),
            ("max agents = 4\n", 1, "`max agents` is not an option name"),
            ("workers =\n", 1, "`workers =` has no value"),
            ("# x\nconfig = /etc/other.conf\n", 2, "cannot name another"),
        ];
        for (text, line, what) in cases {
            let e = parse_options_file(text).unwrap_err();
            assert_eq!(e.line, line, "{text:?}: {e}");
            assert!(e.to_string().contains(what), "{text:?}: {e}");
            assert!(e.to_string().starts_with(&format!("line {line}: ")), "{e}");
        }
    }
}
