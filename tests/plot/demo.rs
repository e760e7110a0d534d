//! `cliff demo`: its pictures and summary, and clear errors for bad plot arguments.

use super::*;

#[test]
fn demo_writes_three_pictures_and_a_summary() {
    let dir = tmp("demo");
    let out = dir.join("tour");
    let stdout = ok(&["demo", "--out", s(&out), "--width", "700", "--seeds", "2"]);
    for f in [
        "map.png",
        "predictions.png",
        "curves.png",
        "summary.csv",
        "per_person.csv",
        "tracks.csv",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
        if f.ends_with(".png") {
            assert!(stdout.contains(s(&out.join(f))), "{stdout}");
        }
    }
    assert!(stdout.contains("evaluated 40 of 40 people"), "{stdout}");
    assert!(
        stdout.contains("cliff") && stdout.contains("cvm") && stdout.contains("12.0s"),
        "{stdout}"
    );
    let frame = Frame::for_map(Floorplan::demo_extent(), 700);
    let map = decode(&out.join("map.png"));
    assert_eq!(map.dimensions(), frame.size);
    let east = hue_saturation(direction_colour(0.0)).0;
    assert!(saturation_of_hue(&map, frame.to_pixel(DVec2::new(-10.8, -2.0)), 2, east) > 0.3);
    let pred = decode(&out.join("predictions.png"));
    assert_eq!(pred.dimensions(), frame.size);
    assert!(count(&pred, |p| p == OBSERVED) > 100);
    assert!(count(&pred, |p| p == TRUTH) > 100);
    assert!(count(&pred, bluish) > 500);
    let curves = decode(&out.join("curves.png"));
    assert_eq!(curves.dimensions(), CurvesStyle::default().size);
    // the tracks file is a THÖR file `cliff eval` reads
    let t = read_tracks(&out.join("tracks.csv"), Format::Thor).unwrap();
    assert_eq!(t.len(), 40);
}

#[test]
fn bad_input_gets_a_clear_error() {
    let dir = tmp("bad");
    let e = fails(&["plot", "map", "--out", s(&dir.join("m.jpg"))]);
    assert!(
        e.contains("m.jpg") && e.contains("unknown picture format"),
        "{e}"
    );
    let e = fails(&[
        "plot",
        "map",
        "--floorplan",
        s(&dir.join("none.png")),
        "--extent=0,1,0,1",
        "--out",
        s(&dir.join("m.png")),
    ]);
    assert!(e.contains("none.png"), "{e}");
    let e = fails(&[
        "plot",
        "map",
        "--floorplan",
        &data("thor1/cliffmap.csv"),
        "--extent=0,1,0,1",
        "--out",
        s(&dir.join("m.png")),
    ]);
    assert!(
        e.contains("cliffmap.csv") && e.contains("floor plan"),
        "{e}"
    );
    let e = fails(&[
        "plot",
        "map",
        "--floorplan",
        &data("thor1/floorplan.png"),
        "--out",
        s(&dir.join("m.png")),
    ]);
    assert!(e.contains("--extent"), "{e}");
    let e = fails(&[
        "plot",
        "map",
        "--view=1,2,3",
        "--out",
        s(&dir.join("m.png")),
    ]);
    assert!(e.contains("expected four numbers"), "{e}");
    let e = fails(&[
        "plot",
        "map",
        "--view=2,1,0,1",
        "--out",
        s(&dir.join("m.png")),
    ]);
    assert!(e.contains("X0 must be less than X1"), "{e}");
    let e = fails(&[
        "plot",
        "predict",
        "--person",
        "999",
        "--out",
        s(&dir.join("p.png")),
    ]);
    assert!(e.contains("person 999 is not in the demo walkers"), "{e}");
    let e = fails(&[
        "plot",
        "predict",
        "--map",
        &data("thor1/cliffmap.csv"),
        "--person",
        "1",
        "--out",
        s(&dir.join("p.png")),
    ]);
    assert!(e.contains("--tracks is needed"), "{e}");
    let e = fails(&[
        "plot",
        "curves",
        "--summary",
        s(&dir.join("nothing.csv")),
        "--out",
        s(&dir.join("c.png")),
    ]);
    assert!(e.contains("nothing.csv"), "{e}");
    let bad = write_summary(&dir.join("bad"), "method,horizon,ade\ncliff,1,0.5\n");
    let e = fails(&[
        "plot",
        "curves",
        "--summary",
        s(&bad),
        "--out",
        s(&dir.join("c.png")),
    ]);
    assert!(
        e.contains("summary.csv:1") && e.contains("fde, ade_sd, fde_sd"),
        "{e}"
    );
    let bad = write_summary(
        &dir.join("bad2"),
        "method,horizon,ade,fde,ade_sd,fde_sd\ncliff,1,0.5,oops,0,0\n",
    );
    let e = fails(&[
        "plot",
        "curves",
        "--summary",
        s(&bad),
        "--out",
        s(&dir.join("c.png")),
    ]);
    assert!(
        e.contains("summary.csv:2: column 4: 'oops' is not a number"),
        "{e}"
    );
    let good = write_summary(
        &dir.join("good"),
        "method,horizon,ade,fde,ade_sd,fde_sd\ncliff,1,0.5,1,0,0\n",
    );
    let e = fails(&[
        "plot",
        "curves",
        "--summary",
        s(&good),
        "--label",
        "a",
        "b",
        "--out",
        s(&dir.join("c.png")),
    ]);
    assert!(e.contains("2 --label value(s) for 1 --summary"), "{e}");
    let e = fails(&[
        "demo",
        "--map",
        &data("thor1/cliffmap.csv"),
        "--out",
        s(&dir.join("d")),
    ]);
    assert!(e.contains("--tracks is needed"), "{e}");
    // a folder that cannot be written
    let e = fails(&["plot", "map", "--out", "/proc/cliff-no-such-dir/m.png"]);
    assert!(e.contains("/proc/cliff-no-such-dir/m.png"), "{e}");
}
