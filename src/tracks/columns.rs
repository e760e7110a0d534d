//! Trajectory CSV files with a header row, read by column name: THÖR-MAGNI and any
//! other CSV whose columns are named (`t=Time,id=ag_id,x=x,y=y`).
//!
//! Each row gives a time, an agent id, a position and optionally its velocity. The
//! velocity of a row comes from, in this order of preference:
//!
//! 1. a `speed` column and an `angle` column (rad);
//! 2. `vx` and `vy` columns (speed `hypot(vx, vy)` unless a `speed` column is named,
//!    heading `atan2(vy, vx)`; heading 0 where both are 0);
//! 3. the positions: the difference to the agent's previous row over the time between
//!    them (the agent's first row takes the difference to its second).
//!
//! Every value is bounded as in the THÖR and ATC readers
//! ([`parse_tracks`](super::read::parse_tracks)), the speeds found by 2. and 3. included: a speed
//! above [`MAX_SPEED`] (two rows a microsecond apart and a metre away, say) is an error
//! at its line.
//!
//! Agent ids: when every id of the file is a whole number and no two are the same number
//! (`12` and `012` are), they are kept as they are. Otherwise ids are strings; when every
//! string id of the file ends in digits and no two end in the same number, the id is that
//! number (`Helmet_4` is person 4), else agents are numbered 1, 2, ... in order of first
//! appearance. [`NamedTracks::names`] maps the numbers back to the file's ids; no two
//! tracks of a file share a number.
//!
//! ```
//! use cliff::tracks::{Columns, parse_named};
//! let text = "Time,ag_id,x,y,speed,x_speed,y_speed\n\
//!             0.0,Helmet_2,1.0,2.0,1.0,1.0,0.0\n\
//!             0.4,Helmet_2,1.4,2.0,1.0,1.0,0.0\n";
//! let named = parse_named(text, "magni.csv", &Columns::magni()).unwrap();
//! assert_eq!(named.tracks[0].id, 2);
//! assert_eq!(named.names[0], (2, "Helmet_2".to_string()));
//! assert_eq!(named.tracks[0].rows[1].speed, 1.0);
//! ```

use std::collections::HashMap;
use std::fmt;
use std::path::Path;
use std::str::FromStr;

use glam::DVec2;

use super::track::{DatasetError, MAX_ANGLE, MAX_POSITION, MAX_SPEED, MAX_TIME, Row, Track};

/// Which header column holds each field. Optional fields may be left out (see the
/// module documentation for how the velocity is found).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Columns {
    /// Time (s).
    pub t: String,
    /// Agent id.
    pub id: String,
    /// Position x (m).
    pub x: String,
    /// Position y (m).
    pub y: String,
    /// Speed (m/s).
    pub speed: Option<String>,
    /// Motion angle (rad).
    pub angle: Option<String>,
    /// Velocity x (m/s).
    pub vx: Option<String>,
    /// Velocity y (m/s).
    pub vy: Option<String>,
}

impl Default for Columns {
    /// `t=t,id=id,x=x,y=y`: velocities from the positions.
    fn default() -> Self {
        Self {
            t: "t".into(),
            id: "id".into(),
            x: "x".into(),
            y: "y".into(),
            speed: None,
            angle: None,
            vx: None,
            vy: None,
        }
    }
}

impl Columns {
    /// THÖR-MAGNI: `t=Time,id=ag_id,x=x,y=y,speed=speed,vx=x_speed,vy=y_speed`.
    pub fn magni() -> Self {
        Self {
            t: "Time".into(),
            id: "ag_id".into(),
            x: "x".into(),
            y: "y".into(),
            speed: Some("speed".into()),
            angle: None,
            vx: Some("x_speed".into()),
            vy: Some("y_speed".into()),
        }
    }
}

impl FromStr for Columns {
    type Err = String;
    /// `field=Header,...` with fields `t`, `id`, `x`, `y` (required) and `speed`,
    /// `angle`, `vx`, `vy`.
    fn from_str(s: &str) -> Result<Self, String> {
        let mut t = None;
        let mut id = None;
        let mut x = None;
        let mut y = None;
        let mut c = Columns::default();
        for part in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let Some((field, header)) = part.split_once('=') else {
                return Err(format!(
                    "column mapping '{part}' is not field=Header (for example t=Time)"
                ));
            };
            let header = header.trim().to_string();
            if header.is_empty() {
                return Err(format!("column mapping '{part}' names no header column"));
            }
            let slot = match field.trim().to_ascii_lowercase().as_str() {
                "t" | "time" => &mut t,
                "id" => &mut id,
                "x" => &mut x,
                "y" => &mut y,
                "speed" => &mut c.speed,
                "angle" | "heading" => &mut c.angle,
                "vx" => &mut c.vx,
                "vy" => &mut c.vy,
                other => {
                    return Err(format!(
                        "unknown field '{other}' in column mapping (expected t, id, x, y, speed, angle, vx, vy)"
                    ));
                }
            };
            if slot.is_some() {
                return Err(format!("field '{}' is mapped twice", field.trim()));
            }
            *slot = Some(header);
        }
        let need = |v: Option<String>, f: &str| {
            v.ok_or_else(|| format!("column mapping lacks '{f}=' (t, id, x and y are required)"))
        };
        c.t = need(t, "t")?;
        c.id = need(id, "id")?;
        c.x = need(x, "x")?;
        c.y = need(y, "y")?;
        if c.vx.is_some() != c.vy.is_some() {
            return Err("column mapping names only one of vx and vy".into());
        }
        if c.angle.is_some() && c.speed.is_none() {
            return Err("column mapping names angle without speed".into());
        }
        if c.speed.is_some() && c.angle.is_none() && c.vx.is_none() {
            return Err("column mapping names speed without angle or vx, vy".into());
        }
        Ok(c)
    }
}

impl fmt::Display for Columns {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "t={},id={},x={},y={}", self.t, self.id, self.x, self.y)?;
        for (k, v) in [
            ("speed", &self.speed),
            ("angle", &self.angle),
            ("vx", &self.vx),
            ("vy", &self.vy),
        ] {
            if let Some(v) = v {
                write!(f, ",{k}={v}")?;
            }
        }
        Ok(())
    }
}

/// Tracks read from a named-column file, with the file's agent ids.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedTracks {
    /// Tracks in order of first appearance.
    pub tracks: Vec<Track>,
    /// `(track id, id in the file)`, one per track, in the same order.
    pub names: Vec<(u64, String)>,
}

/// Read a named-column file.
pub fn read_named(path: &Path, columns: &Columns) -> Result<NamedTracks, DatasetError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| DatasetError::Io {
        file: file.clone(),
        source,
    })?;
    parse_named(&text, &file, columns)
}

/// Read and concatenate the tracks of several named-column files.
pub fn read_many_named(
    paths: &[impl AsRef<Path>],
    columns: &Columns,
) -> Result<Vec<Track>, DatasetError> {
    let mut all = Vec::new();
    for p in paths {
        all.extend(read_named(p.as_ref(), columns)?.tracks);
    }
    Ok(all)
}

/// Parse named-column CSV text; `file` names the source in errors.
pub fn parse_named(text: &str, file: &str, columns: &Columns) -> Result<NamedTracks, DatasetError> {
    let err = |line: usize, column: usize, message: String| DatasetError::Parse {
        file: file.to_string(),
        line,
        column,
        message,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty());
    let Some((hline, header)) = lines.next() else {
        return Err(err(1, 0, "empty file: expected a header row".into()));
    };
    let header: Vec<&str> = header.split(',').map(str::trim).collect();
    let find = |name: &str| -> Result<usize, DatasetError> {
        header.iter().position(|h| *h == name).ok_or_else(|| {
            err(
                hline,
                0,
                format!(
                    "no column named '{name}' in the header ({})",
                    header.join(", ")
                ),
            )
        })
    };
    let find_opt = |name: &Option<String>| name.as_deref().map(find).transpose();
    let (ct, cid, cx, cy) = (
        find(&columns.t)?,
        find(&columns.id)?,
        find(&columns.x)?,
        find(&columns.y)?,
    );
    let (cspeed, cangle, cvx, cvy) = (
        find_opt(&columns.speed)?,
        find_opt(&columns.angle)?,
        find_opt(&columns.vx)?,
        find_opt(&columns.vy)?,
    );
    // Raw rows per agent id string; velocities filled in afterwards where needed.
    let mut raw_ids: Vec<String> = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    let mut rows: Vec<Vec<Row>> = Vec::new();
    // the line of each row, for errors found after reading
    let mut row_lines: Vec<Vec<usize>> = Vec::new();
    for (line, raw) in lines {
        let fields: Vec<&str> = raw.split(',').map(str::trim).collect();
        if fields.len() != header.len() {
            return Err(err(
                line,
                0,
                format!(
                    "expected {} columns as in the header, found {}",
                    header.len(),
                    fields.len()
                ),
            ));
        }
        let num = |c: usize| -> Result<f64, DatasetError> {
            let v: f64 = fields[c].parse().map_err(|_| {
                err(
                    line,
                    c + 1,
                    format!("{}: '{}' is not a number", header[c], fields[c]),
                )
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(err(
                    line,
                    c + 1,
                    format!("{}: '{}' is not finite", header[c], fields[c]),
                ))
            }
        };
        // the same bounds as the THÖR and ATC readers
        let within = |c: usize, max: f64| -> Result<f64, DatasetError> {
            let v = num(c)?;
            if v.abs() <= max {
                Ok(v)
            } else {
                Err(err(
                    line,
                    c + 1,
                    format!("{}: {v} is beyond {max}", header[c]),
                ))
            }
        };
        let id = fields[cid];
        if id.is_empty() {
            return Err(err(
                line,
                cid + 1,
                format!("{}: empty agent id", header[cid]),
            ));
        }
        let t = within(ct, MAX_TIME)?;
        let position = DVec2::new(within(cx, MAX_POSITION)?, within(cy, MAX_POSITION)?);
        let v = match (cvx, cvy) {
            (Some(a), Some(b)) => Some(DVec2::new(within(a, MAX_SPEED)?, within(b, MAX_SPEED)?)),
            _ => None,
        };
        let speed_column = match cspeed {
            Some(c) => {
                let s = within(c, MAX_SPEED)?;
                if s < 0.0 {
                    return Err(err(
                        line,
                        c + 1,
                        format!("{}: negative speed {s}", header[c]),
                    ));
                }
                Some(s)
            }
            None => None,
        };
        let angle_column = cangle.map(|c| within(c, MAX_ANGLE)).transpose()?;
        // the order of preference of the module documentation; (None, None): from the
        // positions, once all rows are read
        let (speed, angle) = match (speed_column, angle_column, v) {
            (Some(s), Some(a), _) => (Some(s), Some(a)),
            (s, _, Some(v)) => {
                let s = s.unwrap_or(v.length());
                if s > MAX_SPEED {
                    let c = cvx.unwrap_or(0);
                    return Err(err(
                        line,
                        c + 1,
                        format!("speed {s} of ({}, {}) is beyond {MAX_SPEED}", v.x, v.y),
                    ));
                }
                (Some(s), Some(heading_of(v)))
            }
            _ => (None, None),
        };
        let i = *index.entry(id.to_string()).or_insert_with(|| {
            raw_ids.push(id.to_string());
            rows.push(Vec::new());
            row_lines.push(Vec::new());
            rows.len() - 1
        });
        if let Some(prev) = rows[i].last()
            && t <= prev.t
        {
            return Err(err(
                line,
                ct + 1,
                format!(
                    "time {t} of agent {id} does not increase (previous row {})",
                    prev.t
                ),
            ));
        }
        rows[i].push(Row {
            t,
            position,
            speed: speed.unwrap_or(f64::NAN),
            angle: angle.unwrap_or(f64::NAN),
        });
        row_lines[i].push(line);
    }
    if speed_from_positions(columns) {
        for ((r, lines), id) in rows.iter_mut().zip(&row_lines).zip(&raw_ids) {
            if let Err((a, b, speed)) = velocities_from_positions(r) {
                return Err(err(
                    lines[b],
                    0,
                    format!(
                        "speed {speed} of agent {id} from its positions at lines {} and {} is beyond {MAX_SPEED}",
                        lines[a], lines[b]
                    ),
                ));
            }
        }
    }
    let ids = number_ids(&raw_ids);
    Ok(NamedTracks {
        names: ids.iter().copied().zip(raw_ids).collect(),
        tracks: ids
            .into_iter()
            .zip(rows)
            .map(|(id, rows)| Track { id, rows })
            .collect(),
    })
}

/// Whether the velocities come from the positions: neither a speed and an angle column
/// nor both of vx and vy (a `Columns` built by hand may name an angle without a speed or
/// only one of vx and vy; `--columns` refuses such mappings).
fn speed_from_positions(c: &Columns) -> bool {
    let speed_and_angle = c.speed.is_some() && c.angle.is_some();
    let components = c.vx.is_some() && c.vy.is_some();
    !(speed_and_angle || components)
}

/// Heading of a velocity; 0 when it is zero (a standing row).
pub(crate) fn heading_of(v: DVec2) -> f64 {
    if v == DVec2::ZERO { 0.0 } else { v.to_angle() }
}

/// Speed and angle of each row from the position difference to the previous row (the
/// first row: to the next one; a lone row stands still). A speed above [`MAX_SPEED`]
/// (infinite too: rows 1e-310 s apart) is returned with the two rows it comes from.
pub(crate) fn velocities_from_positions(rows: &mut [Row]) -> Result<(), (usize, usize, f64)> {
    let n = rows.len();
    for i in 0..n {
        let (a, b) = match (i.checked_sub(1), i + 1 < n) {
            (Some(p), _) => (p, i),
            (None, true) => (0, 1),
            (None, false) => {
                rows[i].speed = 0.0;
                rows[i].angle = 0.0;
                continue;
            }
        };
        let v = (rows[b].position - rows[a].position) / (rows[b].t - rows[a].t);
        let speed = v.length();
        if speed > MAX_SPEED {
            return Err((a, b, speed));
        }
        rows[i].speed = speed;
        rows[i].angle = heading_of(v);
    }
    Ok(())
}

/// Numeric ids for the file's id strings (see the module documentation).
pub(crate) fn number_ids(raw: &[String]) -> Vec<u64> {
    let distinct = |ids: &[u64]| {
        let mut sorted = ids.to_vec();
        sorted.sort_unstable();
        sorted.windows(2).all(|w| w[0] != w[1])
    };
    if let Some(ids) = raw
        .iter()
        .map(|s| s.parse::<u64>().ok())
        .collect::<Option<Vec<u64>>>()
        && distinct(&ids)
    {
        return ids;
    }
    let trailing = |s: &str| {
        let digits = s.len() - s.trim_end_matches(|c: char| c.is_ascii_digit()).len();
        s[s.len() - digits..].parse::<u64>().ok()
    };
    if let Some(ids) = raw
        .iter()
        .map(|s| trailing(s))
        .collect::<Option<Vec<u64>>>()
        && distinct(&ids)
    {
        return ids;
    }
    (1..=raw.len() as u64).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cols(s: &str) -> Columns {
        s.parse().unwrap()
    }

    #[test]
    fn mapping_parses_and_names_what_is_wrong() {
        let c = cols("t=Time,id=ag_id,x=x,y=y");
        assert_eq!((c.t.as_str(), c.id.as_str()), ("Time", "ag_id"));
        assert_eq!(c.to_string(), "t=Time,id=ag_id,x=x,y=y");
        assert_eq!(cols(&Columns::magni().to_string()), Columns::magni());
        let e = |s: &str| s.parse::<Columns>().unwrap_err();
        assert!(e("t=Time,id=a,x=x").contains("lacks 'y='"));
        assert!(e("t=Time,id=a,x=x,y=y,z=z").contains("unknown field 'z'"));
        assert!(e("t=Time,id=a,x=x,y=y,vx=u").contains("only one of vx and vy"));
        assert!(e("t=Time,id=a,x=x,y=y,x=q").contains("mapped twice"));
        assert!(e("t").contains("not field=Header"));
        assert!(e("t=,id=a,x=x,y=y").contains("names no header"));
    }

    #[test]
    fn velocities_from_positions_speed_angle_or_components() {
        // an agent walking north at 2 m/s, sampled every 0.5 s, columns in odd order
        let text = "who,y,x,when\na,0,5,0\na,1,5,0.5\na,2,5,1\n";
        let n = parse_named(text, "p.csv", &cols("t=when,id=who,x=x,y=y")).unwrap();
        let rows = &n.tracks[0].rows;
        assert_eq!(rows.len(), 3);
        for r in rows {
            assert!((r.speed - 2.0).abs() < 1e-12);
            assert!((r.angle - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        }
        // a single string id without digits: numbered 1
        assert_eq!(n.names, vec![(1, "a".to_string())]);
        let text = "t,id,x,y,s,a\n0,7,0,0,1.5,0.25\n";
        let n = parse_named(text, "p", &cols("t=t,id=id,x=x,y=y,speed=s,angle=a")).unwrap();
        assert_eq!((n.tracks[0].id, n.tracks[0].rows[0].speed), (7, 1.5));
        assert_eq!(n.tracks[0].rows[0].angle, 0.25);
        let text = "t,id,x,y,u,v\n0,7,0,0,0,-3\n1,7,0,-3,0,0\n";
        let n = parse_named(text, "p", &cols("t=t,id=id,x=x,y=y,vx=u,vy=v")).unwrap();
        let r = &n.tracks[0].rows;
        assert_eq!(r[0].speed, 3.0);
        assert!((r[0].angle + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!((r[1].speed, r[1].angle), (0.0, 0.0));
    }

    #[test]
    fn string_ids_by_trailing_number_or_first_appearance() {
        let ids = |v: &[&str]| number_ids(&v.iter().map(|s| s.to_string()).collect::<Vec<_>>());
        assert_eq!(ids(&["Helmet_10", "Helmet_2"]), vec![10, 2]);
        assert_eq!(ids(&["a_1", "b_1"]), vec![1, 2]);
        assert_eq!(ids(&["bob", "alice3"]), vec![1, 2]);
        assert_eq!(ids(&["12", "3"]), vec![12, 3]);
    }

    #[test]
    fn errors_name_file_line_column() {
        let e = |text: &str| {
            parse_named(text, "m.csv", &Columns::magni())
                .unwrap_err()
                .to_string()
        };
        let head = "Time,ag_id,x,y,speed,x_speed,y_speed\n";
        assert!(e("").contains("m.csv:1: column 0: empty file"));
        assert!(
            e("Time,id,x,y\n").contains("no column named 'ag_id' in the header (Time, id, x, y)")
        );
        assert!(
            e(&format!("{head}0,H_1,0,0,0,0\n")).contains("m.csv:2: column 0: expected 7 columns")
        );
        assert!(
            e(&format!("{head}0,H_1,0,zz,0,0,0\n"))
                .contains("m.csv:2: column 4: y: 'zz' is not a number")
        );
        assert!(
            e(&format!("{head}0,H_1,0,0,-1,0,0\n")).contains("column 5: speed: negative speed")
        );
        assert!(e(&format!("{head}0,,0,0,0,0,0\n")).contains("column 2: ag_id: empty agent id"));
        assert!(
            e(&format!("{head}0,H_1,1e20,0,0,0,0\n"))
                .contains("m.csv:2: column 3: x: 100000000000000000000 is beyond 1000000")
        );
        assert!(e(&format!("{head}1e300,H_1,0,0,0,0,0\n")).contains("column 1: Time:"));
        assert!(e(&format!("{head}0,H_1,0,0,0,1e9,0\n")).contains("column 6: x_speed:"));
        assert!(
            e(&format!("{head}1,H_1,0,0,0,0,0\n1,H_1,0,0,0,0,0\n"))
                .contains("m.csv:3: column 1: time 1 of agent H_1 does not increase")
        );
    }

    #[test]
    fn track_numbers_are_distinct_velocities_as_documented_and_bounded() {
        // `12` and `012` are the same whole number: numbered by first appearance
        let text = "t,id,x,y\n0,12,0,0\n1,012,5,5\n2,12,1,0\n";
        let n = parse_named(text, "p", &Columns::default()).unwrap();
        assert_eq!(n.names, vec![(1, "12".into()), (2, "012".into())]);
        let text = "t,id,x,y\n0,H_1,0,0\n1,H_01,5,5\n";
        let n = parse_named(text, "p", &Columns::default()).unwrap();
        assert_eq!(n.names, vec![(1, "H_1".into()), (2, "H_01".into())]);
        // a hand-built mapping with an angle but no speed, or only vx: from the positions
        let text = "t,id,x,y,a,u\n0,1,0,0,3,9\n0.5,1,0,1,3,9\n";
        for columns in [
            Columns {
                angle: Some("a".into()),
                ..Columns::default()
            },
            Columns {
                vx: Some("u".into()),
                ..Columns::default()
            },
        ] {
            let n = parse_named(text, "p", &columns).unwrap();
            for r in &n.tracks[0].rows {
                assert_eq!(r.speed, 2.0);
                assert!((r.angle - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
            }
        }
        // speeds from the positions or from vx, vy are bounded as the speed column is
        let e = |text: &str, c: &str| {
            parse_named(text, "p.csv", &cols(c))
                .unwrap_err()
                .to_string()
        };
        let m = e(
            "t,id,x,y\n0,1,0,0\n5,2,0,0\n1e-6,1,2,0\n",
            "t=t,id=id,x=x,y=y",
        );
        assert!(
            m.starts_with("p.csv:4: column 0: speed 19999")
                || m.starts_with("p.csv:4: column 0: speed 20000"),
            "{m}"
        );
        assert!(
            m.ends_with("of agent 1 from its positions at lines 2 and 4 is beyond 1000000"),
            "{m}"
        );
        assert!(
            e("t,id,x,y\n0,1,0,0\n1e-310,1,1,0\n", "t=t,id=id,x=x,y=y")
                .contains("p.csv:3: column 0: speed inf of agent 1")
        );
        assert!(
            e(
                "t,id,x,y,u,v\n0,1,0,0,1e6,1e6\n",
                "t=t,id=id,x=x,y=y,vx=u,vy=v"
            )
            .contains("p.csv:2: column 5: speed 1414213.56")
        );
    }

    #[test]
    fn reads_the_magni_recording() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../shared/data/magni/magni-A-first-16min.csv"
        );
        let n = read_named(path.as_ref(), &Columns::magni()).unwrap();
        // 9 helmets; 17,435 data rows (the data README says 17,434: `wc -l` counts 17,436 lines with the header)
        assert_eq!(n.tracks.len(), 9);
        assert_eq!(n.tracks.iter().map(|t| t.rows.len()).sum::<usize>(), 17_435);
        assert_eq!(n.names[0], (1, "Helmet_1".to_string()));
        assert_eq!(n.tracks[3].id, 10);
        // second row of Helmet_1: 0.41,Helmet_1,-8.022132,-1.276519,0.153186,-0.077607,0.132073
        let r = n.tracks[0].rows[1];
        assert_eq!((r.t, r.position.x, r.speed), (0.41, -8.022132, 0.153186));
        assert!((r.angle - 0.132073f64.atan2(-0.077607)).abs() < 1e-12);
        // the named-column reader with positions only agrees on the direction of motion
        // where people walk
        let p = read_named(path.as_ref(), &cols("t=Time,id=ag_id,x=x,y=y")).unwrap();
        let (mut agree, mut walking) = (0, 0);
        for (a, b) in n.tracks.iter().zip(&p.tracks) {
            for (ra, rb) in a.rows.iter().zip(&b.rows).skip(1) {
                if ra.speed > 0.8 {
                    walking += 1;
                    let d = (ra.angle - rb.angle).rem_euclid(std::f64::consts::TAU);
                    agree += (d.min(std::f64::consts::TAU - d) < 0.5) as usize;
                }
            }
        }
        assert!(
            walking > 3000 && agree as f64 > 0.9 * walking as f64,
            "{agree}/{walking}"
        );
    }
}
