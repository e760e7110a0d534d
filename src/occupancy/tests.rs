//! The occupancy calls against values worked out independently: the normal
//! distribution integrated over cells numerically, independence of people, the stop
//! rules, windows and plans on paths whose geometry is known.

use super::*;
use crate::predict::Point;

/// The mass of a normal of mean `mu` and sigma `s` over `[a, b]`, by the midpoint rule.
fn mass_1d(mu: f64, s: f64, a: f64, b: f64) -> f64 {
    let n = 400;
    let h = (b - a) / n as f64;
    (0..n)
        .map(|j| {
            let z = (a + (j as f64 + 0.5) * h - mu) / s;
            (-0.5 * z * z).exp() / (s * (2.0 * std::f64::consts::PI).sqrt()) * h
        })
        .sum()
}

/// Settings with no bandwidth: every kernel is the person's 0.3 m.
fn fixed() -> Settings {
    Settings {
        bandwidth_scale: 0.0,
        ..Settings::default()
    }
}

#[test]
fn one_sample_puts_the_normal_mass_of_each_cell_on_it() {
    let pos: [Point; 1] = [[0.13, -0.41]];
    let s = Samples::new(&pos, &[1], (1, 1, 1), 0.4).unwrap();
    let grid = GridSpec::around([0.0, 0.0], [4.0, 4.0], 0.1);
    let mut o = Occupancy::new();
    o.compute(&s, &grid, &[0.4], &fixed()).unwrap();
    for (r, c) in [(15, 21), (16, 21), (14, 25), (10, 20), (8, 18), (16, 12)] {
        let [x, y] = grid.cell_center(r, c);
        let want = mass_1d(0.13, 0.3, x - 0.05, x + 0.05) * mass_1d(-0.41, 0.3, y - 0.05, y + 0.05);
        // beyond 3 sigmas the kernel is cut
        let inside = (x - 0.13).abs() < 0.9 + 0.05 && (y + 0.41).abs() < 0.9 + 0.05;
        let got = o.at(0, r, c) as f64;
        if inside {
            assert!((got - want).abs() < 1e-5, "({r}, {c}): {got} vs {want}");
        } else {
            assert_eq!(got, 0.0, "({r}, {c})");
        }
    }
    // the whole cut kernel: (Phi(3) - Phi(-3))^2, give or take the cells cut partly
    let total: f64 = o.layer(0).iter().map(|&v| v as f64).sum();
    assert!((total - 0.9973f64.powi(2)).abs() < 3e-3, "{total}");
}

#[test]
fn people_combine_as_independent() {
    // two people of one sample each, 0.2 m apart
    let pos: [Point; 2] = [[0.0, 0.0], [0.2, 0.0]];
    let s = Samples::new(&pos, &[1, 1], (2, 1, 1), 1.0).unwrap();
    let grid = GridSpec::around([0.1, 0.0], [3.0, 3.0], 0.1);
    let set = fixed();
    let (mut both, mut a, mut b) = (Occupancy::new(), Occupancy::new(), Occupancy::new());
    both.compute(&s, &grid, &[1.0], &set).unwrap();
    a.compute_agent(&s, 0, &grid, &[1.0], &set).unwrap();
    b.compute_agent(&s, 1, &grid, &[1.0], &set).unwrap();
    let mut largest = 0.0f32;
    for i in 0..grid.cells() {
        let (pa, pb) = (a.layer(0)[i], b.layer(0)[i]);
        let want = 1.0 - (1.0 - pa) * (1.0 - pb);
        assert!((both.layer(0)[i] - want).abs() < 1e-6);
        largest = largest.max(both.layer(0)[i]);
    }
    // each person's densest cell holds about 1.8 % of them (0.1 m cells, 0.3 m sigma)
    assert!(largest > 0.03 && largest < 0.04, "{largest}");
    assert!(both.compute_agent(&s, 2, &grid, &[1.0], &set).is_err());
}

#[test]
fn stopped_samples_follow_the_stop_rule() {
    // four samples, two stop after the first of two steps; positions far apart
    let pos: [Point; 8] = [
        [0.0, 0.0],
        [0.0, 1.0],
        [3.0, 0.0],
        [3.0, 1.0],
        [0.0, 3.0],
        [f32::NAN; 2],
        [3.0, 3.0],
        [f32::NAN; 2],
    ];
    let s = Samples::new(&pos, &[2, 2, 1, 1], (1, 4, 2), 1.0).unwrap();
    let grid = GridSpec::covering([-2.0, -2.0], [5.0, 6.0], 0.1);
    let sum = |o: &Occupancy| o.layer(0).iter().map(|&v| v as f64).sum::<f64>();
    let cut = 0.9973f64.powi(2);
    let mut o = Occupancy::new();
    let mut set = fixed();
    // the samples far apart (more than 6 sigmas), so the people's masses add
    set.stopped = Stopped::Renormalise;
    o.compute(&s, &grid, &[2.0], &set).unwrap();
    assert!((sum(&o) - cut).abs() < 5e-3, "{}", sum(&o));
    assert_eq!(o.coverage(0, 0), 0.5);
    set.stopped = Stopped::Drop;
    o.compute(&s, &grid, &[2.0], &set).unwrap();
    assert!((sum(&o) - cut / 2.0).abs() < 5e-3, "{}", sum(&o));
    set.stopped = Stopped::Hold;
    o.compute(&s, &grid, &[2.0], &set).unwrap();
    assert!((sum(&o) - cut).abs() < 5e-3);
    let (r, c) = grid.cell_of(0.01, 3.01).unwrap();
    // the held sample of the four, where it stopped
    let want = 0.25 * mass_1d(0.0, 0.3, 0.0, 0.1) * mass_1d(3.0, 0.3, 3.0, 3.1);
    assert!(
        (o.at(0, r, c) as f64 - want).abs() < 1e-5,
        "{}",
        o.at(0, r, c)
    );
    // a time outside what the samples cover is refused and named
    let e = o.compute(&s, &grid, &[1.0, 2.5], &set).unwrap_err();
    assert!(matches!(e, OccupancyError::Time { index: 1, .. }), "{e}");
}

#[test]
fn a_window_counts_futures_that_pass_through_a_cell() {
    // one person, two samples walking along x at 1 m/s on rows 2 m apart; the second
    // starts 2 m behind: both cross x = 2 in [0, 4] s, at 2 s and 4 s
    let mut pos: Vec<Point> = Vec::new();
    for j in 1..=4 {
        pos.push([j as f32, 0.0]);
    }
    for j in 1..=4 {
        pos.push([j as f32 - 2.0, 0.0]);
    }
    let s = Samples::new(&pos, &[4, 4], (1, 2, 4), 1.0).unwrap();
    let grid = GridSpec::around([2.0, 0.0], [8.0, 3.0], 0.1);
    let mut o = Occupancy::new();
    let set = fixed();
    o.window(&s, &grid, 1.0, 4.0, &set).unwrap();
    assert!(o.is_window() && o.layers() == 1 && o.times() == [1.0, 4.0]);
    let (r, c) = grid.cell_of(2.04, 0.04).unwrap();
    let peak = (mass_1d(0.0, 0.3, 0.0, 0.1) * mass_1d(2.0, 0.3, 2.0, 2.1)) as f32;
    // both futures pass through the cell: the person is there with the kernel's peak
    assert!(
        (o.at(0, r, c) - peak).abs() < 1e-4,
        "{} vs {peak}",
        o.at(0, r, c)
    );
    // at any one time only one future is there: half of that
    let mut t = Occupancy::new();
    t.compute(&s, &grid, &[2.0, 4.0], &set).unwrap();
    assert!((t.at(0, r, c) - peak / 2.0).abs() < 1e-4 && (t.at(1, r, c) - peak / 2.0).abs() < 1e-4);
    // between the steps the samples are read at half steps: the first passes x = 2.5
    // at 2.5 s, the second gets no further than x = 2 by the window's end
    let (r2, c2) = grid.cell_of(2.54, 0.04).unwrap();
    let my = mass_1d(0.0, 0.3, 0.0, 0.1);
    let want = 0.5 * my * mass_1d(2.5, 0.3, 2.5, 2.6) + 0.5 * my * mass_1d(2.0, 0.3, 2.5, 2.6);
    assert!(
        (o.at(0, r2, c2) as f64 - want).abs() < 1e-4,
        "{} vs {want}",
        o.at(0, r2, c2)
    );
    // a window that ends before it starts is refused
    assert!(o.window(&s, &grid, 3.0, 2.0, &set).is_err());
}

#[test]
fn a_plan_meets_the_futures_it_crosses_at_the_same_time() {
    // one person, four samples walking +x at 1 m/s from x = 0 at rows y = 0, 1, 2, 3
    let mut pos: Vec<Point> = Vec::new();
    for row in 0..4 {
        for j in 1..=10 {
            pos.push([j as f32, row as f32]);
        }
    }
    let s = Samples::new(&pos, &[10; 4], (1, 4, 10), 1.0).unwrap();
    let set = fixed();
    let mut out = [0.0f32];
    // a robot standing at x = 5 on row 1 from 4 s to 6 s: meets the sample of row 1
    // (and not row 0 or 2, 1 m away, with 0.2 + 0.3 m of reach)
    let stand = [
        PlanPoint {
            position: [5.0, 1.0],
            time: 4.0,
        },
        PlanPoint {
            position: [5.0, 1.0],
            time: 6.0,
        },
    ];
    path_meets(&s, &stand, 0.2, &set, &mut out).unwrap();
    assert_eq!(out[0], 0.25);
    // a robot crossing the rows along x = 5 between 4.9 s and 5.1 s meets all four
    // (it passes row y at 4.9 + (y + 0.5) / 20 s, when that row's walker is within
    // 0.1 m of x = 5; it is at none of them at 4.9, 5 or 5.1 s)
    let cross = [
        PlanPoint {
            position: [5.0, -0.5],
            time: 4.9,
        },
        PlanPoint {
            position: [5.0, 3.5],
            time: 5.1,
        },
    ];
    path_meets(&s, &cross, 0.2, &set, &mut out).unwrap();
    assert_eq!(out[0], 1.0);
    // the same crossing 3 s later: they are gone
    let late = cross.map(|p| PlanPoint {
        time: p.time + 3.0,
        ..p
    });
    path_meets(&s, &late, 0.2, &set, &mut out).unwrap();
    assert_eq!(out[0], 0.0);
    // a plan that lies before the first step is not checked
    let early = [PlanPoint {
        position: [0.5, 0.0],
        time: 0.5,
    }];
    path_meets(&s, &early, 0.2, &set, &mut out).unwrap();
    assert_eq!(out[0], 0.0);
    // bad plans are named
    let back = [cross[1], cross[0]];
    assert!(matches!(
        path_meets(&s, &back, 0.2, &set, &mut out),
        Err(OccupancyError::Plan { index: 1, .. })
    ));
    assert!(path_meets(&s, &cross, -1.0, &set, &mut out).is_err());
    assert!(path_meets(&s, &cross, 0.2, &set, &mut [0.0; 2]).is_err());
}

#[test]
fn the_density_integrates_to_the_cells_probabilities() {
    // five samples around (1, 1); the density times a cell's area is about the cell's
    // probability where the density is smooth on the cell's scale
    let pos: [Point; 5] = [[1.0, 1.0], [1.4, 1.0], [0.6, 1.2], [1.0, 0.5], [1.1, 1.3]];
    let s = Samples::new(&pos, &[1; 5], (1, 5, 1), 0.4).unwrap();
    let grid = GridSpec::around([1.0, 1.0], [6.0, 6.0], 0.05);
    let set = Settings::default();
    let mut o = Occupancy::new();
    // the kernel's own cells (its 7 cells of sigma would go on the coarser grid, whose
    // own bound is checked below)
    o.exact = true;
    o.compute_agent(&s, 0, &grid, &[0.4], &set).unwrap();
    let mut scratch = Vec::new();
    for (x, y) in [(1.0, 1.0), (0.5, 1.5), (2.0, 0.2)] {
        let (r, c) = grid.cell_of(x, y).unwrap();
        let centre = grid.cell_center(r, c);
        let d = person_density(&s, 0, 0.4, centre, &set, &mut scratch)
            .unwrap()
            .unwrap();
        let p = o.at(0, r, c) as f64;
        assert!(
            (d * 0.0025 - p).abs() < 0.01 * p + 1e-7,
            "({x}, {y}): {d} vs {p}"
        );
    }
}

#[test]
fn times_between_zero_and_the_first_step_need_the_start() {
    let pos: [Point; 2] = [[1.0, 0.0], [2.0, 0.0]];
    let s = Samples::new(&pos, &[2], (1, 1, 2), 1.0).unwrap();
    let grid = GridSpec::around([0.0, 0.0], [4.0, 4.0], 0.1);
    let mut o = Occupancy::new();
    assert!(o.compute(&s, &grid, &[0.5], &fixed()).is_err());
    let starts = [[0.0f32, 0.0]];
    let s = s.with_starts(&starts).unwrap();
    o.compute(&s, &grid, &[0.0, 0.5], &fixed()).unwrap();
    let (r, c) = grid.cell_of(0.51, 0.01).unwrap();
    let (r0, c0) = grid.cell_of(0.01, 0.01).unwrap();
    assert!(o.at(1, r, c) > o.at(1, r0, c0 - 2) && o.at(0, r0, c0) > o.at(0, r, c + 2));
}

#[test]
fn wide_kernels_on_coarser_grids_stay_close_to_the_exact_cells() {
    use crate::map::CliffMap;
    use crate::motion::State;
    use crate::predict::{Params, TrajectoryBatch, predict};
    use crate::tracks::{Format, read_tracks};
    // THÖR1's walkers (the state of each track's ninth row), predicted 12 s on its map
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/thor1");
    let map = CliffMap::load(data.join("cliffmap.csv")).unwrap();
    let tracks = read_tracks(&data.join("exp-1-run-2.csv"), Format::Thor).unwrap();
    let people: Vec<State> = tracks
        .iter()
        .filter(|t| t.rows.len() > 30 && t.rows[8].speed > 0.3)
        .map(|t| State {
            position: t.rows[8].position,
            speed: t.rows[8].speed,
            heading: t.rows[8].angle,
            time: 0.0,
        })
        .take(30)
        .collect();
    assert_eq!(people.len(), 30);
    let params = Params {
        k: 20,
        dt: 0.4,
        horizon: 12.0,
        radius: 0.7071,
        ..Params::default()
    };
    let mut batch = TrajectoryBatch::new();
    predict(&map, &people, &params, &mut batch).unwrap();
    let s = Samples::from_batch(&batch, params.dt).unwrap();
    let n = people.len() as f64;
    let centre = people.iter().fold([0.0, 0.0], |a, p| {
        [a[0] + p.position.x / n, a[1] + p.position.y / n]
    });
    let grid = GridSpec::around(centre, [20.0, 20.0], 0.1);
    let times: Vec<f64> = (1..=30).map(|j| j as f64 * 0.4).collect();
    let set = Settings::default();
    let (mut fast, mut exact) = (Occupancy::new(), Occupancy::new());
    exact.exact = true;
    let (mut coarse, mut worst, mut worst_mass) = (0, 0.0f32, 0.0f32);
    for a in 0..people.len() {
        fast.compute_agent(&s, a, &grid, &times, &set).unwrap();
        exact.compute_agent(&s, a, &grid, &times, &set).unwrap();
        for li in 0..times.len() {
            let (f, e) = (fast.layer(li), exact.layer(li));
            let peak = e.iter().fold(0.0f32, |m, &v| m.max(v));
            let diff = f
                .iter()
                .zip(e)
                .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
            if diff > 1e-4 * peak {
                coarse += 1;
            }
            worst = worst.max(diff / peak.max(1e-12));
            // the person's mass, where the grid holds nearly all of it
            let (mf, me) = (f.iter().sum::<f32>(), e.iter().sum::<f32>());
            if me > 0.99 {
                worst_mass = worst_mass.max((mf - me).abs());
            }
        }
    }
    eprintln!(
        "{coarse} person-times on coarser grids; largest difference {worst} of the peak, of the mass {worst_mass}"
    );
    // the coarser grids were used (a sigma of 0.4 m or more) ...
    assert!(coarse > 100, "{coarse}");
    // ... within 1 % of the person's largest cell probability, and the mass kept
    // within 0.3 % (the kernel's cut at 3 sigmas falls on coarser cells' edges)
    assert!(worst < 0.01, "{worst}");
    assert!(worst_mass < 3e-3, "{worst_mass}");
    // all people at once: within 1 % of the layer's largest probability
    fast.compute(&s, &grid, &times, &set).unwrap();
    exact.compute(&s, &grid, &times, &set).unwrap();
    for (li, t) in times.iter().enumerate() {
        let (f, e) = (fast.layer(li), exact.layer(li));
        let peak = e.iter().fold(0.0f32, |m, &v| m.max(v));
        let diff = f
            .iter()
            .zip(e)
            .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
        assert!(diff < 0.01 * peak, "{t} s: {diff} of {peak}");
    }
}
