//! `cliff plot curves`: error curves from evaluation summaries, with bands.

use super::*;

#[test]
fn curves_from_two_summaries_with_bands() {
    let dir = tmp("curves");
    // Run a: the lead's column set; run b: other order, extra and missing optional columns.
    let a = write_summary(
        &dir.join("run-a"),
        "method,horizon,people,ade,fde,min_ade,min_fde,ade_sd,fde_sd,reach\n\
         cliff,2.0,10,0.5,1.0,0.2,0.3,0.2,0.4,1\n\
         cliff,4.0,10,1.0,2.0,0.4,0.6,0.4,0.8,1\n\
         cliff,6.0,9,1.5,3.0,0.6,0.9,0.6,1.2,1\n\
         cvm,2.0,10,0.8,1.6,0.8,1.6,0.0,0.0,1\n\
         cvm,4.0,10,2.0,4.0,2.0,4.0,0.0,0.0,1\n\
         cvm,6.0,9,3.0,6.0,3.0,6.0,0.0,0.0,1\n",
    );
    let b = write_summary(
        &dir.join("run-b"),
        "horizon,method,fde_sd,ade_sd,fde,ade,note\n\
         2.0,cliff,0.1,0.1,0.5,0.25,x\n\
         6.0,cliff,0.1,0.1,1.5,0.75,y\n",
    );
    let out = dir.join("curves.png");
    let stdout = ok(&[
        "plot",
        "curves",
        "--summary",
        s(&a),
        s(&b),
        "--width",
        "1000",
        "--height",
        "500",
        "--out",
        s(&out),
    ]);
    assert!(
        stdout.contains("run-a: cliff, run-a: cvm, run-b: cliff"),
        "{stdout}"
    );
    let img = decode(&out);
    assert_eq!(img.dimensions(), (1000, 500));
    let runs = vec![
        CurveRun {
            label: "run-a".into(),
            rows: read_summary(&a).unwrap(),
        },
        CurveRun {
            label: "run-b".into(),
            rows: read_summary(&b).unwrap(),
        },
    ];
    let layout = curves_layout(
        &runs,
        &CurvesStyle {
            size: (1000, 500),
            ..CurvesStyle::default()
        },
    )
    .unwrap();
    // largest mean + sd: ADE 3.0 (cvm at 6 s), FDE 6.0
    assert!(
        (layout.ade.extent.y1 - 3.15).abs() < 1e-9 && (layout.fde.extent.y1 - 6.3).abs() < 1e-9
    );
    let colour = |i: usize| layout.series[i].1;
    let ade = |h: f64, v: f64| layout.ade.to_pixel(DVec2::new(h, v));
    let fde = |h: f64, v: f64| layout.fde.to_pixel(DVec2::new(h, v));
    // the lines pass through their points, in their colours, in both panels
    for (h, v) in [(2.0, 0.5), (4.0, 1.0), (6.0, 1.5), (3.0, 0.75)] {
        assert!(has(&img, ade(h, v), 2, colour(0)), "run-a cliff ADE at {h}");
        assert!(
            has(&img, fde(h, 2.0 * v), 2, colour(0)),
            "run-a cliff FDE at {h}"
        );
    }
    for (h, v) in [(2.0, 0.8), (4.0, 2.0), (6.0, 3.0)] {
        assert!(has(&img, ade(h, v), 2, colour(1)), "run-a cvm ADE at {h}");
    }
    for (h, v) in [(2.0, 0.25), (4.0, 0.5), (6.0, 0.75)] {
        assert!(has(&img, ade(h, v), 2, colour(2)), "run-b cliff ADE at {h}");
    }
    // the band: a light tint of the series colour within one sd, none beyond
    let tint = |p: (i32, i32)| {
        let (r, g, b) = px(&img, p).unwrap();
        let (h, s) = hue_saturation((r, g, b));
        (
            hue_distance(h, hue_saturation(colour(0)).0) < 12.0 && s > 0.05 && s < 0.5,
            s,
        )
    };
    for (h, v, sd) in [(3.0, 0.75, 0.3), (5.0, 1.25, 0.5)] {
        assert!(
            tint(ade(h, v + 0.6 * sd)).0,
            "band above the ADE at {h}: {:?}",
            px(&img, ade(h, v + 0.6 * sd))
        );
        assert!(tint(ade(h, v - 0.6 * sd)).0, "band below the ADE at {h}");
        let beyond = px(&img, ade(h, v + 1.4 * sd)).unwrap();
        assert!(
            hue_saturation(beyond).1 < 0.05,
            "beyond the band at {h}: {beyond:?}"
        );
    }
    // without bands: white (or grid grey) where the band was
    let plain = dir.join("plain.svg");
    ok(&[
        "plot",
        "curves",
        "--summary",
        s(&a),
        "--no-bands",
        "--label",
        "A",
        "--out",
        s(&plain),
    ]);
    let svg = std::fs::read_to_string(&plain).unwrap();
    let texts: Vec<&str> = svg
        .split("<text")
        .skip(1)
        .map(|t| {
            t.split('>')
                .nth(1)
                .unwrap_or("")
                .trim_end_matches("</text")
                .trim()
        })
        .collect();
    assert!(
        texts.contains(&"cliff") && texts.contains(&"cvm"),
        "legend: {texts:?}"
    );
    assert!(!svg.contains("data:image/png"));
}

#[test]
fn curves_from_a_real_eval_summary() {
    // `cliff eval` on the demo walkers, then its summary drawn: the contract between the two.
    let dir = tmp("eval-curves");
    let tracks = dir.join("walkers.csv");
    std::fs::write(
        &tracks,
        tracks_csv(&demo_tracks(&SceneOptions {
            people: 12,
            ..SceneOptions::default()
        })),
    )
    .unwrap();
    let eval_dir = dir.join("eval");
    ok(&[
        "eval",
        "--tracks",
        s(&tracks),
        "--format",
        "thor",
        "--seeds",
        "2",
        "--out",
        s(&eval_dir),
    ]);
    let summary = eval_dir.join("summary.csv");
    let out = dir.join("curves.png");
    ok(&["plot", "curves", "--summary", s(&summary), "--out", s(&out)]);
    let img = decode(&out);
    assert_eq!(img.dimensions(), CurvesStyle::default().size);
    let rows = read_summary(&summary).unwrap();
    let runs = [CurveRun {
        label: "eval".into(),
        rows: rows.clone(),
    }];
    let layout = curves_layout(&runs, &CurvesStyle::default()).unwrap();
    assert_eq!(
        layout
            .series
            .iter()
            .map(|s| s.0.as_str())
            .collect::<Vec<_>>(),
        ["cliff", "cvm"]
    );
    for r in rows
        .iter()
        .filter(|r| (r.horizon - 4.0).abs() < 1e-9 || (r.horizon - 10.0).abs() < 1e-9)
    {
        let i = if r.method == "cliff" { 0 } else { 1 };
        let p = layout.ade.to_pixel(DVec2::new(r.horizon, r.ade));
        assert!(
            has(&img, p, 2, layout.series[i].1),
            "{} ADE at {}",
            r.method,
            r.horizon
        );
        let p = layout.fde.to_pixel(DVec2::new(r.horizon, r.fde));
        assert!(
            has(&img, p, 2, layout.series[i].1),
            "{} FDE at {}",
            r.method,
            r.horizon
        );
    }

    // The spread over people: means and bands from per_person.csv, computed here by
    // hand from the file.
    let text = std::fs::read_to_string(eval_dir.join("per_person.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (cm, ch, ca) = (col("method"), col("horizon"), col("ade"));
    let ades: Vec<f64> = lines
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| f[cm] == "cliff" && f[ch] == "6.0")
        .map(|f| f[ca].parse().unwrap())
        .collect();
    assert!(ades.len() >= 10);
    let mean = ades.iter().sum::<f64>() / ades.len() as f64;
    let sd = (ades.iter().map(|a| (a - mean) * (a - mean)).sum::<f64>() / ades.len() as f64).sqrt();
    // (0.047 m with the per-sample generators; a band a few pixels wide)
    assert!(sd > 0.04, "people differ: sd {sd}");
    let out = dir.join("people.png");
    let stdout = ok(&[
        "plot",
        "curves",
        "--summary",
        s(&summary),
        "--spread",
        "people",
        "--out",
        s(&out),
    ]);
    assert!(stdout.contains("cliff, cvm"), "{stdout}");
    let img = decode(&out);
    let rows = cliff::plot::read_per_person_spread(&eval_dir.join("per_person.csv")).unwrap();
    let layout = curves_layout(
        &[CurveRun {
            label: "eval".into(),
            rows,
        }],
        &CurvesStyle::default(),
    )
    .unwrap();
    let blue = layout.series[0].1;
    assert!(has(
        &img,
        layout.ade.to_pixel(DVec2::new(6.0, mean)),
        2,
        blue
    ));
    // inside the band one sd wide, above the line: a tint of the line's hue
    let inside = px(&img, layout.ade.to_pixel(DVec2::new(6.0, mean + 0.7 * sd))).unwrap();
    let (h, sat) = hue_saturation(inside);
    assert!(
        hue_distance(h, hue_saturation(blue).0) < 15.0 && sat > 0.05 && inside != blue,
        "{inside:?}"
    );
    // a summary without its per_person.csv
    let lonely = write_summary(
        &dir.join("lonely"),
        &std::fs::read_to_string(&summary).unwrap(),
    );
    let e = fails(&[
        "plot",
        "curves",
        "--summary",
        s(&lonely),
        "--spread",
        "people",
        "--out",
        s(&out),
    ]);
    assert!(
        e.contains("per_person.csv") && e.contains("--spread people"),
        "{e}"
    );
}
