//! Thirty people from THÖR1 (round 2 of the recording), for the node's benchmark and its
//! allocation test: the recording holds at most 8 people at once, so 30 of its tracks,
//! each started at its own first row, walk side by side (ids `p0`..`p29`), one People
//! message per 0.4 s in the map frame.

use cliff_ros2::msg::{Header, People, Person, Point, Time};

/// The recording, relative to the crate.
pub const TRACKS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../shared/data/thor1/exp-1-run-2.csv"
);
/// Its map.
pub const MAP: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../shared/data/thor1/cliffmap.csv"
);

/// Per person, positions every 0.4 s (each track's rows binned by round(t / 0.4)).
pub struct Thor30 {
    paths: Vec<Vec<(f64, f64)>>,
}

impl Thor30 {
    /// Load the recording: the 30 longest tracks.
    pub fn load() -> Thor30 {
        let text = std::fs::read_to_string(TRACKS).expect("THÖR1 round 2 in ../shared/data");
        let mut by_id: std::collections::BTreeMap<
            u64,
            std::collections::BTreeMap<i64, (f64, f64)>,
        > = Default::default();
        for line in text.lines() {
            let f: Vec<&str> = line.split(',').collect();
            if f.len() < 4 {
                continue;
            }
            let (Ok(t), Ok(id), Ok(x), Ok(y)) = (
                f[0].parse::<f64>(),
                f[1].parse::<f64>(),
                f[2].parse::<f64>(),
                f[3].parse::<f64>(),
            ) else {
                continue;
            };
            by_id
                .entry(id as u64)
                .or_default()
                .insert((t / 0.4).round() as i64, (x, y));
        }
        let mut paths: Vec<Vec<(f64, f64)>> = by_id
            .into_values()
            .map(|m| m.into_values().collect())
            .filter(|p: &Vec<(f64, f64)>| p.len() >= 10)
            .collect();
        paths.sort_by_key(|p| std::cmp::Reverse(p.len()));
        // fewer than 30 tracks: reuse them, shifted along their own path
        let base = paths.len();
        assert!(base > 0, "no tracks in {TRACKS}");
        let mut i = 0;
        while paths.len() < 30 {
            let mut p = paths[i % base].clone();
            let by = (i / base + 1) * 7 % p.len();
            p.rotate_left(by);
            paths.push(p);
            i += 1;
        }
        paths.truncate(30);
        Thor30 { paths }
    }

    /// Message `n` (stamp n × 0.4 s): every person at its step `n` (its path repeats).
    pub fn message(&self, n: usize) -> People {
        let mut m = People {
            header: Header {
                stamp: Time::default(),
                frame_id: "map".into(),
            },
            people: Vec::with_capacity(30),
        };
        for (j, _) in self.paths.iter().enumerate() {
            m.people.push(Person {
                name: format!("p{j}"),
                ..Person::default()
            });
        }
        self.update(&mut m, n);
        m
    }

    /// Make `m` (from [`Thor30::message`]) message `n`, in place.
    pub fn update(&self, m: &mut People, n: usize) {
        m.header.stamp = Time::from_secs_f64(n as f64 * 0.4);
        for (p, path) in m.people.iter_mut().zip(&self.paths) {
            let (x, y) = path[n % path.len()];
            p.position = Point { x, y, z: 0.0 };
        }
    }
}
