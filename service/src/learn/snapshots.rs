//! Learned maps on disk: one snapshot per version in the learning directory, written
//! atomically (temporary file, fsync, rename, fsync of the directory), checked at load
//! (the snapshot format's checksum), the newest good one found at start, the oldest
//! removed ([`write`], [`newest`]).
//!
//! Files of the map `NAME`, version `V`: `NAME.vV.cliff` (the map, a snapshot that
//! `cliffd --map` and `cliff` read: one map, or a time-of-day set with its learned
//! slices) and `NAME.vV.state` (a line of text: version, rows learned, the count scale of
//! each part that learns, comma-separated: one for a map, one per slice for a set),
//! both with `V` as 8 digits.

use cliff::map::MapSet;
use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Snapshots kept per map (older ones are removed after a new one is written).
pub const KEEP: usize = 3;

/// What is saved beside a learned map.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Saved {
    pub version: u32,
    pub rows: u64,
    /// Per part that learns (one for a map, one per slice of a set): its count scale,
    /// `None` when not known yet.
    pub count_scales: Vec<Option<f64>>,
}

fn file(dir: &Path, name: &str, version: u32, ext: &str) -> PathBuf {
    dir.join(format!("{name}.v{version:08}.{ext}"))
}

/// Write `bytes` to `path` atomically: a temporary file beside it, fsync, rename over
/// `path`, fsync of the directory. A crash at any point leaves either the old file or
/// the new one, whole.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let tmp = path.with_extension(format!(
        "{}.tmp",
        path.extension().and_then(|e| e.to_str()).unwrap_or("")
    ));
    {
        let mut f = File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
    }
    fs::rename(&tmp, path)?;
    File::open(dir)?.sync_all()
}

/// Write version `saved.version` of the learned map `name` into `dir` (created when
/// missing), then remove all but the newest [`KEEP`] versions; the map file's path.
pub(crate) fn write(
    dir: &Path,
    name: &str,
    set: &MapSet,
    saved: &Saved,
) -> Result<PathBuf, String> {
    let err = |what: &str, p: &Path, e: std::io::Error| format!("{what} {}: {e}", p.display());
    fs::create_dir_all(dir).map_err(|e| err("cannot create", dir, e))?;
    let state = file(dir, name, saved.version, "state");
    let scales: Vec<String> = saved
        .count_scales
        .iter()
        .map(|c| c.map_or("-".to_string(), |c| c.to_string()))
        .collect();
    let line = format!(
        "version {} rows {} count_scale {}\n",
        saved.version,
        saved.rows,
        if scales.is_empty() {
            "-".to_string()
        } else {
            scales.join(",")
        }
    );
    write_atomic(&state, line.as_bytes()).map_err(|e| err("cannot write", &state, e))?;
    let path = file(dir, name, saved.version, "cliff");
    let bytes = set.to_snapshot_bytes();
    write_atomic(&path, &bytes).map_err(|e| err("cannot write", &path, e))?;
    for old in versions(dir, name).into_iter().skip(KEEP) {
        for ext in ["cliff", "state"] {
            let _ = fs::remove_file(file(dir, name, old, ext));
        }
    }
    Ok(path)
}

/// The versions of `name` with a map file in `dir`, newest first.
pub(crate) fn versions(dir: &Path, name: &str) -> Vec<u32> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Vec::new();
    };
    let prefix = format!("{name}.v");
    let mut v: Vec<u32> = entries
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let f = e.file_name().into_string().ok()?;
            let digits = f.strip_prefix(&prefix)?.strip_suffix(".cliff")?;
            (digits.len() == 8 && digits.bytes().all(|b| b.is_ascii_digit()))
                .then(|| digits.parse().ok())?
        })
        .collect();
    v.sort_unstable_by(|a, b| b.cmp(a));
    v
}

/// Remove the temporary files of `name` that a write killed half-way left in `dir`.
pub(crate) fn remove_temporaries(dir: &Path, name: &str) -> usize {
    let Ok(entries) = fs::read_dir(dir) else {
        return 0;
    };
    let prefix = format!("{name}.v");
    entries
        .filter_map(|e| e.ok())
        .filter(|e| {
            e.file_name()
                .to_str()
                .is_some_and(|f| f.starts_with(&prefix) && f.ends_with(".tmp"))
        })
        .filter(|e| fs::remove_file(e.path()).is_ok())
        .count()
}

/// The newest version of `name` in `dir` that loads (its checksum and checks pass) and
/// that `fits` (`Err`: why not, e.g. a snapshot of a map of another shape), with what was
/// saved beside it; the files that failed, with why, in `skipped`.
pub(crate) fn newest(
    dir: &Path,
    name: &str,
    fits: impl Fn(&MapSet) -> Result<(), String>,
    skipped: &mut Vec<String>,
) -> Option<(MapSet, Saved)> {
    for v in versions(dir, name) {
        let path = file(dir, name, v, "cliff");
        match MapSet::load(&path)
            .map_err(|e| e.to_string())
            .and_then(|set| {
                fits(&set)?;
                Ok(set)
            }) {
            Ok(set) => {
                let saved = read_state(&file(dir, name, v, "state"), v);
                return Some((set, saved));
            }
            Err(e) => skipped.push(format!("{}: {e}", path.display())),
        }
    }
    None
}

/// The state line of version `v` (a missing or unreadable one: no rows, no count scale).
fn read_state(path: &Path, v: u32) -> Saved {
    let mut saved = Saved {
        version: v,
        rows: 0,
        count_scales: Vec::new(),
    };
    let Ok(text) = fs::read_to_string(path) else {
        return saved;
    };
    let words: Vec<&str> = text.split_whitespace().collect();
    if let ["version", version, "rows", rows, "count_scale", scale] = words[..]
        && version.parse() == Ok(v)
    {
        saved.rows = rows.parse().unwrap_or(0);
        saved.count_scales = scale
            .split(',')
            .map(|c| c.parse().ok().filter(|c: &f64| c.is_finite() && *c > 0.0))
            .collect();
    }
    saved
}

/// Whether `name` can name snapshot files: letters, digits, `-`, `_` and `.`, not
/// starting with a dot.
pub(crate) fn usable_name(name: &str) -> bool {
    !name.is_empty()
        && !name.starts_with('.')
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_' || b == b'.')
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use cliff::map::{CliffMap, SetParts};

    use super::*;

    fn any(_: &MapSet) -> Result<(), String> {
        Ok(())
    }

    #[test]
    fn versions_are_written_kept_and_found_newest_first() {
        let dir = tempfile::tempdir().unwrap();
        let map = MapSet::single(CliffMap::demo());
        for v in 1..=5 {
            let saved = Saved {
                version: v,
                rows: 100 * v as u64,
                count_scales: vec![Some(40.5)],
            };
            write(dir.path(), "hall", &map, &saved).unwrap();
        }
        assert_eq!(versions(dir.path(), "hall"), vec![5, 4, 3]);
        let mut skipped = Vec::new();
        let (back, saved) = newest(dir.path(), "hall", any, &mut skipped).unwrap();
        assert_eq!(back.all_day().locations(), map.all_day().locations());
        assert_eq!(
            (saved.version, saved.rows, saved.count_scales),
            (5, 500, vec![Some(40.5)])
        );
        // a damaged newest file is skipped (checksum), the one before it is loaded
        let p = file(dir.path(), "hall", 5, "cliff");
        let mut bytes = fs::read(&p).unwrap();
        let mid = bytes.len() / 2;
        bytes[mid] ^= 0x40;
        fs::write(&p, bytes).unwrap();
        let (_, saved) = newest(dir.path(), "hall", any, &mut skipped).unwrap();
        assert_eq!(saved.version, 4);
        assert_eq!(skipped.len(), 1);
        assert!(
            skipped[0].contains("hall.v00000005.cliff"),
            "{}",
            skipped[0]
        );
        // a snapshot that does not fit is skipped, with why
        skipped.clear();
        let (_, saved) = newest(
            dir.path(),
            "hall",
            |s: &MapSet| (!s.is_sliced()).then_some(()).ok_or("sliced".into()),
            &mut skipped,
        )
        .unwrap();
        assert_eq!(saved.version, 4);
        let none = newest(
            dir.path(),
            "hall",
            |_: &MapSet| Err("a set of 24 slices expected".into()),
            &mut skipped,
        );
        assert!(none.is_none());
        assert!(
            skipped
                .iter()
                .any(|s| s.contains("hall.v00000004.cliff: a set of 24 slices expected")),
            "{skipped:?}"
        );
        // no temporary file is left behind
        let names: Vec<String> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
        assert!(usable_name("atc-1h") && !usable_name("../x") && !usable_name(".x"));
    }

    #[test]
    fn a_time_of_day_set_is_saved_whole_with_a_count_scale_per_slice() {
        let dir = tempfile::tempdir().unwrap();
        let demo = Arc::new(CliffMap::demo());
        let mut slices = vec![None; 24];
        slices[10] = Some(Arc::clone(&demo));
        let set = MapSet::from_parts(SetParts {
            all_day: Arc::new(CliffMap::demo()),
            slices,
            slice_length: 3600.0,
            clock_offset: 32400.0,
            smoothing: None,
            observations: Vec::new(),
        })
        .unwrap();
        let mut scales = vec![None; 24];
        scales[10] = Some(12.0);
        scales[3] = Some(0.5);
        let saved = Saved {
            version: 7,
            rows: 1234,
            count_scales: scales.clone(),
        };
        write(dir.path(), "atc", &set, &saved).unwrap();
        let (back, read) = newest(dir.path(), "atc", any, &mut Vec::new()).unwrap();
        assert_eq!(read, saved);
        assert_eq!(back.slices().len(), 24);
        assert_eq!(back.clock_offset(), 32400.0);
        assert!(back.slices()[10].is_some() && back.slices()[9].is_none());
        // a state line of one map's learner reads as one part
        fs::write(
            file(dir.path(), "atc", 7, "state"),
            "version 7 rows 1 count_scale 40\n",
        )
        .unwrap();
        let (_, read) = newest(dir.path(), "atc", any, &mut Vec::new()).unwrap();
        assert_eq!(read.count_scales, vec![Some(40.0)]);
    }
}
