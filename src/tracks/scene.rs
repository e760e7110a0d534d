//! Synthetic people walking in the built-in demo hall ([`CliffMap::demo`]), so that
//! predictions, evaluations and pictures run on a fresh machine without data.
//!
//! People enter the 30 m x 20 m hall at one end of a corridor, walk along it in its
//! lane (eastbound walkers keep to the south half of the east-west corridor,
//! westbound to the north half, northbound to the east half of the north-south
//! corridor, southbound to the west half, as the demo map's weights say), and some
//! turn left or right into the other corridor at the crossing. They leave the hall at
//! its edge. Rows come every [`SceneOptions::dt`] seconds, with time, position,
//! speed and motion angle as in a THÖR file ([`Row`]).
//!
//! The same options give the same tracks, on every machine.
//!
//! ```
//! use cliff::tracks::scene::{demo_tracks, SceneOptions};
//! let tracks = demo_tracks(&SceneOptions::default());
//! assert_eq!(tracks.len(), SceneOptions::default().people);
//! let first = &tracks[0];
//! assert!(first.rows.len() > 20);
//! // rows at 0.4 s, inside the hall
//! assert!((first.rows[1].t - first.rows[0].t - 0.4).abs() < 1e-9);
//! assert!(first.rows.iter().all(|r| r.position.x.abs() <= 15.0 && r.position.y.abs() <= 10.0));
//! ```
//!
//! [`CliffMap::demo`]: crate::map::CliffMap::demo

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::fmt::Write as _;

use glam::DVec2;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;

use super::track::{Row, Track};

/// Half the hall's length along x (m).
pub const HALL_HALF_LENGTH: f64 = 15.0;
/// Half the hall's width along y (m).
pub const HALL_HALF_WIDTH: f64 = 10.0;

/// How [`demo_tracks`] makes people.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneOptions {
    /// Number of people (ids `1..=people`).
    pub people: usize,
    /// Seed of the generator.
    pub seed: u64,
    /// Time between rows (s); THÖR records at 0.4 s.
    pub dt: f64,
    /// Share of the people who turn into the other corridor at the crossing.
    pub turn_share: f64,
    /// Time between two people entering the hall (s).
    pub spacing: f64,
}

impl Default for SceneOptions {
    /// 40 people, seed 7, rows at 0.4 s, 35 % turning, one entering every 2 s.
    fn default() -> Self {
        SceneOptions {
            people: 40,
            seed: 7,
            dt: 0.4,
            turn_share: 0.35,
            spacing: 2.0,
        }
    }
}

/// A walking direction in the hall.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Dir {
    East,
    North,
    West,
    South,
}

impl Dir {
    fn from_index(i: usize) -> Dir {
        [Dir::East, Dir::North, Dir::West, Dir::South][i % 4]
    }

    fn angle(self) -> f64 {
        match self {
            Dir::East => 0.0,
            Dir::North => FRAC_PI_2,
            Dir::West => PI,
            Dir::South => 3.0 * FRAC_PI_2,
        }
    }

    /// The demo map's mean speed for this direction (m/s).
    fn speed(self) -> f64 {
        match self {
            Dir::East => 1.3,
            Dir::West => 1.2,
            Dir::North => 1.1,
            Dir::South => 1.0,
        }
    }

    /// A lane offset across the corridor: keep right.
    fn lane(self, u: f64) -> f64 {
        let off = 0.3 + 2.2 * u;
        match self {
            Dir::East | Dir::South => -off,
            Dir::West | Dir::North => off,
        }
    }

    fn along_x(self) -> bool {
        matches!(self, Dir::East | Dir::West)
    }

    /// A point on this direction's lane `lane` at coordinate `s` along the corridor.
    fn point(self, lane: f64, s: f64) -> DVec2 {
        if self.along_x() {
            DVec2::new(s, lane)
        } else {
            DVec2::new(lane, s)
        }
    }

    /// The coordinate along the corridor where the hall is entered / left.
    fn ends(self) -> (f64, f64) {
        let half = if self.along_x() {
            HALL_HALF_LENGTH
        } else {
            HALL_HALF_WIDTH
        };
        let inside = half - 0.2;
        match self {
            Dir::East | Dir::North => (-inside, half + 1.0),
            Dir::West | Dir::South => (inside, -half - 1.0),
        }
    }
}

/// Wrap an angle to `(-pi, pi]` as in the datasets' motion-angle column.
fn wrap_pi(a: f64) -> f64 {
    let w = (a + PI).rem_euclid(TAU) - PI;
    if w <= -PI { w + TAU } else { w }
}

/// Make the people of the demo hall (see the [module documentation](self)).
pub fn demo_tracks(options: &SceneOptions) -> Vec<Track> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(options.seed);
    let dt = if options.dt.is_finite() && options.dt > 0.0 {
        options.dt
    } else {
        0.4
    };
    let noise = Normal::new(0.0, 1.0).expect("unit normal");
    let mut tracks = Vec::with_capacity(options.people);
    for i in 0..options.people {
        let first = Dir::from_index(rng.random_range(0..4usize));
        let lane1 = first.lane(rng.random());
        let turns = rng.random::<f64>() < options.turn_share;
        let left: bool = rng.random();
        let (start_s, end_s) = first.ends();
        let mut waypoints = Vec::with_capacity(2);
        if turns {
            let second = Dir::from_index(first as usize + if left { 1 } else { 3 });
            let lane2 = second.lane(rng.random());
            // The corner where the two lanes cross, then out along the second corridor.
            let corner = if first.along_x() {
                DVec2::new(lane2, lane1)
            } else {
                DVec2::new(lane1, lane2)
            };
            waypoints.push(corner);
            waypoints.push(second.point(lane2, second.ends().1));
        } else {
            waypoints.push(first.point(lane1, end_s));
        }
        let preferred = (first.speed() + 0.12 * noise.sample(&mut rng)).clamp(0.7, 1.8);
        let t0 = i as f64 * options.spacing + rng.random::<f64>();
        let mut p = first.point(lane1, start_s);
        let mut heading = first.angle();
        let mut speed = preferred;
        let mut rows = vec![Row {
            t: t0,
            position: p,
            speed,
            angle: wrap_pi(heading),
        }];
        let mut w = 0;
        let max_turn = 0.45; // rad per row at 0.4 s: about 65 deg/s
        for step in 1..2000 {
            // Switch to the next waypoint early, so that people cut the corner.
            if w + 1 < waypoints.len() && p.distance(waypoints[w]) < 1.6 {
                w += 1;
            }
            let to = waypoints[w] - p;
            let want = to.to_angle();
            let diff = wrap_pi(want - heading);
            let turn = diff.clamp(-max_turn, max_turn) * (dt / 0.4).min(1.0);
            heading = wrap_pi(heading + turn + 0.03 * noise.sample(&mut rng));
            speed = (preferred + 0.7 * (speed - preferred) + 0.04 * noise.sample(&mut rng))
                .clamp(0.4, 2.2);
            let next = p + DVec2::from_angle(heading) * speed * dt;
            if next.x.abs() > HALL_HALF_LENGTH || next.y.abs() > HALL_HALF_WIDTH {
                break;
            }
            let step_v = (next - p) / dt;
            p = next;
            rows.push(Row {
                t: t0 + step as f64 * dt,
                position: p,
                speed: step_v.length(),
                angle: wrap_pi(step_v.to_angle()),
            });
        }
        tracks.push(Track {
            id: i as u64 + 1,
            rows,
        });
    }
    tracks
}

/// Tracks as THÖR-format CSV text (no header; `time, person_id, x, y, speed,
/// motion_angle`; rows in time order), readable by
/// [`read_tracks`](crate::tracks::read_tracks) with
/// [`Format::Thor`](crate::tracks::Format::Thor).
///
/// ```
/// use cliff::tracks::{parse_tracks, Format};
/// use cliff::tracks::scene::{demo_tracks, tracks_csv, SceneOptions};
/// let tracks = demo_tracks(&SceneOptions { people: 3, ..SceneOptions::default() });
/// let back = parse_tracks(&tracks_csv(&tracks), "demo.csv", Format::Thor).unwrap();
/// assert_eq!(back.len(), 3);
/// assert_eq!(back[2].rows.len(), tracks[2].rows.len());
/// ```
pub fn tracks_csv(tracks: &[Track]) -> String {
    let mut rows: Vec<(f64, u64, &Row)> = tracks
        .iter()
        .flat_map(|t| t.rows.iter().map(move |r| (r.t, t.id, r)))
        .collect();
    rows.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut s = String::with_capacity(rows.len() * 48);
    for (t, id, r) in rows {
        let _ = writeln!(
            s,
            "{t:.3},{id},{:.4},{:.4},{:.4},{:.4}",
            r.position.x, r.position.y, r.speed, r.angle
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_options_same_tracks_other_seed_other_tracks() {
        let a = demo_tracks(&SceneOptions::default());
        let b = demo_tracks(&SceneOptions::default());
        let c = demo_tracks(&SceneOptions {
            seed: 8,
            ..SceneOptions::default()
        });
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn speed_and_angle_columns_match_the_motion() {
        let tracks = demo_tracks(&SceneOptions::default());
        for t in &tracks {
            for w in t.rows.windows(2) {
                let v = (w[1].position - w[0].position) / (w[1].t - w[0].t);
                assert!((v.length() - w[1].speed).abs() < 1e-9);
                assert!(wrap_pi(v.to_angle() - w[1].angle).abs() < 1e-9);
            }
        }
    }
}
