//! Turning the library's errors into Python exceptions.
//!
//! The exception classes of the package (`Rejected`, `NoDaemon`, `DaemonGone`,
//! `DeadlinePassed`) are plain Python classes in `cliff_lhmp/_errors.py`, so that they can
//! carry attributes and subclass the matching builtins; this module instantiates them.

use std::io::ErrorKind;

use cliff::map::MapError;
use cliff_client::{Error as ClientError, Rejection};
use pyo3::exceptions::{
    PyFileNotFoundError, PyIsADirectoryError, PyOSError, PyPermissionError, PyRuntimeError,
    PyValueError,
};
use pyo3::prelude::*;

/// An instance of the class `name` of `cliff_lhmp._errors`, called with `args`, as a `PyErr`.
fn package_error<'py, A>(py: Python<'py>, name: &str, args: A) -> PyErr
where
    A: pyo3::call::PyCallArgs<'py>,
{
    let made = py
        .import("cliff_lhmp._errors")
        .and_then(|m| m.getattr(name))
        .and_then(|cls| cls.call1(args));
    match made {
        Ok(exc) => PyErr::from_value(exc),
        Err(e) => e,
    }
}

/// An I/O error on `file` as the matching builtin (`FileNotFoundError`, ...), the message
/// naming the argument and the file.
pub fn io_err(what: &str, file: &str, e: &std::io::Error) -> PyErr {
    let msg = format!("{what}: {file}: {e}");
    match e.kind() {
        ErrorKind::NotFound => PyFileNotFoundError::new_err(msg),
        ErrorKind::PermissionDenied => PyPermissionError::new_err(msg),
        ErrorKind::IsADirectory => PyIsADirectoryError::new_err(msg),
        _ => PyOSError::new_err(msg),
    }
}

/// A map error: I/O as `OSError` subclasses, anything about the content as `ValueError`.
pub fn map_err(what: &str, e: MapError) -> PyErr {
    match &e {
        MapError::Io { file, source } => io_err(what, file, source),
        _ => PyValueError::new_err(format!("{what}: {e}")),
    }
}

/// The Python name of a rejection's field: the argument of `predict` it concerns.
fn field_name(r: &Rejection) -> Option<&'static str> {
    use cliff_client::Field;
    match r.field {
        Field::None => None,
        Field::Flags => Some("scores"),
        Field::TimeMode | Field::MapTime => Some("time"),
        f => Some(f.name()),
    }
}

/// Where a rejection points, in the words of the Python call (`histories[2] row 5`).
pub fn rejection_place(r: &Rejection) -> String {
    use cliff_client::Field;
    let mut s = String::new();
    if let Some(a) = r.agent {
        s.push_str(&format!("histories[{a}]"));
        if let Some(row) = r.row.filter(|&row| row != u32::MAX) {
            s.push_str(&format!(" row {row}"));
        }
        let col = match r.field {
            Field::Time => Some("t (column 0)"),
            Field::Position => Some("x, y (columns 1, 2)"),
            Field::Speed => Some("speed (column 3)"),
            Field::Heading => Some("heading (column 4)"),
            _ => None,
        };
        if let Some(c) = col {
            s.push_str(&format!(" {c}"));
        }
    } else if let Some(f) = field_name(r) {
        s.push_str(match r.field {
            Field::Steps => "horizon / dt",
            Field::Agents => "histories",
            Field::HeadingRule => "heading",
            Field::Flags => "scores",
            Field::TimeMode | Field::MapTime => "time",
            _ => f,
        });
    }
    s
}

/// What a status means, for messages.
fn status_text(r: &Rejection) -> String {
    use cliff_client::Status::*;
    let lim = r.limit;
    match r.status {
        UnknownMap => "no map of that name is loaded".into(),
        UnknownMethod => "unknown method or heading rule".into(),
        NonFinite => "is NaN or infinite".into(),
        BadK => format!("k must be between 1 and {lim}"),
        BadSteps => format!("must give between 1 and {lim} steps"),
        BadAgents => format!("must hold between 1 and {lim} histories"),
        HistoryTooShort => format!(
            "too few rows: at least {lim} (2 rows of (t, x, y), or 1 row of (t, x, y, speed, heading))"
        ),
        HistoryNotIncreasing => "times must strictly increase".into(),
        BadValue => match r.field {
            cliff_client::Field::Coast => {
                "is out of range (coast must be between 0 and the horizon)".into()
            }
            cliff_client::Field::SpeedBeta => "is out of range (must not be negative)".into(),
            _ => "is out of range (dt and radius must be positive; beta, horizon and speeds not negative)".into(),
        },
        HistoryTooLong => format!("more than {lim} rows"),
        _ => r.status.name().to_string(),
    }
}

/// A rejection as a message: place, what is wrong, and the status name.
pub fn rejection_message(r: &Rejection) -> String {
    let place = rejection_place(r);
    let text = status_text(r);
    if place.is_empty() {
        format!("{text} ({})", r.status.name())
    } else {
        format!("{place}: {text} ({})", r.status.name())
    }
}

/// A rejection found in-process (same checks as the daemon) as a `ValueError`.
pub fn local_rejection(r: &Rejection) -> PyErr {
    PyValueError::new_err(rejection_message(r))
}

/// A client error as the package's exception classes.
pub fn client_err(py: Python<'_>, e: ClientError) -> PyErr {
    let msg = e.to_string();
    match e {
        ClientError::Rejected(r) => package_error(
            py,
            "Rejected",
            (
                format!("cliffd rejected the request: {}", rejection_message(&r)),
                r.status.name(),
                field_name(&r),
                r.agent,
                r.row.filter(|&row| row != u32::MAX),
                r.limit,
            ),
        ),
        ClientError::NoDaemon { .. } => package_error(py, "NoDaemon", (msg,)),
        ClientError::DaemonGone { .. } => package_error(py, "DaemonGone", (msg,)),
        ClientError::Deadline { deadline } => {
            package_error(py, "DeadlinePassed", (msg, deadline.as_secs_f64()))
        }
        ClientError::InvalidRequest(m) => PyValueError::new_err(m),
        ClientError::Protocol(_) | ClientError::Ipc(_) | ClientError::Zenoh(_) => {
            PyRuntimeError::new_err(msg)
        }
    }
}
