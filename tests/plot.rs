//! Pictures from the command line: each command's picture is decoded and checked for
//! its size and for pixels of the expected colours at the pixels the plotting code
//! maps known world coordinates to (through the library's public `Frame`).

use std::path::{Path, PathBuf};

use cliff::eval::person_seed;
use cliff::eval::protocol::{Case, Protocol, Settings, prepare};
use cliff::map::CliffMap;
use cliff::plot::{
    CurveRun, CurvesStyle, Extent, Floorplan, Frame, MapStyle, OBSERVED, PixelRect, SAMPLE, TRUTH,
    curves_layout, direction_colour, hue_saturation, read_summary,
};
use cliff::predict::{Params, TrajectoryBatch, predict};
use cliff::tracks::scene::{SceneOptions, demo_tracks, tracks_csv};
use cliff::tracks::{Format, read_tracks};
use glam::DVec2;
use image::RgbImage;

mod common;
use common::{cliff, data};

fn ok(args: &[&str]) -> String {
    let o = cliff(args);
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "cliff {args:?} failed: {}{stdout}",
        String::from_utf8_lossy(&o.stderr)
    );
    stdout
}

fn fails(args: &[&str]) -> String {
    let o = cliff(args);
    assert!(!o.status.success(), "cliff {args:?} should fail");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cliff-plot-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn decode(p: &Path) -> RgbImage {
    image::open(p)
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
        .to_rgb8()
}

type Rgb = (u8, u8, u8);

fn px(img: &RgbImage, (x, y): (i32, i32)) -> Option<Rgb> {
    if x < 0 || y < 0 || x as u32 >= img.width() || y as u32 >= img.height() {
        return None;
    }
    let p = img.get_pixel(x as u32, y as u32);
    Some((p[0], p[1], p[2]))
}

/// The pixels within `r` (Chebyshev) of `at`.
fn around(img: &RgbImage, at: (i32, i32), r: i32) -> Vec<Rgb> {
    let mut v = Vec::new();
    for dy in -r..=r {
        for dx in -r..=r {
            if let Some(p) = px(img, (at.0 + dx, at.1 + dy)) {
                v.push(p);
            }
        }
    }
    v
}

fn has(img: &RgbImage, at: (i32, i32), r: i32, colour: Rgb) -> bool {
    around(img, at, r).contains(&colour)
}

fn hue_distance(a: f64, b: f64) -> f64 {
    ((a - b + 180.0).rem_euclid(360.0) - 180.0).abs()
}

/// The largest saturation among the pixels near `at` whose hue is within 20 degrees of
/// `hue`.
fn saturation_of_hue(img: &RgbImage, at: (i32, i32), r: i32, hue: f64) -> f64 {
    around(img, at, r)
        .into_iter()
        .map(hue_saturation)
        .filter(|(h, s)| *s > 0.05 && hue_distance(*h, hue) < 20.0)
        .map(|(_, s)| s)
        .fold(0.0, f64::max)
}

fn count(img: &RgbImage, f: impl Fn(Rgb) -> bool) -> usize {
    img.pixels().filter(|p| f((p[0], p[1], p[2]))).count()
}

fn bluish((r, g, b): Rgb) -> bool {
    let (h, s) = hue_saturation((r, g, b));
    s > 0.15 && hue_distance(h, hue_saturation(SAMPLE).0) < 15.0
}

#[test]
fn map_of_the_demo_hall_has_arrows_coloured_by_direction_and_weight() {
    let dir = tmp("map");
    let out = dir.join("map.png");
    let stdout = ok(&["plot", "map", "--width", "900", "--out", s(&out)]);
    assert!(stdout.contains("315 locations, 728 components"), "{stdout}");
    let img = decode(&out);
    let frame = Frame::for_map(Floorplan::demo_extent(), 900);
    assert_eq!(img.dimensions(), frame.size);
    let at = |x: f64, y: f64| frame.to_pixel(DVec2::new(x, y));
    let (east, north, west, south) = (
        hue_saturation(direction_colour(0.0)).0,
        hue_saturation(direction_colour(std::f64::consts::FRAC_PI_2)).0,
        hue_saturation(direction_colour(std::f64::consts::PI)).0,
        hue_saturation(direction_colour(3.0 * std::f64::consts::FRAC_PI_2)).0,
    );
    // The east-west corridor: an east arrow (red) right of each location, a west
    // arrow (cyan) left of it.
    for x in [-12.0, -8.0, 9.0] {
        for y in [-2.0, 2.0] {
            let e = saturation_of_hue(&img, at(x + 0.2, y), 2, east);
            let w = saturation_of_hue(&img, at(x - 0.2, y), 2, west);
            assert!(e > 0.3 && w > 0.3, "({x}, {y}): east {e}, west {w}");
            // nothing pointing west right of the location
            assert!(saturation_of_hue(&img, at(x + 0.2, y), 2, west) < 0.05);
        }
        // Opacity follows the weight: eastbound walkers keep to the south half (east
        // weight 0.57 at y = -2, 0.43 at y = 2), westbound to the north half.
        let e_south = saturation_of_hue(&img, at(x + 0.2, -2.0), 2, east);
        let e_north = saturation_of_hue(&img, at(x + 0.2, 2.0), 2, east);
        assert!(
            e_south > e_north + 0.05,
            "east arrows {e_south} vs {e_north}"
        );
        let w_south = saturation_of_hue(&img, at(x - 0.2, -2.0), 2, west);
        let w_north = saturation_of_hue(&img, at(x - 0.2, 2.0), 2, west);
        assert!(
            w_north > w_south + 0.05,
            "west arrows {w_north} vs {w_south}"
        );
    }
    // The north-south corridor: north arrows above the locations, south below.
    for y in [-7.0, 6.0] {
        let n = saturation_of_hue(&img, at(1.0, y + 0.2), 2, north);
        let so = saturation_of_hue(&img, at(1.0, y - 0.2), 2, south);
        assert!(n > 0.3 && so > 0.3, "(1, {y}): north {n}, south {so}");
        assert!(saturation_of_hue(&img, at(1.0, y + 0.2), 2, east) < 0.05);
    }
    // The demo floor: grey outside the corridors, white between the arrows.
    for (x, y) in [(-10.0, 7.0), (10.0, -7.0)] {
        let (r, g, b) = px(&img, at(x, y)).unwrap();
        assert!(r == g && g == b && r < 200, "({x}, {y}) is {:?}", (r, g, b));
    }
    assert_eq!(px(&img, at(-9.5, -2.5)), Some((255, 255, 255)));
    // --min-weight leaves out the weaker components: at y = 2 the east weight is 0.43.
    let thin = dir.join("thin.png");
    ok(&[
        "plot",
        "map",
        "--width",
        "900",
        "--min-weight",
        "0.5",
        "--out",
        s(&thin),
    ]);
    let thin = decode(&thin);
    for x in [-12.0, 9.0] {
        assert!(saturation_of_hue(&thin, at(x + 0.2, 2.0), 2, east) < 0.05);
        assert!(saturation_of_hue(&thin, at(x - 0.2, 2.0), 2, west) > 0.3);
        assert!(saturation_of_hue(&thin, at(x + 0.2, -2.0), 2, east) > 0.3);
    }
    // The title is drawn with the embedded font: dark pixels above the plotting area.
    let title_ink = (0..frame.area.top)
        .flat_map(|y| (0..frame.size.0 as i32).map(move |x| (x, y)))
        .filter(|&p| px(&img, p).is_some_and(|(r, _, _)| r < 100))
        .count();
    assert!(title_ink > 150, "title ink {title_ink}");
    // Outside the plotting area, left of it: white margin or black labels, no colour.
    let margin = px(&img, (frame.area.left - 30, frame.area.top + 5)).unwrap();
    assert_eq!(hue_saturation(margin).1, 0.0);
}

#[test]
fn map_over_the_thor1_floor_plan_png_and_svg() {
    let dir = tmp("thor1-map");
    let out = dir.join("thor1.png");
    let extent: Extent = "-11,12,-10,13.5".parse().unwrap();
    let map_file = data("thor1/cliffmap.csv");
    let plan_file = data("thor1/floorplan.png");
    ok(&[
        "plot",
        "map",
        "--map",
        &map_file,
        "--floorplan",
        &plan_file,
        "--extent=-11,12,-10,13.5",
        "--no-legend",
        "--out",
        s(&out),
    ]);
    let img = decode(&out);
    let frame = Frame::for_map(extent, 1000);
    assert_eq!(img.dimensions(), frame.size);
    let map = CliffMap::load(&map_file).unwrap();
    let plan = image::open(&plan_file).unwrap().to_luma8();
    let (dark, light) = check_floorplan(&img, &frame, &map, &plan, &extent, 0.5);
    assert!(dark > 100 && light > 20, "dark {dark}, light {light}");
    // Zoomed in on the obstacle, and zoomed out beyond the plan: the plan stays in place.
    for (view, width, step, want) in [
        ("-2,4,-3,3", 500, 0.2, 20),
        ("-20,20,-15,20", 700, 0.5, 100),
    ] {
        let zoom = dir.join("zoom.png");
        ok(&[
            "plot",
            "map",
            "--map",
            &map_file,
            "--floorplan",
            &plan_file,
            "--extent=-11,12,-10,13.5",
            &format!("--view={view}"),
            "--width",
            &width.to_string(),
            "--no-legend",
            "--out",
            s(&zoom),
        ]);
        let img = decode(&zoom);
        let frame = Frame::for_map(view.parse().unwrap(), width);
        assert_eq!(img.dimensions(), frame.size);
        let (dark, light) = check_floorplan(&img, &frame, &map, &plan, &extent, step);
        assert!(
            dark >= want && light >= want / 5,
            "{view}: dark {dark}, light {light}"
        );
        if view.starts_with("-20") {
            // outside the plan's extent: white
            let p = frame.to_pixel(DVec2::new(-15.0, 0.0));
            assert_eq!(px(&img, p), Some((255, 255, 255)));
        }
    }
    // Arrows: at each location with one component, its colour along its direction.
    let mut checked = 0;
    let seconds = MapStyle::default().arrow_seconds_for(&map);
    for loc in map.locations().iter().filter(|l| l.components.len() == 1) {
        let c = loc.components[0];
        let len = c.rho * seconds;
        if len * frame.scale_x() < 6.0 {
            continue; // too short to find its colour beside the location
        }
        // halfway along the arrow
        let tip = loc.position + DVec2::from_angle(c.theta) * 0.5 * len;
        let sat = saturation_of_hue(
            &img,
            frame.to_pixel(tip),
            2,
            hue_saturation(direction_colour(c.theta)).0,
        );
        assert!(
            sat > 0.2,
            "location {} component at {:.2} rad: {sat}",
            loc.position,
            c.theta
        );
        checked += 1;
    }
    assert!(checked > 50, "{checked}");

    // The same picture as SVG: the floor plan is embedded, arrows are coloured paths.
    let svg_out = dir.join("thor1.svg");
    ok(&[
        "plot",
        "map",
        "--map",
        &map_file,
        "--floorplan",
        &plan_file,
        "--extent=-11,12,-10,13.5",
        "--out",
        s(&svg_out),
    ]);
    let svg = std::fs::read_to_string(&svg_out).unwrap();
    assert!(svg.starts_with("<svg"));
    assert!(svg.contains(&format!(
        r#"width="{}" height="{}""#,
        frame.size.0, frame.size.1
    )));
    assert_eq!(svg.matches("data:image/png;base64,").count(), 1);
    // one shaft (polyline) and one head (polygon) per component
    assert!(
        svg.matches("<polygon").count() >= 527,
        "{}",
        svg.matches("<polygon").count()
    );
    let (r, g, b) = direction_colour(map.locations()[0].components[0].theta);
    assert!(svg.contains(&format!("#{r:02X}{g:02X}{b:02X}")));
}

/// Where the floor plan is black (walls, outside) the picture is the faded grey, where
/// it is white the picture is white: checked on a grid of `step` over the frame's view
/// at points farther than 0.4 m from any map location (the arrows are shorter) and where the
/// plan is uniform around the point (so that scaling does not blur it). Returns the
/// numbers of dark and light points checked.
fn check_floorplan(
    img: &RgbImage,
    frame: &Frame,
    map: &CliffMap,
    plan: &image::GrayImage,
    extent: &Extent,
    step: f64,
) -> (usize, usize) {
    let (w, h) = plan.dimensions();
    let (mut dark, mut light) = (0, 0);
    let v = frame.extent;
    let nx = (v.width() / step) as usize;
    let ny = (v.height() / step) as usize;
    for iy in 0..ny {
        for ix in 0..nx {
            let p = DVec2::new(
                v.x0 + step * (ix as f64 + 0.5),
                v.y0 + step * (iy as f64 + 0.5),
            );
            if map.nearest(p, 0.4).is_some() {
                continue;
            }
            let col = |x: f64| ((x - extent.x0) / extent.width() * w as f64) as i64;
            let row = |y: f64| ((extent.y1 - y) / extent.height() * h as f64) as i64;
            let mut vals = vec![];
            for d in [-0.1, 0.0, 0.1] {
                for e in [-0.1, 0.0, 0.1] {
                    let (c, r) = (col(p.x + d), row(p.y + e));
                    if (0..w as i64).contains(&c) && (0..h as i64).contains(&r) {
                        vals.push(plan.get_pixel(c as u32, r as u32)[0]);
                    }
                }
            }
            if vals.len() < 9 {
                continue;
            }
            let pix = px(img, frame.to_pixel(p)).unwrap();
            if vals.iter().all(|&v| v < 20) {
                dark += 1;
                assert!(pix.0 < 190 && pix.0 > 140 && pix.0 == pix.2, "{p}: {pix:?}");
            } else if vals.iter().all(|&v| v > 235) {
                light += 1;
                assert!(pix.0 > 245 && pix.1 > 245 && pix.2 > 245, "{p}: {pix:?}");
            }
        }
    }
    (dark, light)
}

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

fn write_summary(dir: &Path, text: &str) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let p = dir.join("summary.csv");
    std::fs::write(&p, text).unwrap();
    p
}

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
    assert!(sd > 0.05, "people differ: sd {sd}");
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
