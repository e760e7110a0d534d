//! Windows along long recordings: how they slide, what they keep, and the MAGNI
//! challenge setting on the real recording.

use cliff::eval::protocol::{Protocol, Settings, prepare, prepare_all};
use cliff::tracks::{Row, Track};
use glam::DVec2;

fn challenge() -> Settings {
    Settings {
        protocol: Protocol::Windows,
        obs: 3.2,
        dt: 0.4,
        horizon: 4.8,
        window_every: 4.0,
        ..Settings::default()
    }
}

/// A person at 0.4 s rows: walking east at 1 m/s, except standing still for
/// `stand` seconds from `stand_from`; rows missing in `gap`.
fn track(n: usize, stand_from: f64, stand: f64, gap: (f64, f64)) -> Track {
    let mut x = 0.0;
    let mut rows = Vec::new();
    for i in 0..n {
        let t = i as f64 * 0.4;
        let standing = t > stand_from && t <= stand_from + stand;
        if i > 0 && !standing {
            x += 0.4;
        }
        if t > gap.0 && t < gap.1 {
            continue;
        }
        rows.push(Row {
            t,
            position: DVec2::new(x, 0.0),
            speed: if standing { 0.0 } else { 1.0 },
            angle: 0.0,
        });
    }
    Track { id: 3, rows }
}

#[test]
fn windows_slide_along_the_track() {
    let t = track(101, 1e9, 0.0, (1e9, 1e9)); // 40 s of walking
    let cases = prepare_all(std::slice::from_ref(&t), &challenge());
    // starts every 4 s while start + 3.2 + 0.4 <= 40: 0, 4, ..., 36
    assert_eq!(cases.len(), 10);
    for (m, c) in cases.iter().enumerate() {
        let t_w = 4.0 * m as f64;
        assert_eq!(c.window, m as u32 + 1);
        assert_eq!(c.observed.len(), 8);
        assert!((c.start.time - (t_w + 3.2)).abs() < 1e-9);
        assert!((c.start.position.x - (t_w + 3.2)).abs() < 1e-9);
        assert!((c.start.speed - 1.0).abs() < 1e-12);
        // 12 steps where the track lasts, fewer at its end
        let left = 40.0 - c.start.time;
        assert_eq!(
            c.steps,
            if left >= 4.8 {
                12
            } else {
                (left / 0.4 + 1e-9) as usize
            }
        );
        assert!(c.future.last().unwrap().t <= c.start.time + 4.8 + 1e-6);
    }
    // distinct windows of one person draw distinct seeds
    assert_ne!(cases[0].seed_key(), cases[1].seed_key());
    // the first window is what `prepare` gives
    assert_eq!(prepare(&t, &challenge()).unwrap(), cases[0]);
    // only the windows with 4.8 s of ground truth: the last one (from 36 s) is shorter
    let full = Settings {
        full_horizon_only: true,
        ..challenge()
    };
    let kept = prepare_all(std::slice::from_ref(&t), &full);
    assert_eq!(kept.len(), 9);
    assert!(kept.iter().all(|c| c.steps == 12));
    // back to back (window_every 0): starts at 0, 8, ..., 32
    let s = Settings {
        window_every: 0.0,
        ..challenge()
    };
    assert_eq!(prepare_all(std::slice::from_ref(&t), &s).len(), 5);
}

#[test]
fn idle_filter_and_gaps_apply_per_window() {
    // standing from 12 s to 22 s: the seconds protocol drops the whole person, the
    // windows protocol only the windows with 4 s of standing... or of little motion
    let t = track(101, 12.0, 10.0, (1e9, 1e9));
    let seconds = Settings {
        protocol: Protocol::Seconds,
        ..challenge()
    };
    assert!(prepare(&t, &seconds).is_none());
    let kept: Vec<u32> = prepare_all(std::slice::from_ref(&t), &challenge())
        .iter()
        .map(|c| c.window)
        .collect();
    // window m covers [4(m-1), 4(m-1) + 8]; it is idle when a 4 s span in it moves
    // less than 1 m, i.e. when 4 s of it hold more than 3 s of the standing [12, 22]:
    // windows 3 to 5 ([8, 16] to [16, 24])
    assert_eq!(kept, vec![1, 2, 6, 7, 8, 9, 10]);
    // rows missing from 20 s to 21 s (a 1.2 s gap): windows are cut at the gap
    let t = track(101, 1e9, 0.0, (20.0, 21.0));
    let cases = prepare_all(std::slice::from_ref(&t), &challenge());
    for c in &cases {
        assert!(c.future.windows(2).all(|w| w[1].t - w[0].t < 0.8 + 1e-9));
        assert!(c.observed.windows(2).all(|w| w[1].t - w[0].t < 0.8 + 1e-9));
    }
    // window 5 ([16, 24]) observes 16..19.2, predicts from 19.2 up to the gap (0.8 s)
    let w5 = cases.iter().find(|c| c.window == 5).unwrap();
    assert_eq!(w5.steps, 2);
    // window 6 starts at 20 s, inside the gap: skipped
    assert!(cases.iter().all(|c| c.window != 6));
}

#[test]
fn challenge_windows_on_the_magni_recording() {
    use cliff::tracks::{Columns, read_named};
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/data/magni/magni-A-first-16min.csv"
    );
    let tracks = read_named(path.as_ref(), &Columns::magni()).unwrap().tracks;
    let s = challenge();
    let cases = prepare_all(&tracks, &s);
    let seconds = Settings {
        protocol: Protocol::Seconds,
        ..s
    };
    // every helmet waits somewhere: the whole-track protocol keeps nobody
    assert_eq!(
        tracks.iter().filter_map(|t| prepare(t, &seconds)).count(),
        0
    );
    // but many walking windows remain (2,000 s of tracks at one window per 4 s)
    assert!(cases.len() > 300, "{}", cases.len());
    let mut keys = std::collections::HashSet::new();
    for c in &cases {
        assert!(keys.insert(c.seed_key()));
        // 3.2 s observed: 8 rows, give or take a row missing (a gap of 0.8 s at most)
        // or doubled (a 0.01 s shift of the clock)
        assert!((7..=9).contains(&c.observed.len()), "{}", c.observed.len());
        let observed = c.start.time - c.observed[0].t;
        assert!((3.2 - 1e-6..3.2 + 0.8).contains(&observed), "{observed}");
        assert!(c.steps >= 1 && c.steps <= 12);
        // the window walks: at least 1 m in every 4 s of it
        let rows: Vec<_> = c.observed.iter().chain(&c.future).collect();
        let span = rows.last().unwrap().t - rows[0].t;
        let moved = rows[0].position.distance(rows.last().unwrap().position);
        assert!(
            span < 4.0 || moved >= 1.0,
            "window {} of {}",
            c.window,
            c.id
        );
    }
    // most windows predict the full 12 rows
    let full = cases.iter().filter(|c| c.steps == 12).count();
    assert!(full * 10 > cases.len() * 8, "{full} of {}", cases.len());
}
