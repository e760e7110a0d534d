//! The speed prior of a long recording with few people: the first 8 minutes of the
//! THÖR-MAGNI recording hold 9 helmets, too few people for pairs as the `seconds`
//! protocol takes them, so the prior is fitted from windows along the tracks. The test
//! cuts the windows itself from the CSV rows (its own reading, windows, idle filter,
//! velocity kernel and path speeds, written from the documented rules) and fits the
//! line by least squares; the library's prior must agree.

use std::collections::BTreeMap;
use std::path::Path;

use cliff::eval::speed_prior_fit::{FIT_HORIZONS, FIT_WINDOW_EVERY, MIN_PAIRS};
use cliff::motion::SpeedPrior;
use cliff::tracks::{Format, keep_time_range, read_tracks};

const FILE: &str = "../shared/data/magni/magni-A-first-16min.csv";
const UNTIL: f64 = 480.0;
const OBS: f64 = 3.2;
const DT: f64 = 0.4;

#[derive(Clone, Copy)]
struct Row {
    t: f64,
    x: f64,
    y: f64,
    speed: f64,
}

/// The helmets' rows before `UNTIL`, by helmet, in time order, read from the CSV by its
/// header.
fn helmets() -> Vec<Vec<Row>> {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(FILE)).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| h.trim() == name).unwrap();
    let (ct, cid, cx, cy, cs) = (col("Time"), col("ag_id"), col("x"), col("y"), col("speed"));
    let mut by_id: BTreeMap<String, Vec<Row>> = BTreeMap::new();
    for line in lines.filter(|l| !l.trim().is_empty()) {
        let f: Vec<&str> = line.split(',').collect();
        let num = |i: usize| f[i].trim().parse::<f64>().unwrap();
        let row = Row {
            t: num(ct),
            x: num(cx),
            y: num(cy),
            speed: num(cs),
        };
        if row.t < UNTIL {
            by_id
                .entry(f[cid].trim().to_string())
                .or_default()
                .push(row);
        }
    }
    let mut out: Vec<Vec<Row>> = by_id.into_values().collect();
    for rows in &mut out {
        rows.sort_by(|a, b| a.t.total_cmp(&b.t));
    }
    out
}

/// Linear interpolation of a row value at `t` (inside the rows).
fn at(rows: &[Row], t: f64, f: impl Fn(&Row) -> f64) -> f64 {
    let i = rows.partition_point(|r| r.t < t);
    if i == 0 {
        return f(&rows[0]);
    }
    if i == rows.len() {
        return f(&rows[i - 1]);
    }
    let (a, b) = (&rows[i - 1], &rows[i]);
    let w = (t - a.t) / (b.t - a.t);
    f(a) + w * (f(b) - f(a))
}

/// (start speed, mean path speed over `h`) of the window of `rows` starting at `t_w`,
/// or `None` if it is skipped or does not reach `h` ahead.
fn window_pair(rows: &[Row], t_w: f64, h: f64) -> Option<(f64, f64)> {
    let gap = 2.0 * DT;
    let i0 = rows.iter().position(|r| r.t >= t_w - 1e-6)?;
    if rows[i0].t > t_w + gap {
        return None; // the window begins inside a tracking gap
    }
    // the rows of the window: up to obs + h after its first row, cut at the first gap
    let mut n = i0 + 1;
    while n < rows.len()
        && rows[n].t <= rows[i0].t + OBS + h + 1e-6
        && rows[n].t - rows[n - 1].t <= gap + 1e-9
    {
        n += 1;
    }
    let w = &rows[i0..n];
    let s = w.iter().position(|r| r.t >= w[0].t + OBS - 1e-6)?;
    let (start, last) = (w[s], w[w.len() - 1]);
    if last.t - start.t < h - 1e-9 {
        return None;
    }
    // idle: less than 1 m covered in some 4 s of the window
    for r in w {
        if r.t + 4.0 > last.t + 1e-9 {
            break;
        }
        let (x, y) = (at(w, r.t + 4.0, |q| q.x), at(w, r.t + 4.0, |q| q.y));
        if (x - r.x).hypot(y - r.y) < 1.0 {
            return None;
        }
    }
    // start speed: the speed column at 0.4 s, 0.8 s, ... 3.2 s before the start,
    // weighted exp(-k^2 / (2 1.5^2)), the most recent (k = 1) most
    let (mut sum, mut total) = (0.0, 0.0);
    for k in 1..=8 {
        let t = start.t - k as f64 * DT;
        if t < w[0].t - 1e-9 {
            continue;
        }
        let weight = (-(k * k) as f64 / (2.0 * 1.5 * 1.5)).exp();
        sum += weight * at(&w[..=s], t, |q| q.speed);
        total += weight;
    }
    let v0 = sum / total;
    // the path from the start through the rows up to h ahead
    let mut length = 0.0;
    let (mut px, mut py) = (start.x, start.y);
    for r in &w[s + 1..] {
        if r.t > start.t + h + 1e-9 {
            break;
        }
        length += (r.x - px).hypot(r.y - py);
        (px, py) = (r.x, r.y);
    }
    Some((v0, length / h))
}

#[test]
fn the_first_eight_minutes_of_magni_get_a_prior_from_windows_that_a_direct_fit_agrees_with() {
    let mut tracks = read_tracks(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join(FILE),
        Format::Magni,
    )
    .unwrap();
    keep_time_range(&mut tracks, f64::NEG_INFINITY, UNTIL);
    // as people, at most one pair per helmet and horizon: too few
    assert!(
        tracks.len() * FIT_HORIZONS.len() < MIN_PAIRS,
        "{} tracks",
        tracks.len()
    );
    let prior = SpeedPrior::fit_tracks(&tracks).expect("a prior from windows");

    // the same from the rows, directly
    let mut pairs = vec![];
    for rows in helmets() {
        let (first, last) = (rows[0].t, rows[rows.len() - 1].t);
        for m in 0.. {
            let t_w = first + f64::from(m) * FIT_WINDOW_EVERY;
            if t_w + OBS + DT > last + 1e-6 {
                break;
            }
            for h in FIT_HORIZONS {
                if let Some((v0, ahead)) = window_pair(&rows, t_w, h)
                    && v0 <= 5.0
                    && ahead <= 5.0
                {
                    pairs.push((v0, ahead));
                }
            }
        }
    }
    let n = pairs.len() as f64;
    let mx = pairs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pairs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = pairs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pairs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let slope = sxy / sxx;
    let keep = slope.clamp(0.0, 1.0);
    let mean = (my - keep * mx) / (1.0 - keep);
    eprintln!(
        "{prior:?}; direct: {} pairs, slope {slope:.3}, keep {keep:.3}, mean {mean:.3} m/s",
        pairs.len()
    );
    assert!(pairs.len() >= MIN_PAIRS, "{} pairs", pairs.len());
    assert_eq!(prior.pairs, pairs.len() as u64, "{prior:?}");
    assert!((prior.keep - keep).abs() < 1e-6, "{prior:?} vs keep {keep}");
    assert!((prior.mean - mean).abs() < 1e-6, "{prior:?} vs mean {mean}");
    // on MAGNI the speed seen over 3.2 s says little about the next 10 s of walking
    assert!(slope.abs() < 0.2, "slope {slope}");
    assert!(prior.mean > 0.9 && prior.mean < 1.4, "{prior:?}");
}
