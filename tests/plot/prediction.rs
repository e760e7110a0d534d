//! `cliff plot predict`: observed path, truth and samples of a walker, over a floor plan.

use super::*;

/// The case and prediction `cliff plot predict` makes with its defaults.
fn default_prediction(case: &Case, map: &CliffMap, settings: &Settings) -> TrajectoryBatch {
    let params = Params {
        horizon: case.steps as f64 * settings.dt,
        seed: person_seed(0, case.id),
        ..Params::default()
    };
    let mut batch = TrajectoryBatch::new();
    predict(map, &[case.start], &params, &mut batch).unwrap();
    batch
}

/// Check the observed rows green, the truth rows red and the samples blue where no
/// track covers them.
fn check_prediction_picture(img: &RgbImage, frame: &Frame, case: &Case, batch: &TrajectoryBatch) {
    for r in &case.observed {
        assert!(
            has(img, frame.to_pixel(r.position), 2, OBSERVED),
            "observed {}",
            r.position
        );
    }
    let truth: Vec<DVec2> = case
        .future
        .iter()
        .filter(|r| r.t > case.start.time + 0.01 && r.t <= case.start.time + case.horizon + 1e-6)
        .map(|r| r.position)
        .collect();
    assert!(!truth.is_empty());
    for &p in &truth {
        assert!(has(img, frame.to_pixel(p), 2, TRUTH), "truth {p}");
    }
    // Samples: blue at their points away from the tracks (drawn over them).
    let tracks: Vec<DVec2> = case
        .observed
        .iter()
        .map(|r| r.position)
        .chain(truth.iter().copied())
        .collect();
    let mut blue = 0;
    for s in 0..batch.shape().1 {
        for p in batch.sample(0, s) {
            let p = DVec2::new(p[0] as f64, p[1] as f64);
            if tracks.iter().all(|t| t.distance(p) > 0.6) {
                assert!(
                    around(img, frame.to_pixel(p), 1).into_iter().any(bluish),
                    "sample {s} at {p}"
                );
                blue += 1;
            }
        }
    }
    assert!(blue > 5, "only {blue} sample points away from the tracks");
}

#[test]
fn prediction_of_a_demo_walker_shows_observed_truth_and_samples() {
    let dir = tmp("predict-demo");
    let out = dir.join("p.png");
    let map = CliffMap::demo();
    let settings = Settings {
        protocol: Protocol::Seconds,
        ..Settings::default()
    };
    let tracks = demo_tracks(&SceneOptions::default());
    // a walker who turns: the samples fan out away from the truth
    let case = tracks
        .iter()
        .filter_map(|t| prepare(t, &settings))
        .find(|c| {
            let last = c.future.last().unwrap();
            let d = last.position - c.start.position;
            (d.to_angle() - c.start.heading).sin().abs() > 0.5
        })
        .expect("a turning walker");
    let id = case.id.to_string();
    let stdout = ok(&[
        "plot",
        "predict",
        "--person",
        &id,
        "--width",
        "800",
        "--out",
        s(&out),
    ]);
    assert!(stdout.contains(&format!("person {id}")), "{stdout}");
    let img = decode(&out);
    let frame = Frame::for_map(Floorplan::demo_extent(), 800);
    assert_eq!(img.dimensions(), frame.size);
    let batch = default_prediction(&case, &map, &settings);
    check_prediction_picture(&img, &frame, &case, &batch);
}

#[test]
fn prediction_on_thor1_over_its_floor_plan() {
    let dir = tmp("predict-thor1");
    let out = dir.join("p.png");
    let map_file = data("thor1/cliffmap.csv");
    let tracks_file = data("thor1/exp-1-run-2.csv");
    let stdout = ok(&[
        "plot",
        "predict",
        "--map",
        &map_file,
        "--tracks",
        &tracks_file,
        "--format",
        "thor",
        "--person",
        "12010",
        "--protocol",
        "reference",
        "--floorplan",
        &data("thor1/floorplan.png"),
        "--extent=-11,12,-10,13.5",
        "--out",
        s(&out),
    ]);
    assert!(stdout.contains("person 12010"), "{stdout}");
    let img = decode(&out);
    let frame = Frame::for_map("-11,12,-10,13.5".parse().unwrap(), 1000);
    assert_eq!(img.dimensions(), frame.size);
    let map = CliffMap::load(&map_file).unwrap();
    let tracks = read_tracks(tracks_file.as_ref(), Format::Thor).unwrap();
    let settings = Settings::default(); // the reference protocol's THÖR settings
    let track = tracks.iter().find(|t| t.id == 12010).unwrap();
    let case = prepare(track, &settings).unwrap();
    let batch = default_prediction(&case, &map, &settings);
    check_prediction_picture(&img, &frame, &case, &batch);
    // the view zooms when asked: the start in the middle of a 6 m view
    let zoom = dir.join("zoom.png");
    let p = case.start.position;
    let view = format!(
        "--view={},{},{},{}",
        p.x - 3.0,
        p.x + 3.0,
        p.y - 3.0,
        p.y + 3.0
    );
    ok(&[
        "plot",
        "predict",
        "--map",
        &map_file,
        "--tracks",
        &tracks_file,
        "--person",
        "12010",
        "--protocol",
        "reference",
        &view,
        "--width",
        "600",
        "--out",
        s(&zoom),
    ]);
    let img = decode(&zoom);
    let frame = Frame::for_map(
        Extent::new(p.x - 3.0, p.x + 3.0, p.y - 3.0, p.y + 3.0).unwrap(),
        600,
    );
    assert_eq!(img.dimensions(), frame.size);
    let last_obs = case.observed.last().unwrap().position;
    assert!(has(&img, frame.to_pixel(last_obs), 2, OBSERVED));
    // The tracks leave this view: they are cut at its edges, never drawn in the
    // margins (nor squashed onto the border).
    let leaves = case
        .future
        .iter()
        .any(|r| !frame.extent.contains(r.position));
    assert!(leaves, "the truth should leave the 6 m view");
    let mut outside = 0;
    // lines end at the edge; their width and the dots' radius may reach 4 px beyond
    let grown = PixelRect {
        left: frame.area.left - 4,
        top: frame.area.top - 4,
        right: frame.area.right + 4,
        bottom: frame.area.bottom + 4,
    };
    for (x, y, p) in img.enumerate_pixels() {
        let c = (p[0], p[1], p[2]);
        if !grown.contains((x as i32, y as i32)) && (c == TRUTH || c == OBSERVED || bluish(c)) {
            outside += 1;
        }
    }
    // (the legend's three colour swatches lie inside the plotting area)
    assert_eq!(outside, 0, "track pixels outside the plotting area");
    for row in [frame.area.top, frame.area.top + 1] {
        let on_border = (frame.area.left..frame.area.right)
            .filter(|&x| px(&img, (x, row)) == Some(TRUTH))
            .count();
        assert!(
            on_border < 10,
            "truth drawn along the top border: {on_border} px"
        );
    }
}
