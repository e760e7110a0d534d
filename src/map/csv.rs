//! The published CLiFF-map CSV format.
//!
//! No header; one row per mixture component with 11 columns:
//! `x, y, theta, rho, cov_tt, cov_tr, cov_rt, cov_rr, weight, motion_ratio, observation_ratio`.
//! All components of a location share its x and y.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use glam::DVec2;

use super::{CliffMap, Component, Location, MapError};

/// Number of columns of a map row.
pub const COLUMNS: usize = 11;

/// Read a map from a CSV file.
pub fn read_csv(path: &Path) -> Result<CliffMap, MapError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| MapError::Io {
        file: name.clone(),
        source,
    })?;
    parse(&text, &name)
}

/// Read a map from CSV text (errors name the file as `<string>`).
pub fn read_csv_str(text: &str) -> Result<CliffMap, MapError> {
    parse(text, "<string>")
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
        if v[3] < 0.0 {
            return Err(perr(line, 4, format!("negative speed {}", v[3])));
        }
        if v[8] < 0.0 {
            return Err(perr(line, 9, format!("negative weight {}", v[8])));
        }
        if v[9] < 0.0 {
            return Err(perr(line, 10, format!("negative motion ratio {}", v[9])));
        }
        if !(0.0..=1.0 + 1e-9).contains(&v[10]) {
            return Err(perr(
                line,
                11,
                format!("observation ratio {} is not in [0, 1]", v[10]),
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
            Some(&i) => locations[i].components.push(comp),
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
