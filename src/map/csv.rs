//! The published CLiFF-map CSV format.
//!
//! No header; one row per mixture component with 11 columns:
//! `x, y, theta, rho, cov_tt, cov_tr, cov_rt, cov_rr, weight, motion_ratio, observation_ratio`.
//! All components of a location share its x and y.
//!
//! Limits (see [`CliffMap::with_grid_step`]): files of at most
//! [`MAX_MAP_FILE_BYTES`](super::MAX_MAP_FILE_BYTES); |x|, |y| at most
//! [`MAX_COORDINATE`](super::MAX_COORDINATE) m; at most
//! [`MAX_COMPONENTS`](super::MAX_COMPONENTS) rows per location; the grid step (the
//! smallest spacing of the coordinates) in [1 mm, 1 km] and a bounding box of at most
//! [`MAX_GRID_CELLS`](super::MAX_GRID_CELLS) cells.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use glam::DVec2;

use super::{
    CliffMap, Component, Location, MAX_COMPONENT_VALUE, MAX_COMPONENTS, MAX_COORDINATE,
    MAX_MAP_FILE_BYTES, MapError,
};
use crate::bounded_read::{line_column, read_at_most};

/// Number of columns of a map row.
pub const COLUMNS: usize = 11;

/// Read a map from a CSV file.
///
/// Files larger than [`MAX_MAP_FILE_BYTES`] are refused before they are read; every
/// value is checked against the limits of [`CliffMap::with_grid_step`], and an error
/// names the file, line and column (a location-level error, such as a location off the
/// grid, names the first line of the location).
pub fn read_csv(path: &Path) -> Result<CliffMap, MapError> {
    let name = path.display().to_string();
    let bytes = read_at_most(path, MAX_MAP_FILE_BYTES).map_err(|source| MapError::Io {
        file: name.clone(),
        source,
    })?;
    read_csv_bytes(&bytes, &name)
}

/// Read a map from CSV bytes; `file` names the source in errors (text that is not
/// UTF-8 is an error at its line and column).
pub fn read_csv_bytes(bytes: &[u8], file: &str) -> Result<CliffMap, MapError> {
    match std::str::from_utf8(bytes) {
        Ok(text) => parse(text, file),
        Err(e) => {
            let (line, column) = line_column(bytes, e.valid_up_to());
            Err(MapError::Parse {
                file: file.to_string(),
                line,
                column,
                message: "not UTF-8 text".into(),
            })
        }
    }
}

/// Read a map from CSV text (errors name the file as `<string>`).
pub fn read_csv_str(text: &str) -> Result<CliffMap, MapError> {
    parse(text, "<string>")
}

/// What each column may hold beyond being a finite number: `None` when it is fine,
/// else what is wrong.
fn check_value(column: usize, v: f64) -> Option<String> {
    match column {
        0 | 1 if v.abs() > MAX_COORDINATE => Some(format!(
            "coordinate {v:?} is beyond {MAX_COORDINATE} m from the origin"
        )),
        2 | 4..=7 if v.abs() > MAX_COMPONENT_VALUE => Some(format!(
            "{v:?} is beyond {MAX_COMPONENT_VALUE} in magnitude"
        )),
        3 if v < 0.0 => Some(format!("negative speed {v}")),
        3 if v > MAX_COMPONENT_VALUE => Some(format!("speed {v:?} is above {MAX_COMPONENT_VALUE}")),
        8 if v < 0.0 => Some(format!("negative weight {v:?}")),
        9 if v < 0.0 => Some(format!("negative motion ratio {v:?}")),
        10 if !(0.0..=1.0 + 1e-9).contains(&v) => {
            Some(format!("observation ratio {v:?} is not in [0, 1]"))
        }
        _ => None,
    }
}

fn parse(text: &str, file: &str) -> Result<CliffMap, MapError> {
    let perr = |line: usize, column: usize, message: String| MapError::Parse {
        file: file.to_string(),
        line,
        column,
        message,
    };
    let mut locations: Vec<Location> = Vec::new();
    let mut first_line: Vec<usize> = Vec::new();
    let mut by_pos: HashMap<(u64, u64), usize> = HashMap::new();
    for (ln, raw) in text.lines().enumerate() {
        let line = ln + 1;
        let raw = raw.trim();
        if raw.is_empty() {
            continue;
        }
        let mut v = [0.0f64; COLUMNS];
        let mut n = 0;
        for (ci, field) in raw.split(',').enumerate() {
            if ci >= COLUMNS {
                n = ci + 1;
                continue;
            }
            let f = field.trim();
            let x: f64 = f
                .parse()
                .map_err(|_| perr(line, ci + 1, format!("'{f}' is not a number")))?;
            if !x.is_finite() {
                return Err(perr(line, ci + 1, format!("'{f}' is not finite")));
            }
            if let Some(message) = check_value(ci, x) {
                return Err(perr(line, ci + 1, message));
            }
            v[ci] = x;
            n = ci + 1;
        }
        if n != COLUMNS {
            return Err(perr(
                line,
                0,
                format!("expected {COLUMNS} columns, found {n}"),
            ));
        }
        let comp = Component {
            theta: v[2],
            rho: v[3],
            cov: [v[4], v[5], v[6], v[7]],
            weight: v[8],
        };
        let key = (v[0].to_bits(), v[1].to_bits());
        match by_pos.get(&key) {
            Some(&i) => {
                let comps = &mut locations[i].components;
                if comps.len() >= MAX_COMPONENTS {
                    return Err(perr(
                        line,
                        0,
                        format!(
                            "more than {MAX_COMPONENTS} components at ({}, {}) (first on line {})",
                            v[0], v[1], first_line[i]
                        ),
                    ));
                }
                comps.push(comp);
            }
            None => {
                by_pos.insert(key, locations.len());
                first_line.push(line);
                locations.push(Location {
                    position: DVec2::new(v[0], v[1]),
                    components: vec![comp],
                    motion_ratio: v[9],
                    observation_ratio: v[10],
                });
            }
        }
    }
    if locations.is_empty() {
        return Err(perr(0, 0, "no map rows".into()));
    }
    for (l, &line) in locations.iter().zip(&first_line) {
        let total: f64 = l.components.iter().map(|c| c.weight).sum();
        if !(total > 0.0 && total.is_finite()) {
            return Err(perr(
                line,
                9,
                format!(
                    "the weights of location ({}, {}) sum to {total}",
                    l.position.x, l.position.y
                ),
            ));
        }
    }
    CliffMap::new(locations).map_err(|e| match e {
        MapError::Location { index, message, .. } => perr(first_line[index], 1, message),
        MapError::Empty => perr(0, 0, "no map rows".into()),
        other => other,
    })
}

/// The map as CSV text, one row per component, in location order; values are written
/// as given (shortest representation that reads back to the same number).
pub fn write_csv_string(map: &CliffMap) -> String {
    let mut out = String::with_capacity(map.locations().len() * 120);
    for l in map.locations() {
        for c in &l.components {
            let _ = writeln!(
                out,
                "{},{},{},{},{},{},{},{},{},{},{}",
                l.position.x,
                l.position.y,
                c.theta,
                c.rho,
                c.cov[0],
                c.cov[1],
                c.cov[2],
                c.cov[3],
                c.weight,
                l.motion_ratio,
                l.observation_ratio
            );
        }
    }
    out
}

/// Write the map as CSV.
pub fn write_csv(map: &CliffMap, path: &Path) -> Result<(), MapError> {
    std::fs::write(path, write_csv_string(map)).map_err(|source| MapError::Io {
        file: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROWS: &str = "0,0,1.5,0.9,0.1,0.01,0.01,0.2,0.6,1,1\n0,0,4.5,1.1,0.1,0,0,0.2,0.4,1,1\n0.5,0,3,1,0.3,0,0,0.1,1,1,0.25\n";

    #[test]
    fn groups_rows_into_locations_and_round_trips() {
        let m = read_csv_str(ROWS).unwrap();
        assert_eq!(m.locations().len(), 2);
        assert_eq!(m.locations()[0].components.len(), 2);
        assert_eq!(write_csv_string(&m), ROWS);
    }

    fn err(text: &str) -> String {
        read_csv_str(text).unwrap_err().to_string()
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = err("0,0,1,1,0.1,0,0,0.1,1,1,1\n0,1,1,1,0.1,0,0,0.1,1,1\n");
        assert!(
            e.contains("<string>:2") && e.contains("expected 11 columns, found 10"),
            "{e}"
        );
        let e = err("0,0,1,abc,0.1,0,0,0.1,1,1,1\n");
        assert!(
            e.contains(":1: column 4") && e.contains("'abc' is not a number"),
            "{e}"
        );
        let e = err("0,0,1,1,0.1,0,0,NaN,1,1,1\n");
        assert!(e.contains("column 8") && e.contains("not finite"), "{e}");
        let e = err("0,0,1,-1,0.1,0,0,0.1,1,1,1\n");
        assert!(
            e.contains("column 4") && e.contains("negative speed"),
            "{e}"
        );
        let e = err("0,0,1,1,0.1,0,0,0.1,-0.5,1,1\n");
        assert!(
            e.contains("column 9") && e.contains("negative weight"),
            "{e}"
        );
        let e = err(
            "0,0,1,1,0.1,0,0,0.1,1,1,1\n1,0,1,1,0.1,0,0,0.1,1,1,1\n1.5,0.2,1,1,0.1,0,0,0.1,1,1,1\n",
        );
        assert!(e.contains(":3:") && e.contains("off the grid"), "{e}");
        let e = err("\n\n");
        assert!(e.contains("no map rows"), "{e}");
    }

    #[test]
    fn absurd_coordinates_steps_and_counts_are_errors_with_line_and_column() {
        const ROW: &str = "0,0,1,1,0.1,0,0,0.1,1,1,1\n";
        // The known case: one x of 1e20 used to overflow the grid's cell count and panic.
        let e = err(&format!("{ROW}1e20,0,1,1,0.1,0,0,0.1,1,1,1\n"));
        assert!(
            e.contains("<string>:2: column 1") && e.contains("beyond 1000000 m"),
            "{e}"
        );
        let e = err(&format!("{ROW}0,-3e6,1,1,0.1,0,0,0.1,1,1,1\n"));
        assert!(e.contains(":2: column 2"), "{e}");
        // within the coordinate bound, but a bounding box of 4e12 cells at 0.5 m
        let e = err(&format!(
            "{ROW}0.5,0,1,1,0.1,0,0,0.1,1,1,1\n-1e6,1e6,1,1,0.1,0,0,0.1,1,1,1\n"
        ));
        assert!(
            e.contains("<string>:3: column 1") && e.contains("cells"),
            "{e}"
        );
        // a smallest spacing of 0.1 mm: the inferred step is below 1 mm
        let e = err(&format!("{ROW}0.0001,0,1,1,0.1,0,0,0.1,1,1,1\n"));
        assert!(e.contains(":1: column 1") && e.contains("grid step"), "{e}");
        // two locations 5 km apart: a 5 km grid step
        let e = err(&format!("{ROW}5000,0,1,1,0.1,0,0,0.1,1,1,1\n"));
        assert!(e.contains("grid step 5000.0 m is not in"), "{e}");
        // component values and counts
        let e = err("0,0,1,1,1e7,0,0,0.1,1,1,1\n");
        assert!(e.contains(":1: column 5") && e.contains("beyond"), "{e}");
        let e = err("0,0,1,2e6,0.1,0,0,0.1,1,1,1\n");
        assert!(e.contains(":1: column 4") && e.contains("speed"), "{e}");
        let e = err("0,0,1,1,0.1,0,0,0.1,1e308,1,1\n0,0,1,1,0.1,0,0,0.1,1e308,1,1\n");
        assert!(
            e.contains(":1: column 9") && e.contains("sum to inf"),
            "{e}"
        );
        let e = err("0,0,1,1,0.1,0,0,0.1,0,1,1\n");
        assert!(e.contains(":1: column 9") && e.contains("sum to 0"), "{e}");
        let e = err(&ROW.repeat(MAX_COMPONENTS + 1));
        assert!(
            e.contains(&format!(":{}: column 0", MAX_COMPONENTS + 1))
                && e.contains("more than 64 components"),
            "{e}"
        );
        assert!(read_csv_str(&ROW.repeat(MAX_COMPONENTS)).is_ok());
        // bytes that are not UTF-8
        let e = read_csv_bytes(b"0,0,1,1,0.1,0,0,0.1,1,1,1\n0,\xff", "m.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("m.csv:2: column 3: not UTF-8"), "{e}");
    }

    #[test]
    fn shipped_maps_load_with_expected_counts() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data");
        for (f, locs, comps, step) in [
            ("thor1/cliffmap.csv", 309, 527, 0.5),
            ("thor3/cliffmap.csv", 308, 474, 0.5),
            ("atc/cliffmap-20121024.csv", 1368, 2423, 1.0),
        ] {
            let path = Path::new(dir).join(f);
            let m = read_csv(&path).unwrap();
            let info = m.info();
            assert_eq!((info.locations, info.components), (locs, comps), "{f}");
            assert!(
                (info.grid_step - step).abs() < 1e-9,
                "{f}: {}",
                info.grid_step
            );
            // written back, the text is the same values
            let text = std::fs::read_to_string(&path).unwrap();
            let back = read_csv_str(&write_csv_string(&m)).unwrap();
            assert_eq!(back.locations(), m.locations(), "{f}");
            assert_eq!(write_csv_string(&m).lines().count(), text.lines().count());
        }
    }
}
